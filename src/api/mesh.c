/* Views of a mesh for the public API (packmesh.h). */
#include <packmesh/packmesh.h>

#include "common/measure/classify.h"
#include "common/mesh/mesh.h"

int32_t pm_mesh_node_count(const pm_mesh *m) { return m ? m->nnode : 0; }
const double *pm_mesh_nodes(const pm_mesh *m) { return m ? m->xyz : NULL; }
const int8_t *pm_mesh_node_dims(const pm_mesh *m) { return m ? m->node_dim : NULL; }
const int32_t *pm_mesh_node_cells(const pm_mesh *m) { return m ? m->node_cell : NULL; }

int32_t pm_mesh_element_count(const pm_mesh *m, int dim) {
  if (!m) return 0;
  return dim == 1 ? m->nseg : dim == 2 ? m->ntri : dim == 3 ? m->ntet : 0;
}

const int32_t *pm_mesh_elements(const pm_mesh *m, int dim) {
  if (!m) return NULL;
  return dim == 1 ? m->seg : dim == 2 ? m->tri : dim == 3 ? m->tet : NULL;
}

const int32_t *pm_mesh_element_cells(const pm_mesh *m, int dim) {
  if (!m) return NULL;
  return dim == 1 ? m->seg_cell : dim == 2 ? m->tri_cell : dim == 3 ? m->tet_cell : NULL;
}

pm_status pm_mesh_classify(pm_mesh *m, const pm_model *model, int32_t *classified,
                           int32_t *unmatched, pm_error *err) {
  pm_classify_counts c;
  pm_status s = pm_classify_mesh(m, model, &c, err);
  if (classified) *classified = s ? 0 : c.nodes;
  if (unmatched) *unmatched = s ? 0 : c.unmatched;
  return s;
}
