/* Reading mesh files: the shared machinery of the parsers (see mesh_read_private.h) and the
 * entry points pm_mesh_read / pm_mesh_read_buffer of mesh_io.h. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"

/* ---- gmsh's element types ------------------------------------------------------------------
 * gmsh 4.8.4's table (GmshDefines.h; gmshModelMeshGetElementProperties gives the same family,
 * node count and corners, which test_mesh_read checks type by type, 1 to 150). Lines, triangles and tets
 * of every order are read (reduced to their corners, which come first); points are read for
 * classification; every other type is refused by name. */
static const rd_elem_type elem_types[] = {
    {1, 1, 2, "Line"},           {2, 2, 3, "Triangle"},       {3, -1, 4, "Quadrilateral"},
    {4, 3, 4, "Tetrahedron"},    {5, -1, 8, "Hexahedron"},    {6, -1, 6, "Prism"},
    {7, -1, 5, "Pyramid"},       {8, 1, 3, "Line"},           {9, 2, 6, "Triangle"},
    {10, -1, 9, "Quadrilateral"}, {11, 3, 10, "Tetrahedron"}, {12, -1, 27, "Hexahedron"},
    {13, -1, 18, "Prism"},       {14, -1, 14, "Pyramid"},     {15, 0, 1, "Point"},
    {16, -1, 8, "Quadrilateral"}, {17, -1, 20, "Hexahedron"}, {18, -1, 15, "Prism"},
    {19, -1, 13, "Pyramid"},     {20, 2, 9, "Triangle"},      {21, 2, 10, "Triangle"},
    {22, 2, 12, "Triangle"},     {23, 2, 15, "Triangle"},     {24, 2, 15, "Triangle"},
    {25, 2, 21, "Triangle"},     {26, 1, 4, "Line"},          {27, 1, 5, "Line"},
    {28, 1, 6, "Line"},          {29, 3, 20, "Tetrahedron"},  {30, 3, 35, "Tetrahedron"},
    {31, 3, 56, "Tetrahedron"},  {32, 3, 22, "Tetrahedron"},  {33, 3, 28, "Tetrahedron"},
    {34, -1, 0, "Polygon"},      {35, -1, 0, "Polyhedron"},   {36, -1, 16, "Quadrilateral"},
    {37, -1, 25, "Quadrilateral"}, {38, -1, 36, "Quadrilateral"}, {39, -1, 12, "Quadrilateral"},
    {40, -1, 16, "Quadrilateral"}, {41, -1, 20, "Quadrilateral"}, {42, 2, 28, "Triangle"},
    {43, 2, 36, "Triangle"},     {44, 2, 45, "Triangle"},     {45, 2, 55, "Triangle"},
    {46, 2, 66, "Triangle"},     {47, -1, 49, "Quadrilateral"}, {48, -1, 64, "Quadrilateral"},
    {49, -1, 81, "Quadrilateral"}, {50, -1, 100, "Quadrilateral"}, {51, -1, 121, "Quadrilateral"},
    {52, 2, 18, "Triangle"},     {53, 2, 21, "Triangle"},     {54, 2, 24, "Triangle"},
    {55, 2, 27, "Triangle"},     {56, 2, 30, "Triangle"},     {57, -1, 24, "Quadrilateral"},
    {58, -1, 28, "Quadrilateral"}, {59, -1, 32, "Quadrilateral"}, {60, -1, 36, "Quadrilateral"},
    {61, -1, 40, "Quadrilateral"}, {62, 1, 7, "Line"},        {63, 1, 8, "Line"},
    {64, 1, 9, "Line"},          {65, 1, 10, "Line"},         {66, 1, 11, "Line"},
    {67, -1, 2, "Line Border"},  {68, -1, 3, "Triangle Border"}, {69, -1, 0, "Polygon Border"},
    {70, -1, 2, "Line Child"},   {71, 3, 84, "Tetrahedron"}, {72, 3, 120, "Tetrahedron"},
    {73, 3, 165, "Tetrahedron"}, {74, 3, 220, "Tetrahedron"}, {75, 3, 286, "Tetrahedron"},
    {79, 3, 34, "Tetrahedron"},  {80, 3, 40, "Tetrahedron"},  {81, 3, 46, "Tetrahedron"},
    {82, 3, 52, "Tetrahedron"},  {83, 3, 58, "Tetrahedron"},
    /* Order-0 elements: one node standing for a whole element; no corners to read. */
    {84, -1, 1, "Line"},         {85, -1, 1, "Triangle"},     {86, -1, 1, "Quadrilateral"},
    {87, -1, 1, "Tetrahedron"},  {88, -1, 1, "Hexahedron"},   {89, -1, 1, "Prism"},
    {90, -1, 40, "Prism"},       {91, -1, 75, "Prism"},       {92, -1, 64, "Hexahedron"},  {93, -1, 125, "Hexahedron"}, {94, -1, 216, "Hexahedron"},
    {95, -1, 343, "Hexahedron"}, {96, -1, 512, "Hexahedron"}, {97, -1, 729, "Hexahedron"},
    {98, -1, 1000, "Hexahedron"}, {99, -1, 32, "Hexahedron"}, {100, -1, 44, "Hexahedron"},
    {101, -1, 56, "Hexahedron"}, {102, -1, 68, "Hexahedron"}, {103, -1, 80, "Hexahedron"},
    {104, -1, 92, "Hexahedron"}, {105, -1, 104, "Hexahedron"}, {106, -1, 126, "Prism"},
    {107, -1, 196, "Prism"},     {108, -1, 288, "Prism"},     {109, -1, 405, "Prism"},
    {110, -1, 550, "Prism"},     {111, -1, 24, "Prism"},      {112, -1, 33, "Prism"},
    {113, -1, 42, "Prism"},      {114, -1, 51, "Prism"},      {115, -1, 60, "Prism"},
    {116, -1, 69, "Prism"},      {117, -1, 78, "Prism"},      {118, -1, 30, "Pyramid"},
    {119, -1, 55, "Pyramid"},    {120, -1, 91, "Pyramid"},    {121, -1, 140, "Pyramid"},
    {122, -1, 204, "Pyramid"},   {123, -1, 285, "Pyramid"},   {124, -1, 385, "Pyramid"},
    {125, -1, 21, "Pyramid"},    {126, -1, 29, "Pyramid"},    {127, -1, 37, "Pyramid"},
    {128, -1, 45, "Pyramid"},    {129, -1, 53, "Pyramid"},    {130, -1, 61, "Pyramid"},
    {131, -1, 69, "Pyramid"},    {132, -1, 1, "Pyramid"},     {133, -1, 0, "Point Xfem"},
    {134, -1, 0, "Line Xfem"},   {135, -1, 0, "Triangle Xfem"}, {136, -1, 0, "Tetrahedron Xfem"},
    {137, 3, 16, "Tetrahedron"}, {140, -1, 0, "Trihedron 4"},
};

const rd_elem_type *pm_rd_elem_type(int type) {
  for (size_t i = 0; i < sizeof elem_types / sizeof elem_types[0]; ++i)
    if (elem_types[i].type == type) return &elem_types[i];
  return NULL;
}

int32_t pm_rd_cell_of_tag(int64_t tag) {
  if (tag <= 0 || tag == PM_MSH_UNTAGGED || tag > INT32_MAX) return -1;
  return (int32_t)(tag - 1);
}

/* ---- errors -------------------------------------------------------------------------------- */

void pm_rd_quote(const char *tok, size_t len, char out[40]) {
  size_t n = len < 24 ? len : 24, k = 0;
  for (size_t i = 0; i < n; ++i) {
    unsigned char c = (unsigned char)tok[i];
    out[k++] = (c >= 32 && c < 127) ? (char)c : '?';
  }
  if (len > n) out[k++] = '.', out[k++] = '.', out[k++] = '.';
  out[k] = '\0';
}

pm_status pm_rd_fail(pm_rd *r, const char *at, int binary, const char *fmt, ...) {
  char msg[400];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  if (!at || at < r->base) at = r->base;
  if (at > r->end) at = r->end;
  if (binary)
    return pm_error_setf(r->err, PM_ERR_PARSE, "%s byte %lld: %s", r->name,
                         (long long)(at - r->base), msg);
  long long line = 1;
  for (const char *c = r->base; c < at; ++c) line += *c == '\n';
  return pm_error_setf(r->err, PM_ERR_PARSE, "%s line %lld: %s", r->name, line, msg);
}

/* ---- text ---------------------------------------------------------------------------------- */

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

void pm_rd_skip_space(pm_rd *r) {
  while (r->p < r->end && is_space(*r->p)) ++r->p;
}

void pm_rd_skip_line(pm_rd *r) {
  const char *nl = memchr(r->p, '\n', (size_t)(r->end - r->p));
  r->p = nl ? nl + 1 : r->end;
}

int pm_rd_token(pm_rd *r, const char **tok, size_t *len) {
  pm_rd_skip_space(r);
  const char *s = r->p;
  while (r->p < r->end && !is_space(*r->p)) ++r->p;
  *tok = s;
  *len = (size_t)(r->p - s);
  return *len > 0;
}

int pm_rd_peek_word(pm_rd *r, const char *word, int nocase) {
  const char *save = r->p, *t;
  size_t n;
  if (pm_rd_token(r, &t, &n) && n == strlen(word) &&
      (nocase ? strncasecmp(t, word, n) == 0 : memcmp(t, word, n) == 0))
    return 1;
  r->p = save;
  return 0;
}

pm_status pm_rd_expect(pm_rd *r, const char *word, int nocase, const char *what) {
  pm_rd_skip_space(r);
  const char *at = r->p, *t;
  size_t n;
  if (!pm_rd_token(r, &t, &n))
    return pm_rd_fail(r, at, 0, "the file ends where %s ('%s') should be", what, word);
  if (n != strlen(word) || (nocase ? strncasecmp(t, word, n) : memcmp(t, word, n)) != 0) {
    char q[40];
    pm_rd_quote(t, n, q);
    return pm_rd_fail(r, at, 0, "expected %s ('%s'), found '%s'", what, word, q);
  }
  return PM_OK;
}

/* Parse [t, t + n) as an integer; 0 when it is not one (or overflows). */
static int parse_i64(const char *t, size_t n, int64_t *out) {
  size_t i = 0;
  int neg = 0;
  if (i < n && (t[i] == '+' || t[i] == '-')) neg = t[i++] == '-';
  if (i == n) return 0;
  uint64_t v = 0;
  for (; i < n; ++i) {
    if (t[i] < '0' || t[i] > '9') return 0;
    unsigned d = (unsigned)(t[i] - '0');
    if (v > (UINT64_MAX - d) / 10) return 0;
    v = 10 * v + d;
  }
  if (neg) {
    if (v > (uint64_t)INT64_MAX + 1) return 0;
    *out = v == (uint64_t)INT64_MAX + 1 ? INT64_MIN : -(int64_t)v;
  } else {
    if (v > (uint64_t)INT64_MAX) return 0;
    *out = (int64_t)v;
  }
  return 1;
}

#define WHAT(buf)                         \
  char buf[160];                          \
  do {                                    \
    va_list ap;                           \
    va_start(ap, what);                   \
    vsnprintf(buf, sizeof buf, what, ap); \
    va_end(ap);                           \
  } while (0)

pm_status pm_rd_int(pm_rd *r, int64_t lo, int64_t hi, int64_t *out, const char *what, ...) {
  pm_rd_skip_space(r);
  const char *at = r->p, *t;
  size_t n;
  int64_t v;
  if (pm_rd_token(r, &t, &n) && parse_i64(t, n, &v) && v >= lo && v <= hi) {
    *out = v;
    return PM_OK;
  }
  WHAT(w);
  if (n == 0) return pm_rd_fail(r, at, 0, "the file ends where %s should be", w);
  char q[40];
  pm_rd_quote(t, n, q);
  if (!parse_i64(t, n, &v)) return pm_rd_fail(r, at, 0, "%s: expected a whole number, found '%s'", w, q);
  return pm_rd_fail(r, at, 0, "%s is %s, outside %lld..%lld", w, q, (long long)lo, (long long)hi);
}

/* Parse [t, t + n) as an unsigned integer; 0 when it is not one (or overflows). */
static int parse_u64(const char *t, size_t n, uint64_t *out) {
  size_t i = (n > 0 && t[0] == '+') ? 1 : 0;
  if (i == n) return 0;
  uint64_t v = 0;
  for (; i < n; ++i) {
    if (t[i] < '0' || t[i] > '9') return 0;
    unsigned d = (unsigned)(t[i] - '0');
    if (v > (UINT64_MAX - d) / 10) return 0;
    v = 10 * v + d;
  }
  *out = v;
  return 1;
}

pm_status pm_rd_uint(pm_rd *r, uint64_t lo, uint64_t *out, const char *what, ...) {
  pm_rd_skip_space(r);
  const char *at = r->p, *t;
  size_t n;
  uint64_t v;
  if (pm_rd_token(r, &t, &n) && parse_u64(t, n, &v) && v >= lo) {
    *out = v;
    return PM_OK;
  }
  WHAT(w);
  if (n == 0) return pm_rd_fail(r, at, 0, "the file ends where %s should be", w);
  char q[40];
  pm_rd_quote(t, n, q);
  int64_t sv;
  if (parse_u64(t, n, &v) || (parse_i64(t, n, &sv) && sv < 0))
    return pm_rd_fail(r, at, 0, "%s is %s; it must be %llu or more", w, q, (unsigned long long)lo);
  return pm_rd_fail(r, at, 0, "%s: expected a whole number, found '%s'", w, q);
}

pm_status pm_rd_double(pm_rd *r, double *out, const char *what, ...) {
  pm_rd_skip_space(r);
  const char *at = r->p, *t;
  size_t n;
  if (pm_rd_token(r, &t, &n)) {
    /* strtod stops at the whitespace (or the buffer's final '\0') that ends the token. */
    char *e = NULL;
    double v = strtod(t, &e);
    if (e == t + n) {
      *out = v;
      return PM_OK;
    }
  }
  WHAT(w);
  if (n == 0) return pm_rd_fail(r, at, 0, "the file ends where %s should be", w);
  char q[40];
  pm_rd_quote(t, n, q);
  return pm_rd_fail(r, at, 0, "%s: expected a number, found '%s'", w, q);
}

/* ---- binary -------------------------------------------------------------------------------- */

pm_status pm_rd_bytes(pm_rd *r, size_t n, const char *what, const unsigned char **out) {
  if ((size_t)(r->end - r->p) < n)
    return pm_rd_fail(r, r->p, 1, "the file ends inside %s (%zu bytes needed, %zu left)", what, n,
                      (size_t)(r->end - r->p));
  *out = (const unsigned char *)r->p;
  r->p += n;
  return PM_OK;
}

int pm_rd_host_big(void) {
  const uint16_t one = 1;
  unsigned char b[2];
  memcpy(b, &one, 2);
  return b[0] == 0;
}

static void load(void *dst, const unsigned char *b, size_t n, int swap) {
  unsigned char t[8];
  for (size_t i = 0; i < n; ++i) t[i] = swap ? b[n - 1 - i] : b[i];
  memcpy(dst, t, n);
}

int32_t pm_rd_i32(const unsigned char *b, int swap) {
  int32_t v;
  load(&v, b, 4, swap);
  return v;
}
uint32_t pm_rd_u32(const unsigned char *b, int swap) {
  uint32_t v;
  load(&v, b, 4, swap);
  return v;
}
uint64_t pm_rd_u64(const unsigned char *b, int swap) {
  uint64_t v;
  load(&v, b, 8, swap);
  return v;
}
double pm_rd_f64(const unsigned char *b, int swap) {
  double v;
  load(&v, b, 8, swap);
  return v;
}
float pm_rd_f32(const unsigned char *b, int swap) {
  float v;
  load(&v, b, 4, swap);
  return v;
}

/* ---- bounds -------------------------------------------------------------------------------- */

pm_status pm_rd_room(pm_rd *r, uint64_t count, uint64_t min_bytes, int binary, const char *what) {
  uint64_t left = (uint64_t)(r->end - r->p);
  uint64_t fit = min_bytes ? left / min_bytes : UINT64_MAX;
  if (count > fit)
    return pm_rd_fail(r, r->p, binary,
                      "%s: the file declares %llu, but the %llu bytes left hold at most %llu",
                      what, (unsigned long long)count, (unsigned long long)left,
                      (unsigned long long)fit);
  return PM_OK;
}

/* ---- what was read ------------------------------------------------------------------------- */

static int grow(void **v, size_t *cap, size_t n, size_t sz) {
  if (n < *cap) return 1;
  size_t c = *cap ? 2 * *cap : 256;
  void *p = realloc(*v, c * sz);
  if (!p) return 0;
  *v = p;
  *cap = c;
  return 1;
}

pm_status pm_rd_node(pm_rd *r, const char *at, int binary, uint64_t tag, const double xyz[3],
                     int dim, int32_t cell, const double *par) {
  for (int k = 0; k < 3; ++k) {
    if (!isfinite(xyz[k]))
      return pm_rd_fail(r, at, binary, "%s %llu has a non-finite coordinate (%c = %g)",
                        r->node_word, (unsigned long long)tag, "xyz"[k], xyz[k]);
    if (fabs(xyz[k]) > PM_COORD_MAX)
      return pm_rd_fail(r, at, binary,
                        "%s %llu has coordinate %c = %g, beyond +-%g (the largest packmesh "
                        "measures without overflow)",
                        r->node_word, (unsigned long long)tag, "xyz"[k], xyz[k], PM_COORD_MAX);
  }
  if (par)
    for (int k = 0; k < 2; ++k)
      if (!isfinite(par[k]))
        return pm_rd_fail(r, at, binary, "%s %llu has a non-finite parameter", r->node_word,
                          (unsigned long long)tag);
  if (!grow((void **)&r->node, &r->cap_node, r->nnode, sizeof *r->node))
    return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  rd_node *n = &r->node[r->nnode++];
  n->tag = tag;
  memcpy(n->xyz, xyz, sizeof n->xyz);
  n->dim = (int8_t)(dim >= 0 && dim <= 3 && cell >= 0 ? dim : -1);
  n->cell = n->dim >= 0 ? cell : -1;
  n->par[0] = n->dim >= 0 && par ? par[0] : 0.0;
  n->par[1] = n->dim >= 0 && par ? par[1] : 0.0;
  return PM_OK;
}

pm_status pm_rd_elem(pm_rd *r, int kind, uint64_t tag, const uint64_t *corners, int32_t cell) {
  if (!grow((void **)&r->el, &r->cap_el, r->nel, sizeof *r->el))
    return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  rd_elem *e = &r->el[r->nel];
  memset(e, 0, sizeof *e);
  e->tag = tag;
  e->seq = r->nel++;
  e->kind = (int8_t)kind;
  e->cell = cell;
  for (int q = 0; q <= kind; ++q) e->node[q] = corners[q];
  return PM_OK;
}

pm_status pm_rd_ho(pm_rd *r, uint64_t tag) {
  if (!grow((void **)&r->ho, &r->cap_ho, r->nho, sizeof *r->ho))
    return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  r->ho[r->nho++] = tag;
  return PM_OK;
}

static int cmp_node_tag(const void *pa, const void *pb) {
  uint64_t a = ((const rd_node *)pa)->tag, b = ((const rd_node *)pb)->tag;
  return (a > b) - (a < b);
}

static int cmp_elem_tag(const void *pa, const void *pb) {
  const rd_elem *a = pa, *b = pb;
  if (a->tag != b->tag) return (a->tag > b->tag) - (a->tag < b->tag);
  return (a->seq > b->seq) - (a->seq < b->seq);
}

static int cmp_elem_kind_tag(const void *pa, const void *pb) {
  const rd_elem *a = pa, *b = pb;
  if (a->kind != b->kind) return a->kind - b->kind;
  return cmp_elem_tag(pa, pb);
}

/* gmsh's order for classifying MSH 2 nodes: by dimension, then entity, then file order. */
static int cmp_elem_classify(const void *pa, const void *pb) {
  const rd_elem *a = pa, *b = pb;
  if (a->kind != b->kind) return a->kind - b->kind;
  if (a->cell != b->cell) return (a->cell > b->cell) - (a->cell < b->cell);
  return (a->seq > b->seq) - (a->seq < b->seq);
}

/* Node tag -> index in the sorted node array: a dense table when the tags are not too sparse,
 * else binary search. */
typedef struct tag_map {
  const rd_node *node;
  size_t n;
  int32_t *dense; /* [maxtag + 1] or NULL */
  uint64_t maxtag;
} tag_map;

static int64_t map_find(const tag_map *tm, uint64_t tag) {
  if (tm->dense) return tag <= tm->maxtag ? tm->dense[tag] : -1;
  size_t lo = 0, hi = tm->n;
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (tm->node[mid].tag == tag) return (int64_t)mid;
    if (tm->node[mid].tag < tag)
      lo = mid + 1;
    else
      hi = mid;
  }
  return -1;
}

pm_status pm_rd_finish(pm_rd *r, pm_mesh **out) {
  *out = NULL;
  if (r->nnode == 0) return pm_error_setf(r->err, PM_ERR_PARSE, "%s: the file holds no mesh nodes", r->name);
  size_t count[4] = {0, 0, 0, 0};
  for (size_t i = 0; i < r->nel; ++i) count[r->el[i].kind]++;
  if (count[1] + count[2] + count[3] == 0)
    return pm_error_setf(r->err, PM_ERR_PARSE, "%s: the file holds no lines, triangles or tetrahedra",
                         r->name);
  if (r->nnode > INT32_MAX || count[1] > INT32_MAX || count[2] > INT32_MAX || count[3] > INT32_MAX)
    return pm_error_setf(r->err, PM_ERR_LIMIT, "%s: more than %ld nodes or elements", r->name,
                         (long)INT32_MAX);
  /* Nodes by increasing tag, each tag once. */
  int sorted = 1;
  for (size_t i = 1; i < r->nnode && sorted; ++i) sorted = r->node[i].tag > r->node[i - 1].tag;
  if (!sorted) {
    qsort(r->node, r->nnode, sizeof *r->node, cmp_node_tag);
    for (size_t i = 1; i < r->nnode; ++i)
      if (r->node[i].tag == r->node[i - 1].tag)
        return pm_error_setf(r->err, PM_ERR_PARSE, "%s: %s tag %llu appears twice", r->name,
                             r->node_word, (unsigned long long)r->node[i].tag);
  }
  if (r->unique_elem_tags && r->nel > 1) {
    qsort(r->el, r->nel, sizeof *r->el, cmp_elem_tag);
    for (size_t i = 1; i < r->nel; ++i)
      if (r->el[i].tag == r->el[i - 1].tag)
        return pm_error_setf(r->err, PM_ERR_PARSE, "%s: element tag %llu appears twice", r->name,
                             (unsigned long long)r->el[i].tag);
  }
  tag_map tm = {r->node, r->nnode, NULL, r->node[r->nnode - 1].tag};
  if (tm.maxtag <= 4 * (uint64_t)r->nnode + 1024) {
    tm.dense = malloc(((size_t)tm.maxtag + 1) * sizeof *tm.dense);
    if (!tm.dense) return pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
    for (uint64_t t = 0; t <= tm.maxtag; ++t) tm.dense[t] = -1;
    for (size_t i = 0; i < r->nnode; ++i) tm.dense[r->node[i].tag] = (int32_t)i;
  }
  /* Corner tags -> node indices. */
  pm_status s = PM_OK;
  for (size_t i = 0; i < r->nel && !s; ++i) {
    rd_elem *e = &r->el[i];
    for (int q = 0; q <= e->kind; ++q) {
      int64_t v = map_find(&tm, e->node[q]);
      if (v < 0) {
        s = pm_error_setf(r->err, PM_ERR_PARSE,
                          "%s: element %llu uses %s %llu, which the file does not define", r->name,
                          (unsigned long long)e->tag, r->node_word, (unsigned long long)e->node[q]);
        break;
      }
      e->node[q] = (uint64_t)v;
    }
  }
  /* Higher-order nodes: indices of those that no element has as a corner. */
  uint8_t *drop = NULL;
  if (!s && r->nho > 0) {
    drop = calloc(r->nnode, 1);
    if (!drop) s = pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
    for (size_t i = 0; i < r->nho && !s; ++i) {
      int64_t v = map_find(&tm, r->ho[i]);
      if (v < 0)
        s = pm_error_setf(r->err, PM_ERR_PARSE,
                          "%s: an element uses %s %llu, which the file does not define", r->name,
                          r->node_word, (unsigned long long)r->ho[i]);
      else
        drop[v] = 1;
    }
    for (size_t i = 0; i < r->nel && !s; ++i)
      if (r->el[i].kind > 0)
        for (int q = 0; q <= r->el[i].kind; ++q) drop[r->el[i].node[q]] = 0;
  }
  free(tm.dense);
  if (s) {
    free(drop);
    return s;
  }
  /* MSH 2 classification: the first element (by dimension, entity, file order) using a node. */
  if (r->classify_by_elements) {
    qsort(r->el, r->nel, sizeof *r->el, cmp_elem_classify);
    for (size_t i = 0; i < r->nel; ++i) {
      const rd_elem *e = &r->el[i];
      if (e->cell < 0) continue;
      for (int q = 0; q <= e->kind; ++q) {
        rd_node *n = &r->node[e->node[q]];
        if (n->dim < 0) n->dim = e->kind, n->cell = e->cell;
      }
    }
  }
  qsort(r->el, r->nel, sizeof *r->el, cmp_elem_kind_tag);

  /* The mesh: kept nodes in tag order, elements by kind and tag. */
  int32_t *idx = malloc(r->nnode * sizeof *idx);
  pm_mesh *m = pm_mesh_create();
  if (!idx || !m) s = pm_error_setf(r->err, PM_ERR_NOMEM, "out of memory reading %s", r->name);
  if (!s)
    s = pm_mesh_reserve(m, (int32_t)r->nnode, (int32_t)count[1], (int32_t)count[2],
                        (int32_t)count[3], r->err);
  for (size_t i = 0; i < r->nnode && !s; ++i) {
    idx[i] = -1;
    if (drop && drop[i]) continue;
    const rd_node *n = &r->node[i];
    s = pm_mesh_add_node(m, n->xyz, n->dim, n->cell, n->dim >= 0 ? n->par : NULL, &idx[i], r->err);
  }
  for (size_t i = 0; i < r->nel && !s; ++i) {
    const rd_elem *e = &r->el[i];
    int32_t c[4];
    for (int q = 0; q <= e->kind; ++q) c[q] = idx[e->node[q]];
    if (e->kind == 1)
      s = pm_mesh_add_seg(m, c[0], c[1], e->cell, r->err);
    else if (e->kind == 2)
      s = pm_mesh_add_tri(m, c[0], c[1], c[2], e->cell, r->err);
    else if (e->kind == 3)
      s = pm_mesh_add_tet(m, c[0], c[1], c[2], c[3], e->cell, r->err);
  }
  free(idx);
  free(drop);
  if (s) {
    pm_mesh_destroy(m);
    return s;
  }
  *out = m;
  return PM_OK;
}

/* ---- entry points -------------------------------------------------------------------------- */

static pm_status parse_buffer(const char *name, pm_mesh_format fmt, const char *buf, size_t len,
                              pm_mesh **out, pm_error *err) {
  pm_rd r;
  memset(&r, 0, sizeof r);
  r.name = name;
  r.base = r.p = buf;
  r.end = buf + len;
  r.err = err;
  r.node_word = "node";
  pm_status s;
  switch (fmt) {
    case PM_MESH_MSH: s = pm_rd_parse_msh(&r); break;
    case PM_MESH_VTK: s = pm_rd_parse_vtk(&r); break;
    case PM_MESH_VTU: s = pm_rd_parse_vtu(&r); break;
    case PM_MESH_STL: s = pm_rd_parse_stl(&r); break;
    case PM_MESH_MEDIT: s = pm_rd_parse_medit(&r); break;
    case PM_MESH_OBJ: s = pm_rd_parse_obj(&r); break;
    default:
      s = pm_error_setf(err, PM_ERR_ARG, "%s: packmesh does not read .%s files", name,
                        pm_mesh_format_ext(fmt));
  }
  if (!s) s = pm_rd_finish(&r, out);
  free(r.node);
  free(r.el);
  free(r.ho);
  return s;
}

pm_status pm_mesh_read_buffer(const char *name, pm_mesh_format fmt, const void *data, size_t len,
                              pm_mesh **out, pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_read_buffer: no output");
  *out = NULL;
  if (!name) name = "(buffer)";
  if (len == 0) return pm_error_setf(err, PM_ERR_PARSE, "%s: the file is empty", name);
  /* The parsers rely on a '\0' after the last byte (strtod stops there). */
  char *buf = malloc(len + 1);
  if (!buf) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory reading %s", name);
  memcpy(buf, data, len);
  buf[len] = '\0';
  pm_status s = parse_buffer(name, fmt, buf, len, out, err);
  free(buf);
  return s;
}

pm_status pm_mesh_read(const char *path, pm_mesh **out, pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_read: no output");
  *out = NULL;
  pm_mesh_format fmt;
  pm_status s = pm_mesh_format_of(path, &fmt, err);
  if (s) return s;
  /* stat before opening: opening a FIFO would wait for a writer. */
  struct stat st;
  if (stat(path, &st) != 0)
    return pm_error_setf(err, PM_ERR_IO, "cannot read %s: %s", path, strerror(errno));
  if (S_ISDIR(st.st_mode))
    return pm_error_setf(err, PM_ERR_IO, "cannot read %s: it is a directory", path);
  if (!S_ISREG(st.st_mode))
    return pm_error_setf(err, PM_ERR_IO, "cannot read %s: not a regular file", path);
  if (st.st_size == 0) return pm_error_setf(err, PM_ERR_PARSE, "%s: the file is empty", path);
  FILE *f = fopen(path, "rb");
  if (!f) return pm_error_setf(err, PM_ERR_IO, "cannot read %s: %s", path, strerror(errno));
  size_t len = (size_t)st.st_size;
  char *buf = (uint64_t)st.st_size < SIZE_MAX ? malloc(len + 1) : NULL;
  if (!buf) {
    fclose(f);
    return pm_error_setf(err, PM_ERR_NOMEM, "%s: no memory for its %lld bytes", path,
                         (long long)st.st_size);
  }
  size_t got = fread(buf, 1, len, f);
  int bad = ferror(f);
  fclose(f);
  if (bad || got != len) {
    free(buf);
    return pm_error_setf(err, PM_ERR_IO, "cannot read %s: %s", path,
                         bad ? strerror(errno) : "the file changed size while being read");
  }
  buf[len] = '\0';
  s = parse_buffer(path, fmt, buf, len, out, err);
  free(buf);
  return s;
}
