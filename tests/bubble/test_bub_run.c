/* Whole runs of the bubble method on planar cases: a valid mesh of good quality (pm_mesh_check on
 * every mesh), the same mesh for the same seed and for 1 or 2 threads, trace and frames, the
 * classic settings and RK2, the default size rule, caps and bad input. */
#include "bub_test_util.h"

#include <sys/stat.h>
#include <unistd.h>

#include "common/report/run_report.h"
#include "common/input/cases.h"
#include "common/report/frames.h"
#include "common/geom/geom_cad.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"
#include "common/sizing/sizing.h"
#include "common/report/stats.h"
#include "common/report/trace.h"

static pm_mesh *run(const pm_model *m, const pm_sizing *size, const bub_params *p, int threads,
                    pm_trace *tr, pm_frames *fr, pm_run_output *out) {
  pm_run_report report = {NULL, tr, fr};
  pm_run_observer observer;
  pm_run_report_observer(&report, &observer);
  pm_run_input in = {m, size, 11, threads, 0, PM_DEFAULT_MAX_NODES, &observer};
  pm_error e = {0};
  memset(out, 0, sizeof *out);
  PM_ASSERT_OK(bub_run(&in, p, out, &e), e);
  assert_non_null(out->mesh);
  return out->mesh;
}

static void check_valid(const pm_mesh *mesh, const pm_model *m) {
  pm_check_report r;
  memset(&r, 0, sizeof r);
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &r, &e), e);
  for (int i = 0; i < r.nproblem; ++i) print_error("problem: %s\n", r.problem[i]);
  assert_true(r.valid);
  pm_check_report_clear(&r);
}

/* A run with its statistics in *st (pm_stats_clear after), checked valid and measured into *q
 * (pm_quality_clear after); out->mesh is the caller's. */
static void run_measured(const pm_model *m, const pm_sizing *size, const bub_params *p, int threads,
                         pm_run_output *out, pm_stats *st, pm_quality *q) {
  pm_error e = {0};
  pm_stats_init(st);
  pm_run_report report = {st, NULL, NULL};
  pm_run_observer observer;
  pm_run_report_observer(&report, &observer);
  pm_run_input in = {m, size, 11, threads, 0, PM_DEFAULT_MAX_NODES, &observer};
  memset(out, 0, sizeof *out);
  PM_ASSERT_OK(bub_run(&in, p, out, &e), e);
  check_valid(out->mesh, m);
  PM_ASSERT_OK(pm_quality_compute(out->mesh, size, q, &e), e);
}

/* Everything run_measured (and its caller's flattening, model and field) made. */
static void release_measured(pm_stats_flat *fl, pm_stats *st, pm_quality *q, pm_run_output *out,
                             pm_sizing *size, pm_model *m) {
  pm_stats_flat_clear(fl);
  pm_stats_clear(st);
  pm_quality_clear(q);
  pm_mesh_destroy(out->mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* qi4 (papers/004 section 3.4): valid, well shaped, converged by the self-adaptive stop. */
static void qi4_quality(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("qi4", &m, &size, &e), e);
  bub_params p;
  bub_params_init(&p);
  pm_run_output out;
  pm_stats st;
  pm_quality q;
  run_measured(m, size, &p, 2, &out, &st, &q);
  assert_true(q.tri.s_radius_ratio.mean >= 0.95);
  assert_true(q.tri.s_min_angle.min >= 25);
  /* Edges as long as the size field asks (within 5%). */
  assert_true(fabs(q.tri.size_ratio.mean - 1) < 0.05);
  assert_true(out.mesh->nnode > 450 && out.mesh->nnode < 700);
  assert_non_null(strstr(out.stop_reason, "converged"));
  assert_true(out.iterations > 20);
  /* Phase times and extras. */
  pm_stats_flat fl;
  PM_ASSERT_OK(pm_stats_flatten(&st, &fl, &e), e);
  assert_non_null(pm_stats_flat_find(&fl, "time_s.place"));
  assert_non_null(pm_stats_flat_find(&fl, "time_s.connect"));
  const pm_stats_item *it = pm_stats_flat_find(&fl, "bubble.steps");
  assert_non_null(it);
  PM_ASSERT_NEAR(it->num, (double)out.iterations, 0);
  release_measured(&fl, &st, &q, &out, size, m);
}

/* Held lattice interiors (hold_rings, bub_lattice.c "Holding"): on qi1's uniform field (the
 * rectangle [-1, 1] x [-2, 2], d = 0.1: the lattice grows from a long side, x = 1, and its rows
 * fit 23.09 times across) the grown lattice is perfect but for the seam where its rows meet the
 * far side. Relaxing every bubble spreads that misfit as a strain
 * over every row (the median R / l_min 0.5799, measured); holding the bubbles 4 rings inside the
 * grain relaxes the seam alone, as a front leaves its misfit in one seam (0.5774; gmsh-frontal at
 * the same node count 0.5775), with as good a mean radius ratio (0.9947 against 0.9949 with RK4;
 * 0.9934 against 0.9939 with the default symplectic step, whose relaxation keeps other defects at
 * the seam: the mean radius ratio moves by as much from a 1% change of the size). The held
 * bubbles stay exactly where the lattice put them: the interior rows are straight to the bit. */
static void held_lattice_keeps_its_rows(void **state) {
  (void)state;
  double median[2], rr[2];
  int32_t straight[2];
  for (int hold = 0; hold < 2; ++hold) {
    pm_model *m = NULL;
    pm_sizing *size = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_case_open("qi1", &m, &size, &e), e);
    bub_params p;
    bub_params_init(&p);
    assert_int_equal(p.hold_rings, 4); /* the default */
    if (!hold) p.hold_rings = 0;
    pm_run_output out;
    pm_stats st;
    pm_quality q;
    run_measured(m, size, &p, 1, &out, &st, &q);
    median[hold] = q.tri.s_aspect_ratio.median, rr[hold] = q.tri.s_radius_ratio.mean;
    /* Face nodes in the middle of the rectangle on their lattice row: x on a multiple of
     * 0.1 sqrt(3) / 2 from the side x = 1, to 1e-10. */
    straight[hold] = 0;
    for (int32_t i = 0; i < out.mesh->nnode; ++i) {
      const double *x = &out.mesh->xyz[3 * i];
      if (out.mesh->node_dim[i] != PM_FACE || fabs(x[0]) > 0.5 || fabs(x[1]) > 1) continue;
      double row = (1 - x[0]) / (0.05 * sqrt(3.0));
      straight[hold] += fabs(row - round(row)) < 1e-10;
    }
    print_message("hold_rings=%d: median R/l_min %.4f, mean radius ratio %.4f, %d middle nodes on "
                  "their rows\n", p.hold_rings, median[hold], rr[hold], straight[hold]);
    pm_stats_flat none = {0};
    release_measured(&none, &st, &q, &out, size, m);
  }
  assert_true(median[0] > 0.579);
  assert_true(median[1] < 0.5776);
  assert_true(rr[1] > 0.993 && rr[1] > rr[0] - 0.001);
  assert_true(straight[0] < 10);
  assert_true(straight[1] > 100);
}

/* A run on the torus case (one doubly periodic face) at d = 0.06, about 4300 bubbles:
 * the bubbles population control inserted and removed, the steps, the mean radius ratio. */
typedef struct torus_run {
  double changes, steps, rr;
} torus_run;

static torus_run torus_with(const bub_params *p) {
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("torus", &m, NULL, &e), e);
  PM_ASSERT_OK(pm_sizing_constant(0.06, &size, &e), e);
  pm_run_output out;
  pm_stats st;
  pm_quality q;
  run_measured(m, size, p, 1, &out, &st, &q);
  pm_stats_flat fl;
  PM_ASSERT_OK(pm_stats_flatten(&st, &fl, &e), e);
  const pm_stats_item *ins = pm_stats_flat_find(&fl, "bubble.insertions"), *del = pm_stats_flat_find(&fl, "bubble.deletions");
  assert_non_null(ins);
  assert_non_null(del);
  torus_run r = {ins->num + del->num, (double)out.iterations, q.tri.s_radius_ratio.mean};
  release_measured(&fl, &st, &q, &out, size, m);
  return r;
}

/* The cut-offs of curved faces (curved_open, curved_excess: 000's 5 and 8 by default) against the
 * planes' (face_open 5.6, face_excess 7): the narrow window exchanges the bubbles at the torus's
 * defects at every control (3020 inserted and removed, 4 rounds, when measured) where the wide
 * one leaves them (244, 3 rounds). */
static void curved_cutoffs(void **state) {
  (void)state;
  bub_params p;
  bub_params_init(&p);
  PM_ASSERT_NEAR(p.curved_open, 5, 0);
  PM_ASSERT_NEAR(p.curved_excess, 8, 0);
  torus_run wide = torus_with(&p);
  p.curved_open = p.curved_excess = 0; /* the face cut-offs */
  torus_run narrow = torus_with(&p);
  if (!(wide.changes < 0.3 * narrow.changes))
    fail_msg("changes: curved cut-offs %.0f, face cut-offs %.0f", wide.changes, narrow.changes);
  assert_true(wide.steps < narrow.steps);
  assert_true(wide.rr > 0.97 && narrow.rr > 0.97);
  /* Bad relations are refused. */
  pm_error e = {0};
  bub_params_init(&p);
  p.curved_open = 6.5;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "curved_open"));
}

/* The final steps' damping (final_zeta): the schedule's value before population control ends and
 * with final_zeta = -1 (or automatic with rk2), final_zeta after; on the torus 0.3 relaxes
 * further in the same final steps than the saw-tooth's cap 1.5. */
static void final_damping(void **state) {
  (void)state;
  bub_params p;
  bub_params_init(&p);
  PM_ASSERT_NEAR(p.final_zeta, 0, 0); /* automatic: 0.3 with rk4 and symplectic */
  PM_ASSERT_NEAR(bub_final_zeta(&p), 0.3, 0);
  pm_model *m = bt_square(0, 0, 4);
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(1, &size, &e), e);
  bub_state *s = bt_state(m, size, &p, 1);
  s->steps_in_round = 100; /* the saw-tooth at its cap */
  PM_ASSERT_NEAR(bub_zeta_curved(s), p.zeta_max, 1e-15);
  s->final_phase = 1;
  PM_ASSERT_NEAR(bub_zeta_curved(s), 0.3, 0);
  PM_ASSERT_NEAR(bub_zeta_now(s), p.zeta_max, 1e-15); /* (planes keep the schedule) */
  s->p.final_zeta = -1; /* the schedule */
  PM_ASSERT_NEAR(bub_zeta_curved(s), p.zeta_max, 1e-15);
  s->p.final_zeta = 0, s->p.integrator = BUB_RK2; /* automatic with rk2: the schedule */
  PM_ASSERT_NEAR(bub_zeta_curved(s), p.zeta_max, 1e-15);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
  torus_run low = torus_with(&p); /* final_zeta 0.3 */
  p.final_zeta = -1;
  torus_run cap = torus_with(&p);
  if (!(low.rr > cap.rr)) fail_msg("mean radius ratio: final_zeta 0.3 %.5f, the schedule %.5f", low.rr, cap.rr);
  /* An unstable final damping is refused (the overdamped fast root -2 zeta w0 leaves RK4's
   * region above about 2.2 at the default step); the symplectic step damps implicitly and
   * takes it. */
  bub_params_init(&p);
  p.final_zeta = 10, p.integrator = BUB_RK4;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "final_zeta"));
  p.integrator = BUB_SYMPLECTIC;
  PM_ASSERT_OK(bub_params_check(&p, &e), e);
}

static int same_mesh(const pm_mesh *a, const pm_mesh *b) {
  return a->nnode == b->nnode && a->ntri == b->ntri && a->nseg == b->nseg &&
         !memcmp(a->xyz, b->xyz, sizeof(double) * 3 * (size_t)a->nnode) &&
         !memcmp(a->tri, b->tri, sizeof(int32_t) * 3 * (size_t)a->ntri);
}

/* Same seed: the identical mesh twice, and with 1 or 2 threads (qi1 at d = 0.03: about 10500
 * bubbles, above BUB_PARALLEL_MIN, so the second run does use 2 threads). */
static void determinism(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("qi1", &m, NULL, &e), e);
  PM_ASSERT_OK(pm_sizing_constant(0.03, &size, &e), e);
  bub_params p;
  bub_params_init(&p);
  p.max_steps = 45; /* a few controls are enough to exercise everything */
  pm_run_output o1, o2, o3;
  pm_mesh *a = run(m, size, &p, 1, NULL, NULL, &o1);
  pm_mesh *b = run(m, size, &p, 1, NULL, NULL, &o2);
  pm_mesh *c = run(m, size, &p, 2, NULL, NULL, &o3);
  assert_true(same_mesh(a, b));
  assert_true(same_mesh(a, c));
  assert_int_equal(o1.iterations, o3.iterations);
  assert_true(a->nnode > BUB_PARALLEL_MIN);
  check_valid(a, m);
  pm_mesh_destroy(a), pm_mesh_destroy(b), pm_mesh_destroy(c);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

static int file_exists(const char *path) { return access(path, R_OK) == 0; }

/* --trace: one row per step with the documented columns; --frames: .vtu, .svg and the .pvd. */
static void trace_and_frames(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 1);
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(0.1, &size, &e), e);
  char dir[] = "/tmp/bub_frames_XXXXXX";
  assert_non_null(mkdtemp(dir));
  pm_trace *tr = NULL;
  pm_frames *fr = NULL;
  PM_ASSERT_OK(pm_trace_create(&tr, &e), e);
  PM_ASSERT_OK(pm_frames_create(dir, m, &fr, &e), e);
  bub_params p;
  bub_params_init(&p);
  pm_run_output out;
  run(m, size, &p, 1, tr, fr, &out);
  check_valid(out.mesh, m);
  /* The method only adds snapshots; the caller closes the series (method.h). */
  PM_ASSERT_OK(pm_frames_finish(fr, &e), e);
  const char *want[] = {"step", "bubbles", "kinetic", "potential", "mean_disp", "max_disp",
                        "insertions", "deletions", "eps_t"};
  for (int k = 0; k < 9; ++k) assert_string_equal(pm_trace_column(tr, k), want[k]);
  assert_string_equal(pm_trace_column(tr, 14), "nodes");
  assert_string_equal(pm_trace_column(tr, 15), "event");
  /* One row per step (event 0), steps counting up; a row per population control (event 1) with
   * its insertions and deletions, between the step it follows and the next; the border cleanup
   * (2) when it drops bubbles; last the mesh (3), whose nodes are the mesh's. The node count of
   * a control row is the step's plus its insertions less its deletions. */
  int64_t steps = 0, controls = 0;
  double nodes = 0;
  const int64_t nrow = pm_trace_nrow(tr);
  for (int64_t r = 0; r < nrow; ++r) {
    const double *row = pm_trace_row(tr, r);
    if (row[15] == 0) {
      PM_ASSERT_NEAR(row[0], ++steps, 0);
      PM_ASSERT_NEAR(row[6] + row[7], 0, 0);
    } else if (row[15] == 1) {
      ++controls;
      PM_ASSERT_NEAR(row[0], steps, 0);
      PM_ASSERT_NEAR(row[14], nodes + row[6] - row[7], 0);
    } else {
      assert_true(row[15] == 2 || (row[15] == 3 && r == nrow - 1));
    }
    nodes = row[14];
  }
  assert_int_equal(steps, out.iterations);
  assert_true(controls >= 1);
  PM_ASSERT_NEAR(pm_trace_row(tr, nrow - 1)[15], 3, 0);
  PM_ASSERT_NEAR(pm_trace_row(tr, nrow - 1)[14], out.mesh->nnode, 0);
  char path[512];
  snprintf(path, sizeof path, "%s/frames.pvd", dir);
  assert_true(file_exists(path));
  snprintf(path, sizeof path, "%s/frame_000000.vtu", dir);
  assert_true(file_exists(path));
  snprintf(path, sizeof path, "%s/frame_000000.svg", dir);
  assert_true(file_exists(path));
  snprintf(path, sizeof path, "%s/frame_000000.dat", dir);
  assert_true(file_exists(path));
  assert_true(pm_frames_count(fr) >= 2);
  for (int32_t k = 0; k < pm_frames_count(fr); ++k) {
    snprintf(path, sizeof path, "%s/frame_%06d.vtu", dir, (int)k);
    unlink(path);
    snprintf(path, sizeof path, "%s/frame_%06d.svg", dir, (int)k);
    unlink(path);
    snprintf(path, sizeof path, "%s/frame_%06d.dat", dir, (int)k);
    unlink(path);
  }
  snprintf(path, sizeof path, "%s/frames.pvd", dir);
  unlink(path);
  assert_int_equal(rmdir(dir), 0); /* every file the frames wrote was removed above */
  pm_frames_destroy(fr);
  pm_trace_destroy(tr);
  pm_mesh_destroy(out.mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* The classic settings (constant damping, w2 = 1, no adaptive stop) and Heun's RK2 both give
 * valid meshes; the classic run ends on the displacement tolerance or the step cap. */
static void classic_and_rk2(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("qi4", &m, &size, &e), e);
  bub_params p;
  bub_params_init(&p);
  p.viscosity = BUB_VISC_CONSTANT, p.w2 = 1, p.adaptive_stop = 0, p.max_steps = 400;
  pm_run_output out;
  run(m, size, &p, 2, NULL, NULL, &out);
  check_valid(out.mesh, m);
  assert_true(strstr(out.stop_reason, "max steps") || strstr(out.stop_reason, "moved more than"));
  pm_mesh_destroy(out.mesh);
  bub_params_init(&p);
  p.integrator = BUB_RK2;
  run(m, size, &p, 2, NULL, NULL, &out);
  check_valid(out.mesh, m);
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute(out.mesh, size, &q, &e), e);
  assert_true(q.tri.s_radius_ratio.mean >= 0.94);
  pm_quality_clear(&q);
  pm_mesh_destroy(out.mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* The default size rule on a square with a short notch edge: D/30 far away, the edge's length at
 * the edge, growth 0.3 per unit distance in between; a run without a size uses it. */
static void default_size(void **state) {
  (void)state;
  /* A 4 x 4 square with a 0.05-wide, 0.05-deep notch in its bottom side at x = 2. */
  const pm_planar_piece pc[8] = {
      {PM_PIECE_LINE, {0, 0}, {0, 0}, 0},    {PM_PIECE_LINE, {2, 0}, {0, 0}, 0},
      {PM_PIECE_LINE, {2, 0.05}, {0, 0}, 0}, {PM_PIECE_LINE, {2.05, 0.05}, {0, 0}, 0},
      {PM_PIECE_LINE, {2.05, 0}, {0, 0}, 0}, {PM_PIECE_LINE, {4, 0}, {0, 0}, 0},
      {PM_PIECE_LINE, {4, 4}, {0, 0}, 0},    {PM_PIECE_LINE, {0, 4}, {0, 0}, 0}};
  pm_planar_loop lp = {8, pc};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("notch", 1, &lp, &m, &e), e);
  bub_params p;
  bub_params_init(&p);
  pm_sizing *exact = NULL;
  void *rule = NULL;
  PM_ASSERT_OK(bub_size_rule_create(m, &p, &exact, &rule, &e), e);
  double D = m->diagonal, far[3] = {0.5, 3.5, 0}, at[3] = {2.025, 0.05, 0}, mid[3] = {2.025, 1.05, 0};
  PM_ASSERT_NEAR(pm_sizing_eval(exact, far), D / 30, 1e-12);
  PM_ASSERT_NEAR(pm_sizing_eval(exact, at), 0.05, 1e-9);
  /* One unit above the notch's top edge: 0.05 + 0.3 x 1 (below D / 30 = 0.189? no: 0.35 > 0.189). */
  PM_ASSERT_NEAR(pm_sizing_eval(exact, mid), D / 30, 1e-12);
  double near[3] = {2.025, 0.3, 0};
  PM_ASSERT_NEAR(pm_sizing_eval(exact, near), 0.05 + 0.3 * 0.25, 1e-9);
  /* g-Lipschitz along a line. */
  double prev = -1;
  for (int k = 0; k <= 400; ++k) {
    double x[3] = {k * 0.01, 0.2, 0}, v = pm_sizing_eval(exact, x);
    if (prev >= 0) assert_true(fabs(v - prev) <= 0.3 * 0.01 * (1 + 1e-9));
    prev = v;
  }
  /* bub_default_size: the same rule sampled on a triangulation; within 10% of the exact one on
   * the face. */
  pm_sizing *sampled = NULL;
  PM_ASSERT_OK(bub_default_size(m, &p, 1, 1, &sampled, &e), e);
  for (int k = 0; k < 50; ++k) {
    double x[3] = {0.1 + 0.076 * k, 0.02 + 0.079 * k, 0};
    double a = pm_sizing_eval(exact, x), b = pm_sizing_eval(sampled, x);
    assert_true(fabs(a - b) <= 0.1 * a);
  }
  /* A run without a size field. */
  pm_run_output out;
  pm_mesh *mesh = run(m, NULL, &p, 2, NULL, NULL, &out);
  check_valid(mesh, m);
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute(mesh, exact, &q, &e), e);
  assert_true(q.tri.s_min_angle.min >= 20);
  assert_true(fabs(q.tri.size_ratio.mean - 1) < 0.1);
  pm_quality_clear(&q);
  pm_mesh_destroy(mesh);
  pm_sizing_destroy(sampled);
  pm_sizing_destroy(exact);
  bub_size_rule_free(rule);
  pm_model_destroy(m);
}

/* Caps and bad input: one-line errors, no mesh. */
static void caps_and_errors(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 1);
  pm_sizing *size = NULL, *neg = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(0.05, &size, &e), e);
  bub_params p;
  bub_params_init(&p);
  pm_run_output out;
  memset(&out, 0, sizeof out);
  /* At d = 0.05 the square wants about 500 nodes (the estimate: 462 inside the square); the
   * sparse start has fewer than 300. A cap below 462 / 1.5 is refused before the first bubble,
   * naming the cap and the count the field needs. */
  pm_run_input in = {m, size, 1, 1, 0, 100, NULL};
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_null(out.mesh);
  assert_null(strchr(e.msg, '\n'));
  assert_non_null(strstr(e.msg, "the size field would need about 4"));
  assert_non_null(strstr(e.msg, "over the node cap 100"));
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  p.max_bubbles = 300;
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_null(out.mesh);
  assert_non_null(strstr(e.msg, "over the cap max_bubbles 300"));
  /* The method's own cap ends the run when insertions reach it; the run's node budget is an
   * error. (The lattice starts with about 500 bubbles and would fail at once, naming the cap;
   * the quadtree's sparse start has fewer than 400.) */
  p.max_bubbles = 400;
  p.place = BUB_PLACE_QUADTREE;
  PM_ASSERT_OK(bub_run(&in, &p, &out, &e), e);
  assert_non_null(strstr(out.stop_reason, "bubble cap (400) reached"));
  assert_true(out.mesh->nnode <= 400);
  pm_check_report cr;
  memset(&cr, 0, sizeof cr);
  PM_ASSERT_OK(pm_mesh_check(out.mesh, m, &cr, &e), e);
  assert_true(cr.valid);
  pm_check_report_clear(&cr);
  pm_mesh_destroy(out.mesh);
  out.mesh = NULL;
  bub_params_init(&p);
  in.max_nodes = 400;
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "node budget of 400"));
  assert_null(out.mesh);
  /* A size far too fine for the cap fails before any bubble is placed, naming the cap. */
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  bub_params_init(&p);
  pm_sizing *tiny = NULL;
  PM_ASSERT_OK(pm_sizing_constant(1e-5, &tiny, &e), e); /* about 1.2e10 bubbles */
  in.size = tiny;
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "over the cap max_bubbles 10000000"));
  assert_null(out.mesh);
  { /* the placement itself: nothing placed, the check comes first */
    bub_state *s = bt_state(m, tiny, &p, 1);
    assert_int_equal(bub_place(s, &e), PM_ERR_LIMIT);
    assert_int_equal(s->n, 0);
    assert_non_null(strstr(e.msg, "cap of 10000000"));
    bub_state_destroy(s);
  }
  in.size = size;
  pm_sizing_destroy(tiny);
  p.k0 = 0;
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "k0"));
  bub_params_init(&p);
  p.w2 = 2;
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "w2"));
  bub_params_init(&p);
  PM_ASSERT_OK(pm_sizing_expression("x - 5", &neg, &e), e); /* negative on the square */
  in.size = neg;
  assert_int_equal(bub_run(&in, &p, &out, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "size"));
  assert_null(out.mesh);
  pm_sizing_destroy(neg);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(qi4_quality),      cmocka_unit_test(determinism),
      cmocka_unit_test(curved_cutoffs),   cmocka_unit_test(final_damping),
      cmocka_unit_test(trace_and_frames), cmocka_unit_test(classic_and_rk2),
      cmocka_unit_test(default_size),     cmocka_unit_test(caps_and_errors),
      cmocka_unit_test(held_lattice_keeps_its_rows),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
