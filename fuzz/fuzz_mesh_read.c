/* libFuzzer target: the mesh readers (mesh_read*.c) on any bytes, each input read as every format
 * packmesh reads (.msh, .vtk, .vtu, .stl, .mesh), and what `packmesh quality` does with a mesh
 * that was read: the quality measures (quality.h) and the validity checker (mesh_check.h).
 * Beyond not crashing (ASan + UBSan) and not allocating beyond libFuzzer's limit, each read must
 * keep the reader's contract: on failure no mesh and one line naming the fault; on success a mesh
 * with elements whose node indices are in range. See README.md. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/mesh/mesh_io.h"
#include "common/measure/quality.h"

static void check_mesh(const pm_mesh *m) {
  if (m->nseg + m->ntri + m->ntet <= 0) abort();
  for (int64_t i = 0; i < 2 * (int64_t)m->nseg; ++i)
    if (m->seg[i] < 0 || m->seg[i] >= m->nnode) abort();
  for (int64_t i = 0; i < 3 * (int64_t)m->ntri; ++i)
    if (m->tri[i] < 0 || m->tri[i] >= m->nnode) abort();
  for (int64_t i = 0; i < 4 * (int64_t)m->ntet; ++i)
    if (m->tet[i] < 0 || m->tet[i] >= m->nnode) abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static const pm_mesh_format formats[6] = {PM_MESH_MSH, PM_MESH_VTK, PM_MESH_VTU, PM_MESH_STL,
                                            PM_MESH_MEDIT, PM_MESH_OBJ};
  for (int f = 0; f < 6; ++f) {
    pm_mesh *m = NULL;
    pm_error e = {0};
    pm_status st = pm_mesh_read_buffer("fuzz", formats[f], data, size, &m, &e);
    if (st != PM_OK) {
      if (m || !e.msg[0] || strchr(e.msg, '\n')) abort();
      continue;
    }
    if (!m) abort();
    check_mesh(m);
    pm_quality q = {0};
    pm_check_report r = {0};
    pm_quality_compute(m, NULL, &q, &e);
    pm_quality_clear(&q);
    pm_mesh_check(m, NULL, &r, &e);
    pm_check_report_clear(&r);
    pm_mesh_destroy(m);
  }
  return 0;
}
