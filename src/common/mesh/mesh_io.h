/* Mesh files: writing every output format of the packmesh command and reading meshes made by
 * other tools, so that they can be measured by the same quality code.
 *
 * Formats, chosen by the file extension (case-insensitive):
 *   .msh   gmsh MSH 4.1, ASCII, written by gmsh itself. Every model cell becomes a discrete
 *          entity (dim, tag = cell index + 1); a node is stored on the entity of its cell,
 *          elements on the entity of their cell. The node's parameters (curve: t, face: u v;
 *          Mesh.SaveParametric) are written only on request (pm_mesh_write_opts.msh_parametric):
 *          meshio 7 refuses parametric nodes ("parametric nodes not implemented"), gmsh and
 *          packmesh read both. Three $ElementData blocks follow, the per-element quality of
 *          quality.h ("radius_ratio", "aspect_ratio", "min_angle_deg"; -1 on segments), every
 *          element by tag in the order of the $Elements blocks (gmsh reads by tag, meshio by
 *          order). Unclassified nodes and untagged elements go on a catch-all entity of tag
 *          PM_MSH_UNTAGGED. Reading reverses this exactly (node and element order included, as
 *          they are stored by increasing node / element tag).
 *   .vtk   legacy VTK 3.0, ASCII, written here (gmsh's writer stores no tags): the points,
 *          cells and arrays of .vtu below, as SCALARS of CELL_DATA and POINT_DATA, so that
 *          ParaView colours the legacy file by quality and packmesh reads its cells back.
 *   .stl   ASCII STL, written by gmsh, one solid per face (triangles only; a mesh without
 *          triangles is refused).
 *   .mesh  Medit (INRIA), written by gmsh: element references are the entity tags (cell + 1,
 *          PM_MSH_UNTAGGED for untagged elements); vertex references carry no meaning.
 *   In .mesh files point i is node i of the mesh (gmsh numbers nodes entity by entity, so for
 *   this format every node is put on one entity).
 *   .vtu   VTK XML unstructured grid (ParaView), ASCII, written here (gmsh 4.8.4 has no .vtu
 *          writer): points, lines / triangles / tets, cell data "cell" (the cell index, -1 when
 *          untagged) and the per-element values of element_measure.h, "radius_ratio", "aspect_ratio"
 *          (R / l_min) and "min_angle_deg" (a tet's smallest dihedral angle; -1 on segments),
 *          for colouring in ParaView; point data "node_dim", "node_cell" and "node_par"
 *          (2 components).
 *   .obj   Wavefront OBJ, written here (gmsh has no .obj writer): vertices, "l" segments and
 *          "f" triangles, a group "g cell_<index>" (or "g untagged") opening each run of
 *          elements of one cell. Tets have no OBJ form and are left out.
 * Reading is packmesh's own (mesh_read*.c), for .msh (MSH 2.x and 4.1, text or binary), .vtk
 * (legacy, ASCII or binary), .vtu (ascii arrays), .stl (ASCII or binary), .mesh and .obj: no input file
 * can crash the reader or make it allocate more than a small multiple of the file's size. Every
 * count a file declares is checked against the bytes that follow, every number is parsed whole,
 * coordinates must be finite and within +-PM_COORD_MAX (mesh.h), and every node an element uses
 * must be one the file defines; a file that fails any check is refused with a message naming the
 * file, the line (or byte) and the fault. Element entity tags t become cells t - 1 for .msh and
 * .mesh (PM_MSH_UNTAGGED becomes -1), .stl solids are cells 0, 1, ... in file order, .vtu and .vtk
 * cells come from their "cell" array, .obj elements from their "g cell_N" groups; nodes are classified from .msh (MSH 4.1: the entity block;
 * MSH 2: the lowest-dimensional element using the node, as gmsh does) and from .vtu's and .vtk's
 * node_dim / node_cell / node_par arrays; other formats carry no classification (node_dim = -1). Lines,
 * triangles and tets are read; a higher-order element is reduced to its corner nodes (the other
 * nodes are dropped unless an element has them as corners); any other element type
 * (quadrangles, hexahedra, prisms, pyramids) is refused with a message naming it. Point
 * elements are ignored. Nodes come in increasing tag order (file order for formats without
 * tags), elements by kind (lines, triangles, tets) and, within a kind, by increasing tag.
 *
 * Writing is atomic: the file is written under a temporary name in the same directory (same
 * extension, so gmsh picks the same format) and renamed into place; on any failure the temporary
 * file is removed and nothing is left at the destination.
 *
 * gmsh calls (writing) are made under pm_gmsh_lock() inside a model scope (gmsh_session.h), so a
 * CAD model loaded in gmsh stays current and untouched. Reading makes no gmsh call.
 */
#ifndef PM_MESH_IO_H
#define PM_MESH_IO_H

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Entity tag of the catch-all entity for unclassified nodes and untagged elements in .msh. */
#define PM_MSH_UNTAGGED 1073741824

/* pm_mesh_format, pm_mesh_format_of / _holds / _ext, pm_mesh_write_opts and pm_mesh_write_with
 * are part of the extended API (packmesh_extended.h). */

/* Write m to path (format by extension), atomically. Element indices must be in range and cell
 * indices below PM_MSH_UNTAGGED - 1 (PM_ERR_ARG otherwise); PM_ERR_IO when the file cannot be
 * written; PM_ERR_BACKEND when gmsh fails. */
pm_status pm_mesh_write(const pm_mesh *m, const char *path, pm_error *err);

/* Read a mesh from path (.msh, .vtk, .vtu, .stl, .mesh, .obj). *out receives a new mesh
 * (pm_mesh_destroy) on success, NULL on failure. PM_ERR_IO for a missing or unreadable file (or
 * a directory, a FIFO: only regular files are read), PM_ERR_PARSE for a malformed file or one
 * that holds no mesh, PM_ERR_ARG for an unknown extension or an unsupported
 * element type or variant of a format, PM_ERR_LIMIT beyond INT32_MAX nodes or elements,
 * PM_ERR_NOMEM. */
pm_status pm_mesh_read(const char *path, pm_mesh **out, pm_error *err);

/* The same from memory: `len` bytes at `data` (borrowed) in format fmt; `name` (may be NULL)
 * names the data in messages. */
pm_status pm_mesh_read_buffer(const char *name, pm_mesh_format fmt, const void *data, size_t len,
                              pm_mesh **out, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_MESH_IO_H */
