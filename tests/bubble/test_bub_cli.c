/* The bubble method through the packmesh command, end to end: `packmesh mesh case:qi3 --method
 * bubble -o x.msh --stats s.json` and its JSON, --help, --trace, --frames, a CAD file with the
 * default size, --volume, and bad --set values (one line on stderr, a non-zero exit, no output
 * file). */
#include "cli/cli_run.h"

#include <cjson/cJSON.h>
#include <sys/stat.h>
#include <unistd.h>

static char dir[256];

/* bub_private.h's BUB_PARALLEL_MIN (this test sees the command only). */
#define BUB_PARALLEL_MIN_CLI 8192

static int setup(void **state) {
  (void)state;
  snprintf(dir, sizeof dir, "/tmp/pm_test_bub_cli_XXXXXX");
  return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state) {
  (void)state;
  char cmd[600];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  return system(cmd) == 0 ? 0 : -1;
}

static double num(const cJSON *root, const char *a, const char *b, const char *c) {
  const cJSON *o = cJSON_GetObjectItemCaseSensitive(root, a);
  if (b) o = cJSON_GetObjectItemCaseSensitive(o, b);
  if (c) o = cJSON_GetObjectItemCaseSensitive(o, c);
  if (!cJSON_IsNumber(o)) fail_msg("stats key %s.%s.%s missing", a, b ? b : "", c ? c : "");
  return o->valuedouble;
}

static cJSON *read_json(const char *path) {
  char *text = pm_test_slurp(path);
  assert_non_null(text);
  cJSON *j = cJSON_Parse(text);
  free(text);
  assert_non_null(j);
  return j;
}

/* The documented example: qi3 with --stats. */
static void qi3_stats(void **state) {
  (void)state;
  char args[4096], out[512], js[512];
  snprintf(out, sizeof out, "%s/qi3.msh", dir);
  snprintf(js, sizeof js, "%s/qi3.json", dir);
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble -o '%s' --stats '%s' --threads 2", out, js);
  char *o = NULL, *e = NULL;
  int rc = pm_test_cli(dir, args, &o, &e);
  if (rc) fail_msg("exit %d: %s", rc, e);
  free(o), free(e);
  assert_int_equal(access(out, R_OK), 0);
  cJSON *j = read_json(js);
  assert_string_equal(cJSON_GetObjectItemCaseSensitive(j, "method")->valuestring, "bubble");
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "valid")));
  double nodes = num(j, "nodes", NULL, NULL);
  /* 712 +- 10% (papers/004 section 3.3). */
  assert_true(nodes >= 641 && nodes <= 783);
  assert_true(num(j, "tri", "radius_ratio", "mean") >= 0.95);
  assert_true(num(j, "tri", "min_angle_deg", "min") >= 30);
  assert_true(num(j, "iterations", NULL, NULL) > 0);
  assert_true(num(j, "time_s", "place", NULL) >= 0);
  assert_true(num(j, "time_s", "connect", NULL) >= 0);
  assert_true(num(j, "bubble", "steps", NULL) == num(j, "iterations", NULL, NULL));
  cJSON_Delete(j);
}

/* Byte-identical output files (mesh and trace) with 1, 2 and 4 threads and the same seed: on a
 * planar case and on curved CAD faces (frames, batched evaluation), each above BUB_PARALLEL_MIN
 * bubbles so that the threads do share the work. */
static void threads_identical(void **state) {
  (void)state;
  const char *inputs[2][2] = {{"case:qi1", "0.025"}, {"case:torus", "0.03"}};
  for (int c = 0; c < 2; ++c) {
    char *mesh[3] = {NULL, NULL, NULL}, *trace[3] = {NULL, NULL, NULL};
    const int threads[3] = {1, 2, 4};
    for (int k = 0; k < 3; ++k) {
      char args[4096], out[512], tr[512];
      snprintf(out, sizeof out, "%s/thr%d_%d.msh", dir, c, threads[k]);
      snprintf(tr, sizeof tr, "%s/thr%d_%d.csv", dir, c, threads[k]);
      snprintf(args, sizeof args,
               "mesh %s --size %s --method bubble --seed 5 --threads %d -o '%s' --trace '%s'",
               inputs[c][0], inputs[c][1], threads[k], out, tr);
      char *o = NULL, *e = NULL;
      int rc = pm_test_cli(dir, args, &o, &e);
      if (rc) fail_msg("%s: exit %d: %s", args, rc, e);
      free(o), free(e);
      mesh[k] = pm_test_slurp(out), trace[k] = pm_test_slurp(tr);
      assert_non_null(mesh[k]);
      assert_non_null(trace[k]);
    }
    /* Enough bubbles for the parallel loops (the trace's second column, last row). */
    const char *last = strrchr(trace[0], '\n');
    while (last > trace[0] && last[-1] != '\n') --last;
    const char *comma = strchr(last > trace[0] ? last : trace[0], ',');
    assert_non_null(comma);
    assert_true(atof(comma + 1) > BUB_PARALLEL_MIN_CLI);
    for (int k = 1; k < 3; ++k) {
      if (strcmp(mesh[0], mesh[k]) != 0) fail_msg("%s: the mesh differs with %d threads", inputs[c][0], threads[k]);
      if (strcmp(trace[0], trace[k]) != 0) fail_msg("%s: the trace differs with %d threads", inputs[c][0], threads[k]);
    }
    for (int k = 0; k < 3; ++k) free(mesh[k]), free(trace[k]);
  }
}

/* Bad parameters: one line naming the key, a non-zero exit, no mesh file. */
static void bad_sets(void **state) {
  (void)state;
  const char *bad[][2] = {{"k0=0", "k0"},           {"k0=-1", "k0"},  {"zeta=0", "zeta"},
                          {"w2=1.5", "w2"},         {"w2=0", "w2"},   {"nosuchkey=1", "nosuchkey"},
                          {"integrator=euler", "integrator"},
                          {"face_open=9", "face_open"}};
  char out[512], args[1024];
  snprintf(out, sizeof out, "%s/bad.msh", dir);
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    snprintf(args, sizeof args, "mesh case:qi4 --method bubble --set %s -o '%s'", bad[k][0], out);
    char *o = NULL, *e = NULL;
    int rc = pm_test_cli(dir, args, &o, &e);
    int lines = 0;
    for (const char *c = e; *c; ++c) lines += *c == '\n';
    if (rc == 0 || lines != 1 || !strstr(e, bad[k][1]))
      fail_msg("--set %s: exit %d, stderr '%s'", bad[k][0], rc, e);
    free(o), free(e);
    assert_int_not_equal(access(out, F_OK), 0);
  }
}

/* --help lists every parameter with its default and source. */
static void help(void **state) {
  (void)state;
  char *o = NULL, *e = NULL;
  assert_int_equal(pm_test_cli(dir, "mesh --method bubble --help", &o, &e), 0);
  const char *keys[] = {"k0", "zeta", "w1", "w2", "face_open", "face_excess", "curve_open",
                        "control_steps", "viscosity", "integrator", "adaptive_stop", "max_steps",
                        "volume_open", "volume_excess", "tets"};
  for (size_t k = 0; k < sizeof keys / sizeof keys[0]; ++k) assert_non_null(strstr(o, keys[k]));
  assert_non_null(strstr(o, "000 sec. 4.1.2"));
  free(o), free(e);
}

/* --trace and --frames on a small planar case. */
static void trace_frames(void **state) {
  (void)state;
  char args[4096], out[512], tr[512], fr[512], path[600];
  snprintf(out, sizeof out, "%s/t.vtu", dir);
  snprintf(tr, sizeof tr, "%s/trace.csv", dir);
  snprintf(fr, sizeof fr, "%s/frames", dir);
  snprintf(args, sizeof args, "mesh case:qi4 --method bubble -o '%s' --trace '%s' --frames '%s'", out, tr, fr);
  char *o = NULL, *e = NULL;
  int rc = pm_test_cli(dir, args, &o, &e);
  if (rc) fail_msg("exit %d: %s", rc, e);
  free(o), free(e);
  char *csv = pm_test_slurp(tr);
  assert_non_null(csv);
  assert_true(strncmp(csv, "step,bubbles,kinetic,potential,mean_disp,max_disp,insertions,deletions,eps_t", 74) == 0);
  int rows = 0;
  for (const char *c = csv; *c; ++c) rows += *c == '\n';
  assert_true(rows > 20);
  free(csv);
  snprintf(path, sizeof path, "%s/frames.pvd", fr);
  assert_int_equal(access(path, R_OK), 0);
  snprintf(path, sizeof path, "%s/frame_000001.svg", fr);
  assert_int_equal(access(path, R_OK), 0);
}

/* A CAD file without --size (the default rule) and a solid with --volume. */
static void cad_and_volume(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  char args[4096], out[512], js[512], cad[512];
  snprintf(out, sizeof out, "%s/box.msh", dir);
  snprintf(js, sizeof js, "%s/box.json", dir);
  pm_test_cad("synth_box_hole.step", cad, sizeof cad);
  snprintf(args, sizeof args, "mesh '%s' --method bubble -o '%s' --stats '%s'", cad, out, js);
  char *o = NULL, *e = NULL;
  int rc = pm_test_cli(dir, args, &o, &e);
  if (rc) fail_msg("exit %d: %s", rc, e);
  free(o), free(e);
  cJSON *j = read_json(js);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "valid")));
  assert_true(num(j, "tri", "radius_ratio", "mean") > 0.93);
  cJSON_Delete(j);
  snprintf(out, sizeof out, "%s/cyl.msh", dir);
  snprintf(js, sizeof js, "%s/cyl.json", dir);
  snprintf(args, sizeof args, "mesh case:cylinder --method bubble --volume -o '%s' --stats '%s'", out, js);
  rc = pm_test_cli(dir, args, &o, &e);
  if (rc) fail_msg("exit %d: %s", rc, e);
  free(o), free(e);
  j = read_json(js);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "valid")));
  assert_true(num(j, "tets", NULL, NULL) > 0);
  cJSON_Delete(j);
}

/* --volume on a solid: tets from the volume bubbles (the default), then TetGen's refinement of the
 * same kind of surface (--set tets=tetgen): the JSON has tets, their quality figures, the volume
 * bubbles, and the bubble tets' median radius ratio is above the refined tets'. */
static void volume_bubbles(void **state) {
  (void)state;
  char args[4096], out[512], js[2][512];
  double median[2], tets[2];
  const char *mode[2] = {"bubbles", "tetgen"};
  for (int k = 0; k < 2; ++k) {
    snprintf(out, sizeof out, "%s/vol_%s.vtk", dir, mode[k]);
    snprintf(js[k], sizeof js[k], "%s/vol_%s.json", dir, mode[k]);
    char tr[512], fr[512];
    snprintf(tr, sizeof tr, "%s/vol_%s.csv", dir, mode[k]);
    snprintf(fr, sizeof fr, "%s/vol_%s_frames", dir, mode[k]);
    snprintf(args, sizeof args,
             "mesh case:sphere --method bubble --volume --set tets=%s -o '%s' --stats '%s' --trace "
             "'%s' --frames '%s' --set frame_every=100",
             mode[k], out, js[k], tr, fr);
    char *o = NULL, *e = NULL;
    int rc = pm_test_cli(dir, args, &o, &e);
    if (rc) fail_msg("exit %d: %s", rc, e);
    free(o), free(e);
    cJSON *j = read_json(js[k]);
    assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "valid")));
    tets[k] = num(j, "tets", NULL, NULL);
    median[k] = num(j, "tet", "radius_ratio", "median");
    assert_true(num(j, "tet", "radius_ratio", "min") > 0);
    assert_true(num(j, "tet", "min_dihedral_deg", "min") > 0);
    assert_true(num(j, "tet", "aspect_ratio", "median") > 0);
    if (k == 0) {
      /* The trace's last row is the mesh's (event 3), of the volume phase (phase 3): it counts
       * the volume bubbles, and its nodes are the mesh's. */
      char *text = pm_test_slurp(tr);
      assert_non_null(text);
      assert_non_null(strstr(text, ",phase,q_rel_disp,nodes,event\n"));
      size_t len = strlen(text);
      while (len > 0 && text[len - 1] == '\n') text[--len] = 0;
      char *last = strrchr(text, '\n');
      assert_non_null(last);
      double field[16];
      int nf = 0;
      for (char *f = last + 1; nf < 16; ++nf) {
        field[nf] = *f == ',' || !*f ? -1 : atof(f);
        f = strchr(f, ',');
        if (!f) break;
        ++f;
      }
      assert_int_equal(nf, 15);
      PM_ASSERT_NEAR(field[15], 3, 0);  /* event: the mesh */
      PM_ASSERT_NEAR(field[12], 3, 0);  /* phase */
      PM_ASSERT_NEAR(field[1], num(j, "bubble", "volume_bubbles", NULL), 0);
      PM_ASSERT_NEAR(field[14], num(j, "nodes", NULL, NULL), 0);
      free(text);
      char pvd[600];
      snprintf(pvd, sizeof pvd, "%s/frames.pvd", fr);
      assert_int_equal(access(pvd, R_OK), 0);
      assert_true(num(j, "bubble", "volume_bubbles", NULL) > 300);
      assert_true(num(j, "bubble", "recovery_points", NULL) >= 0);
    }
    cJSON_Delete(j);
  }
  print_message("sphere: bubble tets %g (median radius ratio %.3f), TetGen-refined %g (%.3f)\n",
                tets[0], median[0], tets[1], median[1]);
  assert_true(tets[0] > 1000 && tets[1] > 500);
  assert_true(median[0] > 0.85);
  assert_true(median[0] > median[1] + 0.1);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(qi3_stats),    cmocka_unit_test(threads_identical), cmocka_unit_test(bad_sets),
      cmocka_unit_test(help),         cmocka_unit_test(trace_frames),
      cmocka_unit_test(cad_and_volume), cmocka_unit_test(volume_bubbles),
  };
  return cmocka_run_group_tests(tests, setup, teardown);
}
