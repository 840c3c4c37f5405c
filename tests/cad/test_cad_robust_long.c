/* One file of the robustness corpus (../shared/cad/robust: gmsh's own benchmark files), given on
 * the command line, meshed at the default size with one thread by bubble, gmsh-frontal and psys
 * through the packmesh command: each run exits 0 with a mesh the checker accepts. The one file
 * gmsh itself cannot read (iges__model1.igs) gives one line naming the file and exit 1 for every
 * method. Long (a run of psys on the larger parts takes minutes): ctest -L long. */
#include "cli/cli_stats.h"

#include <cjson/cJSON.h>

static const char *file_arg;

static void run_method(const char *dir, const char *method) {
  char args[4096], stats[1100];
  snprintf(stats, sizeof stats, "%s/stats.json", dir);
  snprintf(args, sizeof args, "mesh '%s' --method %s --threads 1 -o '%s/mesh.msh' --stats '%s'",
           file_arg, method, dir, stats);
  if (strstr(file_arg, "iges__model1.igs")) {
    pm_test_cli_error(dir, args, 1, "iges__model1.igs");
    return;
  }
  char *err = NULL;
  int rc = pm_test_cli(dir, args, NULL, &err);
  if (rc != 0) fail_msg("%s with %s: exit %d: %s", file_arg, method, rc, err);
  free(err);
  cJSON *o = pm_test_read_json(stats);
  const cJSON *valid = cJSON_GetObjectItemCaseSensitive(o, "valid");
  if (!cJSON_IsTrue(valid)) {
    char *p = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(o, "problems"));
    fail_msg("%s with %s: the checker rejects the mesh: %s", file_arg, method, p);
  }
  cJSON_Delete(o);
}

static void corpus_file(void **state) {
  (void)state;
  char dir[] = "/tmp/pm_robust_XXXXXX";
  assert_non_null(mkdtemp(dir));
  run_method(dir, "bubble");
  run_method(dir, "gmsh-frontal");
  run_method(dir, "psys");
  char cmd[200];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  assert_int_equal(system(cmd), 0);
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: test_cad_robust_long FILE\n");
    return 2;
  }
  file_arg = argv[1];
  const struct CMUnitTest tests[] = {cmocka_unit_test(corpus_file)};
  return cmocka_run_group_tests(tests, NULL, NULL);
}
