/* Classification of an untagged mesh onto the model's cells (classify.h). */
#include "common/measure/classify.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"
#include "common/mesh/mesh_topo.h"

/* How far the nearest face may be from a node of a triangle, relative to the diagonal, before the
 * node counts as unmatched (classify.h). */
#define REACH_REL 1e-3
/* The vertex / curve tolerance: relative to the diagonal, and to the node's shortest edge. */
#define TOL_REL 1e-5
#define TOL_EDGE 0.05

/* Where a node occurs (bits): in segments or triangles (a node of the surface or wire), in a
 * segment (so on a curve or vertex), in tets. USE_NONE: in no element. */
enum { USE_NONE = 0, USE_SURFACE = 1, USE_TETS = 2, USE_SEGMENT = 4 };

/* The nearest cell of dimension dim within `reach` of x (index, or -1), its parameters and
 * distance. Cells whose box is farther than the best distance so far are not projected. */
static int32_t nearest_cell(const pm_model *md, int dim, const double x[3], double reach,
                            double par[2], double *dist) {
  int32_t best = -1;
  double bd = reach;
  for (int32_t i = 0; i < md->count[dim]; ++i) {
    const pm_cell *c = &md->cells[dim][i];
    if (dim == PM_CURVE && c->degenerate) continue;
    if (pm_v3_box_dist(x, c->box) > bd) continue;
    double p[2] = {0, 0}, d;
    pm_error e;
    if (pm_cell_project(c, x, NULL, p, NULL, &d, &e) != PM_OK || !(d <= bd)) continue;
    best = i;
    bd = d;
    par[0] = p[0];
    par[1] = dim == PM_FACE ? p[1] : 0.0;
  }
  *dist = bd;
  return best;
}

/* A model vertex's x coordinate and index, sorted by x for the search of nearest_vertex. */
typedef struct vertex_key {
  double x;
  int32_t index;
} vertex_key;

static int by_x(const void *a, const void *b) {
  const vertex_key *p = a, *q = b;
  if (p->x != q->x) return p->x < q->x ? -1 : 1;
  return p->index < q->index ? -1 : p->index > q->index;
}

/* The model vertex within tol of x (the nearest, the lowest index of a tie), or -1. */
static int32_t nearest_vertex(const pm_model *md, const vertex_key *keys, const double x[3],
                              double tol) {
  int32_t n = md->count[PM_VERTEX], lo = 0, hi = n;
  while (lo < hi) { /* the first key with x >= x[0] - tol */
    int32_t mid = lo + (hi - lo) / 2;
    if (keys[mid].x < x[0] - tol)
      lo = mid + 1;
    else
      hi = mid;
  }
  int32_t best = -1;
  double bd = tol;
  for (int32_t k = lo; k < n && keys[k].x <= x[0] + tol; ++k) {
    const pm_cell *c = &md->cells[PM_VERTEX][keys[k].index];
    if (c->stray) continue;
    double d = pm_v3_dist(c->xyz, x);
    if (d <= bd && (best < 0 || d < bd || keys[k].index < best)) {
      best = keys[k].index;
      bd = d;
    }
  }
  return best;
}

/* Shortest edge at each node over every element (DBL_MAX for a node of no element), and where
 * the node occurs. */
static void node_edges(const pm_mesh *m, double *shortest, uint8_t *use) {
  for (int32_t v = 0; v < m->nnode; ++v) shortest[v] = DBL_MAX;
  const int32_t *conn[3] = {m->seg, m->tri, m->tet};
  const int32_t count[3] = {m->nseg, m->ntri, m->ntet};
  for (int k = 0; k < 3; ++k) {
    int per = k + 2;
    for (int32_t e = 0; e < count[k]; ++e) {
      const int32_t *v = conn[k] + (size_t)per * e;
      for (int i = 0; i < per; ++i) {
        use[v[i]] |= k == 0 ? USE_SURFACE | USE_SEGMENT : k == 1 ? USE_SURFACE : USE_TETS;
        for (int j = i + 1; j < per; ++j) {
          const double *a = m->xyz + 3 * (size_t)v[i], *b = m->xyz + 3 * (size_t)v[j];
          double l = pm_v3_dist(a, b);
          if (l < shortest[v[i]]) shortest[v[i]] = l;
          if (l < shortest[v[j]]) shortest[v[j]] = l;
        }
      }
    }
  }
}

static pm_status check_conn(const int32_t *conn, int32_t n, int per, int32_t nnode,
                            const char *what, pm_error *err) {
  for (size_t i = 0; i < (size_t)n * per; ++i)
    if (conn[i] < 0 || conn[i] >= nnode)
      return pm_error_setf(err, PM_ERR_ARG, "%s %zu names node %d of %d", what, i / per,
                           (int)conn[i], (int)nnode);
  return PM_OK;
}

/* The volume of each tet's region (classify.h): regions are tets joined across faces that are no
 * triangle of the mesh; each takes the volume bounded by most of its triangles' faces. */
static pm_status tet_volumes(const pm_mesh *m, const pm_model *md, int32_t *vol, pm_error *err) {
  if (md->count[PM_VOLUME] <= 1) {
    for (int32_t t = 0; t < m->ntet; ++t) vol[t] = md->count[PM_VOLUME] == 1 ? 0 : -1;
    return PM_OK;
  }
  pm_faces f;
  pm_status s = pm_faces_build(m->nnode, m->tet, m->ntet, &f, err);
  if (s) return s;
  int32_t *face_tri = malloc((size_t)(f.nface ? f.nface : 1) * sizeof *face_tri);
  int32_t *root = malloc((size_t)m->ntet * sizeof *root);
  int32_t *score = calloc((size_t)m->ntet * md->count[PM_VOLUME], sizeof *score);
  if (!face_tri || !root || !score) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory classifying tets");
    goto done;
  }
  for (int64_t i = 0; i < f.nface; ++i) face_tri[i] = -1;
  for (int32_t t = 0; t < m->ntri; ++t) {
    const int32_t *v = m->tri + 3 * (size_t)t;
    int64_t i = pm_faces_find(&f, v[0], v[1], v[2], NULL);
    if (i >= 0 && face_tri[i] < 0) face_tri[i] = t;
  }
  /* Union-find with the smaller index as the root, so that regions do not depend on order. */
  for (int32_t t = 0; t < m->ntet; ++t) root[t] = t;
  for (int64_t i = 0; i < f.nface; ++i) {
    if (face_tri[i] >= 0 || f.off[i + 1] - f.off[i] != 2) continue;
    int32_t a = f.tet[f.off[i]], b = f.tet[f.off[i] + 1];
    while (root[a] != a) a = root[a] = root[root[a]];
    while (root[b] != b) b = root[b] = root[root[b]];
    if (a < b) root[b] = a;
    else if (b < a) root[a] = b;
  }
  for (int32_t t = 0; t < m->ntet; ++t) {
    int32_t a = t;
    while (root[a] != a) a = root[a];
    root[t] = a;
  }
  int32_t nv = md->count[PM_VOLUME];
  for (int64_t i = 0; i < f.nface; ++i) {
    if (face_tri[i] < 0) continue;
    int32_t fc = m->tri_cell[face_tri[i]];
    if (fc < 0 || fc >= md->count[PM_FACE]) continue;
    const pm_cell *face = &md->cells[PM_FACE][fc];
    for (int64_t k = f.off[i]; k < f.off[i + 1]; ++k)
      for (int32_t u = 0; u < face->nup; ++u) score[(size_t)root[f.tet[k]] * nv + face->up[u]]++;
  }
  for (int32_t t = 0; t < m->ntet; ++t) {
    const int32_t *sc = score + (size_t)root[t] * nv;
    int32_t best = -1;
    for (int32_t v = 0; v < nv; ++v)
      if (sc[v] > 0 && (best < 0 || sc[v] > sc[best])) best = v;
    vol[t] = best;
  }
done:
  free(face_tri);
  free(root);
  free(score);
  pm_faces_free(&f);
  return s;
}

pm_status pm_classify_mesh(pm_mesh *m, const pm_model *md, pm_classify_counts *counts,
                           pm_error *err) {
  pm_classify_counts cc;
  memset(&cc, 0, sizeof cc);
  if (counts) *counts = cc;
  if (!m || !md)
    return pm_error_setf(err, PM_ERR_ARG, "pm_classify_mesh: no %s", m ? "model" : "mesh");
  pm_status s;
  if ((s = check_conn(m->seg, m->nseg, 2, m->nnode, "segment", err)) ||
      (s = check_conn(m->tri, m->ntri, 3, m->nnode, "triangle", err)) ||
      (s = check_conn(m->tet, m->ntet, 4, m->nnode, "tetrahedron", err)))
    return s;
  int any = 0;
  for (int32_t v = 0; v < m->nnode && !any; ++v) any = m->node_dim[v] < 0;
  if (!any) return PM_OK;

  size_t nn = (size_t)m->nnode;
  double *shortest = malloc(nn * sizeof *shortest);
  uint8_t *use = calloc(nn, 1), *fresh = calloc(nn, 1);
  vertex_key *keys = malloc((size_t)(md->count[PM_VERTEX] + 1) * sizeof *keys);
  int32_t *vol = malloc((size_t)(m->ntet + 1) * sizeof *vol);
  if (!shortest || !use || !fresh || !keys || !vol) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory classifying %d nodes", (int)m->nnode);
    goto done;
  }
  node_edges(m, shortest, use);
  for (int32_t i = 0; i < md->count[PM_VERTEX]; ++i)
    keys[i] = (vertex_key){md->cells[PM_VERTEX][i].xyz[0], i};
  qsort(keys, (size_t)md->count[PM_VERTEX], sizeof *keys, by_x);

  const double reach = REACH_REL * md->diagonal;
  int32_t unmatched = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : unmatched)
  for (int32_t v = 0; v < m->nnode; ++v) {
    if (m->node_dim[v] >= 0 || use[v] == USE_NONE) continue;
    fresh[v] = 1;
    const double *x = m->xyz + 3 * (size_t)v;
    double tol = fmin(TOL_REL * md->diagonal, TOL_EDGE * shortest[v]), par[2] = {0, 0}, d;
    int dim = -1;
    int32_t cell = nearest_vertex(md, keys, x, tol);
    if (cell >= 0) {
      dim = PM_VERTEX;
    } else if ((use[v] & USE_SURFACE) &&
               (cell = nearest_cell(md, PM_CURVE, x, use[v] & USE_SEGMENT ? reach : tol, par,
                                    &d)) >= 0) {
      /* A node of a segment lies on a curve: the nearest one within reach, as a face node's
       * face, since another mesher's curve nodes need not lie on the curve to the tolerance. */
      dim = PM_CURVE;
    } else if ((use[v] & USE_SURFACE) && m->ntri > 0 &&
               (cell = nearest_cell(md, PM_FACE, x, reach, par, &d)) >= 0) {
      dim = PM_FACE;
    } else if (use[v] == USE_TETS) {
      dim = PM_VOLUME; /* the cell follows from its tets' region */
    } else {
      ++unmatched;
    }
    m->node_dim[v] = (int8_t)dim;
    m->node_cell[v] = cell;
    m->node_par[2 * (size_t)v] = par[0];
    m->node_par[2 * (size_t)v + 1] = par[1];
  }
  cc.unmatched = unmatched;

  /* Segments: the curve of a curve node, else the nearest curve to the midpoint. */
  for (int32_t e = 0; e < m->nseg; ++e) {
    const int32_t *v = m->seg + 2 * (size_t)e;
    if (!fresh[v[0]] && !fresh[v[1]]) continue;
    int32_t cell = -1;
    for (int i = 0; i < 2 && cell < 0; ++i)
      if (m->node_dim[v[i]] == PM_CURVE) cell = m->node_cell[v[i]];
    if (cell < 0) {
      double mid[3], par[2], d;
      for (int k = 0; k < 3; ++k)
        mid[k] = 0.5 * (m->xyz[3 * (size_t)v[0] + k] + m->xyz[3 * (size_t)v[1] + k]);
      /* A chord's midpoint lies off a curved curve by its sagitta, less than its length. */
      double len = pm_v3_dist(m->xyz + 3 * (size_t)v[0], m->xyz + 3 * (size_t)v[1]);
      cell = nearest_cell(md, PM_CURVE, mid, fmax(reach, len), par, &d);
    }
    m->seg_cell[e] = cell;
    cc.elements++;
  }
  /* Triangles: the face most of their face nodes lie on (the first of a tie), else the nearest
   * face to the centroid. */
  for (int32_t t = 0; t < m->ntri; ++t) {
    const int32_t *v = m->tri + 3 * (size_t)t;
    if (!fresh[v[0]] && !fresh[v[1]] && !fresh[v[2]]) continue;
    int32_t cell = -1, votes = 0;
    for (int i = 0; i < 3; ++i) {
      if (m->node_dim[v[i]] != PM_FACE) continue;
      int32_t c = m->node_cell[v[i]], n = 0;
      for (int j = 0; j < 3; ++j) n += m->node_dim[v[j]] == PM_FACE && m->node_cell[v[j]] == c;
      if (n > votes) cell = c, votes = n;
    }
    if (cell < 0) {
      double g[3], par[2], d;
      for (int k = 0; k < 3; ++k)
        g[k] = (m->xyz[3 * (size_t)v[0] + k] + m->xyz[3 * (size_t)v[1] + k] +
                m->xyz[3 * (size_t)v[2] + k]) / 3.0;
      /* A flat triangle's centroid lies off a curved face by less than its edges' length. */
      double edge = 0.0;
      for (int i = 0; i < 3; ++i) {
        const double *a = m->xyz + 3 * (size_t)v[i], *b = m->xyz + 3 * (size_t)v[(i + 1) % 3];
        edge = fmax(edge, pm_v3_dist(a, b));
      }
      cell = nearest_cell(md, PM_FACE, g, fmax(reach, edge), par, &d);
    }
    m->tri_cell[t] = cell;
    cc.elements++;
  }
  /* Tets: their region's volume; their volume nodes take it. */
  if (m->ntet > 0 && (s = tet_volumes(m, md, vol, err))) goto done;
  for (int32_t t = 0; t < m->ntet; ++t) {
    const int32_t *v = m->tet + 4 * (size_t)t;
    if (!fresh[v[0]] && !fresh[v[1]] && !fresh[v[2]] && !fresh[v[3]]) continue;
    m->tet_cell[t] = vol[t];
    cc.elements++;
    for (int i = 0; i < 4; ++i)
      if (fresh[v[i]] && m->node_dim[v[i]] == PM_VOLUME && m->node_cell[v[i]] < 0)
        m->node_cell[v[i]] = vol[t];
  }
  for (int32_t v = 0; v < m->nnode; ++v)
    if (fresh[v] && m->node_dim[v] >= 0) {
      cc.nodes++;
      cc.by_dim[m->node_dim[v]]++;
    }
  if (counts) *counts = cc;
done:
  free(shortest);
  free(use);
  free(fresh);
  free(keys);
  free(vol);
  return s;
}
