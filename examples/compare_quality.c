/* Compare two methods' element quality on one input at one size.
 *
 *   compare_quality INPUT [METHOD_A [METHOD_B]]     default: bubble and gmsh-frontal
 *
 * Both methods run on the same model with the same size field (the input's own, or the field
 * psys infers), and their triangles are measured by the same quality module. Prints, per method,
 * the node count and the summaries of the radius ratio and of the smallest angle.
 */
#include <packmesh/packmesh.h>

#include <stdio.h>

static int measure(const pm_model *model, const pm_sizing *size, const char *name,
                   pm_error *err) {
  const pm_method *method = pm_method_find(name);
  if (!method) {
    fprintf(stderr, "compare_quality: unknown method '%s'\n", name);
    return 1;
  }
  pm_generate_options opts;
  pm_generate_options_init(&opts);
  opts.seed = 7;
  pm_mesh *mesh = NULL;
  pm_quality *q = NULL;
  pm_summary rr, angle;
  int rc = 1;
  if (!pm_generate(model, size, method, NULL, &opts, &mesh, NULL, err) &&
      !pm_quality_measure(mesh, size, &q, err) &&
      !pm_quality_summary(q, 2, PM_MEASURE_RADIUS_RATIO, &rr, err) &&
      !pm_quality_summary(q, 2, PM_MEASURE_MIN_ANGLE, &angle, err)) {
    printf("%-14s %7d nodes  radius ratio median %.4f p25 %.4f min %.4f  min angle median %.2f "
           "min %.2f\n",
           name, (int)pm_mesh_node_count(mesh), rr.median, rr.p25, rr.min, angle.median,
           angle.min);
    rc = 0;
  }
  pm_quality_destroy(q);
  pm_mesh_destroy(mesh);
  return rc;
}

int main(int argc, char **argv) {
  if (argc < 2 || argc > 4) {
    fprintf(stderr, "usage: %s INPUT [METHOD_A [METHOD_B]]\n", argv[0]);
    return 2;
  }
  const char *a = argc > 2 ? argv[2] : "bubble", *b = argc > 3 ? argv[3] : "gmsh-frontal";
  pm_error err = {0};
  pm_model *model = NULL;
  pm_sizing *size = NULL;
  int rc = 1;
  if (!pm_model_open(argv[1], &model, &size, &err) &&
      (size || !pm_sizing_inferred(model, 1, 1, &size, &err)))
    rc = measure(model, size, a, &err) || measure(model, size, b, &err);
  if (rc && err.code) fprintf(stderr, "compare_quality: %s\n", err.msg);
  pm_sizing_destroy(size);
  pm_model_destroy(model);
  return rc;
}
