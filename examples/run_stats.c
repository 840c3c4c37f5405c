/* Mesh a model with one method and print the run's stats JSON, the keys `packmesh mesh --stats`
 * writes (docs/DESIGN.md), through the extended API.
 *
 *   run_stats INPUT [METHOD [KEY=VALUE ...]]     INPUT: a CAD file or case:NAME; METHOD: bubble
 *
 * The record (pm_report) collects the method's phase times and counters as it runs; the checker,
 * quality and the two-sided distance are then measured into it. Build against an installed
 * packmesh:
 *   cc run_stats.c $(pkg-config --cflags --libs packmesh) -o run_stats
 */
#include <packmesh/packmesh_extended.h>

#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s INPUT [METHOD [KEY=VALUE ...]]\n", argv[0]);
    return 2;
  }
  const char *name = argc >= 3 ? argv[2] : "bubble";
  const pm_method *method = pm_method_find(name);
  if (!method) {
    char names[256];
    pm_method_names(names, sizeof names);
    fprintf(stderr, "run_stats: unknown method '%s' (one of: %s)\n", name, names);
    return 2;
  }
  pm_error err;
  pm_model *model = NULL;
  pm_sizing *size = NULL, *final_size = NULL;
  pm_method_params *params = NULL;
  pm_report *report = NULL;
  pm_mesh *mesh = NULL;
  char *json = NULL;
  pm_generate_result result;
  pm_generate_options opts;
  pm_generate_options_init(&opts);
  int rc = 1;
  if (pm_model_open(argv[1], &model, &size, &err) || pm_method_params_create(method, &params, &err))
    goto done;
  for (int i = 3; i < argc; ++i)
    if (pm_method_params_set_pair(params, argv[i], &err)) goto done;
  if (pm_report_create(name, argv[1], &report, &err) ||
      pm_generate_report(model, size, method, params, &opts, report, &final_size, &mesh, &result,
                         &err) ||
      pm_report_record_run(report, model, method, params, &opts, &result,
                           final_size ? final_size : size, &err) ||
      pm_report_measure(report, mesh, model, final_size ? final_size : size, PM_REPORT_ALL, &err) ||
      pm_report_set_time(report, "total", result.seconds, &err) ||
      pm_report_stats_json(report, &json, &err))
    goto done;
  fputs(json, stdout);
  rc = 0;
done:
  if (rc) fprintf(stderr, "run_stats: %s\n", err.msg);
  free(json);
  pm_mesh_destroy(mesh);
  pm_report_destroy(report);
  pm_method_params_destroy(params);
  pm_sizing_destroy(final_size);
  pm_sizing_destroy(size);
  pm_model_destroy(model);
  return rc;
}
