/* Wavefront .obj files, as packmesh writes them (mesh_io.h) and as other tools do: one record a
 * line, '#' to the end of the line a comment. "v x y z [w]" is a vertex (nodes 1..n in file
 * order; w ignored); "l a b ..." a polyline, read as its segments; "f a b c" a triangle (a corner
 * may be written a/t/n: the vertex is the first number); negative indices count back from the
 * last vertex read, as OBJ defines. "g cell_N" puts the elements that follow on cell N (packmesh's
 * groups); any other group name, and elements before any group, are untagged. Texture, normal and
 * grouping records (vt, vn, vp, o, s, usemtl, mtllib) are skipped; a face of four or more corners
 * (a polygon) is refused by name, and so is any other record.
 *
 * Checked: every number whole and in range, vertex indices against the vertices read (forward
 * references included, at the end: pm_rd_finish), coordinates finite and within PM_COORD_MAX.
 * Memory grows with the records the file holds: each takes a line.
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

typedef struct obj_line {
  const char *p, *end; /* the rest of the current line */
} obj_line;

/* The next token of the line (spaces and tabs separate tokens); 0 at the end of the line. */
static int next_token(obj_line *l, const char **tok, size_t *len) {
  while (l->p < l->end && (*l->p == ' ' || *l->p == '\t' || *l->p == '\r')) ++l->p;
  if (l->p >= l->end || *l->p == '#') return 0;
  *tok = l->p;
  while (l->p < l->end && *l->p != ' ' && *l->p != '\t' && *l->p != '\r') ++l->p;
  *len = (size_t)(l->p - *tok);
  return 1;
}

/* A token (up to 63 bytes) as a C string for strtod / strtoll; 0 when it is longer. */
static int token_copy(const char *tok, size_t len, char out[64]) {
  if (len >= 64) return 0;
  memcpy(out, tok, len);
  out[len] = '\0';
  return 1;
}

static int word_is(const char *tok, size_t len, const char *word) {
  return strlen(word) == len && strncmp(tok, word, len) == 0;
}

/* A vertex reference of an element: 1-based, or negative counting back from the last vertex
 * read; the part before a '/' only. *out: the node tag (1-based). */
static pm_status vertex_ref(pm_rd *r, const char *at, const char *tok, size_t len, uint64_t nvert,
                            const char *what, uint64_t *out) {
  size_t n = 0;
  while (n < len && tok[n] != '/') ++n;
  char buf[64], q[40];
  char *end = NULL;
  errno = 0;
  long long v = token_copy(tok, n, buf) && n ? strtoll(buf, &end, 10) : 0;
  if (!end || *end != '\0' || errno == ERANGE || v == 0) {
    pm_rd_quote(tok, len, q);
    return pm_rd_fail(r, at, 0, "%s: '%s' is not a vertex index", what, q);
  }
  if (v < 0) {
    if ((uint64_t)(-(v + 1)) >= nvert)
      return pm_rd_fail(r, at, 0, "%s: index %lld goes back beyond the %llu vertices read", what,
                        v, (unsigned long long)nvert);
    *out = nvert + 1 - (uint64_t)(-v);
  } else {
    *out = (uint64_t)v;
  }
  return PM_OK;
}

/* The cell of a group name: N for "cell_N" (N whole, 0 <= N < PM_MSH_UNTAGGED - 1), else -1. */
static int32_t group_cell(const char *tok, size_t len) {
  if (len <= 5 || strncmp(tok, "cell_", 5) != 0) return -1;
  char buf[64], *end = NULL;
  if (!token_copy(tok + 5, len - 5, buf)) return -1;
  errno = 0;
  long long c = strtoll(buf, &end, 10);
  if (*end != '\0' || errno == ERANGE || c < 0 || c >= PM_MSH_UNTAGGED - 1) return -1;
  return (int32_t)c;
}

pm_status pm_rd_parse_obj(pm_rd *r) {
  r->node_word = "vertex";
  uint64_t nvert = 0, lineno = 0;
  int32_t cell = -1;
  pm_status s;
  while (r->p < r->end) {
    const char *at = r->p;
    const char *eol = memchr(r->p, '\n', (size_t)(r->end - r->p));
    obj_line l = {r->p, eol ? eol : r->end};
    r->p = eol ? eol + 1 : r->end;
    ++lineno;
    const char *tok;
    size_t len;
    if (!next_token(&l, &tok, &len)) continue; /* blank or comment */
    char what[64], q[40];
    if (word_is(tok, len, "v")) {
      double x[3];
      int k = 0;
      const char *t2;
      size_t n2;
      char buf[64];
      for (; k < 4 && next_token(&l, &t2, &n2); ++k) {
        char *end = NULL;
        double v = token_copy(t2, n2, buf) ? strtod(buf, &end) : 0;
        if (!end || *end != '\0') {
          pm_rd_quote(t2, n2, q);
          return pm_rd_fail(r, at, 0, "vertex %llu: '%s' is not a number",
                            (unsigned long long)nvert + 1, q);
        }
        if (k < 3) x[k] = v; /* the fourth, w, is a weight packmesh has no use for */
      }
      if (k < 3 || next_token(&l, &t2, &n2))
        return pm_rd_fail(r, at, 0, "vertex %llu: 3 coordinates (and an optional weight) expected",
                          (unsigned long long)nvert + 1);
      if ((s = pm_rd_node(r, at, 0, nvert + 1, x, -1, -1, NULL))) return s;
      ++nvert;
    } else if (word_is(tok, len, "f") || word_is(tok, len, "l")) {
      const int face = tok[0] == 'f';
      uint64_t c[3], prev = 0;
      int k = 0;
      const char *t2;
      size_t n2;
      snprintf(what, sizeof what, "%s on line %llu", face ? "face" : "line",
               (unsigned long long)lineno);
      while (next_token(&l, &t2, &n2)) {
        uint64_t v = 0;
        if ((s = vertex_ref(r, at, t2, n2, nvert, what, &v))) return s;
        if (face) {
          if (k == 3) {
            pm_rd_fail(r, at, 0, "%s has more than 3 corners: packmesh reads triangles, not polygons",
                       what);
            if (r->err) r->err->code = PM_ERR_ARG; /* a valid file packmesh does not handle */
            return PM_ERR_ARG;
          }
          c[k] = v;
        } else if (k > 0) {
          /* A polyline a b c is the segments (a, b), (b, c). */
          uint64_t seg[2] = {prev, v};
          if ((s = pm_rd_elem(r, 1, r->nel + 1, seg, cell))) return s;
        }
        prev = v;
        ++k;
      }
      if (face ? k != 3 : k < 2)
        return pm_rd_fail(r, at, 0, "%s has %d vertices; %s", what, k,
                          face ? "a triangle has 3" : "a line needs 2 at least");
      if (face && (s = pm_rd_elem(r, 2, r->nel + 1, c, cell))) return s;
    } else if (word_is(tok, len, "g")) {
      const char *t2;
      size_t n2;
      cell = next_token(&l, &t2, &n2) ? group_cell(t2, n2) : -1;
    } else if (word_is(tok, len, "vt") || word_is(tok, len, "vn") || word_is(tok, len, "vp") ||
               word_is(tok, len, "o") || word_is(tok, len, "s") || word_is(tok, len, "usemtl") ||
               word_is(tok, len, "mtllib")) {
      continue;
    } else {
      pm_rd_quote(tok, len, q);
      return pm_rd_fail(r, at, 0, "unknown record '%s' (packmesh reads v, l, f and g)", q);
    }
  }
  if (nvert == 0) return pm_rd_fail(r, r->end, 0, "no vertices");
  return PM_OK;
}
