/* Mesh topology tables (see mesh_topo.h).
 *
 * Every table is built the same way: the node-to-element incidence first (two counting passes),
 * then, node by node, the edges (faces) whose smallest node is that node are gathered from the
 * node's incident elements into a small buffer, sorted, and emitted in order. The buffer holds
 * at most (incident elements x edges per element) records, so the sorts stay tiny and the whole
 * build is linear in the mesh size up to a log of the local degree.
 */
#include "common/mesh/mesh_topo.h"

#include <stdlib.h>
#include <string.h>

/* ---- incidence ---------------------------------------------------------------------------- */

static int elem_ok(const int32_t *e, int per, int32_t nnode) {
  for (int k = 0; k < per; ++k)
    if (e[k] < 0 || e[k] >= nnode) return 0;
  return 1;
}

pm_status pm_incidence_build(int32_t nnode, const int32_t *conn, int32_t nelem, int per,
                             pm_incidence *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  out->nnode = nnode;
  out->off = calloc((size_t)nnode + 1, sizeof(int64_t));
  if (!out->off) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (node incidence)");
  for (int32_t t = 0; t < nelem; ++t) {
    const int32_t *e = conn + (size_t)per * t;
    if (!elem_ok(e, per, nnode)) continue;
    for (int k = 0; k < per; ++k) out->off[e[k] + 1]++;
  }
  for (int32_t v = 0; v < nnode; ++v) out->off[v + 1] += out->off[v];
  size_t total = (size_t)out->off[nnode];
  out->elem = malloc((total ? total : 1) * sizeof(int32_t));
  int64_t *fill = malloc(((size_t)nnode + 1) * sizeof(int64_t));
  if (!out->elem || !fill) {
    free(fill);
    pm_incidence_free(out);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (node incidence)");
  }
  memcpy(fill, out->off, ((size_t)nnode + 1) * sizeof(int64_t));
  for (int32_t t = 0; t < nelem; ++t) {
    const int32_t *e = conn + (size_t)per * t;
    if (!elem_ok(e, per, nnode)) continue;
    for (int k = 0; k < per; ++k) out->elem[fill[e[k]]++] = t;
  }
  free(fill);
  return PM_OK;
}

void pm_incidence_free(pm_incidence *inc) {
  if (!inc) return;
  free(inc->off);
  free(inc->elem);
  memset(inc, 0, sizeof *inc);
}

static int64_t max_degree(const pm_incidence *inc) {
  int64_t d = 0;
  for (int32_t v = 0; v < inc->nnode; ++v)
    if (inc->off[v + 1] - inc->off[v] > d) d = inc->off[v + 1] - inc->off[v];
  return d;
}

/* ---- edges -------------------------------------------------------------------------------- */

/* Local edges of a segment, a triangle (oriented along the triangle) and a tet. */
static const int seg_edges[1][2] = {{0, 1}};
static const int tri_edges[3][2] = {{0, 1}, {1, 2}, {2, 0}};
static const int tet_edges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

typedef struct edge_rec {
  int32_t w, t;
  int8_t dir;
} edge_rec;

static int edge_rec_less(const edge_rec *a, const edge_rec *b) {
  return a->w < b->w || (a->w == b->w && a->t < b->t);
}

static int edge_rec_cmp(const void *pa, const void *pb) {
  const edge_rec *a = pa, *b = pb;
  return edge_rec_less(a, b) ? -1 : edge_rec_less(b, a) ? 1 : 0;
}

static void sort_edge_recs(edge_rec *r, size_t n) {
  if (n > 24) {
    qsort(r, n, sizeof *r, edge_rec_cmp);
    return;
  }
  for (size_t i = 1; i < n; ++i) {
    edge_rec x = r[i];
    size_t j = i;
    while (j > 0 && edge_rec_less(&x, &r[j - 1])) {
      r[j] = r[j - 1];
      --j;
    }
    r[j] = x;
  }
}

pm_status pm_edges_build(int32_t nnode, const int32_t *conn, int32_t nelem, int per,
                         pm_edges *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  out->nnode = nnode;
  const int(*local)[2];
  int ne;
  switch (per) {
    case 2: local = seg_edges; ne = 1; break;
    case 3: local = tri_edges; ne = 3; break;
    case 4: local = tet_edges; ne = 6; break;
    default: return pm_error_setf(err, PM_ERR_ARG, "pm_edges_build: %d nodes per element", per);
  }
  pm_incidence inc;
  pm_status s = pm_incidence_build(nnode, conn, nelem, per, &inc, err);
  if (s) return s;

  size_t cap_rec = (size_t)nelem * (size_t)ne; /* every local edge lands in at most one edge */
  size_t bufcap = (size_t)max_degree(&inc) * (size_t)ne;
  edge_rec *buf = malloc((bufcap ? bufcap : 1) * sizeof *buf);
  out->ends = malloc((cap_rec ? 2 * cap_rec : 2) * sizeof(int32_t));
  out->off = malloc((cap_rec + 1) * sizeof(int64_t));
  out->elem = malloc((cap_rec ? cap_rec : 1) * sizeof(int32_t));
  out->dir = malloc((cap_rec ? cap_rec : 1) * sizeof(int8_t));
  out->first = malloc(((size_t)nnode + 1) * sizeof(int64_t));
  if (!buf || !out->ends || !out->off || !out->elem || !out->dir || !out->first) {
    free(buf);
    pm_incidence_free(&inc);
    pm_edges_free(out);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (edge table)");
  }

  int64_t nedge = 0, nrec = 0;
  out->off[0] = 0;
  for (int32_t v = 0; v < nnode; ++v) {
    out->first[v] = nedge;
    size_t nb = 0;
    int32_t prev = -1;
    for (int64_t k = inc.off[v]; k < inc.off[v + 1]; ++k) {
      int32_t t = inc.elem[k];
      if (t == prev) continue; /* an element repeating v is listed twice */
      prev = t;
      const int32_t *e = conn + (size_t)per * t;
      for (int j = 0; j < ne; ++j) {
        int32_t p = e[local[j][0]], q = e[local[j][1]];
        int8_t d = per == 4 ? 0 : 1;
        if (p == v && q > v)
          buf[nb++] = (edge_rec){q, t, d};
        else if (q == v && p > v)
          buf[nb++] = (edge_rec){p, t, (int8_t)-d};
      }
    }
    sort_edge_recs(buf, nb);
    for (size_t i = 0; i < nb; ++i) {
      if (i == 0 || buf[i].w != buf[i - 1].w) {
        out->off[nedge] = nrec;
        out->ends[2 * nedge] = v;
        out->ends[2 * nedge + 1] = buf[i].w;
        ++nedge;
      }
      out->elem[nrec] = buf[i].t;
      out->dir[nrec] = buf[i].dir;
      ++nrec;
    }
    out->off[nedge] = nrec;
  }
  out->first[nnode] = nedge;
  out->off[nedge] = nrec;
  out->nedge = nedge;
  free(buf);
  pm_incidence_free(&inc);
  /* Give back what the upper bound over-allocated (a failed shrink keeps the larger block). */
  int32_t *ends = realloc(out->ends, (nedge ? 2 * (size_t)nedge : 2) * sizeof(int32_t));
  if (ends) out->ends = ends;
  int64_t *off = realloc(out->off, ((size_t)nedge + 1) * sizeof(int64_t));
  if (off) out->off = off;
  return PM_OK;
}

void pm_edges_free(pm_edges *e) {
  if (!e) return;
  free(e->ends);
  free(e->off);
  free(e->elem);
  free(e->dir);
  free(e->first);
  memset(e, 0, sizeof *e);
}

int64_t pm_edges_find(const pm_edges *e, int32_t a, int32_t b) {
  if (a > b) {
    int32_t t = a;
    a = b;
    b = t;
  }
  if (a < 0 || a >= e->nnode || a == b) return -1;
  int64_t lo = e->first[a], hi = e->first[a + 1];
  while (lo < hi) {
    int64_t mid = lo + (hi - lo) / 2;
    int32_t w = e->ends[2 * mid + 1];
    if (w == b) return mid;
    if (w < b)
      lo = mid + 1;
    else
      hi = mid;
  }
  return -1;
}

/* ---- tet faces ---------------------------------------------------------------------------- */

/* The faces of a positive tet (0, 1, 2, 3), each ordered so that its normal points out. */
static const int tet_faces_out[4][3] = {{1, 2, 3}, {0, 2, 1}, {0, 1, 3}, {0, 3, 2}};

typedef struct face_rec {
  int32_t b, c, t;
  int8_t side;
} face_rec;

static int face_rec_less(const face_rec *x, const face_rec *y) {
  if (x->b != y->b) return x->b < y->b;
  if (x->c != y->c) return x->c < y->c;
  return x->t < y->t;
}

static int face_rec_cmp(const void *pa, const void *pb) {
  const face_rec *a = pa, *b = pb;
  return face_rec_less(a, b) ? -1 : face_rec_less(b, a) ? 1 : 0;
}

static void sort_face_recs(face_rec *r, size_t n) {
  if (n > 24) {
    qsort(r, n, sizeof *r, face_rec_cmp);
    return;
  }
  for (size_t i = 1; i < n; ++i) {
    face_rec x = r[i];
    size_t j = i;
    while (j > 0 && face_rec_less(&x, &r[j - 1])) {
      r[j] = r[j - 1];
      --j;
    }
    r[j] = x;
  }
}

/* +1 when (x, y, z) is an even permutation of its sorted order, -1 when odd. */
static int parity3(int32_t x, int32_t y, int32_t z) {
  int inv = (x > y) + (x > z) + (y > z);
  return (inv & 1) ? -1 : 1;
}

pm_status pm_faces_build(int32_t nnode, const int32_t *tet, int32_t ntet, pm_faces *out,
                         pm_error *err) {
  memset(out, 0, sizeof *out);
  out->nnode = nnode;
  pm_incidence inc;
  pm_status s = pm_incidence_build(nnode, tet, ntet, 4, &inc, err);
  if (s) return s;
  size_t cap_rec = (size_t)ntet * 4;
  size_t bufcap = (size_t)max_degree(&inc) * 4;
  face_rec *buf = malloc((bufcap ? bufcap : 1) * sizeof *buf);
  out->abc = malloc((cap_rec ? 3 * cap_rec : 3) * sizeof(int32_t));
  out->off = malloc((cap_rec + 1) * sizeof(int64_t));
  out->tet = malloc((cap_rec ? cap_rec : 1) * sizeof(int32_t));
  out->side = malloc((cap_rec ? cap_rec : 1) * sizeof(int8_t));
  out->first = malloc(((size_t)nnode + 1) * sizeof(int64_t));
  if (!buf || !out->abc || !out->off || !out->tet || !out->side || !out->first) {
    free(buf);
    pm_incidence_free(&inc);
    pm_faces_free(out);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (face table)");
  }
  int64_t nface = 0, nrec = 0;
  out->off[0] = 0;
  for (int32_t v = 0; v < nnode; ++v) {
    out->first[v] = nface;
    size_t nb = 0;
    int32_t prev = -1;
    for (int64_t k = inc.off[v]; k < inc.off[v + 1]; ++k) {
      int32_t t = inc.elem[k];
      if (t == prev) continue;
      prev = t;
      const int32_t *e = tet + 4 * (size_t)t;
      for (int j = 0; j < 4; ++j) {
        int32_t x = e[tet_faces_out[j][0]], y = e[tet_faces_out[j][1]],
                z = e[tet_faces_out[j][2]];
        if (x == y || y == z || x == z) continue;
        int32_t lo = x < y ? (x < z ? x : z) : (y < z ? y : z);
        if (lo != v) continue;
        int32_t hi = x > y ? (x > z ? x : z) : (y > z ? y : z);
        int32_t mid = (int32_t)((int64_t)x + y + z - lo - hi);
        buf[nb++] = (face_rec){mid, hi, t, (int8_t)parity3(x, y, z)};
      }
    }
    sort_face_recs(buf, nb);
    for (size_t i = 0; i < nb; ++i) {
      if (i == 0 || buf[i].b != buf[i - 1].b || buf[i].c != buf[i - 1].c) {
        out->abc[3 * nface] = v;
        out->abc[3 * nface + 1] = buf[i].b;
        out->abc[3 * nface + 2] = buf[i].c;
        out->off[nface] = nrec;
        ++nface;
      }
      out->tet[nrec] = buf[i].t;
      out->side[nrec] = buf[i].side;
      ++nrec;
    }
    out->off[nface] = nrec;
  }
  out->first[nnode] = nface;
  out->off[nface] = nrec;
  out->nface = nface;
  free(buf);
  pm_incidence_free(&inc);
  return PM_OK;
}

void pm_faces_free(pm_faces *f) {
  if (!f) return;
  free(f->abc);
  free(f->off);
  free(f->tet);
  free(f->side);
  free(f->first);
  memset(f, 0, sizeof *f);
}

int64_t pm_faces_find(const pm_faces *f, int32_t a, int32_t b, int32_t c, int *parity) {
  if (parity) *parity = parity3(a, b, c);
  int32_t lo = a < b ? (a < c ? a : c) : (b < c ? b : c);
  int32_t hi = a > b ? (a > c ? a : c) : (b > c ? b : c);
  int32_t mid = (int32_t)((int64_t)a + b + c - lo - hi);
  if (lo < 0 || hi >= f->nnode || lo == mid || mid == hi) return -1;
  int64_t l = f->first[lo], h = f->first[lo + 1];
  while (l < h) {
    int64_t m = l + (h - l) / 2;
    int32_t fb = f->abc[3 * m + 1], fc = f->abc[3 * m + 2];
    if (fb == mid && fc == hi) return m;
    if (fb < mid || (fb == mid && fc < hi))
      l = m + 1;
    else
      h = m;
  }
  return -1;
}
