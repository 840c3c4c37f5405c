/* The inter-particle energy of papers/001 section 3: the modified cotangent kernel (eq. 1), its
 * derivative (eq. 2), the ideal energy of a hexagonal neighbourhood (eq. 6), and a particle's
 * energy E_i and gradient (the sum over neighbours whose pair lies within sigma_ij =
 * max(sigma_i, sigma_j), eq. 1 and 8).
 *
 * Phase 1 (ours; the paper is silent). Energies are computed in world space between all
 * neighbours, whatever their cells. In phase 1 the field knows curvature and the Lipschitz bound
 * only, so particles of two curves can be far closer than their sigma (the outlines of a thin
 * plate, 4.76 apart under a sigma of 87): their pair energy is then huge, and the deletes it
 * causes empty long stretches of one outline where the other keeps its particles. The gap of
 * phase 2 can only be measured between particles, so it never sees such a stretch again. So in
 * phase 1 a particle feels only the particles of its own curve and of the curve's end vertices
 * (its closure); every later phase uses all neighbours, as the paper does.
 *
 * The pair's sigma (pair_sigma). Eq. 1 takes sigma_ij = max(sigma_i, sigma_j): in a graded field
 * an edge settles at the spacing of its larger end, so at the Lipschitz bound (sigma 20% larger
 * one edge further) a lattice triangle has two edges 20% longer than the third, R / l_min near
 * 0.66. pair_sigma = 1 takes the mean instead (about 0.62 for the same triangle). Measured with
 * the inferred field (`packmesh mesh MODEL --method psys --set pair_sigma=1`, median R / l_min
 * and nodes against eq. 1, with neither the connection's smoothing nor the tighter end of phase
 * 3): t20_component8.step 0.659 -> 0.643 (4282 -> 4860 nodes), screw.step 0.640 -> 0.632,
 * cube_fillet.stp 0.635 -> 0.634, synth_box_hole.step 0.634 -> 0.637, planar_step.brep 0.636 ->
 * 0.641: no consistent gain alone. With the smoothing of the connection (smooth = 4) it gains
 * on 9 of 10 models (median R / l_min, max -> mean, both smoothed: wrench.stp 0.6147 -> 0.6085,
 * t20_component8.step 0.6412 -> 0.6346, synth_cone.brep 0.6164 -> 0.6097, bearing.iges 0.6355
 * -> 0.6307; crack.brep 0.6119 -> 0.6154 the exception), for 1% to 14% more nodes on the same
 * field (the packing follows the field where it grades instead of its coarser side): the
 * default is the mean since; 0 is the paper's. */
#include <math.h>
#include <string.h>

#include "common/base/vec3.h"
#include "psys/psys_private.h"

/* Distances below this fraction of sigma are treated as this fraction: eq. 1 diverges as r -> 0
 * (cot) and two particles can meet after a clipped step or a split at a trim boundary. The
 * energy stays finite (about 6e8 sigma, so the pair is deleted at once) and the gradient keeps a
 * direction. */
#define R_FLOOR 1e-9

/* The kernel from one tangent. With t = r / sigma pi/2 in (0, pi/2) and u = pi/2 - t,
 * cot t = tan u =: T, and eq. 1-2 and the second derivative read
 *     E = sigma (cot t + t - pi/2) = sigma (T - u),
 *     dE/dr = pi/2 (1 - 1/sin^2 t) = -pi/2 T^2,
 *     d2E/dr2 = pi^2/(2 sigma) cos t / sin^3 t = pi^2/(2 sigma) T (1 + T^2).
 * tan is evaluated on [0, pi/4] by the rational approximation of Cephes (S. L. Moshier, tan.c:
 * tan x = x + x z P(z)/Q(z), z = x^2; relative error below 2e-16 there, measured against
 * long-double tanl), on u when t >= pi/4 and on t otherwise (T = 1 / tan t). Its form gives
 * T - u = u z P/Q directly, so E keeps its relative precision where it vanishes (r -> sigma:
 * E ~ sigma u^3 / 3), which cot t + t - pi/2 loses to cancellation. One rational function instead
 * of a sine and a cosine: this is the inner loop of every energy. */
static const double TP0 = -1.30936939181383777646E4, TP1 = 1.15351664838587416140E6,
                    TP2 = -1.79565251976484877988E7;
static const double TQ1 = 1.36812963470692954678E4, TQ2 = -1.32089234440210967447E6,
                    TQ3 = 2.50083801823357915839E7, TQ4 = -5.38695755929454629881E7;

/* tan x - x for 0 <= x <= pi/4. */
static inline double tan_minus_x(double x) {
  const double z = x * x;
  const double p = (TP0 * z + TP1) * z + TP2, q = (((z + TQ1) * z + TQ2) * z + TQ3) * z + TQ4;
  return x * z * (p / q);
}

/* For 0 < r < sigma: *em = E / sigma, *T = cot(r / sigma pi/2). */
static inline void kernel(double r, double sigma, double *em, double *T) {
  double x = r / sigma;
  x = (x > R_FLOOR ? x : R_FLOOR) * M_PI_2;
  if (x >= M_PI_4) {
    const double u = M_PI_2 - x, w = tan_minus_x(u);
    *T = u + w, *em = w;
  } else {
    const double tt = 1.0 / (x + tan_minus_x(x));
    *T = tt, *em = tt - (M_PI_2 - x);
  }
}

double psys_pair_energy(double r, double sigma) {
  if (!(r < sigma)) return 0;
  double em, T;
  kernel(r, sigma, &em, &T);
  return sigma * em; /* eq. 1 */
}

double psys_pair_denergy(double r, double sigma) {
  if (!(r < sigma)) return 0;
  double em, T;
  kernel(r, sigma, &em, &T);
  return -M_PI_2 * T * T; /* eq. 2: the sigma of eq. 1 cancels the 1/sigma of dx/dr */
}

double psys_pair_d2energy(double r, double sigma) {
  if (!(r < sigma)) return 0;
  double em, T;
  kernel(r, sigma, &em, &T);
  return M_PI * M_PI_2 / sigma * T * (1 + T * T); /* > 0: the kernel is convex */
}

double psys_ideal_energy(double sigma) {
  /* eq. 6: six one-ring neighbours at |r_ij| / sigma_ij = beta; the two-ring lies at distance
   * sqrt(3) beta sigma = sigma, where the kernel vanishes. */
  return 6.0 * psys_pair_energy(PSYS_BETA, 1.0) * sigma;
}

double psys_energy_at(const psys_sys *s, int32_t self, int32_t ki, double si, const double x[3],
                      const int32_t *ids, int32_t m, double grad[3], double hess[7]) {
  double e = 0, g[3] = {0, 0, 0}, h[7] = {0, 0, 0, 0, 0, 0, 0};
  const double *xs = s->xs;
  const int phase1 = s->phase == 1, mean = s->p.pair_sigma == 1;
  for (int32_t k = 0; k < m; ++k) {
    const int32_t j = ids[k];
    const double *xj = &xs[4 * j];
    const double d[3] = {x[0] - xj[0], x[1] - xj[1], x[2] - xj[2]};
    const double d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    /* sigma_ij = max(sigma_i, sigma_j) (eq. 1), or their mean (pair_sigma = 1) */
    const double sij = mean ? 0.5 * (si + xj[3]) : (si > xj[3] ? si : xj[3]);
    if (!(d2 < sij * sij) || j == self) continue;
    if (phase1 && !psys_interacts(s, ki, j)) continue;
    /* eq. 1-2 and the second derivative (kernel above), the same expressions at a particle and
     * at its trial points, so that Algorithm 1 compares like with like */
    const double r = sqrt(d2);
    double em, T;
    kernel(r, sij, &em, &T);
    e += sij * em;
    if (!(r > 0) || (!grad && !hess)) continue;
    /* dE_ij/dx_i = dE/dr (x_i - x_j) / r; eq. 8's velocity is its negative (repulsive). */
    const double T2 = T * T, f = -M_PI_2 * T2 / r;
    g[0] += f * d[0], g[1] += f * d[1], g[2] += f * d[2];
    if (hess) {
      /* d2E_ij/dx_i2 = E'' u u^T + (E' / r) (I - u u^T), u = (x_i - x_j) / r */
      const double dd = M_PI * M_PI_2 / sij * T * (1 + T2), ir = 1.0 / r;
      const double u[3] = {d[0] * ir, d[1] * ir, d[2] * ir};
      const double a = dd - f;
      h[0] += a * u[0] * u[0] + f, h[1] += a * u[0] * u[1], h[2] += a * u[0] * u[2];
      h[3] += a * u[1] * u[1] + f, h[4] += a * u[1] * u[2], h[5] += a * u[2] * u[2] + f;
      h[6] += dd;
    }
  }
  if (grad) pm_v3_copy(grad, g);
  if (hess) memcpy(hess, h, sizeof h);
  return e;
}
