/* The psys method end to end through the library (pm_method): valid meshes of the inferred
 * field, the same seed giving the same mesh with 1 or 2 threads, volumes, the trace and frames.
 * Every mesh goes through pm_mesh_check. */
#include "test_psys_run_util.h"

#include <unistd.h>

/* The inferred field on built-in solids: valid, decent meshes, the stats keys. */
static void inferred_field_meshes(void **state) {
  (void)state;
  const char *cases[] = {"case:boxhole", "case:torus", "case:cylinder"};
  for (int k = 0; k < 3; ++k) {
    pm_model *m = psys_test_open(cases[k]);
    pm_stats st;
    pm_stats_init(&st);
    pm_mesh *mesh = psys_test_run(m, NULL, 1, 2, 0, NULL, &st, NULL, NULL);
    psys_test_assert_valid(mesh, m);
    assert_true(mesh->ntri > 200);
    pm_summary a = psys_test_aspect(mesh, NULL, NULL);
    /* an equilateral triangle has 0.577; a particle packing stays close (papers/001 Fig. 11) */
    if (!(a.median < 0.68 && a.p75 < 0.75 && a.max < 3))
      fail_msg("%s: R/l_min median %g p75 %g max %g", cases[k], a.median, a.p75, a.max);
    /* phase times and iteration counts */
    int times = 0;
    for (int32_t q = 0; q < st.ntime; ++q)
      times += !strcmp(st.time[q].key, "phase1") || !strcmp(st.time[q].key, "phase2") ||
               !strcmp(st.time[q].key, "phase3") || !strcmp(st.time[q].key, "connect");
    assert_int_equal(times, 4);
    double it3 = -1, np = -1;
    for (int32_t q = 0; q < st.nextra; ++q) {
      if (!strcmp(st.extra[q].key, "psys.iterations.phase3")) it3 = st.extra[q].num;
      if (!strcmp(st.extra[q].key, "psys.particles")) np = st.extra[q].num;
    }
    assert_true(it3 > 0);
    assert_true(np > 0 && np <= mesh->nnode);
    pm_stats_clear(&st);
    pm_mesh_destroy(mesh);
    pm_model_destroy(m);
  }
}

/* The same seed gives the same mesh, to the bit, twice and with 1 or 2 threads; another seed
 * gives another mesh. */
static void same_seed_same_mesh(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:boxhole");
  pm_mesh *a = psys_test_run(m, NULL, 42, 1, 0, NULL, NULL, NULL, NULL);
  pm_mesh *b = psys_test_run(m, NULL, 42, 1, 0, NULL, NULL, NULL, NULL);
  pm_mesh *c = psys_test_run(m, NULL, 42, 2, 0, NULL, NULL, NULL, NULL);
  pm_mesh *d = psys_test_run(m, NULL, 43, 2, 0, NULL, NULL, NULL, NULL);
  const pm_mesh *same[2] = {b, c};
  for (int k = 0; k < 2; ++k) {
    assert_int_equal(a->nnode, same[k]->nnode);
    assert_int_equal(a->ntri, same[k]->ntri);
    assert_int_equal(a->nseg, same[k]->nseg);
    assert_memory_equal(a->xyz, same[k]->xyz, sizeof(double) * 3 * (size_t)a->nnode);
    assert_memory_equal(a->tri, same[k]->tri, sizeof(int32_t) * 3 * (size_t)a->ntri);
  }
  assert_true(a->nnode != d->nnode ||
              memcmp(a->xyz, d->xyz, sizeof(double) * 3 * (size_t)a->nnode) != 0);
  pm_mesh_destroy(a), pm_mesh_destroy(b), pm_mesh_destroy(c), pm_mesh_destroy(d);
  pm_model_destroy(m);
}

/* The same seed gives the same mesh, to the bit, with 1, 2 and 4 threads: on a planar case, on a
 * CAD model with curved faces in closed form (screw.step: cylinder, cone, tori, planes) and on
 * one whose surface gmsh evaluates (synth_bspline_patch.brep: a B-spline patch, its trial points
 * evaluated in batches). */
static void same_mesh_with_1_2_4_threads(void **state) {
  (void)state;
  char buf[2][512];
  const char *inputs[3] = {"case:qi1", NULL, NULL};
  int ninputs = 1;
  if (pm_test_have_cad()) {
    inputs[ninputs++] = pm_test_cad("screw.step", buf[0], sizeof buf[0]);
    inputs[ninputs++] = pm_test_cad("synth_bspline_patch.brep", buf[1], sizeof buf[1]);
  }
  for (int k = 0; k < ninputs; ++k) {
    pm_model *m = psys_test_open(inputs[k]);
    pm_mesh *a = psys_test_run(m, NULL, 5, 1, 0, NULL, NULL, NULL, NULL);
    psys_test_assert_valid(a, m);
    assert_true(a->ntri > 100);
    for (int t = 2; t <= 4; t += 2) {
      pm_mesh *b = psys_test_run(m, NULL, 5, t, 0, NULL, NULL, NULL, NULL);
      if (a->nnode != b->nnode || a->ntri != b->ntri ||
          memcmp(a->xyz, b->xyz, sizeof(double) * 3 * (size_t)a->nnode) ||
          memcmp(a->tri, b->tri, sizeof(int32_t) * 3 * (size_t)a->ntri))
        fail_msg("%s: the mesh with %d threads differs from the one with 1 (%d / %d nodes)",
                 inputs[k], t, b->nnode, a->nnode);
      pm_mesh_destroy(b);
    }
    pm_mesh_destroy(a);
    pm_model_destroy(m);
  }
}

/* --volume: TetGen's quality refinement of the surface mesh (papers/001 section 4.4). */
static void volume_with_tets(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:cylinder");
  pm_mesh *mesh = psys_test_run(m, NULL, 1, 2, 1, NULL, NULL, NULL, NULL);
  psys_test_assert_valid(mesh, m);
  assert_true(mesh->ntet > 100);
  pm_quality q;
  pm_error e = {0};
  PM_ASSERT_OK(pm_quality_compute(mesh, NULL, &q, &e), e);
  /* TetGen -q1.5 bounds the radius-edge ratio R / l_min of the tets it can refine (a regular
   * tet has 0.612) */
  assert_true(q.tet.s_aspect_ratio.median < 1.2);
  assert_true(q.tet.s_aspect_ratio.max < 2.0);
  pm_quality_clear(&q);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* --trace rows and --frames snapshots. */
static void trace_and_frames(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:cylinder");
  pm_trace *tr = NULL;
  pm_frames *fr = NULL;
  pm_error e = {0};
  char dir[256];
  snprintf(dir, sizeof dir, "%s/psys_frames_%d", PM_BINARY_DIR, (int)getpid());
  PM_ASSERT_OK(pm_trace_create(&tr, &e), e);
  PM_ASSERT_OK(pm_frames_create(dir, m, &fr, &e), e);
  const char *sets[] = {"frame_every=5", NULL};
  pm_stats st;
  pm_stats_init(&st);
  pm_mesh *mesh = psys_test_run(m, NULL, 1, 1, 0, sets, &st, tr, fr);
  PM_ASSERT_OK(pm_frames_finish(fr, &e), e);
  const char *cols[] = {"iteration", "phase", "particles", "energy", "mean_move", "max_move",
                        "splits", "deletes", "mean_sigma"};
  assert_true(pm_trace_ncol(tr) >= 9);
  for (int k = 0; k < 9; ++k) assert_string_equal(pm_trace_column(tr, k), cols[k]);
  /* one row per iteration (event 0, nodes = particles), phases in order, then the mesh's row
   * (event 3) whose nodes are the mesh's */
  assert_string_equal(pm_trace_column(tr, 11), "nodes");
  assert_string_equal(pm_trace_column(tr, 12), "event");
  const int64_t nrow = pm_trace_nrow(tr);
  assert_true(nrow > 10);
  double ph = 1, splits = 0;
  for (int64_t r = 0; r + 1 < nrow; ++r) {
    const double *row = pm_trace_row(tr, r);
    assert_true(row[1] >= ph);
    ph = row[1];
    splits += row[6];
    assert_true(row[2] > 0 && row[8] > 0);
    PM_ASSERT_NEAR(row[12], 0, 0);
    PM_ASSERT_NEAR(row[11], row[2], 0);
  }
  const double *last = pm_trace_row(tr, nrow - 1);
  PM_ASSERT_NEAR(last[12], 3, 0);
  PM_ASSERT_NEAR(last[11], mesh->nnode, 0);
  PM_ASSERT_NEAR(last[2], pm_trace_row(tr, nrow - 2)[2], 0);
  assert_true(ph == 3);
  assert_true(splits > 50);
  /* a snapshot every 5 iterations, and one at the end of each phase */
  assert_true(pm_frames_count(fr) >= pm_trace_nrow(tr) / 5);
  char path[512];
  snprintf(path, sizeof path, "%s/frames.pvd", dir);
  assert_int_equal(access(path, R_OK), 0);
  pm_mesh_destroy(mesh);
  pm_stats_clear(&st);
  pm_frames_destroy(fr);
  pm_trace_destroy(tr);
  pm_model_destroy(m);
  char cmd[600];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  assert_int_equal(system(cmd), 0);
}

/* hold_sigma=1 (the default): once population control is off in phase 3 (trace column anneal 0)
 * sigma no longer changes, so mean_sigma is constant over those rows; with 0 it keeps moving. */
static double held_sigma_drift(const pm_model *m, const char *hold) {
  pm_trace *tr = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_trace_create(&tr, &e), e);
  const char *sets[] = {hold, NULL};
  pm_mesh *mesh = psys_test_run(m, NULL, 1, 1, 0, sets, NULL, tr, NULL);
  psys_test_assert_valid(mesh, m);
  assert_string_equal(pm_trace_column(tr, 9), "anneal");
  double drift = 0, first = 0;
  int64_t quiet = 0;
  for (int64_t r = 0; r < pm_trace_nrow(tr); ++r) {
    const double *row = pm_trace_row(tr, r);
    if (row[1] != 3 || row[9] != 0) continue;
    if (!quiet) first = row[8];
    drift = fmax(drift, fabs(row[8] - first) / first);
    ++quiet;
  }
  assert_true(quiet > 3);
  pm_mesh_destroy(mesh);
  pm_trace_destroy(tr);
  return drift;
}

static void hold_sigma_after_annealing(void **state) {
  (void)state;
  /* the hole's gap size moves with the particles around it */
  pm_model *m = psys_test_open("case:qi2");
  assert_true(held_sigma_drift(m, "hold_sigma=1") == 0);
  /* the gap around the hole follows the particles exactly at every update: the mean sigma
   * drifts by about 3e-4 of itself over the quiet iterations */
  assert_true(held_sigma_drift(m, "hold_sigma=0") > 1e-4);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(inferred_field_meshes),
      cmocka_unit_test(same_seed_same_mesh),
      cmocka_unit_test(same_mesh_with_1_2_4_threads),
      cmocka_unit_test(volume_with_tets),
      cmocka_unit_test(trace_and_frames),
      cmocka_unit_test(hold_sigma_after_annealing),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
