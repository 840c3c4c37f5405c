/* psys through the packmesh command (PM_CLI): a mesh with --stats, --trace and --frames, a given
 * size, the parameter table behind --set and --help, and the error paths. Skipped while the
 * command's method table does not list psys. */
#include "test_support.h"

#include "cli/cli_run.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

static char dir[256];

static int setup(void **state) {
  (void)state;
  snprintf(dir, sizeof dir, "/tmp/pm_test_psys_cli_XXXXXX");
  return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state) {
  (void)state;
  char cmd[600];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  return system(cmd) == 0 ? 0 : -1;
}

/* 1 when the command knows the psys method (its help lists the parameters). */
static int have_psys(void) {
  char *out = NULL, *err = NULL;
  int rc = pm_test_cli(dir, "mesh --method psys --help", &out, &err);
  int ok = rc == 0 && strstr(out, "s_kappa") != NULL;
  free(out);
  free(err);
  return ok;
}

static double number(const cJSON *root, const char *a, const char *b) {
  const cJSON *x = cJSON_GetObjectItemCaseSensitive(root, a);
  if (b) x = cJSON_GetObjectItemCaseSensitive(x, b);
  if (!cJSON_IsNumber(x)) fail_msg("stats key %s%s%s missing", a, b ? "." : "", b ? b : "");
  return x->valuedouble;
}

static void mesh_with_stats_trace_frames(void **state) {
  (void)state;
  if (!have_psys()) {
    skip();
    return;
  }
  char args[4096], msh[300], js[300], csv[300], fr[300];
  snprintf(msh, sizeof msh, "%s/box.msh", dir);
  snprintf(js, sizeof js, "%s/box.json", dir);
  snprintf(csv, sizeof csv, "%s/box.csv", dir);
  snprintf(fr, sizeof fr, "%s/frames", dir);
  snprintf(args, sizeof args,
           "mesh case:boxhole --method psys --size inferred --seed 3 --threads 2 -o '%s' "
           "--stats '%s' --trace '%s' --frames '%s'",
           msh, js, csv, fr);
  char *out = NULL, *err = NULL;
  int rc = pm_test_cli(dir, args, &out, &err);
  if (rc != 0) fail_msg("packmesh %s: exit %d, %s", args, rc, err);
  free(out), free(err);
  char *text = pm_test_slurp(js);
  assert_non_null(text);
  cJSON *root = cJSON_Parse(text);
  assert_non_null(root);
  assert_string_equal(cJSON_GetObjectItemCaseSensitive(root, "method")->valuestring, "psys");
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(root, "valid")));
  assert_true(number(root, "nodes", NULL) > 200);
  assert_true(number(root, "iterations", NULL) > 20);
  assert_true(number(root, "time_s", "phase3") > 0);
  assert_true(number(root, "time_s", "connect") >= 0);
  const cJSON *ps = cJSON_GetObjectItemCaseSensitive(root, "psys");
  assert_true(number(ps, "iterations", "phase3") > 0);
  /* the colouring has its own time, and was made at least once per phase */
  assert_true(number(ps, "lists", "recolours") >= 3);
  assert_true(number(ps, "lists", "colour_mends") >= 0); /* present, 0 when none was needed */
  const cJSON *ts = cJSON_GetObjectItemCaseSensitive(root, "time_s");
  const cJSON *tps = cJSON_GetObjectItemCaseSensitive(ts, "psys");
  assert_true(number(tps, "colouring", NULL) > 0);
  assert_true(number(tps, "neighbours", NULL) > 0);
  const cJSON *tri = cJSON_GetObjectItemCaseSensitive(root, "tri");
  assert_true(number(tri, "aspect_ratio", "median") < 0.7);
  cJSON_Delete(root);
  free(text);
  /* the trace: a header with the documented columns, one row per iteration */
  text = pm_test_slurp(csv);
  assert_non_null(text);
  const char *head = "iteration,phase,particles,energy,mean_move,max_move,splits,deletes,mean_sigma";
  assert_true(strncmp(text, head, strlen(head)) == 0);
  int rows = 0;
  for (const char *c = text; *c; ++c) rows += *c == '\n';
  assert_true(rows > 20);
  free(text);
  char pvd[600];
  snprintf(pvd, sizeof pvd, "%s/frames.pvd", fr);
  text = pm_test_slurp(pvd);
  assert_non_null(text);
  assert_non_null(strstr(text, "frame_000000.vtu"));
  free(text);
}

/* A given size: the mean edge follows it (psys's calibration, sigma = d / edge_per_sigma). */
static void given_size(void **state) {
  (void)state;
  if (!have_psys()) {
    skip();
    return;
  }
  char args[4096], msh[300], js[300];
  snprintf(msh, sizeof msh, "%s/qi1.vtk", dir);
  snprintf(js, sizeof js, "%s/qi1.json", dir);
  snprintf(args, sizeof args, "mesh case:qi1 --method psys --size 0.1 -o '%s' --stats '%s'", msh,
           js);
  char *out = NULL, *err = NULL;
  int rc = pm_test_cli(dir, args, &out, &err);
  if (rc != 0) fail_msg("packmesh %s: exit %d, %s", args, rc, err);
  free(out), free(err);
  char *text = pm_test_slurp(js);
  cJSON *root = cJSON_Parse(text);
  assert_non_null(root);
  const cJSON *tri = cJSON_GetObjectItemCaseSensitive(root, "tri");
  double ratio = number(tri, "size_ratio", "mean");
  if (!(ratio > 0.95 && ratio < 1.05)) fail_msg("mean edge / d = %g", ratio);
  cJSON_Delete(root);
  free(text);
}

/* --size inferred for another method: psys_infer_size's sampled field drives the bubble mesher,
 * whose edges then follow it. */
static void inferred_field_for_bubble(void **state) {
  (void)state;
  if (!have_psys()) {
    skip();
    return;
  }
  char args[4096], msh[300], js[300];
  snprintf(msh, sizeof msh, "%s/bub.msh", dir);
  snprintf(js, sizeof js, "%s/bub.json", dir);
  snprintf(args, sizeof args,
           "mesh case:boxhole --method bubble --size inferred -o '%s' --stats '%s'", msh, js);
  char *out = NULL, *err = NULL;
  int rc = pm_test_cli(dir, args, &out, &err);
  if (rc != 0) {
    if (strstr(err, "unknown method")) { /* no bubble method in this build */
      free(out), free(err);
      skip();
      return;
    }
    fail_msg("packmesh %s: exit %d, %s", args, rc, err);
  }
  free(out), free(err);
  char *text = pm_test_slurp(js);
  cJSON *root = cJSON_Parse(text);
  assert_non_null(root);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(root, "valid")));
  const cJSON *size = cJSON_GetObjectItemCaseSensitive(root, "size");
  assert_true(cJSON_IsString(size) && strstr(size->valuestring, "sampled"));
  const cJSON *tri = cJSON_GetObjectItemCaseSensitive(root, "tri");
  double ratio = number(tri, "size_ratio", "mean");
  if (!(ratio > 0.85 && ratio < 1.15)) fail_msg("bubble on psys's field: mean edge / d = %g", ratio);
  cJSON_Delete(root);
  free(text);
}

static void parameters_and_errors(void **state) {
  (void)state;
  if (!have_psys()) {
    skip();
    return;
  }
  char *out = NULL, *err = NULL;
  assert_int_equal(pm_test_cli(dir, "mesh --method psys --help", &out, &err), 0);
  const char *names[] = {"s_kappa", "s_tau", "L", "kappa_min", "kappa_max", "split_ratio",
                         "delete_ratio", "edge_per_sigma", "seeds_per_face"};
  for (int k = 0; k < 9; ++k)
    if (!strstr(out, names[k])) fail_msg("--help does not list %s", names[k]);
  assert_non_null(strstr(out, "001"));
  free(out), free(err);
  char args[1024], msh[300];
  snprintf(msh, sizeof msh, "%s/bad.msh", dir);
  snprintf(args, sizeof args, "mesh case:cylinder --method psys --set s_tau=0 -o '%s'", msh);
  pm_test_cli_error(dir, args, 2, "s_tau");
  snprintf(args, sizeof args, "mesh case:cylinder --method psys --set nokey=1 -o '%s'", msh);
  pm_test_cli_error(dir, args, 2, "nokey");
  snprintf(args, sizeof args,
           "mesh case:cylinder --method psys --set lambda_min=0.9 --set lambda_init=0.5 -o '%s'",
           msh);
  pm_test_cli_error(dir, args, 1, "lambda");
  snprintf(args, sizeof args, "mesh case:cylinder --method psys --max-nodes 30 -o '%s'", msh);
  pm_test_cli_error(dir, args, 1, "cap");
  char *left = pm_test_slurp(msh);
  assert_null(left); /* no half-written mesh */
  /* caps before growth: a size far too small is refused from the estimated particle count,
   * before any particle is placed, naming the cap and the size that fits: case:qi3 is a 6 x 6
   * square, so about 36 / (sqrt(3)/2 d^2) particles, and a cap of 10^6 fits d = 0.00645 */
  snprintf(args, sizeof args,
           "mesh case:qi3 --method psys --size 1e-12 --max-nodes 1000000 -o '%s'", msh);
  pm_test_cli_error(dir, args, 1, "--max-nodes");
  char *out2 = NULL, *err2 = NULL;
  assert_int_equal(pm_test_cli(dir, args, &out2, &err2), 1);
  assert_non_null(strstr(err2, "needs about"));
  const char *fit = strstr(err2, "a size of at least ");
  assert_non_null(fit);
  double d = atof(fit + strlen("a size of at least "));
  if (!(d > 0.0063 && d < 0.0067)) fail_msg("size that fits: %g, want about 0.00645", d);
  free(out2), free(err2);
  assert_null(pm_test_slurp(msh));
  /* and the memory cap the same way */
  snprintf(args, sizeof args,
           "mesh case:qi3 --method psys --size 1e-5 --set max_memory_gb=0.1 -o '%s'", msh);
  pm_test_cli_error(dir, args, 1, "max_memory_gb");
  assert_null(pm_test_slurp(msh));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(mesh_with_stats_trace_frames),
      cmocka_unit_test(given_size),
      cmocka_unit_test(inferred_field_for_bubble),
      cmocka_unit_test(parameters_and_errors),
  };
  return cmocka_run_group_tests(tests, setup, teardown);
}
