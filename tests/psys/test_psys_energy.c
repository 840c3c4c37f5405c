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

/* The bottom side of psys_test_square(1), y = 0 and x from 0 to 1, reparametrized by
 * x = s(t) = 0.02 t + 0.98 max(0, (t - 0.6) / 0.4)^2: its speed is 0.02 up to t = 0.6 and grows
 * to 4.92 at t = 1, so a step that the tangent at a slow point sizes in world space lands much
 * farther along the curve. */
static void (*line_eval)(const pm_cell *, double, int, pm_curve_point *);
static double slow_x(double t) {
  const double u = t > 0.6 ? (t - 0.6) / 0.4 : 0;
  return 0.02 * t + 0.98 * u * u;
}
static void slow_then_fast(const pm_cell *c, double t, int order, pm_curve_point *out) {
  line_eval(c, slow_x(t), order, out);
  pm_v3_scale(out->d1, out->d1, 0.02 + (t > 0.6 ? 12.25 * (t - 0.6) : 0));
  if (order >= 2) pm_v3_zero(out->d2); /* not used by the step */
}

/* A step never ends farther from the particle than its neighbour list is sure to cover,
 * (psys_nbr_reach - 1) sigma (psys_move.c). On the curve above, with sigma = 0.01, a particle at
 * t = 0.59 (speed 0.02) pushed by one 0.5 sigma behind it: its first trial, sized as 0.0016 in
 * the tangent, lies about 3 sigma along the curve, where its list holds nobody and its energy
 * would be 0, so that the step would be taken. */
static void a_stretched_step_stays_within_the_lists(void **state) {
  (void)state;
  pm_model *m = psys_test_square(1);
  pm_cell *c = NULL;
  for (int32_t k = 0; k < m->count[PM_CURVE]; ++k) {
    pm_curve_point a, b;
    const pm_cell *ck = &m->cells[PM_CURVE][k];
    ck->cls->curve_eval(ck, ck->lo[0], 0, &a), ck->cls->curve_eval(ck, ck->hi[0], 0, &b);
    if (fabs(a.p[1]) + fabs(b.p[1]) < 1e-12 && a.p[0] < b.p[0]) c = &m->cells[PM_CURVE][k];
  }
  assert_non_null(c);
  PM_ASSERT_NEAR(c->lo[0], 0, 1e-12);
  PM_ASSERT_NEAR(c->hi[0], 1, 1e-12);
  /* a class of its own for this one cell (the class is shared by every line) */
  static pm_cell_class slow;
  slow = *c->cls;
  line_eval = slow.curve_eval;
  slow.curve_eval = slow_then_fast, slow.project = NULL;
  c->cls = &slow;
  psys_sys *s = psys_test_system(m, NULL, 1);
  s->phase = 2;
  pm_error e = {0};
  const double sigma = 0.01;
  /* the one behind: where x is 0.5 sigma less (bisection on the increasing s) */
  double lo = 0, hi = 0.59;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    *(slow_x(mid) < slow_x(0.59) - 0.5 * sigma ? &lo : &hi) = mid;
  }
  const double t[2] = {lo, 0.59};
  int32_t id[2];
  for (int k = 0; k < 2; ++k)
    PM_ASSERT_OK(psys_add(s, PM_CURVE, c->index, &t[k], sigma, &id[k], &e), e);
  const double apart = pm_v3_dist(&s->xyz[3 * id[0]], &s->xyz[3 * id[1]]);
  PM_ASSERT_NEAR(apart, 0.5 * sigma, 1e-12);
  double before[6];
  memcpy(before, s->xyz, sizeof before);
  psys_move_info mi;
  PM_ASSERT_OK(psys_move_pass(s, &mi, &e), e);
  const double cover = (psys_nbr_reach(&s->p) - 1) * sigma;
  for (int k = 0; k < 2; ++k) {
    const double d = pm_v3_dist(&before[3 * k], &s->xyz[3 * id[k]]);
    if (!(d <= cover * (1 + 1e-9))) fail_msg("particle %d stepped %g, beyond %g", k, d, cover);
  }
  /* the one ahead still stepped forward, a shorter step (Algorithm 1's lambda / 10) */
  assert_true(s->xyz[3 * id[1]] > before[3] + 1e-3 * sigma);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* Over-relaxation in phase 3 (lambda_max_faces, psys_move.c): a lattice patch whose two outer
 * rows are held, displaced by one long wave (the mode that full steps relax slowly, and all that
 * is left in the tail of phase 3), relaxes towards the perfect lattice; after the same number of
 * sweeps the sweep whose steps may reach 1.8 times the Newton step is nearer to it than full
 * steps, and each sweep lowers the energy all the same. (A random displacement of every
 * particle, short waves, relaxes faster with full steps.) In phases 1-2 the cap is lambda_max. */
static double relaxed_excess(double lambda_max_faces, int phase, int sweeps) {
  const double sigma = 0.1, a = PSYS_BETA * sigma;
  pm_model *m = psys_test_square(2);
  psys_params p;
  psys_params_init(&p);
  p.lambda_max_faces = lambda_max_faces;
  psys_sys *s = psys_test_system(m, &p, 1);
  s->phase = phase;
  int32_t n = psys_test_hex(s, a, sigma, 0.4, 0.4, 1.6, 1.6);
  for (int32_t i = 0; i < n; ++i) {
    const double *x = &s->xyz[3 * i];
    s->fixed[i] = x[0] < 0.4 + 1.5 * a || x[0] > 1.6 - 1.5 * a || x[1] < 0.4 + 1.5 * a ||
                  x[1] > 1.6 - 1.5 * a;
  }
  const double ideal = psys_test_energies(s);
  for (int32_t i = 0; i < n; ++i) {
    if (s->fixed[i]) continue;
    const double *x0 = &s->xyz[3 * i];
    const double bump = sin(M_PI * (x0[0] - 0.4) / 1.2) * sin(M_PI * (x0[1] - 0.4) / 1.2);
    double dx[3] = {0.3 * a * bump, 0.2 * a * bump, 0}, par[2];
    pm_cell_displace(pm_model_cell(m, PM_FACE, 0), &s->par[2 * i], dx, par);
    s->par[2 * i] = par[0], s->par[2 * i + 1] = par[1];
    const double x[3] = {par[0], par[1], 0};
    psys_set_xyz(s, i, x);
  }
  double prev = psys_test_energies(s);
  psys_move_info mi;
  pm_error e = {0};
  for (int it = 0; it < sweeps; ++it) {
    PM_ASSERT_OK(psys_move_pass(s, &mi, &e), e);
    const double now = psys_test_energies(s);
    if (!(now <= prev * (1 + 1e-12))) fail_msg("sweep %d raised the energy: %.15g -> %.15g", it, prev, now);
    prev = now;
  }
  psys_sys_destroy(s);
  pm_model_destroy(m);
  return prev - ideal;
}

static void over_relaxed_faces_relax_faster(void **state) {
  (void)state;
  const double full = relaxed_excess(0, 3, 12), over = relaxed_excess(1.8, 3, 12);
  assert_true(full > 0 && over > 0);
  /* 0.0066 against 0.0495 */
  if (!(over < 0.25 * full)) fail_msg("excess energy after 12 sweeps: %g over-relaxed, %g full", over, full);
  /* phases 1-2 keep lambda_max: the same sweeps to the bit */
  assert_true(relaxed_excess(1.8, 2, 12) == relaxed_excess(0, 2, 12));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(pair_energy_values),
      cmocka_unit_test(pair_derivatives_match_finite_differences),
      cmocka_unit_test(particle_energy_gradient_hessian),
      cmocka_unit_test(pair_sigma_choice),
      cmocka_unit_test(hexagonal_lattice_is_stationary),
      cmocka_unit_test(perturbed_lattice_relaxes),
      cmocka_unit_test(a_stretched_step_stays_within_the_lists),
      cmocka_unit_test(over_relaxed_faces_relax_faster),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
