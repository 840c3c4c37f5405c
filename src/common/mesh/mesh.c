/* The output mesh container of mesh.h: flat arrays grown geometrically.
 *
 * Capacities grow by half again (at least to the requested count) so that appending n items
 * costs O(n) amortized; counts are int32_t, so growth stops at INT32_MAX items and asking for
 * more is PM_ERR_LIMIT rather than an overflow.
 */
#include "common/mesh/mesh.h"

#include <stdlib.h>
#include <string.h>

pm_mesh *pm_mesh_create(void) { return calloc(1, sizeof(pm_mesh)); }

void pm_mesh_destroy(pm_mesh *m) {
  if (!m) return;
  free(m->xyz);
  free(m->node_dim);
  free(m->node_cell);
  free(m->node_par);
  free(m->seg);
  free(m->seg_cell);
  free(m->tri);
  free(m->tri_cell);
  free(m->tet);
  free(m->tet_cell);
  free(m);
}

void pm_mesh_clear(pm_mesh *m) {
  if (!m) return;
  m->nnode = m->nseg = m->ntri = m->ntet = 0;
}

/* realloc *p to n items of size sz; on failure *p is untouched. */
static int grow_array(void **p, size_t n, size_t sz) {
  void *q = realloc(*p, n * sz);
  if (!q) return 0;
  *p = q;
  return 1;
}

/* The next capacity for holding `need` items when `cap` are allocated. */
static int32_t next_cap(int32_t cap, int32_t need) {
  int64_t c = cap < 16 ? 16 : (int64_t)cap + cap / 2;
  if (c < need) c = need;
  if (c > INT32_MAX) c = INT32_MAX;
  return (int32_t)c;
}

static pm_status reserve_nodes(pm_mesh *m, int32_t n, pm_error *err) {
  if (n <= m->cap_node) return PM_OK;
  /* Each array is grown separately; a failure leaves the larger ones in place, which is
   * harmless since the capacity is only raised when all succeeded. */
  if (!grow_array((void **)&m->xyz, (size_t)n, 3 * sizeof(double)) ||
      !grow_array((void **)&m->node_dim, (size_t)n, sizeof(int8_t)) ||
      !grow_array((void **)&m->node_cell, (size_t)n, sizeof(int32_t)) ||
      !grow_array((void **)&m->node_par, (size_t)n, 2 * sizeof(double)))
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory growing the mesh to %ld nodes",
                         (long)n);
  m->cap_node = n;
  return PM_OK;
}

static pm_status reserve_elems(int32_t n, int32_t *cap, int32_t **conn, int per, int32_t **cell,
                               const char *what, pm_error *err) {
  if (n <= *cap) return PM_OK;
  if (!grow_array((void **)conn, (size_t)n, (size_t)per * sizeof(int32_t)) ||
      !grow_array((void **)cell, (size_t)n, sizeof(int32_t)))
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory growing the mesh to %ld %s", (long)n,
                         what);
  *cap = n;
  return PM_OK;
}

pm_status pm_mesh_reserve(pm_mesh *m, int32_t nnode, int32_t nseg, int32_t ntri, int32_t ntet,
                          pm_error *err) {
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_reserve: no mesh");
  if (nnode < 0 || nseg < 0 || ntri < 0 || ntet < 0)
    return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_reserve: negative count");
  pm_status s = reserve_nodes(m, nnode, err);
  if (!s) s = reserve_elems(nseg, &m->cap_seg, &m->seg, 2, &m->seg_cell, "segments", err);
  if (!s) s = reserve_elems(ntri, &m->cap_tri, &m->tri, 3, &m->tri_cell, "triangles", err);
  if (!s) s = reserve_elems(ntet, &m->cap_tet, &m->tet, 4, &m->tet_cell, "tetrahedra", err);
  return s;
}

/* Room for one more item when `count` are stored; PM_ERR_LIMIT at INT32_MAX. */
static pm_status full(int32_t count, const char *what, pm_error *err) {
  if (count == INT32_MAX)
    return pm_error_setf(err, PM_ERR_LIMIT, "a mesh holds at most %ld %s", (long)INT32_MAX,
                         what);
  return PM_OK;
}

pm_status pm_mesh_add_node(pm_mesh *m, const double xyz[3], int dim, int32_t cell,
                           const double *par, int32_t *id, pm_error *err) {
  pm_status s = full(m->nnode, "nodes", err);
  if (s) return s;
  if (m->nnode == m->cap_node) {
    s = reserve_nodes(m, next_cap(m->cap_node, m->nnode + 1), err);
    if (s) return s;
  }
  int32_t i = m->nnode++;
  memcpy(m->xyz + 3 * (size_t)i, xyz, 3 * sizeof(double));
  m->node_dim[i] = (int8_t)dim;
  m->node_cell[i] = cell;
  /* A curve node has one parameter, a face node two; the rest of the pair stays 0. */
  m->node_par[2 * (size_t)i] = 0.0;
  m->node_par[2 * (size_t)i + 1] = 0.0;
  if (par) {
    int np = dim == 1 ? 1 : dim == 2 ? 2 : 0;
    for (int k = 0; k < np; ++k) m->node_par[2 * (size_t)i + k] = par[k];
  }
  if (id) *id = i;
  return PM_OK;
}

pm_status pm_mesh_add_seg(pm_mesh *m, int32_t a, int32_t b, int32_t cell, pm_error *err) {
  pm_status s = full(m->nseg, "segments", err);
  if (s) return s;
  if (m->nseg == m->cap_seg) {
    s = reserve_elems(next_cap(m->cap_seg, m->nseg + 1), &m->cap_seg, &m->seg, 2, &m->seg_cell,
                      "segments", err);
    if (s) return s;
  }
  int32_t i = m->nseg++;
  m->seg[2 * (size_t)i] = a;
  m->seg[2 * (size_t)i + 1] = b;
  m->seg_cell[i] = cell;
  return PM_OK;
}

pm_status pm_mesh_add_tri(pm_mesh *m, int32_t a, int32_t b, int32_t c, int32_t cell,
                          pm_error *err) {
  pm_status s = full(m->ntri, "triangles", err);
  if (s) return s;
  if (m->ntri == m->cap_tri) {
    s = reserve_elems(next_cap(m->cap_tri, m->ntri + 1), &m->cap_tri, &m->tri, 3, &m->tri_cell,
                      "triangles", err);
    if (s) return s;
  }
  int32_t i = m->ntri++;
  int32_t *t = m->tri + 3 * (size_t)i;
  t[0] = a;
  t[1] = b;
  t[2] = c;
  m->tri_cell[i] = cell;
  return PM_OK;
}

pm_status pm_mesh_add_tet(pm_mesh *m, int32_t a, int32_t b, int32_t c, int32_t d, int32_t cell,
                          pm_error *err) {
  pm_status s = full(m->ntet, "tetrahedra", err);
  if (s) return s;
  if (m->ntet == m->cap_tet) {
    s = reserve_elems(next_cap(m->cap_tet, m->ntet + 1), &m->cap_tet, &m->tet, 4, &m->tet_cell,
                      "tetrahedra", err);
    if (s) return s;
  }
  int32_t i = m->ntet++;
  int32_t *t = m->tet + 4 * (size_t)i;
  t[0] = a;
  t[1] = b;
  t[2] = c;
  t[3] = d;
  m->tet_cell[i] = cell;
  return PM_OK;
}

pm_mesh *pm_mesh_copy(const pm_mesh *m) {
  if (!m) return NULL;
  pm_mesh *c = pm_mesh_create();
  if (!c) return NULL;
  if (pm_mesh_reserve(c, m->nnode, m->nseg, m->ntri, m->ntet, NULL) != PM_OK) {
    pm_mesh_destroy(c);
    return NULL;
  }
  size_t nn = (size_t)m->nnode, ns = (size_t)m->nseg, nt = (size_t)m->ntri,
         nk = (size_t)m->ntet;
  if (nn) {
    memcpy(c->xyz, m->xyz, 3 * nn * sizeof(double));
    memcpy(c->node_dim, m->node_dim, nn * sizeof(int8_t));
    memcpy(c->node_cell, m->node_cell, nn * sizeof(int32_t));
    memcpy(c->node_par, m->node_par, 2 * nn * sizeof(double));
  }
  if (ns) {
    memcpy(c->seg, m->seg, 2 * ns * sizeof(int32_t));
    memcpy(c->seg_cell, m->seg_cell, ns * sizeof(int32_t));
  }
  if (nt) {
    memcpy(c->tri, m->tri, 3 * nt * sizeof(int32_t));
    memcpy(c->tri_cell, m->tri_cell, nt * sizeof(int32_t));
  }
  if (nk) {
    memcpy(c->tet, m->tet, 4 * nk * sizeof(int32_t));
    memcpy(c->tet_cell, m->tet_cell, nk * sizeof(int32_t));
  }
  c->nnode = m->nnode;
  c->nseg = m->nseg;
  c->ntri = m->ntri;
  c->ntet = m->ntet;
  return c;
}

pm_status pm_mesh_surface_nodes(const pm_mesh *m, int32_t *count, pm_error *err) {
  *count = 0;
  if (m->ntri == 0) return PM_OK;
  unsigned char *seen = calloc((size_t)m->nnode, 1);
  if (!seen) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (surface nodes)");
  int32_t n = 0;
  for (int64_t k = 0; k < 3 * (int64_t)m->ntri; ++k)
    if (!seen[m->tri[k]]) seen[m->tri[k]] = 1, ++n;
  free(seen);
  *count = n;
  return PM_OK;
}
