/* The peers through the packmesh command, end to end: `packmesh mesh INPUT --method PEER` with
 * --stats, --set, --volume, --help, --target-nodes and the error paths (one line on stderr, a
 * non-zero exit, no output file left). The stats JSON is read back and checked against figures
 * measured through the library (the reference figure of gmsh's Frontal-Delaunay on qi3).
 *
 * The tests skip while the command's method table does not list the peers. */
#include "test_support.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "cli/cli_stats.h"
#include "common/backends/gmsh_session.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_io.h"

static char dir[256];
static int have_peers = -1;

/* The command under test: PM_CLI, or PM_TEST_CLI when set (to try another build). */
static const char *cli(void) {
  const char *c = getenv("PM_TEST_CLI");
  return c && *c ? c : PM_CLI;
}

/* Run the command line; capture stdout and stderr; return the exit code. */
static int run(const char *args, char **out, char **err) {
  char cmd[3072], po[600], pe[600];
  snprintf(po, sizeof po, "%s/stdout", dir);
  snprintf(pe, sizeof pe, "%s/stderr", dir);
  snprintf(cmd, sizeof cmd, "cd '%s' && '%s' %s > '%s' 2> '%s'", dir, cli(), args, po, pe);
  int st = system(cmd);
  assert_true(WIFEXITED(st));
  const char *paths[2] = {po, pe};
  char **bufs[2] = {out, err};
  for (int k = 0; k < 2; ++k) {
    FILE *f = fopen(paths[k], "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    *bufs[k] = malloc((size_t)n + 1);
    assert_int_equal(fread(*bufs[k], 1, (size_t)n, f), (size_t)n);
    (*bufs[k])[n] = '\0';
    fclose(f);
  }
  return WEXITSTATUS(st);
}

static int setup(void **state) {
  (void)state;
  snprintf(dir, sizeof dir, "/tmp/pm_test_peer_cli_XXXXXX");
  return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state) {
  (void)state;
  char cmd[600];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  pm_gmsh_shutdown();
  return system(cmd) == 0 ? 0 : -1;
}

static void need_peers(void) {
  if (have_peers < 0) {
    char *out, *err;
    int code = run("mesh --method gmsh-frontal --help", &out, &err);
    have_peers = code == 0;
    free(out), free(err);
  }
  if (!have_peers) skip();
}

static cJSON *read_json(const char *name) {
  char path[600];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  return pm_test_read_json(path);
}

static int exists(const char *name) {
  char path[600];
  struct stat st;
  snprintf(path, sizeof path, "%s/%s", dir, name);
  return stat(path, &st) == 0;
}

/* The reference figure through the command: gmsh-frontal on qi3 with the case's own field. */
static void frontal_qi3(void **state) {
  (void)state;
  need_peers();
  char *out, *err;
  int code = run("mesh case:qi3 --method gmsh-frontal -o qi3.msh --stats qi3.json", &out, &err);
  if (code) fail_msg("exit %d: %s", code, err);
  assert_non_null(strstr(out, "gmsh-frontal case:qi3"));
  cJSON *s = read_json("qi3.json");
  assert_string_equal(cJSON_GetObjectItem(s, "method")->valuestring, "gmsh-frontal");
  assert_true(cJSON_IsTrue(cJSON_GetObjectItem(s, "valid")));
  PM_ASSERT_NEAR(pm_test_stat(s, "nodes", NULL, NULL), 736, 15);
  PM_ASSERT_NEAR(pm_test_stat(s, "tri", "radius_ratio", "mean"), 0.967, 0.005);
  PM_ASSERT_NEAR(pm_test_stat(s, "tri", "radius_ratio", "min"), 0.611, 0.03);
  PM_ASSERT_NEAR(pm_test_stat(s, "tri", "min_angle_deg", "min"), 31.8, 1.0);
  PM_ASSERT_NEAR(pm_test_stat(s, "tri", "size_ratio", "mean"), 1, 0.15);
  assert_true(pm_test_stat(s, "time_s", "surface", NULL) >= 0);
  assert_true(pm_test_stat(s, "distance", "max", NULL) < 1e-9);
  cJSON_Delete(s);
  /* The mesh file holds the same mesh, with its classification. */
  char path[600];
  snprintf(path, sizeof path, "%s/qi3.msh", dir);
  pm_mesh *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_read(path, &m, &e), e);
  PM_ASSERT_NEAR(m->nnode, 736, 15);
  int32_t on_face = 0;
  for (int32_t i = 0; i < m->nnode; ++i) on_face += m->node_dim[i] == 2;
  assert_true(on_face > 600);
  pm_mesh_destroy(m);
  free(out), free(err);
}

/* Every peer on qi1 through the command, with parameters set; CGAL with ODT smoothing. */
static void every_peer(void **state) {
  (void)state;
  need_peers();
  static const char *const runs[][2] = {
      {"gmsh-meshadapt", "--set smoothing=3"},
      {"gmsh-delaunay", ""},
      {"gmsh-frontal", "--set smoothing=0"},
      {"cgal", "--set optimizer=odt --set opt_iterations=15"},
  };
  for (size_t k = 0; k < sizeof runs / sizeof runs[0]; ++k) {
    char args[600], *out, *err;
    snprintf(args, sizeof args, "mesh case:qi1 --method %s %s -o m.vtk --stats m.json",
             runs[k][0], runs[k][1]);
    int code = run(args, &out, &err);
    if (code) fail_msg("%s: exit %d: %s", runs[k][0], code, err);
    cJSON *s = read_json("m.json");
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(s, "valid")));
    PM_ASSERT_NEAR(pm_test_stat(s, "nodes", NULL, NULL) / 985, 1, 0.15);
    PM_ASSERT_NEAR(pm_test_stat(s, "tri", "size_ratio", "mean"), 1, 0.10);
    assert_true(pm_test_stat(s, "tri", "min_angle_deg", "min") > 20);
    cJSON_Delete(s);
    free(out), free(err);
  }
}

/* --volume: gmsh's 3D Delaunay and, with --set volume=tetgen, TetGen refinement. */
static void volumes(void **state) {
  (void)state;
  need_peers();
  static const char *const sets[2] = {"", "--set volume=tetgen --set radius_edge=1.4"};
  for (int k = 0; k < 2; ++k) {
    char args[600], *out, *err;
    snprintf(args, sizeof args,
             "mesh case:boxhole --method gmsh-delaunay --volume %s -o v.msh --stats v.json",
             sets[k]);
    int code = run(args, &out, &err);
    if (code) fail_msg("exit %d: %s", code, err);
    cJSON *s = read_json("v.json");
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(s, "valid")));
    assert_true(pm_test_stat(s, "tets", NULL, NULL) > 500);
    assert_true(pm_test_stat(s, "tet", "radius_ratio", "min") > 0);
    cJSON_Delete(s);
    free(out), free(err);
  }
}

/* A CAD file with no --size: the peers' default (1/30 of the diagonal). */
static void cad_default_size(void **state) {
  (void)state;
  need_peers();
  if (!pm_test_have_cad()) skip();
  char args[900], *out, *err;
  snprintf(args, sizeof args, "mesh '%s/screw.step' --method gmsh-frontal -o s.stl --stats s.json",
           PM_CAD_DIR);
  int code = run(args, &out, &err);
  if (code) fail_msg("exit %d: %s", code, err);
  cJSON *s = read_json("s.json");
  assert_true(cJSON_IsTrue(cJSON_GetObjectItem(s, "valid")));
  assert_true(pm_test_stat(s, "triangles", NULL, NULL) > 1000);
  cJSON_Delete(s);
  free(out), free(err);
}

/* --target-nodes scales the case's field until the count is within a few percent. */
static void target_nodes(void **state) {
  (void)state;
  need_peers();
  char *out, *err;
  int code = run("mesh case:qi1 --method cgal --target-nodes 500 -o t.msh --stats t.json", &out,
                 &err);
  if (code) fail_msg("exit %d: %s", code, err);
  cJSON *s = read_json("t.json");
  PM_ASSERT_NEAR(pm_test_stat(s, "nodes", NULL, NULL), 500, 0.05 * 500);
  cJSON_Delete(s);
  free(out), free(err);
}

/* A JSON case file: a half disk (a segment and a 180-degree arc, which the gmsh peers build as
 * a rational B-spline) with a circular hole and its own size field, through both kinds of peer. */
static void json_domain(void **state) {
  (void)state;
  need_peers();
  char path[600];
  snprintf(path, sizeof path, "%s/half.json", dir);
  FILE *f = fopen(path, "w");
  assert_non_null(f);
  fputs("{ \"name\": \"half disk with a hole\",\n"
        "  \"domain\": { \"loops\": [\n"
        "    [ {\"line\": [0, 0]}, {\"arc\": {\"from\": [2, 0], \"centre\": [1, 0], \"ccw\": true}} ],\n"
        "    [ {\"arc\": {\"from\": [1.2, 0.4], \"centre\": [1, 0.4], \"ccw\": false}} ] ] },\n"
        "  \"size\": \"0.04+0.05*y\" }\n",
        f);
  fclose(f);
  static const char *const methods[] = {"gmsh-frontal", "gmsh-meshadapt", "cgal"};
  for (int k = 0; k < 3; ++k) {
    char args[800], *out, *err;
    snprintf(args, sizeof args, "mesh half.json --method %s -o h.vtu --stats h.json", methods[k]);
    int code = run(args, &out, &err);
    if (code) fail_msg("%s: exit %d: %s", methods[k], code, err);
    cJSON *st = read_json("h.json");
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(st, "valid")));
    PM_ASSERT_NEAR(pm_test_stat(st, "tri", "size_ratio", "mean"), 1, 0.15);
    /* Boundary nodes lie on the arcs: the two-sided distance is the chords' sag only. */
    assert_true(pm_test_stat(st, "distance", "max", NULL) < 0.005);
    cJSON_Delete(st);
    free(out), free(err);
  }
}

/* --help lists the parameters with their sources. */
static void help(void **state) {
  (void)state;
  need_peers();
  char *out, *err;
  assert_int_equal(run("mesh --method gmsh-meshadapt --help", &out, &err), 0);
  assert_non_null(strstr(out, "smoothing"));
  assert_non_null(strstr(out, "Mesh.Smoothing"));
  assert_non_null(strstr(out, "tetgen"));
  free(out), free(err);
  assert_int_equal(run("mesh --method cgal --help", &out, &err), 0);
  assert_non_null(strstr(out, "shape_bound"));
  assert_non_null(strstr(out, "lloyd"));
  free(out), free(err);
}

/* Errors: one line on stderr, a non-zero exit, no output file. */
static void errors(void **state) {
  (void)state;
  need_peers();
  static const char *const bad[][2] = {
      {"mesh case:boxhole --method cgal -o e1.msh", "planar"},
      {"mesh case:qi1 --method gmsh-frontal --set smoothing=-1 -o e2.msh", "smoothing"},
      {"mesh case:qi1 --method gmsh-delaunay --set volume=netgen -o e3.msh", "volume"},
      {"mesh case:qi1 --method cgal --set shape_bound=0.3 -o e4.msh", "shape_bound"},
      {"mesh case:qi1 --method gmsh-frontal --size 0.001 --max-nodes 1000 -o e5.msh", "cap"},
      {"mesh case:qi1 --method cgal --size 0.001 --max-nodes 1000 -o e6.msh", "cap"},
  };
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    char *out, *err;
    int code = run(bad[k][0], &out, &err);
    if (code == 0) fail_msg("'%s' succeeded", bad[k][0]);
    if (!strstr(err, bad[k][1])) fail_msg("'%s': %s", bad[k][0], err);
    char *nl = strchr(err, '\n');
    assert_true(nl == NULL || nl[1] == '\0');
    char name[16];
    snprintf(name, sizeof name, "e%d.msh", (int)k + 1);
    assert_false(exists(name));
    free(out), free(err);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(frontal_qi3), cmocka_unit_test(every_peer),
      cmocka_unit_test(volumes),     cmocka_unit_test(cad_default_size),
      cmocka_unit_test(target_nodes), cmocka_unit_test(json_domain),
      cmocka_unit_test(help),
      cmocka_unit_test(errors),
  };
  if (getenv("PM_TEST_FILTER")) cmocka_set_test_filter(getenv("PM_TEST_FILTER"));
  return cmocka_run_group_tests(tests, setup, teardown);
}
