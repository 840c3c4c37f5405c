/* The three phases of papers/001 section 4.1-4.2, their seeding and their end.
 *
 *   Phase 1: one particle on every vertex, one at the middle of every curve; vertex and curve
 *            particles are optimized with the curvature and Lipschitz constraints only.
 *   Phase 2: the same particles, with the gap size added outside the corner balls; a vertex's
 *            corner ball is its sigma at the end of phase 1 (section 4.2). With a given size
 *            field there is nothing to add, and phase 2 is skipped.
 *   Phase 3: k random particles on every face; the vertex and curve particles are held fixed,
 *            their sigma too, and the face particles are optimized.
 *
 * When a phase ends (ours; "a phase is considered complete when the change from one iteration to
 * the next drops below some threshold"). The change has two parts: the population and the
 * positions. The population is left to the split/delete rules until the particle count has
 * settled -- it moved by at most max(2, pop_tol n) (pop_tol = 0.5%) over the last 10
 * iterations: the random bias keeps a few splits and deletes going at any time, so their number
 * says less than their balance -- and no particle is "hungry" (its E_i below half the split
 * threshold, so eq. 4 splits it whatever its eps: the front of a chain still growing into an
 * empty stretch of its curve). A curve grows from its one seed by about two particles per front
 * every few iterations; on a model with many curves the global count settles long before a long
 * curve is filled, and annealing then froze the curve with empty ends (the bottle's thread
 * helices: a third of each left empty, the faces along them folded over; see test_psys_phases).
 * Curves are since filled by halving their gaps (psys_population.c), which no count can miss,
 * while the random bias keeps making a few curve particles hungry around each delete at any
 * time: counted, they held population control on until anneal_after in nearly every phase 1 and
 * 2 (featuretype.step: 3 to 26 hungry at any iteration after the count had settled at iteration
 * 10; 95 and 164 iterations). So only face particles count as hungry (hungry_curves = 0; 1 counts
 * curves too). On a large model the same bias keeps a few face particles hungry at any
 * iteration: engine_block.stp's phase 3, at 273000 particles and about 600 splits and 500
 * deletes an iteration, had 1 to 15 hungry at every iteration after the fronts, so population
 * control stayed on until anneal_after. The count has therefore settled with up to
 * floor(hungry_tol n) hungry (hungry_tol = 1e-4: none below 10^4 particles, where the meshes are
 * those of hungry_tol = 0; 27 there). The price: a face front still growing into an empty
 * stretch with no more than that many hungry particles is no longer told apart from the bias,
 * and annealing may then start before it has filled the stretch (as a falls, a hungry
 * particle splits only for some eps, and for none once a is small). Measured with it: the 17
 * robust files where psys makes 10^4 nodes or more are valid without an unforced needle
 * (bench_robust --methods psys), and so are engine_block.stp and box_sides.step; the other
 * shared models above 10^4 particles (bench_psys models) are valid, all but fusee.stp and
 * t20_component8.step with the meshes of before.
 * Population control ends at the latest after anneal_after (150) iterations; then the annealing
 * weight a of psys_population.c is multiplied by anneal_rate (0.75) every iteration,
 * and once it falls below anneal_off (0.02, about 14 iterations) splits and deletes stop for
 * good. The phase ends at the first iteration after that whose mean move is below move_tol
 * (0.2%) of sigma, or at max_iter (1500) iterations. (A tighter move_tol helps where the field
 * is uniform and hardly elsewhere. With 5e-4 the median R / l_min of case:qi1 --size 0.05 goes
 * from 0.607 to 0.597 (120 -> 324 iterations in all), of synth_sphere.brep from 0.612 to 0.610;
 * on the graded fields of synth_box_hole, synth_cone, cube_fillet, screw, t20_component8 and
 * bearing it moved by 0.004 at most, for 1.3 to 6 times the iterations, measured with
 * ring_curve = 1.5.) Phase 3 can be given its own tolerance, move_tol_faces (0: move_tol), since
 * the curves of phases 1-2 need not settle further for the faces to: phase 2 of
 * t20_component8.step does not reach 5e-4 in 1500 iterations. On a uniform field the relaxation
 * keeps improving the lattice long after 2e-3 (case:sphere --size 0.038, 10134 nodes: median
 * R / l_min 0.605 after 49 phase-3 iterations, 0.594 with move_tol_faces = 5e-4 after 292, 0.591
 * with 1e-4 after 1181; lattice defects 22% -> 12% -> 10% of the triangles), but on the graded
 * inferred field of t20_component8.step it moves the median from 0.659 to 0.656 (1e-3, 95
 * iterations) and 0.655 (5e-4, 150), and on case:qi1 --size 0.05, filled by the bootstrap fronts,
 * from 0.5878 to 0.5895 (3e-4). With the pairs' mean sigma (pair_sigma = 1) and the
 * connection's smoothing (smooth = 4) the longer relaxation pays on the graded fields too
 * (median R / l_min at move_tol 2e-3 -> 1e-3, iterations of all phases: wrench.stp 0.6085 ->
 * 0.6027, 168 -> 282; table.brep 0.6109 -> 0.6047, 116 -> 178; t20_component8.step 0.6346 ->
 * 0.6322; bearing.iges 0.6307 -> 0.6290; synth_torus.brep 0.6024 -> 0.5981; crack.brep 0.6154
 * -> 0.6183 the one loss of ten; 5e-4 gains another 0.001 to 0.004 for about twice the
 * iterations again): phase 3 ended at move_tol_faces = 1e-3 with full steps; with the
 * over-relaxed sweep of psys_move.c (lambda_max_faces = 1.8, the default) it ends at 1.8e-3, the
 * same residual (1e-3 with lambda_max_faces = 0 gives full steps again).
 * Phase 3 holds sigma once population control is off (hold_sigma = 1, the default; 0 keeps
 * updating it). The field was inferred while the particles moved, and the count followed it; with
 * the count fixed, what is left is relaxing the packing in that field. Updated further, the field
 * changes no count, but on large thin-walled models it keeps creeping and the particles follow it,
 * so the mean move approaches move_tol only slowly: box_sides.step, mean sigma 0.6978 -> 0.7027
 * over 36 iterations at 647685 particles, mean move 0.0031 after 244 phase-3 iterations;
 * solid56.step, mean move 0.002035 after 693 phase-3 iterations and falling by 4e-7 per
 * iteration. Holding it also skips the update, which costs about three quarters of a phase-3
 * iteration there. On synth_cone.brep phase 3 takes 213 iterations instead of 480, with the same
 * node count. Phases 1 and 2 are not held: they move curve particles only, so their tails are
 * cheap, and the curve field at their end is the one the faces grow from. A particle added
 * without a sigma (a face seeded again because the last population pass emptied it) starts at
 * its curvature bound, sigma_max on a plane, so the update runs once more before the hold: on
 * box_sides.step eight sliver faces were seeded again in that pass, held at sigma 23.7 among
 * neighbours at 0.69, and the total energy jumped from 1.9e5 to 1.25e7 at the first held
 * iteration.
 * Trace columns (--trace): iteration (over all phases), phase, particles, energy (sum of E_i),
 * mean_move and max_move (world-space displacement of the movable particles), splits, deletes,
 * mean_sigma, anneal (the weight a, 0 once population control is off), mean_rel_move (mean
 * displacement / sigma, the convergence measure).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/mesh/mesh.h"
#include "common/base/rng.h"
#include "psys/psys_private.h"

/* ---- seeding --------------------------------------------------------------------------------- */

pm_status psys_seed_curves(psys_sys *s, pm_error *err) {
  const pm_model *m = s->model;
  pm_status st;
  for (int32_t v = 0; v < m->count[PM_VERTEX]; ++v) {
    const pm_cell *c = pm_model_cell(m, PM_VERTEX, v);
    /* A point that bounds nothing and lies in nothing (a stray construction point of a CAD
     * file) is no part of the mesh's geometry. */
    if (c->nup == 0 && c->nhost == 0) continue;
    if ((st = psys_add(s, PM_VERTEX, v, NULL, 0, NULL, err))) return st;
  }
  for (int32_t e = 0; e < m->count[PM_CURVE]; ++e) {
    const pm_cell *c = pm_model_cell(m, PM_CURVE, e);
    if (c->degenerate) continue; /* a pole: its vertex carries it */
    double t = 0.5 * (c->lo[0] + c->hi[0]);
    if ((st = psys_add(s, PM_CURVE, e, &t, 0, NULL, err))) return st;
  }
  return PM_OK;
}

static uint64_t mix64(uint64_t x) {
  x ^= x >> 30, x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27, x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

pm_status psys_seed_face(psys_sys *s, int32_t f, int k, pm_error *err) {
  const pm_cell *c = pm_model_cell(s->model, PM_FACE, f);
  pm_rng r;
  pm_rng_init(&r, s->seed, mix64(0x5eedface00000000ULL ^ (uint64_t)(uint32_t)f));
  int placed = 0;
  pm_status st;
  /* Uniform in the parameter box, kept when inside the trimmed region. */
  for (int tries = 0; tries < 200 * k && placed < k; ++tries) {
    double uv[2] = {pm_rng_range(&r, c->lo[0], c->hi[0]), pm_rng_range(&r, c->lo[1], c->hi[1])};
    if (!pm_face_inside(c, uv)) continue;
    if ((st = psys_add(s, PM_FACE, f, uv, 0, NULL, err))) return st;
    ++placed;
  }
  if (placed) return PM_OK;
  /* A sliver of its box (a thin strip along a diagonal): step inwards from the middle of the
   * outer loop's polyline segments. */
  for (int32_t l = 0; l < c->nloop && !placed; ++l) {
    const pm_loop *lp = &c->loop[l];
    if (lp->outer != 1) continue;
    for (int32_t q = 0; q < lp->npts && !placed; ++q) {
      const double *a = &lp->uv[2 * q], *b = &lp->uv[2 * ((q + 1) % lp->npts)];
      double dx = b[0] - a[0], dy = b[1] - a[1];
      for (double f2 = 0.5; f2 > 1e-4 && !placed; f2 *= 0.25) {
        /* outer loops run counter-clockwise: the inside is on the left */
        double uv[2] = {0.5 * (a[0] + b[0]) - f2 * dy, 0.5 * (a[1] + b[1]) + f2 * dx};
        if (!pm_face_inside(c, uv)) continue;
        if ((st = psys_add(s, PM_FACE, f, uv, 0, NULL, err))) return st;
        ++placed;
      }
    }
  }
  return PM_OK;
}

/* One front per face (in parallel), the particles appended in face order; a face the front
 * leaves empty (too small for a row) gets seeds_per_face random ones. */
static pm_status fronts(psys_sys *s, const psys_hint *hint, pm_error *err) {
  const int32_t nf = s->model->count[PM_FACE];
  double **uv = calloc((size_t)nf + 1, sizeof(double *));
  double **sg = calloc((size_t)nf + 1, sizeof(double *));
  int32_t *cnt = calloc((size_t)nf + 1, sizeof(int32_t));
  pm_status *fst = calloc((size_t)nf + 1, sizeof(pm_status));
  pm_error *ferr = calloc((size_t)nf + 1, sizeof(pm_error));
  pm_status st = PM_OK;
  if (!uv || !sg || !cnt || !fst || !ferr) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 1)
  for (int32_t f = 0; f < nf; ++f)
    if (s->face_on[f]) fst[f] = psys_seed_front(s, f, hint, &uv[f], &sg[f], &cnt[f], &ferr[f]);
  for (int32_t f = 0; f < nf && !st; ++f) {
    if (!s->face_on[f]) continue;
    if (fst[f]) {
      if (err) *err = ferr[f];
      st = fst[f];
      break;
    }
    for (int32_t k = 0; k < cnt[f] && !st; ++k)
      st = psys_add(s, PM_FACE, f, &uv[f][2 * k], sg[f][k], NULL, err);
    if (!st && cnt[f] == 0) st = psys_seed_face(s, f, s->p.seeds_per_face, err);
  }
out:
  for (int32_t f = 0; f < nf && uv; ++f) free(uv[f]), free(sg[f]);
  free(uv), free(sg), free(cnt), free(fst), free(ferr);
  return st;
}

/* Phase 3's seeds: k random particles per face (seeding = 0, section 4.1), or the bootstrap
 * fronts of psys_seed.c (seeding = 1): a first front per face, one sizing update of its
 * particles (the gap across walls, the Lipschitz closure over the model), and a second front
 * with that field as its hint. */
static pm_status seed_faces(psys_sys *s, pm_error *err) {
  const int32_t nf = s->model->count[PM_FACE];
  if (s->p.seeding == 0) {
    for (int32_t f = 0; f < nf; ++f) {
      if (!s->face_on[f]) continue;
      pm_status st = psys_seed_face(s, f, s->p.seeds_per_face, err);
      if (st) return st;
    }
    return PM_OK;
  }
  const int32_t n0 = s->n;
  pm_status st = fronts(s, NULL, err);
  if (st || s->size) return st; /* a given field: the first front had it already */
  if ((st = psys_sigma_update(s, err))) return st;
  psys_hint hint = {NULL, NULL, NULL};
  const int32_t m = s->n - n0;
  double *hx = malloc(sizeof(double) * 3 * ((size_t)m + 1));
  double *hs = malloc(sizeof(double) * ((size_t)m + 1));
  uint8_t *dead = calloc((size_t)s->n + 1, 1);
  if (!hx || !hs || !dead) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  if ((st = pm_grid_create(1e-2 * s->sigma_min, &hint.grid, err))) goto out;
  for (int32_t k = 0; k < m && !st; ++k) {
    memcpy(&hx[3 * k], &s->xyz[3 * (n0 + k)], 3 * sizeof(double));
    hs[k] = s->sigma[n0 + k];
    dead[n0 + k] = 1;
    /* filed at its spacing: the radius sets the size of a point's cell only (ball queries do
     * not read it), and at 0 every query, 2 sigma wide, walked down from the apex */
    st = pm_grid_insert(hint.grid, k, &hx[3 * k], s->p.edge_per_sigma * hs[k], err);
  }
  hint.xyz = hx, hint.sigma = hs;
  if (!st) st = psys_compact(s, dead, err);
  if (!st) st = fronts(s, &hint, err);
out:
  pm_grid_destroy(hint.grid);
  free(hx), free(hs), free(dead);
  return st;
}

/* ---- observation -------------------------------------------------------------------------- */

/* The trace: one row per iteration (event 0; its population pass is part of the iteration, so
 * `particles` is the count after it and `nodes` equals it), then one row for the connection
 * (event 3, as bubble's), whose `nodes` is the mesh's: the particles and the nodes the connection
 * step added (repairs; with --volume, TetGen's interior nodes). Its step measures are empty. */
static const char *const trace_cols[] = {"iteration", "phase",      "particles", "energy",
                                         "mean_move", "max_move",   "splits",    "deletes",
                                         "mean_sigma", "anneal",    "mean_rel_move", "nodes",
                                         "event"};
#define NTRACE ((int)(sizeof trace_cols / sizeof trace_cols[0]))

static pm_status observe(psys_sys *s, const psys_observer *obs, const psys_move_info *mi,
                         int32_t sp, int32_t de, double a, int frame, pm_error *err) {
  if (!obs) return PM_OK;
  pm_status st;
  if (pm_observe_wants_trace(obs->run)) {
    double ms = 0;
    for (int32_t i = 0; i < s->n; ++i) ms += s->sigma[i];
    if (s->n) ms /= s->n;
    double row[NTRACE] = {(double)s->iter, s->phase,     s->n,        mi->energy,
                          mi->mean_move,   mi->max_move, sp,          de,
                          ms,              a,            mi->mean_rel, s->n, 0};
    if ((st = pm_observe_trace_row(obs->run, row, err))) return st;
  }
  if (frame) {
    /* Drawn at edge_per_sigma sigma / 2, half the ideal edge length: neighbours at the spacing
     * the calibration gives touch, as bubbles do (at sigma itself the circles overlap about three
     * deep and hide each other). Coloured by E_i, the particle's energy (eq. 3). */
    static const char *const names[4] = {"", "curves", "gap sizes", "faces"};
    const pm_run_frame f = {s->iter, s->phase, names[s->phase & 3], s->n, s->xyz, s->sigma,
                            0.5 * s->p.edge_per_sigma, s->dim, s->cell, s->par, s->energy};
    return pm_observe_frame(obs->run, &f, err);
  }
  return PM_OK;
}

pm_status psys_trace_mesh(const psys_observer *obs, int64_t iterations, int32_t particles,
                          int32_t nodes, pm_error *err) {
  if (!obs || !pm_observe_wants_trace(obs->run)) return PM_OK;
  double row[NTRACE];
  for (int k = 0; k < NTRACE; ++k) row[k] = NAN;
  row[0] = (double)(iterations > 0 ? iterations - 1 : 0), row[1] = 3, row[2] = particles;
  row[6] = row[7] = 0;
  row[11] = nodes, row[12] = 3;
  return pm_observe_trace_row(obs->run, row, err);
}

/* ---- one phase -------------------------------------------------------------------------------- */

#define POP_WINDOW 10
#define REORDER_FRACTION 0.25

int psys_count_settled(int32_t n, int32_t then, int32_t hungry, double pop_tol, double hungry_tol) {
  if (then < 0) return 0;
  const int32_t tol = (int32_t)fmax(2.0, pop_tol * n);
  /* a few hungry particles at any iteration are the random bias's, not a front still growing
   * (hungry_tol; see the file comment) */
  const int32_t hungry_ok = (int32_t)floor(hungry_tol * n);
  return abs(n - then) <= tol && hungry <= hungry_ok;
}

pm_status psys_run_phase(psys_sys *s, int phase, const uint8_t *faces, const psys_observer *obs,
                         psys_phase_report *rep, pm_error *err) {
  const double t0 = pm_seconds();
  memset(rep, 0, sizeof *rep);
  pm_status st = PM_OK;
  s->phase = phase;
  psys_nbr_reset(s); /* the gap relation and the list radii change with the phase */
  double tc = pm_seconds();
  if (phase == 1) {
    s->gap_curves = s->gap_faces = 0;
    if (s->n == 0 && (st = psys_seed_curves(s, err))) return st;
  } else if (phase == 2) {
    /* Section 4.2: each vertex's sigma after phase 1 becomes its corner-ball radius. */
    for (int32_t i = 0; i < s->n; ++i)
      if (s->dim[i] == PM_VERTEX) s->corner[s->cell[i]] = s->sigma[i];
    s->gap_curves = s->size == NULL;
    s->gap_faces = 0;
  } else {
    /* The new optimization uses the fixed positions of the previous phases (section 3). */
    for (int32_t i = 0; i < s->n; ++i) s->fixed[i] = 1, s->frozen[i] = 1;
    s->gap_faces = s->size == NULL;
    if ((st = psys_build_chains(s, err))) return st;
    const int32_t nf = s->model->count[PM_FACE];
    free(s->face_on);
    if (!(s->face_on = calloc((size_t)nf + 1, 1)))
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t f = 0; f < nf; ++f) s->face_on[f] = !faces || faces[f];
    if ((st = seed_faces(s, err))) return st;
  }
  psys_clock_add(s, PSYS_T_SEEDING, pm_seconds() - tc);
  const double move_tol =
      phase == 3 && s->p.move_tol_faces > 0 ? s->p.move_tol_faces : s->p.move_tol;
  double a = 1;
  int pop_on = 1;
  int32_t hist[POP_WINDOW]; /* particle counts of the last POP_WINDOW iterations */
  for (int64_t it = 0;; ++it) {
    psys_move_info mi;
    int32_t sp = 0, de = 0;
    /* particles added since the last spatial ordering sit at the end of the arrays, far from
     * their neighbours in memory: order again once they are a quarter of all (psys_reorder) */
    if ((double)(s->next_serial - s->ordered_serial) > REORDER_FRACTION * s->n) {
      tc = pm_seconds();
      if ((st = psys_reorder(s, err))) return st;
      psys_clock_add(s, PSYS_T_NEIGHBOURS, pm_seconds() - tc);
    }
    const int held = phase == 3 && !pop_on && s->p.hold_sigma && !s->unsized;
    if (held) psys_nbr_hold(s);
    if (!held && (st = psys_sigma_update(s, err))) return st;
    if ((st = psys_move_pass(s, &mi, err))) return st;
    tc = pm_seconds();
    /* the population's own time: the neighbour structure's work in it is counted as such */
    const double nbr0 = s->tstep[phase - 1][PSYS_T_NEIGHBOURS];
    const int32_t hungry = pop_on && a == 1 ? psys_hungry_count(s) : 0; /* fresh energies */
    if (pop_on && (st = psys_population_pass(s, a, &sp, &de, err))) return st;
    psys_clock_add(s, PSYS_T_POPULATION,
                   pm_seconds() - tc - (s->tstep[phase - 1][PSYS_T_NEIGHBOURS] - nbr0));
    rep->iterations = it + 1;
    /* the count POP_WINDOW iterations ago, then this one in its place */
    int32_t then = it >= POP_WINDOW ? hist[it % POP_WINDOW] : -1;
    hist[it % POP_WINDOW] = s->n;
    int done = 0;
    if (pop_on) {
      if (a == 1) {
        int calm = psys_count_settled(s->n, then, hungry, s->p.pop_tol, s->p.hungry_tol);

        if (calm || it + 1 >= s->p.anneal_after) a *= s->p.anneal_rate;
      } else {
        a *= s->p.anneal_rate;
        if (a < s->p.anneal_off) pop_on = 0;
      }
    } else if (mi.mean_rel < move_tol) {
      done = 1, rep->converged = 1;
    }
    if (mi.movable == 0 && sp == 0 && de == 0 && s->n > 0) {
      /* nothing can move and nothing changed: only splits could, and there were none */
      int movable = 0;
      for (int32_t i = 0; i < s->n && !movable; ++i) movable = !s->fixed[i];
      if (!movable) done = 1, rep->converged = 1;
    }
    if (!done && it + 1 >= s->p.max_iter) done = 1;
    int frame = done || it % s->p.frame_every == 0;
    if ((st = observe(s, obs, &mi, sp, de, pop_on ? a : 0, frame, err))) return st;
    s->iter++;
    if (done) break;
  }
  rep->particles = s->n;
  rep->seconds = pm_seconds() - t0;
  return PM_OK;
}

pm_status psys_optimize(psys_sys *s, const psys_observer *obs, psys_phase_report rep[3],
                        pm_error *err) {
  memset(rep, 0, 3 * sizeof *rep);
  pm_status st = pm_observe_trace_columns(obs ? obs->run : NULL, NTRACE, trace_cols, err);
  if (!st) st = psys_run_phase(s, 1, NULL, obs, &rep[0], err);
  if (st) return pm_error_prefix(err, "psys phase 1");
  if (!s->size && (st = psys_run_phase(s, 2, NULL, obs, &rep[1], err)))
    return pm_error_prefix(err, "psys phase 2");
  if (s->size) rep[1].converged = 1, rep[1].particles = s->n;
  if ((st = psys_run_phase(s, 3, NULL, obs, &rep[2], err)))
    return pm_error_prefix(err, "psys phase 3");
  return PM_OK;
}

pm_status psys_to_mesh(const psys_sys *s, pm_mesh **out, pm_error *err) {
  *out = NULL;
  pm_mesh *m = pm_mesh_create();
  if (!m) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status st = pm_mesh_reserve(m, s->n, 0, 0, 0, err);
  for (int32_t i = 0; i < s->n && !st; ++i)
    st = pm_mesh_add_node(m, &s->xyz[3 * i], s->dim[i], s->cell[i],
                          s->dim[i] == PM_VERTEX ? NULL : &s->par[2 * i], NULL, err);
  if (st) {
    pm_mesh_destroy(m);
    return st;
  }
  *out = m;
  return PM_OK;
}
