/* Legacy VTK files (.vtk), ASCII or BINARY (big-endian, as the format requires): DATASET
 * UNSTRUCTURED_GRID (POINTS, CELLS, CELL_TYPES) or POLYDATA (POINTS, LINES, POLYGONS; VERTICES
 * are ignored), with cell lists in the classic form (a count before each cell's points) or in
 * VTK 5's (OFFSETS and CONNECTIVITY arrays). Point i is node i (tag i + 1); cells carry no tag.
 * Cells read: lines, poly-lines (one segment per pair of consecutive points), triangles, tets,
 * and their quadratic forms (reduced to their corners); vertices are ignored; any other cell
 * type is refused by name. Of the data sections, the SCALARS arrays packmesh writes are read:
 * cell data "cell" (the element's cell, -1 untagged; UNSTRUCTURED_GRID only) and point data
 * "node_dim", "node_cell", "node_par" (the node's classification, as in .vtu); other SCALARS
 * arrays are passed over, and what follows any other data keyword (VECTORS, FIELD, ...) is not
 * read.
 *
 * Checked: every count against the bytes left, each cell's point count against its type, and
 * every point a cell uses against the number of points ("cell 4 uses point 77; the file has 3
 * points").
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

/* A list of cells: cell i has points conn[off[i] .. off[i + 1]). */
typedef struct cell_list {
  uint64_t n;
  uint64_t *off;  /* [n + 1] */
  uint64_t *conn; /* [off[n]] */
  const char *at; /* where the list starts, for messages */
} cell_list;

/* A SCALARS array packmesh reads (NULL values: absent). */
typedef struct data_array {
  double *v;      /* [n * ncomp] */
  const char *at; /* where its values start, for messages */
} data_array;

typedef struct vtk {
  pm_rd *r;
  int binary;
  uint64_t npoint;
  int have_points;
  cell_list cells, lines, polys;
  int32_t *types;  /* [cells.n] */
  uint64_t ntypes;
  const char *types_at;
  data_array cell, node_dim, node_cell, node_par;
} vtk;

static void list_free(cell_list *l) {
  free(l->off);
  free(l->conn);
  memset(l, 0, sizeof *l);
}

/* Binary data starts on the line after its keyword line. */
static pm_status data_line(vtk *v) {
  pm_rd *r = v->r;
  while (r->p < r->end && (*r->p == ' ' || *r->p == '\t' || *r->p == '\r')) ++r->p;
  if (r->p < r->end && *r->p == '\n') {
    ++r->p;
    return PM_OK;
  }
  return pm_rd_fail(r, r->p, 0, "expected the end of the line before binary data");
}

/* One integer of a list: 4-byte (or 8-byte when wide) big-endian, or a text number. */
static pm_status list_int(vtk *v, int wide, const char *what, uint64_t *out) {
  pm_rd *r = v->r;
  if (!v->binary) return pm_rd_uint(r, 0, out, "%s", what);
  const unsigned char *b;
  const char *at = r->p;
  pm_status s = pm_rd_bytes(r, wide ? 8 : 4, what, &b);
  if (s) return s;
  int swap = !pm_rd_host_big();
  int64_t x = wide ? (int64_t)pm_rd_u64(b, swap) : pm_rd_i32(b, swap);
  if (x < 0) return pm_rd_fail(r, at, 1, "%s is %lld; it must be 0 or more", what, (long long)x);
  *out = (uint64_t)x;
  return PM_OK;
}

/* The integer type named after OFFSETS / CONNECTIVITY: vtktypeint64 (wide) or vtktypeint32. */
static pm_status array_type(vtk *v, int *wide) {
  pm_rd *r = v->r;
  const char *at, *t;
  size_t n;
  pm_rd_skip_space(r);
  at = r->p;
  if (!pm_rd_token(r, &t, &n)) return pm_rd_fail(r, at, 0, "the file ends where an array type should be");
  if (n == 12 && strncasecmp(t, "vtktypeint64", n) == 0)
    *wide = 1;
  else if (n == 12 && strncasecmp(t, "vtktypeint32", n) == 0)
    *wide = 0;
  else {
    char q[40];
    pm_rd_quote(t, n, q);
    return pm_rd_fail(r, at, 0, "array type '%s' (vtktypeint64 or vtktypeint32 expected)", q);
  }
  return v->binary ? data_line(v) : PM_OK;
}

/* A cell list after its keyword ("CELLS n size", "LINES n size", "POLYGONS n size"). */
static pm_status read_list(vtk *v, const char *kw, cell_list *l) {
  pm_rd *r = v->r;
  if (l->off) return pm_rd_fail(r, r->p, 0, "a second %s list", kw);
  uint64_t n, size;
  pm_status s;
  if ((s = pm_rd_uint(r, 0, &n, "the number of %s", kw)) ||
      (s = pm_rd_uint(r, 0, &size, "the size of the %s list", kw)))
    return s;
  l->at = r->p;
  const char *save = r->p;
  if (pm_rd_peek_word(r, "OFFSETS", 1)) {
    /* VTK 5: n is the number of offsets (cells + 1), size the connectivity's length. */
    int wide;
    if ((s = array_type(v, &wide))) return s;
    if (n < 1) return pm_rd_fail(r, save, 0, "%s: an OFFSETS array needs at least one entry", kw);
    if ((s = pm_rd_room(r, n, v->binary ? (wide ? 8 : 4) : 2, v->binary, "offsets"))) return s;
    l->n = n - 1;
    l->off = malloc(n * sizeof *l->off);
    if (!l->off) return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
    for (uint64_t i = 0; i < n; ++i) {
      if ((s = list_int(v, wide, "an offset", &l->off[i]))) return s;
      if ((i == 0 && l->off[0] != 0) || (i > 0 && l->off[i] < l->off[i - 1]) || l->off[i] > size)
        return pm_rd_fail(r, r->p, v->binary,
                          "%s offset %llu is %llu (offsets start at 0, never decrease and end at "
                          "the connectivity's length %llu)",
                          kw, (unsigned long long)i, (unsigned long long)l->off[i],
                          (unsigned long long)size);
    }
    if (l->off[n - 1] != size)
      return pm_rd_fail(r, r->p, v->binary, "%s: the last offset is %llu, the connectivity has %llu",
                        kw, (unsigned long long)l->off[n - 1], (unsigned long long)size);
    if ((s = pm_rd_expect(r, "CONNECTIVITY", 1, "the CONNECTIVITY array")) ||
        (s = array_type(v, &wide)) ||
        (s = pm_rd_room(r, size, v->binary ? (wide ? 8 : 4) : 2, v->binary, "connectivity entries")))
      return s;
    l->conn = malloc((size ? size : 1) * sizeof *l->conn);
    if (!l->conn) return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
    for (uint64_t i = 0; i < size; ++i)
      if ((s = list_int(v, wide, "a point index", &l->conn[i]))) return s;
    return PM_OK;
  }
  /* The classic form: for each cell its point count, then its points; size numbers in all. */
  if (v->binary && (s = data_line(v))) return s;
  if ((s = pm_rd_room(r, size, v->binary ? 4 : 2, v->binary, "numbers in the cell list")))
    return s;
  if (n > size)
    return pm_rd_fail(r, l->at, 0, "%s: %llu cells cannot fit in a list of %llu numbers", kw,
                      (unsigned long long)n, (unsigned long long)size);
  l->n = n;
  l->off = malloc((n + 1) * sizeof *l->off);
  l->conn = malloc((size ? size : 1) * sizeof *l->conn);
  if (!l->off || !l->conn) return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  uint64_t used = 0, k = 0;
  l->off[0] = 0;
  for (uint64_t i = 0; i < n; ++i) {
    uint64_t c;
    if (used >= size)
      return pm_rd_fail(r, r->p, v->binary, "%s: the list of %llu numbers ends before cell %llu",
                        kw, (unsigned long long)size, (unsigned long long)i);
    if ((s = list_int(v, 0, "a cell's point count", &c))) return s;
    if (c > size - used - 1)
      return pm_rd_fail(r, r->p, v->binary,
                        "%s cell %llu claims %llu points; the list has %llu numbers left", kw,
                        (unsigned long long)i, (unsigned long long)c,
                        (unsigned long long)(size - used - 1));
    used += 1 + c;
    for (uint64_t j = 0; j < c; ++j)
      if ((s = list_int(v, 0, "a point index", &l->conn[k++]))) return s;
    l->off[i + 1] = k;
  }
  if (used != size)
    return pm_rd_fail(r, r->p, v->binary, "%s: the list declares %llu numbers, its cells hold %llu",
                      kw, (unsigned long long)size, (unsigned long long)used);
  return PM_OK;
}

static pm_status read_points(vtk *v) {
  pm_rd *r = v->r;
  if (v->have_points) return pm_rd_fail(r, r->p, 0, "a second POINTS section");
  v->have_points = 1;
  uint64_t n;
  pm_status s = pm_rd_uint(r, 0, &n, "the number of points");
  if (s) return s;
  pm_rd_skip_space(r);
  const char *at = r->p, *t;
  size_t len;
  if (!pm_rd_token(r, &t, &len)) return pm_rd_fail(r, at, 0, "the file ends where the POINTS type should be");
  int size = 0;
  if (len == 5 && strncasecmp(t, "float", 5) == 0) size = 4;
  if (len == 6 && strncasecmp(t, "double", 6) == 0) size = 8;
  if (!size) {
    char q[40];
    pm_rd_quote(t, len, q);
    return pm_rd_fail(r, at, 0, "POINTS of type '%s' (float or double expected)", q);
  }
  if (v->binary && (s = data_line(v))) return s;
  if ((s = pm_rd_room(r, n, v->binary ? 3 * (uint64_t)size : 6, v->binary, "POINTS"))) return s;
  int swap = !pm_rd_host_big();
  for (uint64_t i = 0; i < n && !s; ++i) {
    double x[3];
    const char *pat = r->p;
    if (v->binary) {
      const unsigned char *b;
      if ((s = pm_rd_bytes(r, 3 * (size_t)size, "a point", &b))) break;
      for (int k = 0; k < 3; ++k)
        x[k] = size == 8 ? pm_rd_f64(b + 8 * k, swap) : (double)pm_rd_f32(b + 4 * k, swap);
    } else {
      pm_rd_skip_space(r);
      pat = r->p;
      for (int k = 0; k < 3 && !s; ++k) s = pm_rd_double(r, &x[k], "a coordinate of point %llu", (unsigned long long)i);
      if (s) break;
    }
    s = pm_rd_node(r, pat, v->binary, i + 1, x, -1, -1, NULL);
  }
  v->npoint = n;
  return s;
}

static pm_status read_types(vtk *v) {
  pm_rd *r = v->r;
  if (v->types) return pm_rd_fail(r, r->p, 0, "a second CELL_TYPES section");
  uint64_t n;
  pm_status s = pm_rd_uint(r, 0, &n, "the number of cell types");
  if (s) return s;
  v->types_at = r->p;
  if (v->binary && (s = data_line(v))) return s;
  if ((s = pm_rd_room(r, n, v->binary ? 4 : 2, v->binary, "CELL_TYPES"))) return s;
  v->types = malloc((n ? n : 1) * sizeof *v->types);
  if (!v->types) return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  v->ntypes = n;
  for (uint64_t i = 0; i < n; ++i) {
    uint64_t t;
    if ((s = list_int(v, 0, "a cell type", &t))) return s;
    v->types[i] = t > INT32_MAX ? INT32_MAX : (int32_t)t;
  }
  return PM_OK;
}

/* The data types of legacy VTK arrays: size in bytes, real or integer, signed. */
typedef struct data_type {
  const char *name;
  int size, real, is_signed;
} data_type;

static const data_type data_types[] = {
    {"unsigned_char", 1, 0, 0},  {"char", 1, 0, 1},          {"unsigned_short", 2, 0, 0},
    {"short", 2, 0, 1},          {"unsigned_int", 4, 0, 0},  {"int", 4, 0, 1},
    {"unsigned_long", 8, 0, 0},  {"long", 8, 0, 1},          {"vtktypeuint64", 8, 0, 0},
    {"vtktypeint64", 8, 0, 1},   {"vtktypeuint32", 4, 0, 0}, {"vtktypeint32", 4, 0, 1},
    {"float", 4, 1, 1},          {"double", 8, 1, 1},
};

/* One value of a data array: a text number, or `t->size` big-endian bytes. */
static pm_status data_value(vtk *v, const data_type *t, double *out) {
  pm_rd *r = v->r;
  if (!v->binary) return pm_rd_double(r, out, "a data value");
  const unsigned char *b;
  pm_status s = pm_rd_bytes(r, (size_t)t->size, "a data value", &b);
  if (s) return s;
  int swap = !pm_rd_host_big();
  if (t->real) {
    *out = t->size == 8 ? pm_rd_f64(b, swap) : (double)pm_rd_f32(b, swap);
    return PM_OK;
  }
  uint64_t u = 0;
  for (int k = 0; k < t->size; ++k) u = u << 8 | b[k]; /* big-endian, as the format requires */
  if (t->is_signed && t->size < 8 && (u >> (8 * t->size - 1)))
    u |= ~UINT64_C(0) << (8 * t->size); /* sign-extend */
  *out = t->is_signed ? (double)(int64_t)u : (double)u;
  return PM_OK;
}

/* The SCALARS arrays after "POINT_DATA n" or "CELL_DATA n": those packmesh writes are kept,
 * others read past. Returns at the first keyword that is not SCALARS. */
static pm_status read_data(vtk *v, int on_cells) {
  pm_rd *r = v->r;
  const char *at = r->p;
  uint64_t n;
  pm_status s = pm_rd_uint(r, 0, &n, "the number of %s data values", on_cells ? "cell" : "point");
  if (s) return s;
  if (on_cells ? !v->cells.off : !v->have_points)
    return pm_rd_fail(r, at, 0, "%s before %s", on_cells ? "CELL_DATA" : "POINT_DATA",
                      on_cells ? "CELLS" : "POINTS");
  uint64_t want = on_cells ? v->cells.n : v->npoint;
  if (n != want)
    return pm_rd_fail(r, at, 0, "%s %llu for %llu %s", on_cells ? "CELL_DATA" : "POINT_DATA",
                      (unsigned long long)n, (unsigned long long)want,
                      on_cells ? "cells" : "points");
  while (!s && pm_rd_peek_word(r, "SCALARS", 1)) {
    const char *name, *type;
    size_t nlen, tlen;
    pm_rd_skip_space(r);
    at = r->p;
    if (!pm_rd_token(r, &name, &nlen) || (pm_rd_skip_space(r), !pm_rd_token(r, &type, &tlen)))
      return pm_rd_fail(r, at, 0, "the file ends in a SCALARS line");
    const data_type *t = NULL;
    for (size_t i = 0; i < sizeof data_types / sizeof data_types[0]; ++i)
      if (strlen(data_types[i].name) == tlen && strncasecmp(type, data_types[i].name, tlen) == 0)
        t = &data_types[i];
    if (!t) {
      char q[40];
      pm_rd_quote(type, tlen, q);
      return pm_rd_fail(r, at, 0, "SCALARS of type '%s' (a VTK integer or real type expected)", q);
    }
    uint64_t ncomp = 1;
    if (!pm_rd_peek_word(r, "LOOKUP_TABLE", 1)) {
      if ((s = pm_rd_uint(r, 1, &ncomp, "the number of SCALARS components"))) return s;
      if (ncomp > 4)
        return pm_rd_fail(r, at, 0, "SCALARS with %llu components (1 to 4)",
                          (unsigned long long)ncomp);
      if ((s = pm_rd_expect(r, "LOOKUP_TABLE", 1, "the LOOKUP_TABLE line"))) return s;
    }
    pm_rd_skip_space(r);
    const char *table;
    size_t len;
    if (!pm_rd_token(r, &table, &len)) return pm_rd_fail(r, r->p, 0, "the file ends in a LOOKUP_TABLE line");
    if (v->binary && (s = data_line(v))) return s;
    if ((s = pm_rd_room(r, n * ncomp, v->binary ? (uint64_t)t->size : 2, v->binary, "data values")))
      return s;
    data_array *keep = NULL;
#define NAMED(w) (nlen == sizeof(w) - 1 && strncmp(name, w, nlen) == 0)
    if (on_cells && NAMED("cell") && ncomp == 1) keep = &v->cell;
    if (!on_cells && NAMED("node_dim") && ncomp == 1) keep = &v->node_dim;
    if (!on_cells && NAMED("node_cell") && ncomp == 1) keep = &v->node_cell;
    if (!on_cells && NAMED("node_par") && ncomp == 2) keep = &v->node_par;
#undef NAMED
    if (keep && keep->v) return pm_rd_fail(r, at, 0, "a second array of this name");
    if (keep) {
      keep->at = r->p;
      keep->v = malloc((n > 0 ? n * ncomp : 1) * sizeof *keep->v);
      if (!keep->v) return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
    }
    for (uint64_t i = 0; i < n * ncomp && !s; ++i) {
      double x;
      if (!(s = data_value(v, t, &x)) && keep) keep->v[i] = x;
    }
  }
  return s;
}

/* A value of a "cell", "node_dim" or "node_cell" array as an index in [lo, INT32_MAX). */
static int index_value(double x, double lo, int32_t *out) {
  if (!(x >= lo && x < INT32_MAX) || x != (double)(int64_t)x) return 0;
  *out = (int32_t)x;
  return 1;
}

/* The nodes' classification from node_dim, node_cell and node_par, when the first two are
 * there (as .vtu: a node with dimension -1 or cell -1 is unclassified). */
static pm_status classify_points(vtk *v) {
  pm_rd *r = v->r;
  if (!v->node_dim.v || !v->node_cell.v) return PM_OK;
  for (uint64_t i = 0; i < v->npoint; ++i) {
    int32_t d, c;
    if (!index_value(v->node_dim.v[i], -1, &d) || d > 3 || !index_value(v->node_cell.v[i], -1, &c))
      return pm_rd_fail(r, v->node_dim.at, 0, "point %llu: node_dim %g, node_cell %g (-1..3 and "
                        "-1 or more expected)", (unsigned long long)i, v->node_dim.v[i],
                        v->node_cell.v[i]);
    rd_node *n = &r->node[i];
    n->dim = (int8_t)(d >= 0 && c >= 0 ? d : -1);
    n->cell = n->dim >= 0 ? c : -1;
    if (n->dim < 0 || !v->node_par.v) continue;
    for (int k = 0; k < 2; ++k) {
      n->par[k] = v->node_par.v[2 * i + k];
      if (!isfinite(n->par[k]))
        return pm_rd_fail(r, v->node_par.at, 0, "point %llu has a non-finite parameter",
                          (unsigned long long)i);
    }
  }
  return PM_OK;
}

/* VTK's cell types: name, and what packmesh makes of them. */
typedef struct vtk_type {
  int id;
  const char *name;
  int kind;   /* 0 ignored (vertices), 1 line, 2 triangle, 3 tet, 4 poly-line; -1 refused */
  int npts;   /* points per cell (0: any number) */
} vtk_type;

static const vtk_type vtk_types[] = {
    {1, "VTK_VERTEX", 0, 1},          {2, "VTK_POLY_VERTEX", 0, 0},
    {3, "VTK_LINE", 1, 2},            {4, "VTK_POLY_LINE", 4, 0},
    {5, "VTK_TRIANGLE", 2, 3},        {6, "VTK_TRIANGLE_STRIP", -1, 0},
    {7, "VTK_POLYGON", -1, 0},        {8, "VTK_PIXEL", -1, 4},
    {9, "VTK_QUAD", -1, 4},           {10, "VTK_TETRA", 3, 4},
    {11, "VTK_VOXEL", -1, 8},         {12, "VTK_HEXAHEDRON", -1, 8},
    {13, "VTK_WEDGE", -1, 6},         {14, "VTK_PYRAMID", -1, 5},
    {21, "VTK_QUADRATIC_EDGE", 1, 3}, {22, "VTK_QUADRATIC_TRIANGLE", 2, 6},
    {23, "VTK_QUADRATIC_QUAD", -1, 8}, {24, "VTK_QUADRATIC_TETRA", 3, 10},
    {25, "VTK_QUADRATIC_HEXAHEDRON", -1, 20}, {26, "VTK_QUADRATIC_WEDGE", -1, 15},
    {27, "VTK_QUADRATIC_PYRAMID", -1, 13}, {42, "VTK_POLYHEDRON", -1, 0},
};

pm_status pm_rd_vtk_cell(pm_rd *r, const char *at, int binary, int type, uint64_t index,
                         const uint64_t *pts, uint64_t n, uint64_t npoint, int32_t cell) {
  const vtk_type *t = NULL;
  for (size_t i = 0; i < sizeof vtk_types / sizeof vtk_types[0]; ++i)
    if (vtk_types[i].id == type) t = &vtk_types[i];
  if (!t || t->kind < 0) {
    char name[48];
    if (t)
      snprintf(name, sizeof name, "%s", t->name);
    else
      snprintf(name, sizeof name, "VTK cell of type %d", type);
    pm_rd_fail(r, at, binary, "cell %llu is a %s; packmesh reads lines, triangles and tetrahedra only",
               (unsigned long long)index, name);
    if (r->err) r->err->code = PM_ERR_ARG; /* a valid file packmesh does not handle */
    return PM_ERR_ARG;
  }
  for (uint64_t j = 0; j < n; ++j)
    if (pts[j] >= npoint)
      return pm_rd_fail(r, at, binary, "cell %llu uses point %llu; the file has %llu points",
                        (unsigned long long)index, (unsigned long long)pts[j],
                        (unsigned long long)npoint);
  if (t->npts && n != (uint64_t)t->npts)
    return pm_rd_fail(r, at, binary, "cell %llu: a %s has %d points, this one %llu",
                      (unsigned long long)index, t->name, t->npts, (unsigned long long)n);
  if (t->kind == 0) return PM_OK;
  pm_status s = PM_OK;
  if (t->kind == 4) {
    if (n < 2)
      return pm_rd_fail(r, at, binary, "cell %llu: a %s needs 2 points or more",
                        (unsigned long long)index, t->name);
    for (uint64_t j = 0; j + 1 < n && !s; ++j) {
      uint64_t c[2] = {pts[j] + 1, pts[j + 1] + 1};
      s = pm_rd_elem(r, 1, r->nel + 1, c, cell);
    }
    return s;
  }
  uint64_t c[4];
  for (int q = 0; q <= t->kind; ++q) c[q] = pts[q] + 1;
  s = pm_rd_elem(r, t->kind, r->nel + 1, c, cell);
  for (uint64_t j = (uint64_t)t->kind + 1; j < n && !s; ++j) s = pm_rd_ho(r, pts[j] + 1);
  return s;
}

static pm_status refuse(vtk *v, const char *at, const char *what, uint64_t index) {
  pm_rd_fail(v->r, at, 0, "cell %llu is a %s; packmesh reads lines, triangles and tetrahedra only",
             (unsigned long long)index, what);
  if (v->r->err) v->r->err->code = PM_ERR_ARG; /* a valid file packmesh does not handle */
  return PM_ERR_ARG;
}

static pm_status build(vtk *v, int polydata) {
  pm_rd *r = v->r;
  if (!v->have_points) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: no POINTS", r->name);
  pm_status s = classify_points(v);
  if (s) return s;
  if (!polydata) {
    if (!v->cells.off) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: no CELLS", r->name);
    if (!v->types) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: CELLS without CELL_TYPES", r->name);
    if (v->ntypes != v->cells.n)
      return pm_rd_fail(r, v->types_at, 0, "CELL_TYPES gives %llu types for %llu cells",
                        (unsigned long long)v->ntypes, (unsigned long long)v->cells.n);
    for (uint64_t i = 0; i < v->cells.n && !s; ++i) {
      int32_t cell = -1;
      if (v->cell.v && !index_value(v->cell.v[i], -1, &cell))
        return pm_rd_fail(r, v->cell.at, 0, "cell %llu has cell index %g (-1 or more expected)",
                          (unsigned long long)i, v->cell.v[i]);
      s = pm_rd_vtk_cell(r, v->cells.at, v->binary, v->types[i], i, v->cells.conn + v->cells.off[i],
                         v->cells.off[i + 1] - v->cells.off[i], v->npoint, cell);
    }
    return s;
  }
  for (uint64_t i = 0; i < v->lines.n && !s; ++i)
    s = pm_rd_vtk_cell(r, v->lines.at, v->binary, 4 /* VTK_POLY_LINE */, i,
                       v->lines.conn + v->lines.off[i], v->lines.off[i + 1] - v->lines.off[i],
                       v->npoint, -1);
  for (uint64_t i = 0; i < v->polys.n && !s; ++i) {
    uint64_t n = v->polys.off[i + 1] - v->polys.off[i];
    if (n != 3) {
      char what[64];
      snprintf(what, sizeof what, "polygon of %llu points", (unsigned long long)n);
      s = refuse(v, v->polys.at, what, v->lines.n + i);
      break;
    }
    s = pm_rd_vtk_cell(r, v->polys.at, v->binary, 5 /* VTK_TRIANGLE */, v->lines.n + i,
                       v->polys.conn + v->polys.off[i], n, v->npoint, -1);
  }
  return s;
}

pm_status pm_rd_parse_vtk(pm_rd *r) {
  r->node_word = "point";
  static const char magic[] = "# vtk DataFile Version";
  if ((size_t)(r->end - r->base) < sizeof magic - 1 || memcmp(r->base, magic, sizeof magic - 1) != 0)
    return pm_rd_fail(r, r->base, 0, "not a legacy VTK file: it does not begin with '%s'", magic);
  vtk v;
  memset(&v, 0, sizeof v);
  v.r = r;
  pm_rd_skip_line(r); /* the version line */
  pm_rd_skip_line(r); /* the title */
  pm_status s = PM_OK;
  pm_rd_skip_space(r);
  if (pm_rd_peek_word(r, "BINARY", 1))
    v.binary = 1;
  else if (!pm_rd_peek_word(r, "ASCII", 1))
    return pm_rd_fail(r, r->p, 0, "expected ASCII or BINARY on the third line");
  if ((s = pm_rd_expect(r, "DATASET", 1, "the DATASET line"))) return s;
  int polydata = 0;
  if (pm_rd_peek_word(r, "POLYDATA", 1)) {
    polydata = 1;
  } else if (!pm_rd_peek_word(r, "UNSTRUCTURED_GRID", 1)) {
    pm_rd_skip_space(r);
    const char *at = r->p, *t;
    size_t n;
    pm_rd_token(r, &t, &n);
    char q[40];
    pm_rd_quote(t, n, q);
    pm_rd_fail(r, at, 0, "DATASET %s is not read (packmesh reads UNSTRUCTURED_GRID and POLYDATA)", q);
    if (r->err) r->err->code = PM_ERR_ARG;
    return PM_ERR_ARG;
  }
  int in_data = 0;
  while (!s) {
    pm_rd_skip_space(r);
    if (r->p >= r->end) break;
    const char *at = r->p, *t;
    size_t n;
    pm_rd_token(r, &t, &n);
#define IS(w) (n == sizeof(w) - 1 && strncasecmp(t, w, n) == 0)
    if (IS("POINTS")) {
      s = read_points(&v);
    } else if (!polydata && IS("CELLS")) {
      s = read_list(&v, "CELLS", &v.cells);
    } else if (!polydata && IS("CELL_TYPES")) {
      s = read_types(&v);
    } else if (polydata && IS("LINES")) {
      s = read_list(&v, "LINES", &v.lines);
    } else if (polydata && IS("POLYGONS")) {
      s = read_list(&v, "POLYGONS", &v.polys);
    } else if (polydata && IS("VERTICES")) {
      cell_list ignored = {0, NULL, NULL, NULL};
      s = read_list(&v, "VERTICES", &ignored);
      list_free(&ignored);
    } else if (polydata && IS("TRIANGLE_STRIPS")) {
      s = refuse(&v, at, "triangle strip", 0);
    } else if (IS("POINT_DATA") || (!polydata && IS("CELL_DATA"))) {
      in_data = 1;
      s = read_data(&v, IS("CELL_DATA"));
    } else if (in_data || IS("CELL_DATA") || IS("FIELD") || IS("METADATA")) {
      break; /* other data arrays, and a POLYDATA's cell data: not read */
    } else {
      char q[40];
      pm_rd_quote(t, n, q);
      s = pm_rd_fail(r, at, 0, "unexpected keyword '%s'", q);
    }
#undef IS
  }
  if (!s) s = build(&v, polydata);
  list_free(&v.cells);
  list_free(&v.lines);
  list_free(&v.polys);
  free(v.types);
  free(v.cell.v);
  free(v.node_dim.v);
  free(v.node_cell.v);
  free(v.node_par.v);
  return s;
}
