/* packmesh mesh end to end: the stats keys of DESIGN.md, output files written whole, traces and
 * frames, --target-nodes, reproducibility with the thread count, and one-line errors for bad
 * input (a missing file, a corrupt STEP, bad sizes, unknown options and parameters). */
#include "test_support.h"

#include <cjson/cJSON.h>
#include <sys/stat.h>

#include "cli_stats.h"

static char dir[256];

static int exists(const char *path) {
  struct stat st;
  return stat(path, &st) == 0;
}

static void stats_keys_of_design(void **state) {
  (void)state;
  char args[1024], msh[300], js[300], tr[300], fr[300];
  snprintf(msh, sizeof msh, "%s/qi1.msh", dir);
  snprintf(js, sizeof js, "%s/qi1.json", dir);
  snprintf(tr, sizeof tr, "%s/qi1.csv", dir);
  snprintf(fr, sizeof fr, "%s/frames", dir);
  snprintf(args, sizeof args, "mesh case:qi1 --method gmsh-frontal -o '%s' --stats '%s'", msh, js);
  char *out = NULL;
  assert_int_equal(pm_test_cli(dir, args, &out, NULL), 0);
  assert_non_null(strstr(out, "gmsh-frontal case:qi1"));
  free(out);
  cJSON *j = pm_test_read_json(js);
  assert_string_equal(cJSON_GetObjectItemCaseSensitive(j, "method")->valuestring, "gmsh-frontal");
  assert_string_equal(cJSON_GetObjectItemCaseSensitive(j, "input")->valuestring, "case:qi1");
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "valid")));
  assert_true(cJSON_IsArray(cJSON_GetObjectItemCaseSensitive(j, "problems")));
  /* qi1: 8 units of area at d = 0.1 is about 8 / (sqrt(3)/4 0.01) / 2 ~ 924 nodes. */
  double nodes = pm_test_stat(j, "nodes", NULL, NULL), tris = pm_test_stat(j, "triangles", NULL, NULL);
  assert_true(nodes > 800 && nodes < 1100);
  assert_true(tris > 1.8 * nodes && tris < 2.1 * nodes);
  assert_int_equal((int)pm_test_stat(j, "segments", NULL, NULL), 120); /* 12 units of boundary / 0.1 */
  assert_int_equal((int)pm_test_stat(j, "tets", NULL, NULL), 0);
  pm_test_stat(j, "iterations", NULL, NULL);
  assert_true(pm_test_stat(j, "time_s", "total", NULL) >= 0);
  const char *summ[] = {"radius_ratio", "aspect_ratio", "min_angle_deg", "max_angle_deg"};
  const char *stat[] = {"min", "p25", "median", "p75", "max", "mean"};
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 6; ++b) pm_test_stat(cJSON_GetObjectItemCaseSensitive(j, "tri"), summ[a], stat[b], NULL);
  assert_true(pm_test_stat(j, "tri", "radius_ratio", "mean") > 0.95);
  pm_test_stat(j, "tri", "eps_t", NULL);
  pm_test_stat(j, "tri", "eps_g", NULL);
  /* Size conformity on a uniform field: mean edge / d near 1. */
  double sr = pm_test_stat(j, "tri", "size_ratio", "mean");
  assert_true(fabs(sr - 1) < 0.1);
  pm_test_stat(j, "tri", "size_ratio", "std");
  /* A planar mesh of a planar domain: distance 0 to round-off. */
  assert_true(pm_test_stat(j, "distance", "max", NULL) < 1e-9);
  PM_ASSERT_NEAR(pm_test_stat(j, "distance", "bbox_diagonal", NULL), sqrt(20.0), 1e-12);
  cJSON_Delete(j);
  assert_true(exists(msh));

  /* A particle method with its trace and frames. */
  snprintf(args, sizeof args,
           "mesh case:qi1 --method bubble --size 0.25 -o '%s' --trace '%s' --frames '%s'", msh, tr, fr);
  assert_int_equal(pm_test_cli(dir, args, NULL, NULL), 0);
  char *csv = pm_test_slurp(tr);
  assert_non_null(csv);
  int rows = 0;
  for (const char *c = csv; *c; ++c) rows += *c == '\n';
  assert_true(rows > 10);
  free(csv);
  char pvd[400];
  snprintf(pvd, sizeof pvd, "%s/frames.pvd", fr);
  assert_true(exists(pvd));
}

static void target_nodes_and_threads(void **state) {
  (void)state;
  char args[1024], js[300], a1[300], a2[300];
  snprintf(js, sizeof js, "%s/t.json", dir);
  snprintf(args, sizeof args, "mesh case:qi3 --method gmsh-frontal --target-nodes 1500 -o '%s/t.msh' --stats '%s'", dir, js);
  assert_int_equal(pm_test_cli(dir, args, NULL, NULL), 0);
  cJSON *j = pm_test_read_json(js);
  double n = pm_test_stat(j, "nodes", NULL, NULL);
  assert_true(fabs(n - 1500) <= 0.03 * 1500);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "target_nodes_met")));
  assert_true(pm_test_stat(j, "size_scale", NULL, NULL) < 1); /* more nodes than the case's own field */
  cJSON_Delete(j);
  /* The same seed gives the identical mesh with one or two threads. */
  snprintf(a1, sizeof a1, "%s/t1.vtu", dir);
  snprintf(a2, sizeof a2, "%s/t2.vtu", dir);
  snprintf(args, sizeof args, "mesh case:shimada --method bubble --seed 7 --threads 1 -o '%s'", a1);
  assert_int_equal(pm_test_cli(dir, args, NULL, NULL), 0);
  snprintf(args, sizeof args, "mesh case:shimada --method bubble --seed 7 --threads 2 -o '%s'", a2);
  assert_int_equal(pm_test_cli(dir, args, NULL, NULL), 0);
  char *x1 = pm_test_slurp(a1), *x2 = pm_test_slurp(a2);
  assert_non_null(x1);
  assert_string_equal(x1, x2);
  free(x1);
  free(x2);
}

/* --target-surface-nodes: a volume mesh's surface nodes (the nodes of its triangles, stats key
 * surface_nodes) end within 3% of the target while its interior nodes are not counted; the stats
 * name the target; it and --target-nodes together, or a value below 3, are usage errors. */
static void target_surface_nodes(void **state) {
  (void)state;
  char args[1024], js[300];
  snprintf(js, sizeof js, "%s/ts.json", dir);
  snprintf(args, sizeof args,
           "mesh case:boxhole --volume --method gmsh-frontal --target-surface-nodes 800 -o "
           "'%s/ts.msh' --stats '%s'",
           dir, js);
  assert_int_equal(pm_test_cli(dir, args, NULL, NULL), 0);
  cJSON *j = pm_test_read_json(js);
  double surface = pm_test_stat(j, "surface_nodes", NULL, NULL), all = pm_test_stat(j, "nodes", NULL, NULL);
  if (!(fabs(surface / 800 - 1) <= 0.03)) fail_msg("%g surface nodes for a target of 800", surface);
  assert_true(all > surface); /* the interior nodes are there, and were not counted */
  assert_int_equal((int)pm_test_stat(j, "target_surface_nodes", NULL, NULL), 800);
  assert_null(cJSON_GetObjectItemCaseSensitive(j, "target_nodes"));
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "target_nodes_met")));
  cJSON_Delete(j);
  snprintf(args, sizeof args, "mesh case:qi3 --target-nodes 100 --target-surface-nodes 100 -o '%s/x.msh'", dir);
  pm_test_cli_error(dir, args, 2, "--target-nodes and --target-surface-nodes: give one");
  snprintf(args, sizeof args, "mesh case:qi3 --target-surface-nodes 2 -o '%s/x.msh'", dir);
  pm_test_cli_error(dir, args, 2, "--target-surface-nodes takes a whole number >= 3, got '2'");
  assert_false(exists("x.msh"));
}

/* A target the method cannot reach: qi3's square has 4 corners, and 5 nodes is within 3% of
 * nothing bubble can place (it ends with the 4 corners). The mesh is written (exit 0), stderr has
 * one warning line naming the target and the count, and the stats say target_nodes_met false. */
static void target_nodes_missed(void **state) {
  (void)state;
  char args[1024], js[300], msh[300];
  snprintf(js, sizeof js, "%s/miss.json", dir);
  snprintf(msh, sizeof msh, "%s/miss.msh", dir);
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble --target-nodes 5 -o '%s' --stats '%s'",
           msh, js);
  char *out = NULL, *err = NULL;
  assert_int_equal(pm_test_cli(dir, args, &out, &err), 0);
  int lines = 0;
  for (const char *c = err; *c; ++c) lines += *c == '\n';
  if (lines != 1 || !strstr(err, "warning: --target-nodes 5 missed: 4 nodes after 8 runs"))
    fail_msg("stderr '%s'", err);
  free(out), free(err);
  cJSON *j = pm_test_read_json(js);
  assert_int_equal((int)pm_test_stat(j, "nodes", NULL, NULL), 4);
  assert_int_equal((int)pm_test_stat(j, "target_runs", NULL, NULL), 8);
  assert_true(cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(j, "target_nodes_met")));
  cJSON_Delete(j);
  assert_true(exists(msh));
}

/* Every usage error exits 2 with one line that names where the valid values are listed, and
 * leaves nothing behind: bad option values, unknown parameters and parameters out of range (the
 * method's --help lists them), size text that is neither a number nor an expression, and options
 * that do not apply (--volume on an input without volumes, --trace and --frames with a method
 * that records no iterations, a planar-only method on a solid). */
static void usage_errors_exit_2(void **state) {
  (void)state;
  char out[300], args[1200];
  snprintf(out, sizeof out, "%s/usage.msh", dir);
  static const char *const cases[][2] = {
      {"case:qi3 --method bubble --set foo=1", "'packmesh mesh --method bubble --help' lists the parameters"},
      {"case:qi3 --method psys --set s_tau=0", "'packmesh mesh --method psys --help' lists the parameters"},
      {"case:qi3 --method bubble --set k0", "'packmesh mesh --method bubble --help' lists the parameters"},
      {"case:qi3 --method gmsh-frontal --set algorithm=1", "'packmesh mesh --method gmsh-frontal --help' lists"},
      {"case:qi3 --size abc", "see 'packmesh mesh --help'"},
      {"case:qi3 --size 0", "see 'packmesh mesh --help'"},
      {"case:qi3 --volume", "--volume: 'case:qi3' has no volumes to mesh (a planar domain) (see 'packmesh mesh --help')"},
      {"case:qi3 --method gmsh-frontal --trace T.csv", "--trace: method gmsh-frontal records no iterations (the methods that do: bubble, psys)"},
      {"case:qi3 --method cgal --frames FR", "--frames: method cgal records no iterations"},
      {"case:sphere --method cgal", "planar domains only"},
      {"case:qi3 --threads x", "see 'packmesh mesh --help'"},
      {"case:qi3 --method bubbel", "(known: bubble, psys"},
  };
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    snprintf(args, sizeof args, "mesh %s -o '%s' --stats '%s/usage.json'", cases[k][0], out, dir);
    pm_test_cli_error(dir, args, 2, cases[k][1]);
    assert_false(exists(out));
  }
  assert_false(exists("T.csv"));
  assert_false(exists("FR"));
  char *err = NULL;
  assert_int_equal(pm_test_cli(dir, "quality x.msh --size abc", NULL, &err), 2);
  assert_non_null(strstr(err, "see 'packmesh quality --help'"));
  free(err);
}

/* A format that cannot hold an element kind leaves it out with one warning line naming the kinds
 * and counts (.stl: triangles only; .obj: no tets); a format that holds them all says nothing.
 * The counts are those of the summary line. `packmesh quality` reads every format back with the
 * counts it holds (.stl: the triangles and their corners). */
static void formats_that_drop_elements_warn(void **state) {
  (void)state;
  static const struct {
    const char *ext, *warning;
  } runs[] = {{"stl", "warning: a .stl file cannot hold 147 segments and "},
              {"obj", "warning: a .obj file cannot hold "},
              {"vtu", NULL},
              {"msh", NULL},
              {"vtk", NULL},
              {"mesh", NULL}};
  for (size_t k = 0; k < sizeof runs / sizeof runs[0]; ++k) {
    char args[1024], *out = NULL, *err = NULL;
    snprintf(args, sizeof args, "mesh case:boxhole --method bubble --volume -o '%s/drop.%s'", dir,
             runs[k].ext);
    assert_int_equal(pm_test_cli(dir, args, &out, &err), 0);
    int tets = 0, segs = 0;
    const char *at = strstr(out, " segments, ");
    assert_non_null(at);
    while (at > out && at[-1] != ' ') --at;
    segs = atoi(at);
    at = strstr(out, " tets in ");
    assert_non_null(at);
    while (at > out && at[-1] != ' ') --at;
    tets = atoi(at);
    assert_int_equal(segs, 147);
    assert_true(tets > 1000);
    int nodes = atoi(out + (strstr(out, ": ") - out) + 2), tris = atoi(strstr(out, " segments, ") + 11);
    int is_stl = strcmp(runs[k].ext, "stl") == 0, is_obj = strcmp(runs[k].ext, "obj") == 0;
    char q[600], *qout = NULL;
    snprintf(q, sizeof q, "quality '%s/drop.%s' --json", dir, runs[k].ext);
    assert_int_equal(pm_test_cli(dir, q, &qout, NULL), 0);
    cJSON *j = cJSON_Parse(qout);
    free(qout);
    assert_non_null(j);
    const int want[4] = {is_stl ? -1 : nodes, is_stl ? 0 : segs, tris, is_stl || is_obj ? 0 : tets};
    const char *keys[4] = {"nodes", "segments", "triangles", "tets"};
    for (int c = 0; c < 4; ++c)
      if (want[c] >= 0 && (int)pm_test_stat(j, keys[c], NULL, NULL) != want[c])
        fail_msg("quality of .%s: %s %g, written %d", runs[k].ext, keys[c],
                 pm_test_stat(j, keys[c], NULL, NULL), want[c]);
    /* .stl: the triangles' corners only, the interior nodes of the tets are not in it */
    if (is_stl && !(pm_test_stat(j, "nodes", NULL, NULL) < nodes)) fail_msg(".stl kept every node");
    cJSON_Delete(j);
    if (!runs[k].warning) {
      if (err[0]) fail_msg(".%s: stderr '%s'", runs[k].ext, err);
    } else {
      char want[160];
      snprintf(want, sizeof want, "%d tets; they are not in ", tets);
      int lines = 0;
      for (const char *c = err; *c; ++c) lines += *c == '\n';
      if (lines != 1 || !strstr(err, runs[k].warning) || !strstr(err, want))
        fail_msg(".%s: stderr '%s'", runs[k].ext, err);
    }
    free(out), free(err);
  }
}

static void one_line_errors(void **state) {
  (void)state;
  char args[1024], bad[300], out[300];
  snprintf(out, sizeof out, "%s/never.msh", dir);
  snprintf(args, sizeof args, "mesh '%s/missing.step' -o '%s'", dir, out);
  pm_test_cli_error(dir, args, 1, "missing.step");
  /* A corrupt STEP: a header and garbage. */
  snprintf(bad, sizeof bad, "%s/corrupt.step", dir);
  FILE *f = fopen(bad, "w");
  fputs("ISO-10303-21;\nHEADER;\nthis is not a STEP file at all\n", f);
  fclose(f);
  snprintf(args, sizeof args, "mesh '%s' -o '%s'", bad, out);
  pm_test_cli_error(dir, args, 1, "corrupt.step");
  snprintf(args, sizeof args, "mesh case:qi1 --size -0.1 -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "-0.1");
  snprintf(args, sizeof args, "mesh case:qi1 --size nan -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "nan");
  snprintf(args, sizeof args, "mesh case:qi1 --size '0.1*(x' -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "--size");
  snprintf(args, sizeof args, "mesh case:qi1 --size '0.5-x' -o '%s'", out); /* <= 0 in the domain */
  pm_test_cli_error(dir, args, 1, "size");
  snprintf(args, sizeof args, "mesh case:qi1 --bogus -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "--bogus");
  snprintf(args, sizeof args, "mesh case:qi1 --method bubble --set nokey=1 -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "nokey");
  snprintf(args, sizeof args, "mesh case:qi1 --method bubble --set k0=-1 -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "k0");
  snprintf(args, sizeof args, "mesh case:qi1 --method nomethod -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "nomethod");
  snprintf(args, sizeof args, "mesh case:qi1 -o '%s/x.docx'", dir);
  pm_test_cli_error(dir, args, 2, "docx");
  snprintf(args, sizeof args, "mesh case:qi1 --method gmsh-frontal -o '/nonexistent/dir/x.msh'");
  pm_test_cli_error(dir, args, 1, "x.msh");
  pm_test_cli_error(dir, "mesh case:qi1", 2, "-o");
  pm_test_cli_error(dir, "mesh -o x.msh", 2, "INPUT");
  snprintf(args, sizeof args, "mesh case:sphere --method cgal -o '%s'", out);
  pm_test_cli_error(dir, args, 2, "planar");
  pm_test_cli_error(dir, "mesh case:qi1 --threads 0 -o x.msh", 2, "--threads");
  /* Nothing was left behind by the failures. */
  assert_false(exists(out));
  /* --help of a method lists its parameters with their sources. */
  char *help = NULL;
  assert_int_equal(pm_test_cli(dir, "mesh --method bubble --help", &help, NULL), 0);
  assert_non_null(strstr(help, "k0"));
  assert_non_null(strstr(help, "003"));
  free(help);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_cli_mesh_%d", (int)getpid());
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
  if (system(cmd) != 0) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(stats_keys_of_design),
      cmocka_unit_test(target_nodes_and_threads),
      cmocka_unit_test(target_nodes_missed),
      cmocka_unit_test(target_surface_nodes),
      cmocka_unit_test(usage_errors_exit_2),
      cmocka_unit_test(formats_that_drop_elements_warn),
      cmocka_unit_test(one_line_errors),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
