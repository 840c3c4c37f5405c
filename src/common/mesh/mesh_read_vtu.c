/* VTK XML unstructured grids (.vtu) with ascii DataArrays: the format packmesh writes, and
 * ParaView's when saved as ascii. One Piece; Points; Cells (connectivity, offsets, types, the
 * same cell types as .vtk); and, when present, the arrays packmesh writes: cell data "cell" (the
 * element's cell, -1 untagged) and point data "node_dim", "node_cell", "node_par" (the node's
 * classification), so that a .vtu written by packmesh reads back whole. Arrays stored as binary,
 * or appended, are refused by name.
 *
 * The XML is scanned, not validated: tags, attributes and the text of DataArrays are read; what
 * the reader does not need is skipped. Checked: the Piece's counts against the bytes left, each
 * array's length against them, offsets (increasing, ending at the connectivity's length), the
 * points each cell uses, the cell types, and the classification values' ranges.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

typedef struct xml_tag {
  const char *at;          /* the '<' */
  const char *name;        /* after '<' or '</' */
  size_t nlen;
  const char *attrs, *attrs_end;
  int closing, empty;      /* </name>, <name/> */
} xml_tag;

/* A growing array of numbers, read as doubles (integers are checked to be whole). */
typedef struct num_array {
  double *v;
  size_t n, cap;
  int present;
  const char *at;
} num_array;

typedef struct vtu {
  pm_rd *r;
  int have_piece;
  uint64_t npoint, ncell;
  num_array points, conn, offsets, types, cell, node_dim, node_cell, node_par;
} vtu;

/* The next tag from the cursor; 0 at the end of the file. Comments, processing instructions and
 * declarations are skipped. */
static pm_status next_tag(pm_rd *r, xml_tag *t, int *found) {
  *found = 0;
  for (;;) {
    const char *lt = memchr(r->p, '<', (size_t)(r->end - r->p));
    if (!lt) {
      r->p = r->end;
      return PM_OK;
    }
    r->p = lt;
    const char *close = NULL;
    if (r->end - lt >= 4 && memcmp(lt, "<!--", 4) == 0) {
      for (const char *c = lt + 4; c + 3 <= r->end; ++c)
        if (memcmp(c, "-->", 3) == 0) {
          close = c + 3;
          break;
        }
      if (!close) return pm_rd_fail(r, lt, 0, "a comment is not closed");
      r->p = close;
      continue;
    }
    if (r->end - lt >= 2 && (lt[1] == '?' || lt[1] == '!')) {
      const char *gt = memchr(lt, '>', (size_t)(r->end - lt));
      if (!gt) return pm_rd_fail(r, lt, 0, "a declaration is not closed");
      r->p = gt + 1;
      continue;
    }
    memset(t, 0, sizeof *t);
    t->at = lt;
    const char *c = lt + 1;
    if (c < r->end && *c == '/') t->closing = 1, ++c;
    t->name = c;
    while (c < r->end && *c != '>' && *c != '/' && *c != ' ' && *c != '\t' && *c != '\n' && *c != '\r') ++c;
    t->nlen = (size_t)(c - t->name);
    if (t->nlen == 0) return pm_rd_fail(r, lt, 0, "a tag without a name");
    t->attrs = c;
    char quote = 0;
    while (c < r->end && (quote || *c != '>')) {
      if (quote && *c == quote)
        quote = 0;
      else if (!quote && (*c == '"' || *c == '\''))
        quote = *c;
      ++c;
    }
    if (c >= r->end) return pm_rd_fail(r, lt, 0, "a tag is not closed");
    t->attrs_end = c;
    if (c > t->attrs && c[-1] == '/') t->empty = 1, t->attrs_end = c - 1;
    r->p = c + 1;
    *found = 1;
    return PM_OK;
  }
}

static int tag_is(const xml_tag *t, const char *name) {
  return t->nlen == strlen(name) && memcmp(t->name, name, t->nlen) == 0;
}

/* The value of attribute `name` (not NUL-terminated): 1 when present. */
static int attr(const xml_tag *t, const char *name, const char **v, size_t *vlen) {
  size_t nl = strlen(name);
  const char *c = t->attrs;
  while (c < t->attrs_end) {
    while (c < t->attrs_end && (*c == ' ' || *c == '\t' || *c == '\n' || *c == '\r')) ++c;
    const char *an = c;
    while (c < t->attrs_end && *c != '=' && *c != ' ' && *c != '\t' && *c != '\n' && *c != '\r') ++c;
    size_t al = (size_t)(c - an);
    while (c < t->attrs_end && *c != '=' && *c != '"' && *c != '\'') ++c;
    if (c < t->attrs_end && *c == '=') ++c;
    while (c < t->attrs_end && (*c == ' ' || *c == '\t' || *c == '\n' || *c == '\r')) ++c;
    if (c >= t->attrs_end) return 0;
    if (*c != '"' && *c != '\'') {
      ++c;
      continue;
    }
    char q = *c++;
    const char *vs = c;
    while (c < t->attrs_end && *c != q) ++c;
    if (al == nl && memcmp(an, name, nl) == 0) {
      *v = vs;
      *vlen = (size_t)(c - vs);
      return 1;
    }
    if (c < t->attrs_end) ++c;
  }
  return 0;
}

static int attr_is(const xml_tag *t, const char *name, const char *value) {
  const char *v;
  size_t n;
  return attr(t, name, &v, &n) && n == strlen(value) && memcmp(v, value, n) == 0;
}

/* A whole-number attribute, checked against the bytes left (each item takes `min_bytes`). */
static pm_status count_attr(vtu *u, const xml_tag *t, const char *name, uint64_t min_bytes,
                            uint64_t *out) {
  pm_rd *r = u->r;
  const char *v;
  size_t n;
  if (!attr(t, name, &v, &n)) return pm_rd_fail(r, t->at, 0, "the Piece has no %s", name);
  uint64_t x = 0;
  if (n == 0 || n > 19) return pm_rd_fail(r, t->at, 0, "%s is not a whole number", name);
  for (size_t i = 0; i < n; ++i) {
    if (v[i] < '0' || v[i] > '9') return pm_rd_fail(r, t->at, 0, "%s is not a whole number", name);
    x = 10 * x + (uint64_t)(v[i] - '0');
  }
  pm_status s = pm_rd_room(r, x, min_bytes, 0, name);
  if (s) return s;
  *out = x;
  return PM_OK;
}

/* The text of a DataArray up to its </DataArray>, as numbers (whole numbers when `whole`). */
static pm_status read_array(vtu *u, const xml_tag *t, num_array *a, const char *name, int whole) {
  pm_rd *r = u->r;
  if (a->present) return pm_rd_fail(r, t->at, 0, "a second DataArray '%s'", name);
  a->present = 1;
  a->at = t->at;
  const char *fv;
  size_t fl;
  if (attr(t, "format", &fv, &fl) && !(fl == 5 && memcmp(fv, "ascii", 5) == 0)) {
    char q[40];
    pm_rd_quote(fv, fl, q);
    pm_rd_fail(r, t->at, 0, "DataArray '%s' is stored as '%s'; packmesh reads .vtu files with ascii arrays",
               name, q);
    if (r->err) r->err->code = PM_ERR_ARG; /* a valid file packmesh does not handle */
    return PM_ERR_ARG;
  }
  if (t->empty) return PM_OK;
  /* Numbers up to the next '<' (the closing tag). */
  const char *lt = memchr(r->p, '<', (size_t)(r->end - r->p));
  if (!lt) return pm_rd_fail(r, t->at, 0, "DataArray '%s' is not closed (truncated file?)", name);
  const char *save_end = r->end;
  r->end = lt;
  pm_status s = PM_OK;
  for (;;) {
    pm_rd_skip_space(r);
    if (r->p >= r->end) break;
    if (a->n == a->cap) {
      size_t c = a->cap ? 2 * a->cap : 256;
      double *p = realloc(a->v, c * sizeof *p);
      if (!p) {
        s = pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
        break;
      }
      a->v = p, a->cap = c;
    }
    double x;
    const char *at = r->p;
    if ((s = pm_rd_double(r, &x, "a value of DataArray '%s'", name))) break;
    /* Range first: converting a double beyond int64 (or NaN) is undefined. */
    if (whole && !(x > -1e18 && x < 1e18 && x == (double)(int64_t)x)) {
      s = pm_rd_fail(r, at, 0, "DataArray '%s' holds %g, not a whole number", name, x);
      break;
    }
    a->v[a->n++] = x;
  }
  r->end = save_end;
  if (s) return s;
  xml_tag close;
  int found;
  if ((s = next_tag(r, &close, &found))) return s;
  if (!found || !close.closing || !tag_is(&close, "DataArray"))
    return pm_rd_fail(r, found ? close.at : r->p, 0, "DataArray '%s' is not closed by </DataArray>", name);
  return PM_OK;
}

static void array_free(num_array *a) { free(a->v); }

/* Skip the content of an element we do not read, to its closing tag. */
static pm_status skip_array(vtu *u, const xml_tag *t) {
  pm_rd *r = u->r;
  if (t->empty) return PM_OK;
  static const char close[] = "</DataArray>";
  for (const char *c = r->p; c + sizeof close - 1 <= r->end; ++c) {
    c = memchr(c, '<', (size_t)(r->end - c));
    if (!c) break;
    if ((size_t)(r->end - c) >= sizeof close - 1 && memcmp(c, close, sizeof close - 1) == 0) {
      r->p = c + sizeof close - 1;
      return PM_OK;
    }
  }
  return pm_rd_fail(r, t->at, 0, "a DataArray is not closed (truncated file?)");
}

static pm_status length_is(vtu *u, const num_array *a, const char *name, uint64_t want) {
  if (a->n != want)
    return pm_rd_fail(u->r, a->at, 0, "DataArray '%s' holds %zu values, %llu expected", name, a->n,
                      (unsigned long long)want);
  return PM_OK;
}

static pm_status build(vtu *u) {
  pm_rd *r = u->r;
  pm_status s;
  if (!u->have_piece) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: no Piece", r->name);
  if (!u->points.present) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: no Points", r->name);
  if ((s = length_is(u, &u->points, "Points", 3 * u->npoint))) return s;
  if (!u->conn.present || !u->offsets.present || !u->types.present)
    return pm_error_setf(r->err, PM_ERR_PARSE,
                         "%s: Cells needs the DataArrays connectivity, offsets and types", r->name);
  if ((s = length_is(u, &u->offsets, "offsets", u->ncell)) ||
      (s = length_is(u, &u->types, "types", u->ncell)))
    return s;
  int classified = u->node_dim.present && u->node_cell.present;
  if (classified && ((s = length_is(u, &u->node_dim, "node_dim", u->npoint)) ||
                     (s = length_is(u, &u->node_cell, "node_cell", u->npoint))))
    return s;
  if (u->node_par.present && (s = length_is(u, &u->node_par, "node_par", 2 * u->npoint))) return s;
  if (u->cell.present && (s = length_is(u, &u->cell, "cell", u->ncell))) return s;
  for (uint64_t i = 0; i < u->npoint; ++i) {
    int dim = -1;
    int32_t cell = -1;
    if (classified) {
      double d = u->node_dim.v[i], c = u->node_cell.v[i];
      if (d < -1 || d > 3 || c < -1 || c >= INT32_MAX)
        return pm_rd_fail(r, u->node_dim.at, 0, "point %llu: node_dim %g, node_cell %g (-1..3 and "
                          "-1 or more expected)", (unsigned long long)i, d, c);
      dim = (int)d, cell = (int32_t)c;
    }
    const double *par = u->node_par.present ? u->node_par.v + 2 * i : NULL;
    if ((s = pm_rd_node(r, u->points.at, 0, i + 1, u->points.v + 3 * i, dim, cell, par))) return s;
  }
  uint64_t prev = 0, *pts = NULL;
  size_t cap = 0;
  for (uint64_t i = 0; i < u->ncell && !s; ++i) {
    double o = u->offsets.v[i];
    if (o < (double)prev || o > (double)u->conn.n) {
      s = pm_rd_fail(r, u->offsets.at, 0, "offset %llu is %g (offsets never decrease and end at "
                     "the connectivity's length %zu)", (unsigned long long)i, o, u->conn.n);
      break;
    }
    uint64_t end = (uint64_t)o, n = end - prev;
    if (n > cap) {
      free(pts);
      cap = n;
      pts = malloc(cap * sizeof *pts);
      if (!pts) {
        s = pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
        break;
      }
    }
    for (uint64_t j = 0; j < n; ++j) {
      double x = u->conn.v[prev + j];
      pts[j] = x < 0 ? UINT64_MAX : (uint64_t)x;
    }
    double ty = u->types.v[i], ce = u->cell.present ? u->cell.v[i] : -1;
    if (ce < -1 || ce >= INT32_MAX) {
      s = pm_rd_fail(r, u->cell.at, 0, "cell %llu has cell index %g (-1 or more expected)",
                     (unsigned long long)i, ce);
      break;
    }
    s = pm_rd_vtk_cell(r, u->conn.at, 0, ty < 0 || ty > INT32_MAX ? -1 : (int)ty, i, pts, n,
                       u->npoint, (int32_t)ce);
    prev = end;
  }
  free(pts);
  if (!s && prev != u->conn.n)
    s = pm_rd_fail(r, u->offsets.at, 0, "the last offset is %llu, the connectivity has %zu values",
                   (unsigned long long)prev, u->conn.n);
  return s;
}

pm_status pm_rd_parse_vtu(pm_rd *r) {
  r->node_word = "point";
  vtu u;
  memset(&u, 0, sizeof u);
  u.r = r;
  /* Open elements, innermost last. */
  enum { DEPTH = 16 };
  xml_tag open[DEPTH];
  int depth = 0, seen_root = 0;
  pm_status s = PM_OK;
  for (;;) {
    xml_tag t;
    int found;
    if ((s = next_tag(r, &t, &found)) || !found) break;
    if (t.closing) {
      if (depth == 0 || open[depth - 1].nlen != t.nlen ||
          memcmp(open[depth - 1].name, t.name, t.nlen) != 0) {
        char q[40];
        pm_rd_quote(t.name, t.nlen, q);
        s = pm_rd_fail(r, t.at, 0, "</%s> does not close the open element", q);
        break;
      }
      --depth;
      if (depth == 0) break; /* </VTKFile> */
      continue;
    }
    if (!seen_root) {
      if (!tag_is(&t, "VTKFile")) {
        s = pm_rd_fail(r, t.at, 0, "not a VTK XML file: the first element is not VTKFile");
        break;
      }
      if (!attr_is(&t, "type", "UnstructuredGrid")) {
        pm_rd_fail(r, t.at, 0, "not an unstructured grid (VTKFile type=\"UnstructuredGrid\" expected)");
        if (r->err) r->err->code = PM_ERR_ARG;
        s = PM_ERR_ARG;
        break;
      }
      seen_root = 1;
    }
    const char *parent = "";
    size_t plen = 0;
    if (depth > 0) parent = open[depth - 1].name, plen = open[depth - 1].nlen;
#define PARENT_IS(w) (plen == sizeof(w) - 1 && memcmp(parent, w, plen) == 0)
    if (tag_is(&t, "Piece")) {
      if (u.have_piece) {
        s = pm_rd_fail(r, t.at, 0, "a second Piece (packmesh reads one)");
        break;
      }
      u.have_piece = 1;
      /* Each point takes at least 6 bytes of text, each cell 2 ("0\n" in offsets). */
      if ((s = count_attr(&u, &t, "NumberOfPoints", 6, &u.npoint)) ||
          (s = count_attr(&u, &t, "NumberOfCells", 2, &u.ncell)))
        break;
    } else if (tag_is(&t, "AppendedData")) {
      pm_rd_fail(r, t.at, 0, "AppendedData: packmesh reads .vtu files with ascii arrays");
      if (r->err) r->err->code = PM_ERR_ARG;
      s = PM_ERR_ARG;
      break;
    } else if (tag_is(&t, "DataArray")) {
      const char *nv = "";
      size_t nl = 0;
      attr(&t, "Name", &nv, &nl);
#define NAME_IS(w) (nl == sizeof(w) - 1 && memcmp(nv, w, nl) == 0)
      num_array *a = NULL;
      int whole = 1;
      if (PARENT_IS("Points")) a = &u.points, whole = 0;
      else if (PARENT_IS("Cells") && NAME_IS("connectivity")) a = &u.conn;
      else if (PARENT_IS("Cells") && NAME_IS("offsets")) a = &u.offsets;
      else if (PARENT_IS("Cells") && NAME_IS("types")) a = &u.types;
      else if (PARENT_IS("CellData") && NAME_IS("cell")) a = &u.cell;
      else if (PARENT_IS("PointData") && NAME_IS("node_dim")) a = &u.node_dim;
      else if (PARENT_IS("PointData") && NAME_IS("node_cell")) a = &u.node_cell;
      else if (PARENT_IS("PointData") && NAME_IS("node_par")) a = &u.node_par, whole = 0;
#undef NAME_IS
      if (a) {
        char name[40];
        pm_rd_quote(nv, nl, name);
        s = read_array(&u, &t, a, PARENT_IS("Points") ? "Points" : name, whole);
      } else {
        s = skip_array(&u, &t);
      }
      if (s) break;
      continue; /* read_array / skip_array consumed the closing tag */
    }
#undef PARENT_IS
    if (!t.empty) {
      if (depth == DEPTH) {
        s = pm_rd_fail(r, t.at, 0, "elements nested deeper than %d", DEPTH);
        break;
      }
      open[depth++] = t;
    }
  }
  if (!s && !seen_root) s = pm_rd_fail(r, r->base, 0, "not a VTK XML file: no VTKFile element");
  if (!s && depth > 0) s = pm_rd_fail(r, r->end, 0, "the file ends inside an element (truncated file?)");
  if (!s) s = build(&u);
  array_free(&u.points);
  array_free(&u.conn);
  array_free(&u.offsets);
  array_free(&u.types);
  array_free(&u.cell);
  array_free(&u.node_dim);
  array_free(&u.node_cell);
  array_free(&u.node_par);
  return s;
}
