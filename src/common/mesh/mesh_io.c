/* Writing mesh files (see mesh_io.h for the formats and conventions): the checks, the atomic
 * write and the formats written by hand (.vtu, .obj). The formats gmsh writes are in
 * mesh_io_gmsh.c; reading is mesh_read*.c. */
#include "common/mesh/mesh_io.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "common/base/atomic_file.h"
#include "common/mesh/element_measure.h"
#include "common/mesh/mesh_io_gmsh.h"


static const char *const format_ext[PM_MESH_FORMAT_COUNT] = {"msh", "vtk", "vtu",
                                                             "stl", "obj", "mesh"};

const char *pm_mesh_format_ext(pm_mesh_format fmt) {
  return (fmt >= 0 && fmt < PM_MESH_FORMAT_COUNT) ? format_ext[fmt] : "";
}

/* The extension of path (after the last '.' of the last component), or NULL. */
static const char *path_ext(const char *path) {
  const char *slash = strrchr(path, '/');
  const char *base = slash ? slash + 1 : path;
  const char *dot = strrchr(base, '.');
  return (dot && dot != base && dot[1]) ? dot + 1 : NULL;
}

int pm_mesh_format_holds(pm_mesh_format fmt, int dim) {
  if (fmt == PM_MESH_STL) return dim == 2;
  if (fmt == PM_MESH_OBJ) return dim == 1 || dim == 2;
  return dim >= 1 && dim <= 3;
}

pm_status pm_mesh_format_of(const char *path, pm_mesh_format *fmt, pm_error *err) {
  if (!path || !path[0]) return pm_error_setf(err, PM_ERR_ARG, "no mesh file name given");
  const char *ext = path_ext(path);
  if (!ext)
    return pm_error_setf(err, PM_ERR_ARG,
                         "%s: no file extension (use .msh, .vtk, .vtu, .stl, .obj or .mesh)",
                         path);
  for (int f = 0; f < PM_MESH_FORMAT_COUNT; ++f)
    if (strcasecmp(ext, format_ext[f]) == 0) {
      *fmt = (pm_mesh_format)f;
      return PM_OK;
    }
  return pm_error_setf(err, PM_ERR_ARG,
                       "%s: unknown mesh format '.%s' (use .msh, .vtk, .vtu, .stl, .obj or .mesh)",
                       path, ext);
}

static pm_status check_mesh(const pm_mesh *m, pm_error *err) {
  struct {
    const int32_t *conn, *cell;
    int32_t n;
    int per;
    const char *what;
  } k[3] = {{m->seg, m->seg_cell, m->nseg, 2, "segment"},
            {m->tri, m->tri_cell, m->ntri, 3, "triangle"},
            {m->tet, m->tet_cell, m->ntet, 4, "tetrahedron"}};
  for (int j = 0; j < 3; ++j)
    for (int32_t t = 0; t < k[j].n; ++t) {
      for (int q = 0; q < k[j].per; ++q) {
        int32_t v = k[j].conn[(size_t)k[j].per * t + q];
        if (v < 0 || v >= m->nnode)
          return pm_error_setf(err, PM_ERR_ARG, "%s %ld uses node %ld, the mesh has %ld nodes",
                               k[j].what, (long)t, (long)v, (long)m->nnode);
      }
      if (k[j].cell[t] >= PM_MSH_UNTAGGED - 1)
        return pm_error_setf(err, PM_ERR_ARG, "%s %ld has cell index %ld, too large for a file",
                             k[j].what, (long)t, (long)k[j].cell[t]);
    }
  for (int32_t v = 0; v < m->nnode; ++v)
    if (m->node_dim[v] >= 0 && m->node_cell[v] >= PM_MSH_UNTAGGED - 1)
      return pm_error_setf(err, PM_ERR_ARG, "node %ld has cell index %ld, too large for a file",
                           (long)v, (long)m->node_cell[v]);
  return PM_OK;
}

static void put_double(FILE *f, double x) { fprintf(f, "%.17g", x); }

/* ---- writing by hand: .vtk, .vtu and .obj -------------------------------------------------------- */


/* The values of the cells in VTK's order, one per line: segments first (-1: a segment has no
 * such measure), then the triangles', then the tets'. */
static void put_cell_values(FILE *f, const pm_mesh *m, const double *tri, const double *tet) {
  for (int32_t i = 0; i < m->nseg; ++i) fputs("-1\n", f);
  for (int32_t i = 0; i < m->ntri; ++i) {
    put_double(f, tri[i]);
    fputc('\n', f);
  }
  for (int32_t i = 0; i < m->ntet; ++i) {
    put_double(f, tet[i]);
    fputc('\n', f);
  }
}

/* The cell of each cell in VTK's order (-1 untagged). */
static void put_cell_cells(FILE *f, const pm_mesh *m) {
  for (int32_t i = 0; i < m->nseg; ++i) fprintf(f, "%ld\n", (long)m->seg_cell[i]);
  for (int32_t i = 0; i < m->ntri; ++i) fprintf(f, "%ld\n", (long)m->tri_cell[i]);
  for (int32_t i = 0; i < m->ntet; ++i) fprintf(f, "%ld\n", (long)m->tet_cell[i]);
}

/* The points, one per line. */
static void put_points(FILE *f, const pm_mesh *m) {
  for (int32_t v = 0; v < m->nnode; ++v) {
    for (int k = 0; k < 3; ++k) {
      if (k) fputc(' ', f);
      put_double(f, m->xyz[3 * (size_t)v + k]);
    }
    fputc('\n', f);
  }
}

/* The point data of both VTK formats, each array under the header its format gives it (legacy
 * SCALARS lines, XML DataArray tags): node_dim, node_cell (-1 when unclassified), node_par. */
static void put_node_dims(FILE *f, const pm_mesh *m) {
  for (int32_t v = 0; v < m->nnode; ++v) fprintf(f, "%d\n", (int)m->node_dim[v]);
}

static void put_node_cells(FILE *f, const pm_mesh *m) {
  for (int32_t v = 0; v < m->nnode; ++v)
    fprintf(f, "%ld\n", (long)(m->node_dim[v] >= 0 ? m->node_cell[v] : -1));
}

static void put_node_pars(FILE *f, const pm_mesh *m) {
  for (int32_t v = 0; v < m->nnode; ++v) {
    put_double(f, m->node_par[2 * (size_t)v]);
    fputc(' ', f);
    put_double(f, m->node_par[2 * (size_t)v + 1]);
    fputc('\n', f);
  }
}

/* VTK cell types: 3 = VTK_LINE, 5 = VTK_TRIANGLE, 10 = VTK_TETRA. */
static void put_cell_types(FILE *f, const pm_mesh *m) {
  for (int32_t i = 0; i < m->nseg; ++i) fputs("3\n", f);
  for (int32_t i = 0; i < m->ntri; ++i) fputs("5\n", f);
  for (int32_t i = 0; i < m->ntet; ++i) fputs("10\n", f);
}

/* Legacy VTK, ASCII: the same points, cells, cell data and point data as .vtu, for the tools that
 * read the legacy format only. */
static int write_vtk(const pm_mesh *m, const pm_element_values *q, FILE *f) {
  int64_t ncell = (int64_t)m->nseg + m->ntri + m->ntet;
  int64_t size = 3 * (int64_t)m->nseg + 4 * (int64_t)m->ntri + 5 * (int64_t)m->ntet;
  fprintf(f, "# vtk DataFile Version 3.0\npackmesh %s\nASCII\nDATASET UNSTRUCTURED_GRID\n"
             "POINTS %ld double\n", pm_version(), (long)m->nnode);
  put_points(f, m);
  fprintf(f, "CELLS %lld %lld\n", (long long)ncell, (long long)size);
  for (int32_t i = 0; i < m->nseg; ++i)
    fprintf(f, "2 %ld %ld\n", (long)m->seg[2 * (size_t)i], (long)m->seg[2 * (size_t)i + 1]);
  for (int32_t i = 0; i < m->ntri; ++i) {
    const int32_t *t = m->tri + 3 * (size_t)i;
    fprintf(f, "3 %ld %ld %ld\n", (long)t[0], (long)t[1], (long)t[2]);
  }
  for (int32_t i = 0; i < m->ntet; ++i) {
    const int32_t *t = m->tet + 4 * (size_t)i;
    fprintf(f, "4 %ld %ld %ld %ld\n", (long)t[0], (long)t[1], (long)t[2], (long)t[3]);
  }
  fprintf(f, "CELL_TYPES %lld\n", (long long)ncell);
  put_cell_types(f, m);
  fprintf(f, "CELL_DATA %lld\nSCALARS cell int 1\nLOOKUP_TABLE default\n", (long long)ncell);
  put_cell_cells(f, m);
  for (int a = 0; a < PM_ELEMENT_VALUES; ++a) {
    fprintf(f, "SCALARS %s double 1\nLOOKUP_TABLE default\n", pm_element_value_names[a]);
    put_cell_values(f, m, q->tri[a], q->tet[a]);
  }
  fprintf(f, "POINT_DATA %ld\nSCALARS node_dim int 1\nLOOKUP_TABLE default\n", (long)m->nnode);
  put_node_dims(f, m);
  fprintf(f, "SCALARS node_cell int 1\nLOOKUP_TABLE default\n");
  put_node_cells(f, m);
  fprintf(f, "SCALARS node_par double 2\nLOOKUP_TABLE default\n");
  put_node_pars(f, m);
  return !ferror(f);
}

static int write_vtu(const pm_mesh *m, const pm_element_values *q, FILE *f) {
  int64_t ncell = (int64_t)m->nseg + m->ntri + m->ntet;
  fprintf(f,
          "<?xml version=\"1.0\"?>\n"
          "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
          "header_type=\"UInt64\">\n"
          "  <UnstructuredGrid>\n"
          "    <Piece NumberOfPoints=\"%ld\" NumberOfCells=\"%lld\">\n",
          (long)m->nnode, (long long)ncell);
  fprintf(f, "      <PointData Scalars=\"node_dim\">\n"
             "        <DataArray type=\"Int32\" Name=\"node_dim\" format=\"ascii\">\n");
  put_node_dims(f, m);
  fprintf(f, "        </DataArray>\n"
             "        <DataArray type=\"Int32\" Name=\"node_cell\" format=\"ascii\">\n");
  put_node_cells(f, m);
  fprintf(f, "        </DataArray>\n"
             "        <DataArray type=\"Float64\" Name=\"node_par\" NumberOfComponents=\"2\" "
             "format=\"ascii\">\n");
  put_node_pars(f, m);
  fprintf(f, "        </DataArray>\n      </PointData>\n"
             "      <CellData Scalars=\"cell\">\n"
             "        <DataArray type=\"Int32\" Name=\"cell\" format=\"ascii\">\n");
  put_cell_cells(f, m);
  fprintf(f, "        </DataArray>\n");
  /* Per-element quality (quality.h), for colouring in ParaView: radius ratio, R / l_min and the
   * smallest angle (a tet's smallest dihedral angle). */
  for (int a = 0; a < PM_ELEMENT_VALUES; ++a) {
    fprintf(f, "        <DataArray type=\"Float64\" Name=\"%s\" format=\"ascii\">\n",
            pm_element_value_names[a]);
    put_cell_values(f, m, q->tri[a], q->tet[a]);
    fputs("        </DataArray>\n", f);
  }
  fprintf(f, "      </CellData>\n"
             "      <Points>\n"
             "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n");
  put_points(f, m);
  fprintf(f, "        </DataArray>\n      </Points>\n      <Cells>\n"
             "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
  for (int32_t i = 0; i < m->nseg; ++i)
    fprintf(f, "%ld %ld\n", (long)m->seg[2 * (size_t)i], (long)m->seg[2 * (size_t)i + 1]);
  for (int32_t i = 0; i < m->ntri; ++i) {
    const int32_t *t = m->tri + 3 * (size_t)i;
    fprintf(f, "%ld %ld %ld\n", (long)t[0], (long)t[1], (long)t[2]);
  }
  for (int32_t i = 0; i < m->ntet; ++i) {
    const int32_t *t = m->tet + 4 * (size_t)i;
    fprintf(f, "%ld %ld %ld %ld\n", (long)t[0], (long)t[1], (long)t[2], (long)t[3]);
  }
  fprintf(f, "        </DataArray>\n"
             "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
  int64_t off = 0;
  for (int32_t i = 0; i < m->nseg; ++i) fprintf(f, "%lld\n", (long long)(off += 2));
  for (int32_t i = 0; i < m->ntri; ++i) fprintf(f, "%lld\n", (long long)(off += 3));
  for (int32_t i = 0; i < m->ntet; ++i) fprintf(f, "%lld\n", (long long)(off += 4));
  fprintf(f, "        </DataArray>\n"
             "        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
  put_cell_types(f, m);
  fprintf(f, "        </DataArray>\n      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n"
             "</VTKFile>\n");
  return !ferror(f);
}

static void obj_group(FILE *f, int32_t cell, int32_t *current, int *started) {
  if (*started && cell == *current) return;
  if (cell >= 0)
    fprintf(f, "g cell_%ld\n", (long)cell);
  else
    fputs("g untagged\n", f);
  *current = cell;
  *started = 1;
}

static int write_obj(const pm_mesh *m, FILE *f) {
  fprintf(f, "# packmesh %s: %ld vertices, %ld segments, %ld triangles\n", pm_version(),
          (long)m->nnode, (long)m->nseg, (long)m->ntri);
  for (int32_t v = 0; v < m->nnode; ++v) {
    fputs("v ", f);
    for (int k = 0; k < 3; ++k) {
      if (k) fputc(' ', f);
      put_double(f, m->xyz[3 * (size_t)v + k]);
    }
    fputc('\n', f);
  }
  int32_t cur = 0;
  int started = 0;
  for (int32_t i = 0; i < m->nseg; ++i) {
    obj_group(f, m->seg_cell[i], &cur, &started);
    fprintf(f, "l %ld %ld\n", (long)m->seg[2 * (size_t)i] + 1, (long)m->seg[2 * (size_t)i + 1] + 1);
  }
  started = 0;
  for (int32_t i = 0; i < m->ntri; ++i) {
    const int32_t *t = m->tri + 3 * (size_t)i;
    obj_group(f, m->tri_cell[i], &cur, &started);
    fprintf(f, "f %ld %ld %ld\n", (long)t[0] + 1, (long)t[1] + 1, (long)t[2] + 1);
  }
  return !ferror(f);
}

static pm_status hand_write(const pm_mesh *m, pm_mesh_format fmt, FILE *f, const char *path,
                            pm_error *err) {
  int ok;
  if (fmt == PM_MESH_VTU || fmt == PM_MESH_VTK) {
    pm_element_values q;
    pm_status s = pm_element_values_compute(m, &q, err);
    if (s) return s;
    ok = fmt == PM_MESH_VTU ? write_vtu(m, &q, f) : write_vtk(m, &q, f);
    pm_element_values_clear(&q);
  } else {
    ok = write_obj(m, f);
  }
  if (!ok) return pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
  return PM_OK;
}

pm_status pm_mesh_write(const pm_mesh *m, const char *path, pm_error *err) {
  return pm_mesh_write_with(m, path, NULL, err);
}

pm_status pm_mesh_write_with(const pm_mesh *m, const char *path, const pm_mesh_write_opts *opts,
                             pm_error *err) {
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_write: no mesh");
  const int parametric = opts && opts->msh_parametric;
  pm_mesh_format fmt;
  pm_status s = pm_mesh_format_of(path, &fmt, err);
  if (s) return s;
  s = check_mesh(m, err);
  if (s) return s;
  if (fmt == PM_MESH_STL && m->ntri == 0)
    return pm_error_setf(err, PM_ERR_ARG, "%s: an STL file holds triangles; the mesh has none",
                         path);
  int by_hand = fmt == PM_MESH_VTU || fmt == PM_MESH_VTK || fmt == PM_MESH_OBJ;
  pm_atomic_file a;
  s = pm_atomic_begin(&a, path, by_hand, err);
  if (s) return s;
  if (by_hand)
    s = hand_write(m, fmt, a.f, path, err);
  else
    s = pm_mesh_write_gmsh(m, fmt, parametric, a.tmp, path, err);
  if (s) {
    pm_atomic_abort(&a);
    return s;
  }
  return pm_atomic_commit(&a, err);
}
