/* Element and mesh quality measures (see quality.h for the definitions and conventions).
 *
 * Element measures are computed in parallel (each element writes its own slot, so the result
 * does not depend on the thread count); sums are then taken sequentially in index order. The
 * node degrees of eps_t and the unique edges of the size conformity come from the edge table of
 * mesh_topo.h (linear time).
 */
#include "common/measure/quality.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"
#include "common/mesh/mesh_topo.h"


/* ---- a whole mesh ------------------------------------------------------------------------- */

static pm_status check_indices(const int32_t *conn, int32_t n, int per, int32_t nnode,
                               const char *what, pm_error *err) {
  for (int32_t t = 0; t < n; ++t)
    for (int k = 0; k < per; ++k) {
      int32_t v = conn[(size_t)per * t + k];
      if (v < 0 || v >= nnode)
        return pm_error_setf(err, PM_ERR_ARG, "%s %ld uses node %ld, the mesh has %ld nodes",
                             what, (long)t, (long)v, (long)nnode);
    }
  return PM_OK;
}

static pm_status kind_alloc(pm_kind_quality *k, int32_t n, pm_error *err) {
  memset(k, 0, sizeof *k);
  k->n = n;
  size_t sz = (size_t)(n ? n : 1) * sizeof(double);
  k->radius_ratio = malloc(sz);
  k->aspect_ratio = malloc(sz);
  k->min_angle = malloc(sz);
  k->max_angle = malloc(sz);
  if (!k->radius_ratio || !k->aspect_ratio || !k->min_angle || !k->max_angle)
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring %ld elements", (long)n);
  return PM_OK;
}

static void kind_free(pm_kind_quality *k) {
  free(k->radius_ratio);
  free(k->aspect_ratio);
  free(k->min_angle);
  free(k->max_angle);
  memset(k, 0, sizeof *k);
}

void pm_quality_clear(pm_quality *q) {
  if (!q) return;
  kind_free(&q->tri);
  kind_free(&q->tet);
  memset(q, 0, sizeof *q);
}

/* The four summaries are independent: one per thread. */
static pm_status kind_summaries(pm_kind_quality *k, pm_error *err) {
  const double *in[4] = {k->radius_ratio, k->aspect_ratio, k->min_angle, k->max_angle};
  pm_summary *out[4] = {&k->s_radius_ratio, &k->s_aspect_ratio, &k->s_min_angle,
                        &k->s_max_angle};
  pm_status st[4] = {PM_OK, PM_OK, PM_OK, PM_OK};
  pm_error e[4];
#pragma omp parallel for schedule(static, 1)
  for (int i = 0; i < 4; ++i) st[i] = pm_summary_compute(in[i], (size_t)k->n, out[i], &e[i]);
  for (int i = 0; i < 4; ++i)
    if (st[i]) {
      if (err) *err = e[i];
      return st[i];
    }
  return PM_OK;
}

/* eps_t of papers/003 eq. 8 from the edge table: degree = number of distinct neighbours.
 * `interior[v]` says whether node v counts. */
static void eps_t_from_edges(const pm_edges *e, const uint8_t *interior, int D,
                             pm_kind_quality *k, int32_t *deg) {
  memset(deg, 0, (size_t)e->nnode * sizeof *deg);
  for (int64_t i = 0; i < e->nedge; ++i) {
    deg[e->ends[2 * i]]++;
    deg[e->ends[2 * i + 1]]++;
  }
  double sum = 0.0;
  int32_t n = 0;
  for (int32_t v = 0; v < e->nnode; ++v) {
    if (!interior[v] || deg[v] == 0) continue;
    sum += fabs((double)deg[v] - D);
    ++n;
  }
  k->eps_t_nodes = n;
  k->eps_t = n ? sum / n : 0.0;
}

/* Size conformity over the unique edges: |b - a| / d((a + b) / 2). */
static pm_status size_ratios(const pm_mesh *m, const pm_edges *e, pm_sizing_fn fn, void *user,
                             pm_kind_quality *k, pm_error *err) {
  int64_t ne = e->nedge;
  k->nedge = ne;
  if (ne == 0) {
    k->has_size = 1;
    return PM_OK;
  }
  double *ratio = malloc((size_t)ne * sizeof *ratio);
  if (!ratio) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (size conformity)");
  int64_t bad = ne; /* the first edge whose d is not usable: reported deterministically */
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < ne; ++i) {
    const double *a = m->xyz + 3 * (size_t)e->ends[2 * i];
    const double *b = m->xyz + 3 * (size_t)e->ends[2 * i + 1];
    double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])}, ab[3];
    double d = fn(mid, user);
    pm_v3_sub(ab, b, a);
    if (!(d > 0.0) || !isfinite(d)) {
#pragma omp critical(pm_quality_bad_size)
      if (i < bad) bad = i;
      ratio[i] = 0.0;
    } else {
      ratio[i] = pm_v3_norm(ab) / d;
    }
  }
  if (bad < ne) {
    const double *a = m->xyz + 3 * (size_t)e->ends[2 * bad];
    const double *b = m->xyz + 3 * (size_t)e->ends[2 * bad + 1];
    double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
    double d = fn(mid, user);
    free(ratio);
    return pm_error_setf(err, PM_ERR_ARG,
                         "the size field is %g at (%g, %g, %g); it must be finite and > 0", d,
                         mid[0], mid[1], mid[2]);
  }
  pm_status s = pm_summary_compute(ratio, (size_t)ne, &k->size_ratio, err);
  if (!s) {
    double mean = k->size_ratio.mean, ss = 0.0;
    for (int64_t i = 0; i < ne; ++i) ss += (ratio[i] - mean) * (ratio[i] - mean);
    k->size_ratio_std = sqrt(ss / (double)ne);
    k->has_size = 1;
  }
  free(ratio);
  return s;
}

const char *pm_tri_site_name(pm_tri_site site) {
  static const char *const name[PM_TRI_SITES] = {"boundary", "irregular", "regular"};
  return site >= 0 && site < PM_TRI_SITES ? name[site] : "?";
}

/* The site of triangle c (quality.h), from the degrees and interior flags of eps_t. */
static pm_tri_site tri_site(const int32_t c[3], const int32_t *deg, const uint8_t *interior) {
  pm_tri_site w = PM_TRI_REGULAR;
  for (int j = 0; j < 3; ++j) {
    if (!interior[c[j]]) return PM_TRI_BOUNDARY;
    if (deg[c[j]] != 6) w = PM_TRI_IRREGULAR;
  }
  return w;
}

/* R / l_min of the triangles of each site: grouped by site (a counting sort), then summarized. */
static pm_status site_summaries(const pm_mesh *m, const pm_kind_quality *k, const int32_t *deg,
                                const uint8_t *interior, pm_summary out[PM_TRI_SITES],
                                pm_error *err) {
  const int32_t n = m->ntri;
  double *v = malloc((size_t)(n ? n : 1) * sizeof *v);
  if (!v) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (triangle sites)");
  int32_t count[PM_TRI_SITES] = {0}, at[PM_TRI_SITES];
  for (int32_t t = 0; t < n; ++t) count[tri_site(m->tri + 3 * (size_t)t, deg, interior)]++;
  at[0] = 0;
  for (int w = 1; w < PM_TRI_SITES; ++w) at[w] = at[w - 1] + count[w - 1];
  for (int32_t t = 0; t < n; ++t)
    v[at[tri_site(m->tri + 3 * (size_t)t, deg, interior)]++] = k->aspect_ratio[t];
  pm_status s = PM_OK;
  for (int w = 0; w < PM_TRI_SITES && !s; ++w)
    s = pm_summary_compute(v + (at[w] - count[w]), (size_t)count[w], &out[w], err);
  free(v);
  return s;
}

static pm_status triangles(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                           int32_t *deg, uint8_t *interior, pm_error *err) {
  pm_kind_quality *k = &q->tri;
  pm_status s = kind_alloc(k, m->ntri, err);
  if (s) return s;
  int32_t n = m->ntri;
  double *rr = malloc((size_t)(n ? n : 1) * sizeof *rr);
  uint8_t *dg = malloc((size_t)(n ? n : 1));
  if (!rr || !dg) {
    free(rr);
    free(dg);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring triangles");
  }
#pragma omp parallel for schedule(static)
  for (int32_t t = 0; t < n; ++t) {
    const int32_t *v = m->tri + 3 * (size_t)t;
    pm_tri_measure me;
    pm_tri_measure_eval(m->xyz + 3 * (size_t)v[0], m->xyz + 3 * (size_t)v[1],
                        m->xyz + 3 * (size_t)v[2], &me);
    k->radius_ratio[t] = me.radius_ratio;
    k->aspect_ratio[t] = me.aspect_ratio;
    k->min_angle[t] = me.min_angle;
    k->max_angle[t] = me.max_angle;
    rr[t] = me.rr;
    dg[t] = (uint8_t)me.degenerate;
  }
  double sum_g = 0.0;
  for (int32_t t = 0; t < n; ++t) {
    k->degenerate += dg[t];
    sum_g += PM_EPS_G_A_TRI - rr[t]; /* papers/003 eq. 9 */
    int bin = (int)floor(k->min_angle[t] / 10.0);
    if (bin < 0) bin = 0;
    if (bin > 5) bin = 5; /* [50, 60]: 60 itself (equilateral) and rounding above it */
    q->tri_min_angle_bins[bin]++;
    if (k->max_angle[t] > 90.0) q->tri_max_angle_over[0]++;
    if (k->max_angle[t] > 120.0) q->tri_max_angle_over[1]++;
    if (k->max_angle[t] > 150.0) q->tri_max_angle_over[2]++;
  }
  k->eps_g = n ? sum_g / n : 0.0;
  free(rr);
  free(dg);
  s = kind_summaries(k, err);
  if (s || n == 0) return s;

  pm_edges e;
  s = pm_edges_build(m->nnode, m->tri, n, 3, &e, err);
  if (s) return s;
  /* Interior nodes (quality.h): classified on a face, or, unclassified, touching no edge that
   * has other than two triangles. */
  memset(interior, 1, (size_t)m->nnode);
  for (int64_t i = 0; i < e.nedge; ++i)
    if (e.off[i + 1] - e.off[i] != 2) {
      interior[e.ends[2 * i]] = 0;
      interior[e.ends[2 * i + 1]] = 0;
    }
  for (int32_t v = 0; v < m->nnode; ++v)
    if (m->node_dim[v] >= 0) interior[v] = m->node_dim[v] == PM_FACE;
  eps_t_from_edges(&e, interior, 6, k, deg);
  s = site_summaries(m, k, deg, interior, q->tri_site_aspect, err);
  if (!s && fn) s = size_ratios(m, &e, fn, user, k, err);
  pm_edges_free(&e);
  return s;
}

static pm_status tets(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                      int32_t *deg, uint8_t *interior, pm_error *err) {
  pm_kind_quality *k = &q->tet;
  pm_status s = kind_alloc(k, m->ntet, err);
  if (s) return s;
  int32_t n = m->ntet;
  double *rr = malloc((size_t)(n ? n : 1) * sizeof *rr);
  uint8_t *dg = malloc((size_t)(n ? n : 1));
  if (!rr || !dg) {
    free(rr);
    free(dg);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring tetrahedra");
  }
#pragma omp parallel for schedule(static)
  for (int32_t t = 0; t < n; ++t) {
    const int32_t *v = m->tet + 4 * (size_t)t;
    pm_tet_measure me;
    pm_tet_measure_eval(m->xyz + 3 * (size_t)v[0], m->xyz + 3 * (size_t)v[1],
                        m->xyz + 3 * (size_t)v[2], m->xyz + 3 * (size_t)v[3], &me);
    k->radius_ratio[t] = me.radius_ratio;
    k->aspect_ratio[t] = me.aspect_ratio;
    k->min_angle[t] = me.min_dihedral;
    k->max_angle[t] = me.max_dihedral;
    rr[t] = me.rr;
    dg[t] = (uint8_t)me.degenerate;
  }
  double sum_g = 0.0;
  for (int32_t t = 0; t < n; ++t) {
    k->degenerate += dg[t];
    sum_g += PM_EPS_G_A_TET - rr[t]; /* papers/003 eq. 9 */
  }
  k->eps_g = n ? sum_g / n : 0.0;
  free(rr);
  free(dg);
  s = kind_summaries(k, err);
  if (s || n == 0) return s;

  /* Interior nodes: classified in a volume, or, unclassified, on no boundary face (a face of a
   * single tet). The face table is only built when some node needs it. */
  int need_faces = 0;
  for (int32_t t = 0; t < n && !need_faces; ++t)
    for (int j = 0; j < 4; ++j)
      if (m->node_dim[m->tet[4 * (size_t)t + j]] < 0) need_faces = 1;
  memset(interior, 1, (size_t)m->nnode);
  if (need_faces) {
    pm_faces f;
    s = pm_faces_build(m->nnode, m->tet, n, &f, err);
    if (s) return s;
    for (int64_t i = 0; i < f.nface; ++i)
      if (f.off[i + 1] - f.off[i] == 1)
        for (int j = 0; j < 3; ++j) interior[f.abc[3 * i + j]] = 0;
    pm_faces_free(&f);
  }
  for (int32_t v = 0; v < m->nnode; ++v)
    if (m->node_dim[v] >= 0) interior[v] = m->node_dim[v] == PM_VOLUME;
  pm_edges e;
  s = pm_edges_build(m->nnode, m->tet, n, 4, &e, err);
  if (s) return s;
  eps_t_from_edges(&e, interior, 12, k, deg);
  if (fn) s = size_ratios(m, &e, fn, user, k, err);
  pm_edges_free(&e);
  return s;
}

pm_status pm_quality_compute_fn(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                                pm_error *err) {
  memset(q, 0, sizeof *q);
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_quality_compute: no mesh");
  pm_status s = check_indices(m->tri, m->ntri, 3, m->nnode, "triangle", err);
  if (!s) s = check_indices(m->tet, m->ntet, 4, m->nnode, "tetrahedron", err);
  if (s) return s;
  size_t nn = (size_t)(m->nnode ? m->nnode : 1);
  int32_t *deg = malloc(nn * sizeof *deg);
  uint8_t *interior = malloc(nn);
  if (!deg || !interior) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory (node degrees)");
  } else {
    s = triangles(m, fn, user, q, deg, interior, err);
    if (!s) s = tets(m, fn, user, q, deg, interior, err);
  }
  free(deg);
  free(interior);
  if (s) pm_quality_clear(q);
  return s;
}

static double eval_sizing(const double xyz[3], void *user) {
  return pm_sizing_eval((const pm_sizing *)user, xyz);
}

pm_status pm_quality_compute(const pm_mesh *m, const pm_sizing *size, pm_quality *q,
                             pm_error *err) {
  return pm_quality_compute_fn(m, size ? eval_sizing : NULL, (void *)size, q, err);
}
