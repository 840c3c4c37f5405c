/* gmsh MSH files, versions 2.x and 4.1, ASCII and binary (either byte order).
 *
 * MSH 4.1 ($Nodes and $Elements in entity blocks): a node's classification is its block's
 * entity (dimension, tag), with its parameters when the block is parametric; an element's cell
 * is its block's entity tag - 1 (PM_MSH_UNTAGGED: none). MSH 2.x (one line, or one binary
 * record, per node and per element): an element's cell is its elementary tag - 1 (the second
 * tag); nodes are classified as gmsh does for that format, on the entity of the
 * lowest-dimensional element using them, unless $ParametricNodes gives their entity.
 * Every other section ($Entities, $PhysicalNames, $Periodic, data sections ...) is skipped to
 * its $End line.
 *
 * What is checked, beyond the syntax: each declared count (blocks, nodes, elements, tags per
 * element) against the bytes left; that each block's count adds up to the section's; entity
 * dimensions 0..3 and entity tags >= 1; element types gmsh defines, of the block's dimension;
 * node and element tags >= 1 and, in MSH 4.1, within the section's declared range; and, when
 * the mesh is built (mesh_read.c), that every node an element uses is defined, and tags unique.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

typedef struct msh {
  pm_rd *r;
  int v4;      /* 4.1; else 2.x */
  int binary;
  int swap;    /* binary data in the other byte order */
  int have_nodes, have_elements;
} msh;

/* After a section's name (binary data starts after its line break). */
static void end_of_line(pm_rd *r) {
  if (r->p < r->end && *r->p == '\r') ++r->p;
  if (r->p < r->end && *r->p == '\n') ++r->p;
}

static pm_status expect_end(msh *x, const char *section) {
  char word[64];
  snprintf(word, sizeof word, "$End%s", section);
  char what[80];
  snprintf(what, sizeof what, "the end of $%s", section);
  return pm_rd_expect(x->r, word, 0, what);
}

/* An element type that is not a line, triangle, tet or point: refused by name. */
static pm_status refuse_type(msh *x, const char *at, int type, uint64_t count) {
  const rd_elem_type *t = pm_rd_elem_type(type);
  if (!t) return pm_rd_fail(x->r, at, x->binary, "element type %d is not one gmsh defines", type);
  char name[64];
  if (t->nnode > 0)
    snprintf(name, sizeof name, "%s %d", t->family, t->nnode);
  else
    snprintf(name, sizeof name, "%s", t->family);
  pm_rd_fail(x->r, at, x->binary,
             "%llu element%s of type '%s' (gmsh type %d); packmesh reads lines, triangles and "
             "tetrahedra only",
             (unsigned long long)count, count == 1 ? "" : "s", name, type);
  if (x->r->err) x->r->err->code = PM_ERR_ARG; /* a valid file packmesh does not handle */
  return PM_ERR_ARG;
}

/* Add one element read as `nnode` node tags (corners first). */
static pm_status add_element(msh *x, const rd_elem_type *t, uint64_t tag, const uint64_t *nodes,
                             int32_t cell) {
  pm_status s = pm_rd_elem(x->r, t->kind, tag, nodes, cell);
  for (int q = t->kind + 1; q < t->nnode && !s; ++q) s = pm_rd_ho(x->r, nodes[q]);
  return s;
}

/* ---- MSH 4.1 -------------------------------------------------------------------------------- */

/* Counts of a section header: four size_t (binary) or four whole numbers. */
static pm_status header4(msh *x, const char *section, uint64_t h[4]) {
  pm_rd *r = x->r;
  static const char *const what[4] = {"number of entity blocks", "number of items",
                                      "smallest tag", "largest tag"};
  if (x->binary) {
    const unsigned char *b;
    pm_status s = pm_rd_bytes(r, 32, "a section header", &b);
    if (s) return s;
    for (int k = 0; k < 4; ++k) h[k] = pm_rd_u64(b + 8 * k, x->swap);
    return PM_OK;
  }
  for (int k = 0; k < 4; ++k) {
    pm_status s = pm_rd_uint(r, 0, &h[k], "the %s of $%s", what[k], section);
    if (s) return s;
  }
  return PM_OK;
}

/* An entity block header: dimension, tag, a third int (parametric or element type), count. */
static pm_status block4(msh *x, const char *section, uint64_t b_index, int *dim, int *tag,
                        int *third, uint64_t *count, const char **at) {
  pm_rd *r = x->r;
  if (!x->binary) pm_rd_skip_space(r);
  *at = r->p;
  if (x->binary) {
    const unsigned char *b;
    pm_status s = pm_rd_bytes(r, 20, "an entity block header", &b);
    if (s) return s;
    *dim = pm_rd_i32(b, x->swap);
    *tag = pm_rd_i32(b + 4, x->swap);
    *third = pm_rd_i32(b + 8, x->swap);
    *count = pm_rd_u64(b + 12, x->swap);
  } else {
    int64_t v[3];
    static const char *const name[2][3] = {{"entity dimension", "entity tag", "parametric flag"},
                                           {"entity dimension", "entity tag", "element type"}};
    int el = section[0] == 'E';
    for (int k = 0; k < 3; ++k) {
      pm_status s = pm_rd_int(r, INT32_MIN, INT32_MAX, &v[k], "the %s of $%s block %llu",
                              name[el][k], section, (unsigned long long)b_index + 1);
      if (s) return s;
    }
    *dim = (int)v[0], *tag = (int)v[1], *third = (int)v[2];
    pm_status s = pm_rd_uint(r, 0, count, "the count of $%s block %llu", section,
                             (unsigned long long)b_index + 1);
    if (s) return s;
  }
  if (*dim < 0 || *dim > 3)
    return pm_rd_fail(r, *at, x->binary, "$%s block %llu: entity dimension %d (0 to 3 expected)",
                      section, (unsigned long long)b_index + 1, *dim);
  if (*tag < 1)
    return pm_rd_fail(r, *at, x->binary, "$%s block %llu: entity tag %d (tags are 1 or more)",
                      section, (unsigned long long)b_index + 1, *tag);
  return PM_OK;
}

static pm_status tag_in_range(msh *x, const char *at, const char *what, uint64_t tag,
                              const uint64_t h[4]) {
  if (tag < 1 || tag < h[2] || tag > h[3])
    return pm_rd_fail(x->r, at, x->binary,
                      "%s tag %llu lies outside the section's declared range %llu..%llu", what,
                      (unsigned long long)tag, (unsigned long long)h[2], (unsigned long long)h[3]);
  return PM_OK;
}

static pm_status nodes4(msh *x) {
  pm_rd *r = x->r;
  uint64_t h[4];
  pm_status s = header4(x, "Nodes", h);
  if (s) return s;
  int bin = x->binary;
  /* Smallest sizes: a block header is 20 bytes binary, 8 as text ("0 1 0 0\n"); a node 32
   * bytes binary (tag, x, y, z), 8 as text ("1\n0 0 0\n"). */
  if ((s = pm_rd_room(r, h[0], bin ? 20 : 8, bin, "$Nodes entity blocks")) ||
      (s = pm_rd_room(r, h[1], bin ? 32 : 8, bin, "$Nodes nodes")))
    return s;
  uint64_t total = 0, *tags = NULL;
  for (uint64_t b = 0; b < h[0] && !s; ++b) {
    int dim, etag, param;
    uint64_t n;
    const char *at;
    if ((s = block4(x, "Nodes", b, &dim, &etag, &param, &n, &at))) break;
    if (param != 0 && param != 1) {
      s = pm_rd_fail(r, at, bin, "$Nodes block %llu: parametric flag %d (0 or 1 expected)",
                     (unsigned long long)b + 1, param);
      break;
    }
    int npar = param ? dim : 0;
    if (n > h[1] - total) {
      s = pm_rd_fail(r, at, bin,
                     "$Nodes block %llu holds %llu nodes, more than the %llu the section "
                     "declares are left",
                     (unsigned long long)b + 1, (unsigned long long)n,
                     (unsigned long long)(h[1] - total));
      break;
    }
    if ((s = pm_rd_room(r, n, bin ? 32 + 8 * (uint64_t)npar : 8 + 2 * (uint64_t)npar, bin,
                        "nodes in a $Nodes block")))
      break;
    total += n;
    free(tags);
    tags = malloc((n ? n : 1) * sizeof *tags);
    if (!tags) {
      s = pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
      break;
    }
    int32_t cell = pm_rd_cell_of_tag(etag);
    for (uint64_t i = 0; i < n && !s; ++i) {
      if (!bin) pm_rd_skip_space(r);
      const char *tat = r->p;
      if (bin) {
        const unsigned char *bt;
        if (!(s = pm_rd_bytes(r, 8, "a node tag", &bt))) tags[i] = pm_rd_u64(bt, x->swap);
      } else {
        s = pm_rd_uint(r, 1, &tags[i], "a node tag of $Nodes block %llu", (unsigned long long)b + 1);
      }
      if (!s) s = tag_in_range(x, tat, "node", tags[i], h);
    }
    for (uint64_t i = 0; i < n && !s; ++i) {
      double v[6] = {0, 0, 0, 0, 0, 0};
      if (!bin) pm_rd_skip_space(r);
      const char *vat = r->p;
      if (bin) {
        const unsigned char *bv;
        if ((s = pm_rd_bytes(r, 8 * (3 + (size_t)npar), "node coordinates", &bv))) break;
        for (int k = 0; k < 3 + npar; ++k) v[k] = pm_rd_f64(bv + 8 * k, x->swap);
      } else {
        for (int k = 0; k < 3 + npar && !s; ++k)
          s = pm_rd_double(r, &v[k], "%s of node %llu", k < 3 ? "a coordinate" : "a parameter",
                           (unsigned long long)tags[i]);
        if (s) break;
      }
      /* Curves carry t, faces (u, v); a volume's (u, v, w) are not kept. */
      double par[2] = {npar >= 1 && dim <= 2 ? v[3] : 0, npar >= 2 && dim <= 2 ? v[4] : 0};
      s = pm_rd_node(r, vat, bin, tags[i], v, dim, cell, par);
    }
  }
  free(tags);
  if (s) return s;
  if (total != h[1])
    return pm_rd_fail(r, r->p, bin, "$Nodes declares %llu nodes, its blocks hold %llu",
                      (unsigned long long)h[1], (unsigned long long)total);
  return PM_OK;
}

static pm_status elements4(msh *x) {
  pm_rd *r = x->r;
  uint64_t h[4];
  pm_status s = header4(x, "Elements", h);
  if (s) return s;
  int bin = x->binary;
  /* Smallest sizes: a point element is 16 bytes binary (tag, node), 4 as text ("1 1\n"). */
  if ((s = pm_rd_room(r, h[0], bin ? 20 : 8, bin, "$Elements entity blocks")) ||
      (s = pm_rd_room(r, h[1], bin ? 16 : 4, bin, "$Elements elements")))
    return s;
  uint64_t total = 0, nodes[400];
  for (uint64_t b = 0; b < h[0] && !s; ++b) {
    int dim, etag, type;
    uint64_t n;
    const char *at;
    if ((s = block4(x, "Elements", b, &dim, &etag, &type, &n, &at))) break;
    const rd_elem_type *t = pm_rd_elem_type(type);
    if (!t || t->kind < 0) {
      s = refuse_type(x, at, type, n);
      break;
    }
    if (t->kind != dim) {
      s = pm_rd_fail(r, at, bin,
                     "$Elements block %llu: %s elements (dimension %d) on an entity of dimension %d",
                     (unsigned long long)b + 1, t->family, t->kind, dim);
      break;
    }
    if (n > h[1] - total) {
      s = pm_rd_fail(r, at, bin,
                     "$Elements block %llu claims %llu elements, more than the %llu the section "
                     "declares are left",
                     (unsigned long long)b + 1, (unsigned long long)n,
                     (unsigned long long)(h[1] - total));
      break;
    }
    uint64_t per = 1 + (uint64_t)t->nnode;
    char what[96];
    snprintf(what, sizeof what, "elements in $Elements block %llu", (unsigned long long)b + 1);
    if ((s = pm_rd_room(r, n, bin ? 8 * per : 2 * per, bin, what))) break;
    total += n;
    int32_t cell = pm_rd_cell_of_tag(etag);
    for (uint64_t i = 0; i < n && !s; ++i) {
      if (!bin) pm_rd_skip_space(r);
      const char *eat = r->p;
      uint64_t tag = 0;
      if (bin) {
        const unsigned char *be;
        if ((s = pm_rd_bytes(r, 8 * (size_t)per, "an element", &be))) break;
        tag = pm_rd_u64(be, x->swap);
        for (int q = 0; q < t->nnode; ++q) nodes[q] = pm_rd_u64(be + 8 * (q + 1), x->swap);
      } else {
        if ((s = pm_rd_uint(r, 1, &tag, "an element tag of $Elements block %llu",
                            (unsigned long long)b + 1)))
          break;
        for (int q = 0; q < t->nnode && !s; ++q)
          s = pm_rd_uint(r, 1, &nodes[q], "node %d of element %llu", q + 1,
                         (unsigned long long)tag);
        if (s) break;
      }
      if ((s = tag_in_range(x, eat, "element", tag, h))) break;
      s = add_element(x, t, tag, nodes, cell);
    }
  }
  if (s) return s;
  if (total != h[1])
    return pm_rd_fail(r, r->p, bin, "$Elements declares %llu elements, its blocks hold %llu",
                      (unsigned long long)h[1], (unsigned long long)total);
  return PM_OK;
}

/* ---- MSH 2.x -------------------------------------------------------------------------------- */

static pm_status nodes2(msh *x, int parametric) {
  pm_rd *r = x->r;
  uint64_t n;
  const char *sec = parametric ? "ParametricNodes" : "Nodes";
  pm_status s = pm_rd_uint(r, 0, &n, "the number of nodes of $%s", sec);
  if (s) return s;
  int bin = x->binary;
  if (bin) {
    if (parametric)
      return pm_rd_fail(r, r->p, 0, "binary $ParametricNodes are not read (write the file as text)");
    end_of_line(r);
  }
  if ((s = pm_rd_room(r, n, bin ? 28 : 8, bin, "$Nodes nodes"))) return s;
  for (uint64_t i = 0; i < n && !s; ++i) {
    if (!bin) pm_rd_skip_space(r);
    const char *at = r->p;
    uint64_t tag;
    double v[3];
    if (bin) {
      const unsigned char *b;
      if ((s = pm_rd_bytes(r, 28, "a node", &b))) break;
      int32_t t = pm_rd_i32(b, x->swap);
      if (t < 1) {
        s = pm_rd_fail(r, at, 1, "node tag %d (tags are 1 or more)", (int)t);
        break;
      }
      tag = (uint64_t)t;
      for (int k = 0; k < 3; ++k) v[k] = pm_rd_f64(b + 4 + 8 * k, x->swap);
      s = pm_rd_node(r, at, 1, tag, v, -1, -1, NULL);
      continue;
    }
    if ((s = pm_rd_uint(r, 1, &tag, "a node tag"))) break;
    for (int k = 0; k < 3 && !s; ++k) s = pm_rd_double(r, &v[k], "a coordinate of node %llu", (unsigned long long)tag);
    int64_t dim = -1, ent = 0;
    double par[2] = {0, 0};
    if (!s && parametric) {
      if ((s = pm_rd_int(r, 0, 3, &dim, "the entity dimension of node %llu", (unsigned long long)tag)) ||
          (s = pm_rd_int(r, 1, INT32_MAX, &ent, "the entity tag of node %llu", (unsigned long long)tag)))
        break;
      for (int k = 0; k < 2 && k < dim && dim <= 2 && !s; ++k)
        s = pm_rd_double(r, &par[k], "a parameter of node %llu", (unsigned long long)tag);
    }
    if (!s) s = pm_rd_node(r, at, 0, tag, v, (int)dim, pm_rd_cell_of_tag(ent), par);
  }
  return s;
}

static pm_status elements2(msh *x) {
  pm_rd *r = x->r;
  uint64_t n;
  pm_status s = pm_rd_uint(r, 0, &n, "the number of elements of $Elements");
  if (s) return s;
  int bin = x->binary;
  if (bin) end_of_line(r);
  /* Smallest: "1 15 0 1\n" (8 bytes); binary, a 12-byte block header and two ints. */
  if ((s = pm_rd_room(r, n, bin ? 8 : 8, bin, "$Elements elements"))) return s;
  uint64_t nodes[400], done = 0;
  if (bin) {
    while (done < n && !s) {
      const char *at = r->p;
      const unsigned char *b;
      if ((s = pm_rd_bytes(r, 12, "an element block header", &b))) break;
      int32_t type = pm_rd_i32(b, x->swap), count = pm_rd_i32(b + 4, x->swap),
              ntags = pm_rd_i32(b + 8, x->swap);
      const rd_elem_type *t = pm_rd_elem_type(type);
      if (!t || t->kind < 0) {
        s = refuse_type(x, at, type, count > 0 ? (uint64_t)count : 0);
        break;
      }
      if (count < 1 || (uint64_t)count > n - done || ntags < 0) {
        s = pm_rd_fail(r, at, 1, "element block of %d elements with %d tags each (%llu elements left)",
                       (int)count, (int)ntags, (unsigned long long)(n - done));
        break;
      }
      uint64_t per = 1 + (uint64_t)ntags + (uint64_t)t->nnode;
      if ((s = pm_rd_room(r, (uint64_t)count, 4 * per, 1, "elements in a binary element block"))) break;
      for (int32_t i = 0; i < count && !s; ++i) {
        const char *eat = r->p;
        const unsigned char *e;
        if ((s = pm_rd_bytes(r, 4 * (size_t)per, "an element", &e))) break;
        int32_t tag = pm_rd_i32(e, x->swap);
        int32_t elementary = ntags > 1 ? pm_rd_i32(e + 8, x->swap) : 0;
        if (tag < 1) {
          s = pm_rd_fail(r, eat, 1, "element tag %d (tags are 1 or more)", (int)tag);
          break;
        }
        for (int q = 0; q < t->nnode && !s; ++q) {
          int32_t v = pm_rd_i32(e + 4 * (1 + (size_t)ntags + (size_t)q), x->swap);
          if (v < 1) s = pm_rd_fail(r, eat, 1, "element %d uses node %d (tags are 1 or more)", (int)tag, (int)v);
          nodes[q] = (uint64_t)v;
        }
        if (!s) s = add_element(x, t, (uint64_t)tag, nodes, pm_rd_cell_of_tag(elementary));
      }
      done += (uint64_t)count;
    }
    return s;
  }
  for (uint64_t i = 0; i < n && !s; ++i) {
    pm_rd_skip_space(r);
    const char *at = r->p;
    uint64_t tag;
    int64_t type, ntags, tagv, elementary = 0;
    if ((s = pm_rd_uint(r, 1, &tag, "an element tag")) ||
        (s = pm_rd_int(r, INT32_MIN, INT32_MAX, &type, "the type of element %llu", (unsigned long long)tag)))
      break;
    const rd_elem_type *t = pm_rd_elem_type((int)type);
    if (!t || t->kind < 0) {
      s = refuse_type(x, at, (int)type, 1);
      break;
    }
    if ((s = pm_rd_int(r, 0, INT32_MAX, &ntags, "the number of tags of element %llu", (unsigned long long)tag)) ||
        (s = pm_rd_room(r, (uint64_t)ntags, 2, 0, "tags of an element")))
      break;
    for (int64_t k = 0; k < ntags && !s; ++k) {
      s = pm_rd_int(r, INT32_MIN, INT32_MAX, &tagv, "tag %lld of element %llu", (long long)k + 1,
                    (unsigned long long)tag);
      if (k == 1) elementary = tagv;
    }
    for (int q = 0; q < t->nnode && !s; ++q)
      s = pm_rd_uint(r, 1, &nodes[q], "node %d of element %llu", q + 1, (unsigned long long)tag);
    if (!s) s = add_element(x, t, tag, nodes, pm_rd_cell_of_tag(elementary));
  }
  return s;
}

/* ---- sections ------------------------------------------------------------------------------- */

/* Skip an unknown section $name to the line after its $Endname. */
static pm_status skip_section(msh *x, const char *at, const char *name, size_t len) {
  pm_rd *r = x->r;
  char end[80];
  if (len > 60) len = 60;
  snprintf(end, sizeof end, "$End%.*s", (int)len, name);
  size_t el = strlen(end);
  const char *p = r->p;
  while (p < r->end) {
    const char *hit = memchr(p, '$', (size_t)(r->end - p));
    if (!hit) break;
    if ((size_t)(r->end - hit) >= el && memcmp(hit, end, el) == 0 &&
        (hit + el == r->end || hit[el] == '\n' || hit[el] == '\r' || hit[el] == ' ' || hit[el] == '\t')) {
      r->p = hit + el;
      return PM_OK;
    }
    p = hit + 1;
  }
  char q[40];
  pm_rd_quote(name, len, q);
  return pm_rd_fail(r, at, 0, "section $%s has no %s (truncated file?)", q, end);
}

pm_status pm_rd_parse_msh(pm_rd *r) {
  msh x = {r, 0, 0, 0, 0, 0};
  r->unique_elem_tags = 1;
  pm_rd_skip_space(r);
  if (!pm_rd_peek_word(r, "$MeshFormat", 0))
    return pm_rd_fail(r, r->p, 0, "not a MSH file: it does not begin with $MeshFormat");
  pm_rd_skip_space(r);
  const char *vat = r->p;
  double version;
  int64_t ftype, dsize;
  pm_status s;
  if ((s = pm_rd_double(r, &version, "the MSH version")) ||
      (s = pm_rd_int(r, 0, 1, &ftype, "the MSH file type (0 text, 1 binary)")) ||
      (s = pm_rd_int(r, 0, 1024, &dsize, "the MSH data size")))
    return s;
  if (version >= 2 && version < 3)
    x.v4 = 0;
  else if (version == 4.1)
    x.v4 = 1;
  else
    return pm_rd_fail(r, vat, 0, "MSH version %g is not read (packmesh reads 2.x and 4.1)", version);
  x.binary = ftype == 1;
  if (dsize != 8)
    return pm_rd_fail(r, vat, 0, "data size %lld (8 expected)", (long long)dsize);
  if (x.binary) {
    end_of_line(r);
    const unsigned char *b;
    if ((s = pm_rd_bytes(r, 4, "the byte-order mark", &b))) return s;
    if (pm_rd_i32(b, 0) == 1)
      x.swap = 0;
    else if (pm_rd_i32(b, 1) == 1)
      x.swap = 1;
    else
      return pm_rd_fail(r, (const char *)b, 1, "the byte-order mark is not the integer 1");
  }
  if ((s = expect_end(&x, "MeshFormat"))) return s;
  for (;;) {
    pm_rd_skip_space(r);
    if (r->p >= r->end) break;
    const char *at = r->p, *t;
    size_t n;
    pm_rd_token(r, &t, &n);
    char q[40];
    pm_rd_quote(t, n, q);
    if (t[0] != '$') return pm_rd_fail(r, at, 0, "expected a section ($Name), found '%s'", q);
    if (n > 4 && memcmp(t, "$End", 4) == 0)
      return pm_rd_fail(r, at, 0, "%s without its section", q);
#define IS(w) (n == sizeof(w) - 1 && memcmp(t, w, n) == 0)
    if (IS("$Nodes") || IS("$ParametricNodes")) {
      int param = IS("$ParametricNodes");
      if (param && x.v4) return pm_rd_fail(r, at, 0, "$ParametricNodes belongs to MSH 2, not 4.1");
      if (x.have_nodes) return pm_rd_fail(r, at, 0, "a second node section");
      x.have_nodes = 1;
      if (x.binary && x.v4) end_of_line(r);
      s = x.v4 ? nodes4(&x) : nodes2(&x, param);
      if (!s) s = expect_end(&x, param ? "ParametricNodes" : "Nodes");
    } else if (IS("$Elements")) {
      if (x.have_elements) return pm_rd_fail(r, at, 0, "a second $Elements section");
      x.have_elements = 1;
      if (x.binary && x.v4) end_of_line(r);
      s = x.v4 ? elements4(&x) : elements2(&x);
      if (!s) s = expect_end(&x, "Elements");
    } else if (IS("$MeshFormat")) {
      return pm_rd_fail(r, at, 0, "a second $MeshFormat section");
    } else {
      s = skip_section(&x, at, t + 1, n - 1);
    }
#undef IS
    if (s) return s;
  }
  if (!x.have_nodes) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: no $Nodes section", r->name);
  if (!x.have_elements) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: no $Elements section", r->name);
  r->classify_by_elements = !x.v4;
  return PM_OK;
}
