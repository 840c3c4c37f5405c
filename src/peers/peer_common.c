/* Helpers shared by the peers (see peer_common.h). */
#include "peers/peer_common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/geom_cad.h"
#include "common/sizing/sizing_features.h"
#include "common/base/vec3.h"
#include "common/mesh/element_measure.h"
#include "common/mesh/mesh_topo.h"

int peer_is_planar_domain(const pm_model *m) {
  if (!m || pm_cad_gmsh_model(m) != NULL) return 0;
  if (m->count[PM_VOLUME] != 0 || m->count[PM_FACE] != 1) return 0;
  if (m->box[2] != 0 || m->box[5] != 0) return 0;
  const pm_cell *f = &m->cells[PM_FACE][0];
  if (!f->cls || !f->cls->name || strcmp(f->cls->name, "plane") != 0) return 0;
  for (int32_t i = 0; i < m->count[PM_CURVE]; ++i) {
    const pm_cell *c = &m->cells[PM_CURVE][i];
    if (!c->cls || !c->cls->name) return 0;
    if (strcmp(c->cls->name, "segment") != 0 && strcmp(c->cls->name, "arc") != 0) return 0;
  }
  /* The face must be the identity map (u, v) -> (u, v, 0): check the corners and the centre of
   * its parameter box exactly (the analytic plane evaluates without rounding). */
  for (int k = 0; k < 5; ++k) {
    double uv[2] = {k == 4 ? 0.5 * (f->lo[0] + f->hi[0]) : (k & 1 ? f->hi[0] : f->lo[0]),
                    k == 4 ? 0.5 * (f->lo[1] + f->hi[1]) : (k & 2 ? f->hi[1] : f->lo[1])};
    pm_face_point fp;
    pm_face_eval(f, uv, 0, &fp);
    if (fp.p[0] != uv[0] || fp.p[1] != uv[1] || fp.p[2] != 0) return 0;
  }
  return 1;
}

pm_status peer_default_size(const pm_model *m, const void *params, uint64_t seed, int threads,
                            pm_sizing **out, pm_error *err) {
  (void)params, (void)seed, (void)threads;
  *out = NULL;
  if (!(m->diagonal > 0) || !isfinite(m->diagonal))
    return pm_error_setf(err, PM_ERR_GEOM, "model '%s' has no extent: no default size",
                         m->name);
  pm_feature_size *fs = NULL;
  pm_status s = pm_feature_size_create(m, PEER_DEFAULT_SIZE_FRACTION * m->diagonal,
                                       PEER_DEFAULT_SIZE_GRADE, PM_FEATURE_ALL, &fs, err);
  if (s) return s;
  s = pm_sizing_features(NULL, fs, out, err);
  if (s) pm_feature_size_destroy(fs);
  return s;
}

/* ---- tag map ---------------------------------------------------------------------------- */

pm_status peer_tagmap_add(peer_tagmap *t, int dim, int tag, int32_t cell, pm_error *err) {
  int32_t n = t->n[dim];
  /* Grow by doubling: capacity is the next power of two above n. */
  if ((n & (n - 1)) == 0) {
    int32_t cap = n ? 2 * n : 4;
    int *nt = realloc(t->tag[dim], sizeof(int) * (size_t)cap);
    if (nt) t->tag[dim] = nt;
    int32_t *nc = realloc(t->cell[dim], sizeof(int32_t) * (size_t)cap);
    if (nc) t->cell[dim] = nc;
    if (!nt || !nc) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  t->tag[dim][n] = tag;
  t->cell[dim][n] = cell;
  t->n[dim] = n + 1;
  return PM_OK;
}

pm_status peer_tagmap_finish(peer_tagmap *t, pm_error *err) {
  for (int d = 0; d < 4; ++d) {
    /* Insertion sort: maps are small (one entry per model cell) and mostly in order. */
    for (int32_t i = 1; i < t->n[d]; ++i) {
      int tg = t->tag[d][i];
      int32_t c = t->cell[d][i], j = i - 1;
      while (j >= 0 && t->tag[d][j] > tg) {
        t->tag[d][j + 1] = t->tag[d][j];
        t->cell[d][j + 1] = t->cell[d][j];
        --j;
      }
      t->tag[d][j + 1] = tg;
      t->cell[d][j + 1] = c;
    }
    for (int32_t i = 1; i < t->n[d]; ++i)
      if (t->tag[d][i] == t->tag[d][i - 1])
        return pm_error_setf(err, PM_ERR_INTERNAL, "entity (%d, %d) maps to two cells", d,
                             t->tag[d][i]);
  }
  return PM_OK;
}

int32_t peer_tagmap_find(const peer_tagmap *t, int dim, int tag) {
  if (dim < 0 || dim > 3) return -1;
  int32_t lo = 0, hi = t->n[dim] - 1;
  while (lo <= hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (t->tag[dim][mid] == tag) return t->cell[dim][mid];
    if (t->tag[dim][mid] < tag) lo = mid + 1;
    else hi = mid - 1;
  }
  return -1;
}

void peer_tagmap_free(peer_tagmap *t) {
  if (!t) return;
  for (int d = 0; d < 4; ++d) {
    free(t->tag[d]);
    free(t->cell[d]);
  }
  memset(t, 0, sizeof *t);
}

/* ---- orientation ------------------------------------------------------------------------ */

int32_t peer_orient_faces(const pm_model *m, pm_mesh *mesh) {
  int32_t nf = m->count[PM_FACE];
  int64_t *vote = calloc((size_t)nf + 1, sizeof(int64_t));
  if (!vote) return 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell[t];
    if (f < 0 || f >= nf) continue;
    const int32_t *v = &mesh->tri[3 * t];
    int32_t at = -1;
    for (int q = 0; q < 3 && at < 0; ++q)
      if (mesh->node_dim[v[q]] == PM_FACE && mesh->node_cell[v[q]] == f) at = v[q];
    const pm_cell *fc = &m->cells[PM_FACE][f];
    double uv[2];
    if (at >= 0) {
      uv[0] = mesh->node_par[2 * at], uv[1] = mesh->node_par[2 * at + 1];
    } else {
      /* Only boundary nodes (a small face meshed by gmsh without an interior node): the
       * surface's normal at the foot of the centroid. */
      double c[3];
      for (int k = 0; k < 3; ++k)
        c[k] = (mesh->xyz[3 * v[0] + k] + mesh->xyz[3 * v[1] + k] + mesh->xyz[3 * v[2] + k]) / 3;
      if (pm_cell_project(fc, c, NULL, uv, NULL, NULL, NULL) != PM_OK) continue;
    }
    pm_face_point fp;
    pm_face_eval(fc, uv, 1, &fp);
    double N[3], ab[3], ac[3], n[3];
    pm_v3_cross(N, fp.su, fp.sv);
    pm_v3_sub(ab, &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[0]]);
    pm_v3_sub(ac, &mesh->xyz[3 * v[2]], &mesh->xyz[3 * v[0]]);
    pm_v3_cross(n, ab, ac);
    double d = pm_v3_dot(n, N);
    if (d > 0) vote[f]++;
    else if (d < 0) vote[f]--;
  }
  int32_t turned = 0;
  uint8_t *flip = calloc((size_t)nf + 1, 1);
  if (!flip) {
    free(vote);
    return 0;
  }
  for (int32_t f = 0; f < nf; ++f) {
    int want = pm_face_mesh_sign(m, f);
    if ((want > 0 && vote[f] < 0) || (want < 0 && vote[f] > 0)) flip[f] = 1, ++turned;
  }
  for (int32_t t = 0; t < mesh->ntri && turned; ++t) {
    int32_t f = mesh->tri_cell[t];
    if (f < 0 || f >= nf || !flip[f]) continue;
    int32_t x = mesh->tri[3 * t + 1];
    mesh->tri[3 * t + 1] = mesh->tri[3 * t + 2];
    mesh->tri[3 * t + 2] = x;
  }
  free(flip);
  free(vote);
  return turned;
}


/* ---- flat triangles ----------------------------------------------------------------------- */

static const double *node_at(const pm_mesh *mesh, int32_t v) { return &mesh->xyz[3 * v]; }

/* Whether triangle t (of nodes v) is flat, and if so, which corner lies between the other two
 * (the corner opposite the longest edge), in *apex. */
static int flat_apex(const pm_mesh *mesh, const int32_t *v, int *apex) {
  const double *p[3] = {node_at(mesh, v[0]), node_at(mesh, v[1]), node_at(mesh, v[2])};
  if (!pm_tri_degenerate(p[0], p[1], p[2])) return 0;
  double best = -1;
  for (int q = 0; q < 3; ++q) {
    const double l = pm_v3_dist2(p[(q + 1) % 3], p[(q + 2) % 3]);
    if (l > best) best = l, *apex = q;
  }
  /* the apex must lie strictly inside the longest edge, not on a repeated node */
  return pm_v3_dist2(p[*apex], p[(*apex + 1) % 3]) > 0 && pm_v3_dist2(p[*apex], p[(*apex + 2) % 3]) > 0;
}

/* One pass over the flat triangles flat[nflat]: each is flipped at most once, and a triangle
 * changed in this pass is not used again until the edges are listed anew (mesh_topo.h's table).
 * Returns the flips, -1 when out of memory. */
static int32_t flip_pass(pm_mesh *mesh, const int32_t *flat, int32_t nflat) {
  pm_edges E = {0};
  uint8_t *used = calloc((size_t)mesh->ntri + 1, 1);
  if (!used || pm_edges_build(mesh->nnode, mesh->tri, mesh->ntri, 3, &E, NULL)) {
    free(used);
    pm_edges_free(&E);
    return -1;
  }
  int32_t flips = 0;
  for (int32_t k = 0; k < nflat; ++k) {
    const int32_t t = flat[k];
    int32_t *v = &mesh->tri[3 * t];
    int a;
    if (used[t] || !flat_apex(mesh, v, &a)) continue;
    const int32_t b = v[a], e0 = v[(a + 1) % 3], e1 = v[(a + 2) % 3];
    const int64_t e = pm_edges_find(&E, e0, e1);
    if (e < 0 || E.off[e + 1] - E.off[e] != 2) continue; /* a boundary or non-manifold edge */
    const int32_t t2 = E.elem[E.off[e]] == t ? E.elem[E.off[e] + 1] : E.elem[E.off[e]];
    if (used[t2] || mesh->tri_cell[t2] != mesh->tri_cell[t]) continue; /* a curve between faces */
    int32_t *w = &mesh->tri[3 * t2], d = -1;
    for (int q = 0; q < 3; ++q)
      if (w[q] == e1 && w[(q + 1) % 3] == e0) d = w[(q + 2) % 3];
    if (d < 0) continue; /* the two disagree in orientation */
    if (pm_edges_find(&E, b, d) >= 0) continue; /* the new edge exists already */
    if (pm_tri_degenerate(node_at(mesh, b), node_at(mesh, e0), node_at(mesh, d)) ||
        pm_tri_degenerate(node_at(mesh, b), node_at(mesh, d), node_at(mesh, e1)))
      continue;
    v[0] = b, v[1] = e0, v[2] = d;
    w[0] = b, w[1] = d, w[2] = e1;
    used[t] = used[t2] = 1;
    ++flips;
  }
  free(used);
  pm_edges_free(&E);
  return flips;
}

int32_t peer_flip_flat_triangles(pm_mesh *mesh) {
  int32_t *flat = NULL, nflat = 0, cap = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int apex;
    if (!flat_apex(mesh, &mesh->tri[3 * t], &apex)) continue;
    if (nflat == cap) {
      int32_t *nf = realloc(flat, sizeof(int32_t) * (size_t)(cap = cap ? 2 * cap : 16));
      if (!nf) {
        free(flat);
        return -1;
      }
      flat = nf;
    }
    flat[nflat++] = t;
  }
  int32_t total = 0;
  /* flat triangles side by side need a pass each; a pass flips each of the others */
  for (int pass = 0; pass < 8 && nflat; ++pass) {
    const int32_t k = flip_pass(mesh, flat, nflat);
    if (k < 0) {
      total = -1;
      break;
    }
    if (!k) break;
    total += k;
  }
  free(flat);
  return total;
}
