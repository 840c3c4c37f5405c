/* The inter-bubble force (papers/003 eq. 10-11, papers/004 eq. 2.1).
 *
 * 003 eq. 11 asks for a cubic f(l) = a l^3 + b l^2 + c l + d on 0 <= l <= 1.5 l0, zero beyond,
 * with f(l0) = f(1.5 l0) = 0, f'(0) = 0 and f'(l0) = -k0, where l0 = (d_i + d_j) / 2 is the stable
 * distance (eq. 10). Its unique solution is f(l) = k0 l0 g(l / l0) with
 *   g(lambda) = 5/4 lambda^3 - 19/8 lambda^2 + 9/8 = 5/4 (lambda - 1)(lambda - 1.5)(lambda + 0.6),
 * and k0 g(lambda) is exactly Qi et al.'s normalized form (004 eq. 2.1). So Qi's f(lambda) is the
 * force per unit of l0, and the force in length units carries the factor l0: with it, k0 is the
 * spring constant of every bubble pair whatever its size (f'(l0) = -k0 as eq. 11 states), the
 * natural period 2 pi sqrt(m / k0) is the same for small and large bubbles, and a graded mesh
 * relaxes at the same pace everywhere (bub_dynamics.c relies on this for its time step).
 * The force saturates at l = 0 (f(0) = 9/8 k0 l0), as 003 section 3.3 wants.
 */
#include "bubble/bub_private.h"

double bub_force_normalized(double k0, double lambda) {
  if (!(lambda <= 1.5)) return 0; /* also NaN */
  if (lambda < 0) lambda = 0;
  /* Horner form of 5/4 x^3 - 19/8 x^2 + 9/8. */
  return k0 * ((1.25 * lambda - 2.375) * lambda * lambda + 1.125);
}

double bub_force(double k0, double l, double l0) {
  if (!(l0 > 0)) return 0;
  return l0 * bub_force_normalized(k0, l / l0);
}

/* G(mu) = integral of g from 0 to mu. */
static double g_integral(double mu) {
  return ((0.3125 * mu - 0.79166666666666667) * mu * mu + 1.125) * mu;
}

double bub_potential(double k0, double l, double l0) {
  if (!(l0 > 0)) return 0;
  double lambda = l / l0;
  if (!(lambda < 1.5)) return 0;
  if (lambda < 0) lambda = 0;
  return k0 * l0 * l0 * (g_integral(1.5) - g_integral(lambda));
}
