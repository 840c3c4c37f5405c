/* Medit (INRIA) .mesh files, ASCII: MeshVersionFormatted, Dimension (2 or 3), then keyword
 * sections, each a count and that many records, up to End. Vertices (coordinates and a
 * reference) are nodes 1..n; Edges, Triangles and Tetrahedra are read with their reference as
 * the entity tag (cell = reference - 1; 0, negative and PM_MSH_UNTAGGED references: untagged);
 * the annotation sections mmg and gmsh write (Corners, Ridges, Required*, Normals, Tangents and
 * their *AtVertices) are skipped record by record; element sections packmesh does not read
 * (Quadrilaterals, Hexahedra, Prisms, Pyramids, P2 elements) are refused by name, and so is any
 * other keyword. '#' starts a comment to the end of the line.
 *
 * Checked: counts against the bytes left, vertex indices (1..number of vertices), coordinates.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

typedef struct medit_kw {
  const char *name;
  int kind;     /* 1..3 elements of that kind; 0 skipped; -1 refused; 9 vertices */
  int ints;     /* integers per record (element: corner indices and the reference) */
  int reals;    /* reals per record, in units of the dimension when negative (-1: dim reals) */
} medit_kw;

static const medit_kw keywords[] = {
    {"Vertices", 9, 1, -1},
    {"Edges", 1, 3, 0},
    {"Triangles", 2, 4, 0},
    {"Tetrahedra", 3, 5, 0},
    {"Corners", 0, 1, 0},
    {"RequiredVertices", 0, 1, 0},
    {"Ridges", 0, 1, 0},
    {"RequiredEdges", 0, 1, 0},
    {"RequiredTriangles", 0, 1, 0},
    {"RequiredTetrahedra", 0, 1, 0},
    {"Normals", 0, 0, -1},
    {"Tangents", 0, 0, -1},
    {"NormalAtVertices", 0, 2, 0},
    {"TangentAtVertices", 0, 2, 0},
    {"NormalAtTriangleVertices", 0, 3, 0},
    {"Quadrilaterals", -1, 5, 0},
    {"Hexahedra", -1, 9, 0},
    {"Prisms", -1, 7, 0},
    {"Pyramids", -1, 6, 0},
    {"EdgesP2", -1, 4, 0},
    {"TrianglesP2", -1, 7, 0},
    {"TetrahedraP2", -1, 11, 0},
};

/* Skip blanks and '#' comments. */
static void skip(pm_rd *r) {
  for (;;) {
    pm_rd_skip_space(r);
    if (r->p < r->end && *r->p == '#')
      pm_rd_skip_line(r);
    else
      return;
  }
}

pm_status pm_rd_parse_medit(pm_rd *r) {
  r->node_word = "vertex";
  pm_status s;
  skip(r);
  if ((s = pm_rd_expect(r, "MeshVersionFormatted", 1, "the Medit header"))) return s;
  int64_t version, dim;
  if ((s = pm_rd_int(r, 1, 4, &version, "the Medit version"))) return s;
  skip(r);
  if ((s = pm_rd_expect(r, "Dimension", 1, "the Dimension line")) ||
      (s = pm_rd_int(r, 2, 3, &dim, "the dimension")))
    return s;
  uint64_t nvertex = 0;
  int have_vertices = 0;
  for (;;) {
    skip(r);
    if (r->p >= r->end) break;
    const char *at = r->p, *t;
    size_t n;
    pm_rd_token(r, &t, &n);
    if (n == 3 && strncasecmp(t, "End", 3) == 0) break;
    const medit_kw *kw = NULL;
    for (size_t k = 0; k < sizeof keywords / sizeof keywords[0]; ++k)
      if (strlen(keywords[k].name) == n && strncasecmp(keywords[k].name, t, n) == 0)
        kw = &keywords[k];
    char q[40];
    pm_rd_quote(t, n, q);
    if (!kw) return pm_rd_fail(r, at, 0, "unknown keyword '%s'", q);
    if (kw->kind < 0) {
      pm_rd_fail(r, at, 0, "%s: packmesh reads edges, triangles and tetrahedra only", kw->name);
      if (r->err) r->err->code = PM_ERR_ARG; /* a valid file packmesh does not handle */
      return PM_ERR_ARG;
    }
    uint64_t count;
    skip(r);
    if ((s = pm_rd_uint(r, 0, &count, "the number of %s", kw->name))) return s;
    int reals = kw->reals < 0 ? (int)dim : kw->reals;
    /* Each number takes 2 bytes at least. */
    if ((s = pm_rd_room(r, count, 2 * (uint64_t)(kw->ints + reals), 0, kw->name))) return s;
    if (kw->kind == 9) {
      if (have_vertices) return pm_rd_fail(r, at, 0, "a second Vertices section");
      have_vertices = 1;
      nvertex = count;
    }
    for (uint64_t i = 0; i < count; ++i) {
      skip(r);
      const char *rat = r->p;
      if (kw->kind == 9) {
        double x[3] = {0, 0, 0};
        int64_t ref;
        for (int k = 0; k < dim; ++k)
          if ((s = pm_rd_double(r, &x[k], "a coordinate of vertex %llu", (unsigned long long)i + 1)))
            return s;
        if ((s = pm_rd_int(r, INT64_MIN, INT64_MAX, &ref, "the reference of vertex %llu",
                           (unsigned long long)i + 1)) ||
            (s = pm_rd_node(r, rat, 0, i + 1, x, -1, -1, NULL)))
          return s;
        continue;
      }
      if (kw->kind == 0) {
        double x;
        int64_t v;
        for (int k = 0; k < reals; ++k)
          if ((s = pm_rd_double(r, &x, "a value of %s record %llu", kw->name, (unsigned long long)i + 1)))
            return s;
        for (int k = 0; k < kw->ints; ++k)
          if ((s = pm_rd_int(r, INT64_MIN, INT64_MAX, &v, "a value of %s record %llu", kw->name,
                             (unsigned long long)i + 1)))
            return s;
        continue;
      }
      uint64_t c[4];
      int64_t ref;
      for (int q2 = 0; q2 <= kw->kind; ++q2) {
        if ((s = pm_rd_uint(r, 1, &c[q2], "vertex %d of %s record %llu", q2 + 1, kw->name,
                            (unsigned long long)i + 1)))
          return s;
        if (have_vertices && c[q2] > nvertex)
          return pm_rd_fail(r, rat, 0, "%s record %llu uses vertex %llu; the file has %llu vertices",
                            kw->name, (unsigned long long)i + 1, (unsigned long long)c[q2],
                            (unsigned long long)nvertex);
      }
      if ((s = pm_rd_int(r, INT64_MIN, INT64_MAX, &ref, "the reference of %s record %llu",
                         kw->name, (unsigned long long)i + 1)) ||
          (s = pm_rd_elem(r, kw->kind, r->nel + 1, c, pm_rd_cell_of_tag(ref))))
        return s;
    }
  }
  return PM_OK;
}
