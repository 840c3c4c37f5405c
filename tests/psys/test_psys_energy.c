/* The energy of papers/001 section 3: eq. 1-2 against finite differences, eq. 6, a particle's
 * energy, gradient and Hessian against finite differences, and the hexagonal lattice at spacing
 * beta sigma (eq. 6): stationary, with E_i = E_ideal. */
#include "test_psys_util.h"

/* Independent evaluation of eq. 1 for unit sigma. */
static double e_unit(double x) {
  double a = x * M_PI / 2;
  return cos(a) / sin(a) + a - M_PI / 2;
}

static void pair_energy_values(void **state) {
  (void)state;
  /* eq. 1 scaled by sigma, 0 at and beyond sigma */
  for (double sigma = 0.01; sigma < 200; sigma *= 7.3)
    for (double x = 0.05; x < 1; x += 0.05)
      PM_ASSERT_NEAR(psys_pair_energy(x * sigma, sigma), sigma * e_unit(x),
                     1e-12 * sigma * (1 + e_unit(x)));
  assert_true(psys_pair_energy(1.0, 1.0) == 0);
  assert_true(psys_pair_energy(1.3, 1.0) == 0);
  assert_true(psys_pair_denergy(1.3, 1.0) == 0);
  /* near sigma the kernel and its derivative vanish continuously */
  assert_true(psys_pair_energy(0.999999, 1.0) < 1e-10);
  assert_true(fabs(psys_pair_denergy(0.999999, 1.0)) < 1e-5);
  /* eq. 6: beta = 0.5 / cos(pi/6), E_ideal = 6 E(beta) sigma = 0.71082590819 sigma */
  PM_ASSERT_NEAR(PSYS_BETA, 0.5 / cos(M_PI / 6), 1e-15);
  PM_ASSERT_NEAR(psys_ideal_energy(1.0), 0.7108259081922572, 1e-12);
  PM_ASSERT_NEAR(psys_ideal_energy(3.5), 3.5 * 0.7108259081922572, 1e-11);
  /* repulsive and convex: E decreases, dE/dr < 0, d2E/dr2 > 0 inside the ball */
  for (double x = 0.05; x < 0.99; x += 0.01) {
    assert_true(psys_pair_energy(x, 1.0) > psys_pair_energy(x + 0.01, 1.0));
    assert_true(psys_pair_denergy(x, 1.0) < 0);
    assert_true(psys_pair_d2energy(x, 1.0) > 0);
  }
}

static void pair_derivatives_match_finite_differences(void **state) {
  (void)state;
  const double sigmas[] = {0.02, 1.0, 37.0};
  for (int k = 0; k < 3; ++k) {
    const double sg = sigmas[k];
    for (double x = 0.1; x < 0.96; x += 0.05) {
      const double r = x * sg, h = 1e-6 * sg;
      double fd = (psys_pair_energy(r + h, sg) - psys_pair_energy(r - h, sg)) / (2 * h);
      double d1 = psys_pair_denergy(r, sg);
      if (!(fabs(fd - d1) <= 1e-6 * (1 + fabs(d1))))
        fail_msg("dE/dr at r/sigma %g, sigma %g: %.12g vs finite difference %.12g", x, sg, d1, fd);
      double fd2 = (psys_pair_denergy(r + h, sg) - psys_pair_denergy(r - h, sg)) / (2 * h);
      double d2 = psys_pair_d2energy(r, sg);
      if (!(fabs(fd2 - d2) <= 1e-5 * (1 + fabs(d2))))
        fail_msg("d2E/dr2 at r/sigma %g, sigma %g: %.12g vs finite difference %.12g", x, sg, d2,
                 fd2);
    }
  }
}

/* A particle's energy, gradient and Hessian among neighbours of different sigma (sigma_ij =
 * max(sigma_i, sigma_j)), in 3D: particles on a plane, the particle itself moved off it. */
static void particle_energy_gradient_hessian(void **state) {
  (void)state;
  pm_model *m = psys_test_square(4);
  psys_sys *s = psys_test_system(m, NULL, 1);
  s->p.pair_sigma = 0; /* eq. 1's max, as the sum below */
  pm_error e = {0};
  pm_rng r;
  pm_rng_init(&r, 11, 0);
  int32_t ids[40];
  for (int k = 0; k < 40; ++k) {
    double uv[2] = {pm_rng_range(&r, 1.2, 2.8), pm_rng_range(&r, 1.2, 2.8)};
    PM_ASSERT_OK(psys_add(s, PM_FACE, 0, uv, pm_rng_range(&r, 0.3, 0.9), &ids[k], &e), e);
  }
  const int32_t i = ids[0];
  double base[3] = {s->xyz[0] + 0.013, s->xyz[1] - 0.021, 0.07};
  double g[3], h[7];
  double e0 = psys_particle_energy(s, i, base, ids, 40, g, h);
  assert_true(e0 > 0);
  /* the sum of eq. 1 over the pairs within sigma_ij, by hand */
  double sum = 0;
  for (int k = 1; k < 40; ++k) {
    const double *x = &s->xyz[3 * ids[k]];
    double d = sqrt((base[0] - x[0]) * (base[0] - x[0]) + (base[1] - x[1]) * (base[1] - x[1]) +
                    base[2] * base[2]);
    double sij = fmax(s->sigma[i], s->sigma[ids[k]]);
    if (d < sij) sum += sij * e_unit(d / sij);
  }
  PM_ASSERT_NEAR(e0, sum, 1e-10 * sum);
  const double hstep = 1e-6;
  for (int c = 0; c < 3; ++c) {
    double xp[3] = {base[0], base[1], base[2]}, xm[3] = {base[0], base[1], base[2]};
    xp[c] += hstep, xm[c] -= hstep;
    double gp[3], gm[3];
    double ep = psys_particle_energy(s, i, xp, ids, 40, gp, NULL);
    double em = psys_particle_energy(s, i, xm, ids, 40, gm, NULL);
    double fd = (ep - em) / (2 * hstep);
    if (!(fabs(fd - g[c]) <= 1e-5 * (1 + fabs(g[c]))))
      fail_msg("dE_i/dx[%d] = %.10g, finite difference %.10g", c, g[c], fd);
    /* Hessian column c (packed xx, xy, xz, yy, yz, zz) */
    static const int idx[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};
    for (int rr = 0; rr < 3; ++rr) {
      double fdh = (gp[rr] - gm[rr]) / (2 * hstep), hv = h[idx[rr][c]];
      if (!(fabs(fdh - hv) <= 1e-4 * (1 + fabs(hv))))
        fail_msg("d2E_i/dx%d dx%d = %.10g, finite difference %.10g", rr, c, hv, fdh);
    }
  }
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* pair_sigma: sigma_ij is max(sigma_i, sigma_j) with pair_sigma = 0 (eq. 1) and their mean with
 * pair_sigma = 1 (the default); a pair beyond the mean and within the max interacts only with
 * eq. 1's max. */
static void pair_sigma_choice(void **state) {
  (void)state;
  pm_model *m = psys_test_square(4);
  for (int mean = 0; mean < 2; ++mean) {
    psys_params p;
    psys_params_init(&p);
    p.pair_sigma = mean;
    psys_sys *s = psys_test_system(m, &p, 1);
    pm_error e = {0};
    int32_t ids[3];
    const double uv[3][2] = {{1, 1}, {2.2, 1}, {1, 2.8}};
    const double sg[3] = {1, 2, 2};
    for (int k = 0; k < 3; ++k) PM_ASSERT_OK(psys_add(s, PM_FACE, 0, uv[k], sg[k], &ids[k], &e), e);
    const int32_t others[2] = {ids[1], ids[2]};
    /* particle 0 (sigma 1) against particles at 1.2 and 1.8, both of sigma 2 */
    const double got = psys_particle_energy(s, ids[0], &s->xyz[3 * ids[0]], others, 2, NULL, NULL);
    const double want = mean ? psys_pair_energy(1.2, 1.5)
                             : psys_pair_energy(1.2, 2.0) + psys_pair_energy(1.8, 2.0);
    assert_true(want > 0);
    assert_true(fabs(got - want) <= 1e-12 * want);
    psys_sys_destroy(s);
  }
  pm_model_destroy(m);
}

/* A hexagonal lattice at spacing beta sigma: every interior particle sees six neighbours at
 * beta sigma (its second ring lies at sigma, where the kernel vanishes), so its energy is
 * E_ideal (eq. 6) and its force zero: an Algorithm 1 sweep leaves it in place. */
static void hexagonal_lattice_is_stationary(void **state) {
  (void)state;
  const double sigma = 0.1, a = PSYS_BETA * sigma;
  pm_model *m = psys_test_square(2);
  psys_sys *s = psys_test_system(m, NULL, 2);
  int32_t n = psys_test_hex(s, a, sigma, 0.4, 0.4, 1.6, 1.6);
  assert_true(n > 300);
  psys_test_energies(s);
  const double eid = psys_ideal_energy(sigma);
  double *before = malloc(sizeof(double) * 3 * (size_t)n);
  memcpy(before, s->xyz, sizeof(double) * 3 * (size_t)n);
  int interior = 0;
  for (int32_t i = 0; i < n; ++i) {
    const double *x = &s->xyz[3 * i];
    /* three rows inside the patch */
    if (x[0] < 0.4 + 3 * a || x[0] > 1.6 - 3 * a || x[1] < 0.4 + 3 * a || x[1] > 1.6 - 3 * a)
      continue;
    ++interior;
    if (!(fabs(s->energy[i] - eid) <= 0.05 * eid))
      fail_msg("particle %d: E_i = %g, E_ideal = %g", (int)i, s->energy[i], eid);
    PM_ASSERT_NEAR(s->energy[i], eid, 1e-6 * eid); /* in fact exact up to rounding */
    assert_true(pm_v3_norm(&s->force[3 * i]) < 1e-9);
  }
  assert_true(interior > 100);
  /* Sweeps of Algorithm 1 with the two outer rows held (a patch of an infinite lattice): the
   * lattice stays where it is. */
  for (int32_t i = 0; i < n; ++i) {
    const double *x = &s->xyz[3 * i];
    s->fixed[i] = x[0] < 0.4 + 1.5 * a || x[0] > 1.6 - 1.5 * a || x[1] < 0.4 + 1.5 * a ||
                  x[1] > 1.6 - 1.5 * a;
  }
  psys_move_info mi;
  pm_error e = {0};
  for (int it = 0; it < 5; ++it) PM_ASSERT_OK(psys_move_pass(s, &mi, &e), e);
  assert_true(mi.movable > 200);
  for (int32_t i = 0; i < n; ++i)
    if (!(pm_v3_dist(&before[3 * i], &s->xyz[3 * i]) <= 1e-9 * sigma))
      fail_msg("particle %d moved by %g", (int)i, pm_v3_dist(&before[3 * i], &s->xyz[3 * i]));
  /* whereas a free border spreads */
  memset(s->fixed, 0, (size_t)n);
  PM_ASSERT_OK(psys_move_pass(s, &mi, &e), e);
  assert_true(mi.max_move > 1e-3 * sigma);
  free(before);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* A perturbed lattice relaxes back: Algorithm 1 lowers the total energy sweep after sweep. */
static void perturbed_lattice_relaxes(void **state) {
  (void)state;
  const double sigma = 0.1, a = PSYS_BETA * sigma;
  pm_model *m = psys_test_square(2);
  psys_sys *s = psys_test_system(m, NULL, 1);
  int32_t n = psys_test_hex(s, a, sigma, 0.3, 0.3, 1.7, 1.7);
  pm_rng r;
  pm_rng_init(&r, 5, 0);
  pm_error e = {0};
  for (int32_t i = 0; i < n; ++i) {
    double dx[3] = {pm_rng_range(&r, -0.15, 0.15) * a, pm_rng_range(&r, -0.15, 0.15) * a, 0};
    double par[2];
    pm_cell_displace(pm_model_cell(m, PM_FACE, 0), &s->par[2 * i], dx, par);
    s->par[2 * i] = par[0], s->par[2 * i + 1] = par[1];
    const double x[3] = {par[0], par[1], 0};
    psys_set_xyz(s, i, x);
  }
  psys_move_info mi;
  /* Each accepted step lowers E_i with the others in place, hence the total (a sum over pairs)
   * by twice as much: the total falls sweep after sweep. */
  const double first = psys_test_energies(s);
  double prev = first;
  for (int it = 0; it < 30; ++it) {
    PM_ASSERT_OK(psys_move_pass(s, &mi, &e), e);
    double now = psys_test_energies(s);
    if (!(now <= prev * (1 + 1e-12))) fail_msg("sweep %d raised the energy: %.15g -> %.15g", it, prev, now);
    prev = now;
  }
  assert_true(prev < 0.9 * first);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(pair_energy_values),
      cmocka_unit_test(pair_derivatives_match_finite_differences),
      cmocka_unit_test(particle_energy_gradient_hessian),
      cmocka_unit_test(pair_sigma_choice),
      cmocka_unit_test(hexagonal_lattice_is_stationary),
      cmocka_unit_test(perturbed_lattice_relaxes),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
