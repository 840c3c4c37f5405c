/* A size field written in C: edges of 0.02 near the point (0.5, 0.5), growing linearly to 0.2
 * away from it, on the unit square of the built-in case "shimada" (or INPUT). Meshes it with
 * bubble and prints how closely the edges follow the field (edge length / d at its midpoint).
 *
 *   size_callback [INPUT]
 */
#include <packmesh/packmesh.h>

#include <math.h>
#include <stdio.h>

typedef struct graded {
  double centre[3], near, far, grade;
} graded;

/* Called from several threads at once: it only reads its argument. */
static double graded_size(const double xyz[3], void *user) {
  const graded *g = user;
  double dx = xyz[0] - g->centre[0], dy = xyz[1] - g->centre[1], dz = xyz[2] - g->centre[2];
  double d = g->near + g->grade * sqrt(dx * dx + dy * dy + dz * dz);
  return d < g->far ? d : g->far;
}

int main(int argc, char **argv) {
  const char *input = argc > 1 ? argv[1] : "case:shimada";
  graded g = {{0.5, 0.5, 0}, 0.02, 0.2, 0.5};
  pm_error err = {0};
  pm_model *model = NULL;
  pm_sizing *size = NULL;
  pm_mesh *mesh = NULL;
  pm_quality *q = NULL;
  int rc = 1;
  if (!pm_model_open(input, &model, NULL, &err) &&
      !pm_sizing_callback(graded_size, &g, "graded from (0.5, 0.5)", &size, &err) &&
      !pm_generate(model, size, pm_method_find("bubble"), NULL, NULL, &mesh, NULL, &err) &&
      !pm_quality_measure(mesh, size, &q, &err)) {
    pm_summary ratio = pm_quality_size_ratio(q, 2);
    printf("%s, size %s: %d nodes, edge length / d: median %.3f, p25 %.3f, p75 %.3f\n", input,
           pm_sizing_describe(size), (int)pm_mesh_node_count(mesh), ratio.median, ratio.p25,
           ratio.p75);
    rc = 0;
  }
  if (rc) fprintf(stderr, "size_callback: %s\n", err.msg);
  pm_quality_destroy(q);
  pm_mesh_destroy(mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(model);
  return rc;
}
