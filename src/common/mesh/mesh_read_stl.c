/* STL files, ASCII or binary. Each solid's triangles get the solid's index as their cell (the
 * order of the solids in the file; a binary file is one solid, cell 0). STL repeats a vertex in
 * every triangle that uses it: vertices with exactly the same coordinates become one node, in
 * the order they first appear. (gmsh merges within a tolerance instead; an STL writer prints one
 * vertex the same way every time, so equality is enough and never merges distinct points.)
 *
 * Binary or ASCII: a file of exactly 84 + 50 n bytes whose 4 bytes at offset 80 say n is binary
 * (its 80-byte header may begin with "solid" too); otherwise it must be ASCII, beginning with
 * "solid". ASCII is read keyword by keyword (facet normal, outer loop, three vertices, endloop,
 * endfacet; endsolid) so that a truncated or malformed file is an error naming its line.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "common/base/hash.h"
#include "common/base/keyindex.h"
#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

typedef struct stl {
  pm_rd *r;
  pm_keyindex index; /* coordinates' hash -> node (tag - 1) */
} stl;

static uint64_t coord_key(const double x[3], uint64_t salt) {
  uint64_t h = salt;
  for (int k = 0; k < 3; ++k) {
    double v = x[k] == 0 ? 0.0 : x[k]; /* -0 and +0 are one point */
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    h = pm_mix64(h ^ b);
  }
  return h;
}

/* The node at x: an existing one with exactly these coordinates, or a new one. */
static pm_status vertex(stl *s, const char *at, int binary, const double x[3], uint64_t *tag) {
  pm_rd *r = s->r;
  uint64_t key = coord_key(x, 0);
  for (;;) {
    int32_t id = pm_keyindex_get(&s->index, key);
    if (id < 0) break;
    const double *y = r->node[id].xyz;
    if (y[0] == x[0] && y[1] == x[1] && y[2] == x[2]) {
      *tag = (uint64_t)id + 1;
      return PM_OK;
    }
    key = coord_key(x, key + 1); /* another point with this hash: probe the next key */
  }
  if (r->nnode >= INT32_MAX)
    return pm_error_setf(r->err, PM_ERR_LIMIT, "%s: more than %ld vertices", r->name, (long)INT32_MAX);
  pm_status st = pm_rd_node(r, at, binary, r->nnode + 1, x, -1, -1, NULL);
  if (st) return st;
  if (!pm_keyindex_reserve(&s->index, (int32_t)r->nnode))
    return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  pm_keyindex_put(&s->index, key, (int32_t)(r->nnode - 1));
  *tag = r->nnode;
  return PM_OK;
}

static pm_status binary_stl(stl *s, uint32_t n) {
  pm_rd *r = s->r;
  r->p = r->base + 84;
  int swap = pm_rd_host_big(); /* binary STL is little-endian */
  pm_status st = PM_OK;
  for (uint32_t i = 0; i < n && !st; ++i) {
    const unsigned char *b;
    if ((st = pm_rd_bytes(r, 50, "a triangle", &b))) break;
    uint64_t tags[3];
    for (int v = 0; v < 3 && !st; ++v) {
      double x[3];
      for (int k = 0; k < 3; ++k) x[k] = (double)pm_rd_f32(b + 12 + 12 * v + 4 * k, swap);
      st = vertex(s, (const char *)b, 1, x, &tags[v]);
    }
    if (!st) st = pm_rd_elem(r, 2, (uint64_t)i + 1, tags, 0);
  }
  return st;
}

static pm_status ascii_stl(stl *s) {
  pm_rd *r = s->r;
  pm_status st = PM_OK;
  int32_t solid = 0;
  uint64_t ntri = 0;
  for (;;) {
    pm_rd_skip_space(r);
    if (r->p >= r->end) break;
    if ((st = pm_rd_expect(r, "solid", 1, "a solid"))) return st;
    pm_rd_skip_line(r); /* the solid's name */
    for (;;) {
      pm_rd_skip_space(r);
      if (pm_rd_peek_word(r, "endsolid", 1)) {
        pm_rd_skip_line(r);
        break;
      }
      const char *at = r->p;
      if ((st = pm_rd_expect(r, "facet", 1, "a facet or endsolid")) ||
          (st = pm_rd_expect(r, "normal", 1, "the facet's normal")))
        return st;
      double nrm;
      for (int k = 0; k < 3; ++k)
        if ((st = pm_rd_double(r, &nrm, "a component of the normal of triangle %llu",
                               (unsigned long long)ntri + 1)))
          return st;
      if ((st = pm_rd_expect(r, "outer", 1, "'outer loop'")) ||
          (st = pm_rd_expect(r, "loop", 1, "'outer loop'")))
        return st;
      uint64_t tags[3];
      for (int v = 0; v < 3; ++v) {
        pm_rd_skip_space(r);
        const char *vat = r->p;
        double x[3];
        if ((st = pm_rd_expect(r, "vertex", 1, "a vertex (a triangle has three)"))) return st;
        for (int k = 0; k < 3; ++k)
          if ((st = pm_rd_double(r, &x[k], "a coordinate of triangle %llu",
                                 (unsigned long long)ntri + 1)))
            return st;
        if ((st = vertex(s, vat, 0, x, &tags[v]))) return st;
      }
      if ((st = pm_rd_expect(r, "endloop", 1, "'endloop' after three vertices")) ||
          (st = pm_rd_expect(r, "endfacet", 1, "'endfacet'")))
        return st;
      (void)at;
      if ((st = pm_rd_elem(r, 2, ++ntri, tags, solid))) return st;
    }
    if (solid == INT32_MAX - 1)
      return pm_rd_fail(r, r->p, 0, "more than %ld solids", (long)INT32_MAX - 1);
    ++solid;
  }
  if (solid == 0) return pm_rd_fail(r, r->p, 0, "no solid");
  return PM_OK;
}

pm_status pm_rd_parse_stl(pm_rd *r) {
  r->node_word = "vertex";
  stl s;
  memset(&s, 0, sizeof s);
  s.r = r;
  s.index = (pm_keyindex)PM_KEYINDEX_INIT;
  size_t len = (size_t)(r->end - r->base);
  pm_status st;
  uint32_t n = 0;
  if (len >= 84) n = pm_rd_u32((const unsigned char *)r->base + 80, pm_rd_host_big());
  if (len >= 84 && (uint64_t)len == 84 + 50 * (uint64_t)n) {
    st = binary_stl(&s, n);
  } else {
    const char *p = r->base;
    while (p < r->end && (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')) ++p;
    if ((size_t)(r->end - p) < 5 || strncasecmp(p, "solid", 5) != 0) {
      if (len >= 84)
        st = pm_rd_fail(r, r->base, 0,
                        "neither ASCII STL (it does not begin with 'solid') nor binary STL (%u "
                        "triangles would take %llu bytes, the file has %zu)",
                        n, 84 + 50 * (unsigned long long)n, len);
      else
        st = pm_rd_fail(r, r->base, 0, "not an STL file: it does not begin with 'solid'");
    } else {
      st = ascii_stl(&s);
    }
  }
  pm_keyindex_free(&s.index);
  return st;
}
