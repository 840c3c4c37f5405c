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
 * (its closure); every later phase uses all neighbours, as the paper does. */
#include <math.h>
#include <string.h>

#include "common/vec3.h"
#include "psys/psys_private.h"

/* Distances below this fraction of sigma are treated as this fraction: eq. 1 diverges as r -> 0
 * (cot) and two particles can meet after a clipped step or a split at a trim boundary. The
 * energy stays finite (about 6e8 sigma, so the pair is deleted at once) and the gradient keeps a
 * direction. */
#define R_FLOOR 1e-9

double psys_pair_energy(double r, double sigma) {
  if (!(r < sigma)) return 0;
  double x = fmax(r / sigma, R_FLOOR) * M_PI_2;
  /* eq. 1: sigma [cot(x) + x - pi/2] */
  return sigma * (1.0 / tan(x) + x - M_PI_2);
}

double psys_pair_denergy(double r, double sigma) {
  if (!(r < sigma)) return 0;
  double x = fmax(r / sigma, R_FLOOR) * M_PI_2;
  double sn = sin(x);
  /* eq. 2: dE/dr = pi/2 [1 - sin^-2(x)], the sigma of eq. 1 cancelling the 1/sigma of dx/dr. */
  return M_PI_2 * (1.0 - 1.0 / (sn * sn));
}

double psys_pair_d2energy(double r, double sigma) {
  if (!(r < sigma)) return 0;
  double x = fmax(r / sigma, R_FLOOR) * M_PI_2;
  double sn = sin(x);
  /* d/dr of eq. 2: pi^2 / (2 sigma) cos(x) / sin^3(x) > 0 (the kernel is convex). */
  return M_PI * M_PI_2 / sigma * cos(x) / (sn * sn * sn);
}

double psys_ideal_energy(double sigma) {
  /* eq. 6: six one-ring neighbours at |r_ij| / sigma_ij = beta; the two-ring lies at distance
   * sqrt(3) beta sigma = sigma, where the kernel vanishes. */
  return 6.0 * psys_pair_energy(PSYS_BETA, 1.0) * sigma;
}

double psys_particle_energy(const psys_sys *s, int32_t i, const double x[3], const int32_t *ids,
                            int32_t m, double grad[3], double hess[7]) {
  double e = 0, g[3] = {0, 0, 0}, h[7] = {0, 0, 0, 0, 0, 0, 0};
  const double si = s->sigma[i];
  const int32_t ki = psys_key(s, s->dim[i], s->cell[i]);
  for (int32_t k = 0; k < m; ++k) {
    int32_t j = ids[k];
    if (j == i || !psys_interacts(s, ki, j)) continue;
    const double *xj = &s->xyz[3 * j];
    double d[3] = {x[0] - xj[0], x[1] - xj[1], x[2] - xj[2]};
    double r = sqrt(pm_v3_dot(d, d));
    double sij = si > s->sigma[j] ? si : s->sigma[j]; /* sigma_ij = max(sigma_i, sigma_j) */
    if (!(r < sij)) continue;
    e += psys_pair_energy(r, sij);
    if (!(r > 0) || (!grad && !hess)) continue;
    /* dE_ij/dx_i = dE/dr (x_i - x_j) / r; eq. 8's velocity is its negative (repulsive). */
    double d1 = psys_pair_denergy(r, sij), f = d1 / r;
    g[0] += f * d[0], g[1] += f * d[1], g[2] += f * d[2];
    if (hess) {
      /* d2E_ij/dx_i2 = E'' u u^T + (E' / r) (I - u u^T), u = (x_i - x_j) / r */
      double d2 = psys_pair_d2energy(r, sij), u[3] = {d[0] / r, d[1] / r, d[2] / r};
      double a = d2 - f;
      h[0] += a * u[0] * u[0] + f, h[1] += a * u[0] * u[1], h[2] += a * u[0] * u[2];
      h[3] += a * u[1] * u[1] + f, h[4] += a * u[1] * u[2], h[5] += a * u[2] * u[2] + f;
      h[6] += d2;
    }
  }
  if (grad) pm_v3_copy(grad, g);
  if (hess) memcpy(hess, h, sizeof h);
  return e;
}
