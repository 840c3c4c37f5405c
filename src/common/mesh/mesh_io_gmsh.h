/* The mesh formats written through gmsh (mesh_io_gmsh.c), for mesh_io.c only: the one file of
 * the mesh folder that calls gmsh. */
#ifndef PM_MESH_IO_GMSH_H
#define PM_MESH_IO_GMSH_H

#include <packmesh/packmesh.h>

#include "common/mesh/mesh.h"
#include "common/mesh/mesh_io.h"

/* Write m in format fmt (.msh, .stl or .mesh) to the temporary file tmp with gmsh; path
 * is the destination, named in messages. .msh files get the node parameters when parametric is
 * set, and the per-element values of element_measure.h as $ElementData. The mesh is checked
 * already (element indices, cell indices below PM_MSH_UNTAGGED - 1). */
pm_status pm_mesh_write_gmsh(const pm_mesh *m, pm_mesh_format fmt, int parametric,
                             const char *tmp, const char *path, pm_error *err);

#endif /* PM_MESH_IO_GMSH_H */
