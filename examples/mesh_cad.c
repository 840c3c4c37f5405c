/* Mesh a CAD file (or a built-in case) with the bubble mesher and write the mesh.
 *
 *   mesh_cad INPUT [SIZE [OUT]]     INPUT: a .step/.iges/.brep file or case:NAME
 *
 * Without SIZE the input's own size field is used (a case's), else bubble's default rule from the
 * model's features. Prints the node, triangle and tet counts. Build against an installed packmesh:
 *   cc mesh_cad.c $(pkg-config --cflags --libs packmesh) -o mesh_cad
 */
#include <packmesh/packmesh.h>

#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {
  if (argc < 2 || argc > 4) {
    fprintf(stderr, "usage: %s INPUT [SIZE [OUT]]\n", argv[0]);
    return 2;
  }
  pm_error err;
  pm_model *model = NULL;
  pm_sizing *size = NULL;
  pm_mesh *mesh = NULL;
  pm_generate_result result;
  int rc = 1;
  if (pm_model_open(argv[1], &model, &size, &err)) goto done;
  if (argc >= 3) {
    pm_sizing_destroy(size); /* the given size replaces the input's own */
    size = NULL;
    if (pm_sizing_parse(argv[2], &size, &err)) goto done;
  }
  if (pm_generate(model, size, pm_method_find("bubble"), NULL, NULL, &mesh, &result, &err))
    goto done;
  printf("bubble %s: %d nodes, %d triangles, %d tets (%s)\n", pm_model_name(model),
         (int)pm_mesh_node_count(mesh), (int)pm_mesh_element_count(mesh, 2),
         (int)pm_mesh_element_count(mesh, 3), result.stop_reason);
  if (argc == 4 && pm_mesh_write(mesh, argv[3], &err)) goto done;
  rc = 0;
done:
  if (rc) fprintf(stderr, "mesh_cad: %s\n", err.msg);
  pm_mesh_destroy(mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(model);
  return rc;
}
