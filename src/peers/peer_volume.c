/* TetGen quality refinement of a finished surface mesh (see peer_volume.h). */
#include "peers/peer_volume.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/predicates.h"
#include "common/quality.h"
#include "common/self_intersect.h"
#include "common/tet_flip.h"
#include "common/tet_tetgen.h"
#include "common/vec3.h"

/* Triangles per face (CSR over mesh->tri_cell). */
typedef struct face_tris {
  int32_t *start; /* [nface + 1] */
  int32_t *tri;   /* [ntri] triangle indices, grouped by face */
} face_tris;

static int face_tris_build(const pm_model *m, const pm_mesh *mesh, face_tris *ft) {
  int32_t nf = m->count[PM_FACE];
  ft->start = calloc((size_t)nf + 2, sizeof(int32_t));
  ft->tri = malloc(sizeof(int32_t) * ((size_t)mesh->ntri + 1));
  if (!ft->start || !ft->tri) return 0;
  for (int32_t t = 0; t < mesh->ntri; ++t)
    if (mesh->tri_cell[t] >= 0 && mesh->tri_cell[t] < nf) ft->start[mesh->tri_cell[t] + 1]++;
  for (int32_t f = 0; f < nf; ++f) ft->start[f + 1] += ft->start[f];
  int32_t *fill = malloc(sizeof(int32_t) * ((size_t)nf + 1));
  if (!fill) return 0;
  memcpy(fill, ft->start, sizeof(int32_t) * (size_t)nf);
  for (int32_t t = 0; t < mesh->ntri; ++t)
    if (mesh->tri_cell[t] >= 0 && mesh->tri_cell[t] < nf) ft->tri[fill[mesh->tri_cell[t]]++] = t;
  free(fill);
  return 1;
}

static void face_tris_free(face_tris *ft) {
  free(ft->start);
  free(ft->tri);
}

/* Does the segment p-q cross triangle (a, b, c)? 1 yes, 0 no, -1 when it touches an edge, a
 * vertex or the plane at an end point (the caller then tries another ray). Exact predicates. */
static int segment_hits(const double *p, const double *q, const double *a, const double *b,
                        const double *c) {
  int s1 = pm_orient3d(a, b, c, p), s2 = pm_orient3d(a, b, c, q);
  if (s1 == 0 || s2 == 0) return s1 == s2 ? 0 : -1;
  if (s1 == s2) return 0;
  int e1 = pm_orient3d(p, q, a, b), e2 = pm_orient3d(p, q, b, c), e3 = pm_orient3d(p, q, c, a);
  if ((e1 > 0 && e2 > 0 && e3 > 0) || (e1 < 0 && e2 < 0 && e3 < 0)) return 1;
  if (e1 == 0 || e2 == 0 || e3 == 0) {
    int pos = (e1 > 0) + (e2 > 0) + (e3 > 0), neg = (e1 < 0) + (e2 < 0) + (e3 < 0);
    if (pos == 0 || neg == 0) return -1;
  }
  return 0;
}

/* Ray parity of x against volume v's shell: 1 inside, 0 outside, -1 undecided. */
static int inside_shell(const pm_model *m, const pm_mesh *mesh, const face_tris *ft,
                        const pm_cell *v, const double x[3]) {
  static const double dirs[5][3] = {{0.5773, 0.5779, 0.5768}, {-0.3121, 0.8126, 0.4921},
                                    {0.7071, -0.1234, -0.6963}, {-0.6417, -0.5132, 0.5700},
                                    {0.1111, 0.2222, -0.9686}};
  for (int k = 0; k < 5; ++k) {
    double q[3];
    pm_v3_axpy(q, x, 4 * m->diagonal, dirs[k]);
    int parity = 0, bad = 0;
    for (int32_t b = 0; b < v->nbound && !bad; ++b) {
      int32_t f = v->bound[b].cell;
      for (int32_t i = ft->start[f]; i < ft->start[f + 1] && !bad; ++i) {
        const int32_t *t = &mesh->tri[3 * ft->tri[i]];
        int h = segment_hits(x, q, &mesh->xyz[3 * t[0]], &mesh->xyz[3 * t[1]],
                             &mesh->xyz[3 * t[2]]);
        if (h < 0) bad = 1;
        parity ^= h > 0;
      }
    }
    if (!bad) return parity;
  }
  return -1;
}

/* A point strictly inside volume v: a small step inward from the centroid of one of its
 * boundary triangles (inward: against the triangle's normal times the face's mesh sign and its
 * sense in v), confirmed by ray parity. */
static int region_seed(const pm_model *m, const pm_mesh *mesh, const face_tris *ft,
                       const pm_cell *v, double seed[3]) {
  for (int32_t b = 0; b < v->nbound; ++b) {
    int32_t f = v->bound[b].cell, n = ft->start[f + 1] - ft->start[f];
    int stored = pm_face_mesh_sign(m, f), here = v->bound[b].sense < 0 ? -1 : 1;
    for (int32_t i = 0; i < n; i += 1 + n / 8) {
      const int32_t *t = &mesh->tri[3 * ft->tri[ft->start[f] + i]];
      const double *A = &mesh->xyz[3 * t[0]], *B = &mesh->xyz[3 * t[1]], *C = &mesh->xyz[3 * t[2]];
      double ab[3], ac[3], nrm[3], ctr[3];
      pm_v3_sub(ab, B, A), pm_v3_sub(ac, C, A);
      pm_v3_cross(nrm, ab, ac);
      double area2 = pm_v3_normalize(nrm);
      if (!(area2 > 0)) continue;
      for (int k = 0; k < 3; ++k) ctr[k] = (A[k] + B[k] + C[k]) / 3;
      double h = 0.1 * sqrt(area2), sgn = -(double)(stored * here);
      for (int tries = 0; tries < 4; ++tries, h *= 0.25) {
        double x[3];
        pm_v3_axpy(x, ctr, sgn * h, nrm);
        if (inside_shell(m, mesh, ft, v, x) == 1) {
          pm_v3_copy(seed, x);
          return 1;
        }
      }
    }
  }
  return 0;
}

/* One TetGen run for the volumes with ingroup[v] set. */
static pm_status volume_group(const pm_model *m, pm_mesh *mesh, const face_tris *ft,
                              const uint8_t *ingroup, double radius_edge, int64_t max_nodes,
                              int32_t *steiner, int32_t *flat_left, pm_error *err) {
  int32_t nf = m->count[PM_FACE], nvol = m->count[PM_VOLUME];
  uint8_t *use_face = calloc((size_t)nf + 1, 1);
  uint8_t *use_curve = calloc((size_t)m->count[PM_CURVE] + 1, 1);
  int32_t *map = malloc(sizeof(int32_t) * ((size_t)mesh->nnode + 1));
  int32_t *back = malloc(sizeof(int32_t) * ((size_t)mesh->nnode + 1));
  double *xyz = malloc(sizeof(double) * 3 * ((size_t)mesh->nnode + 1));
  double *region = malloc(sizeof(double) * 4 * ((size_t)nvol + 1));
  int32_t *tri = NULL, *tag = NULL, *seg = NULL;
  pm_tet_result res = {0};
  pm_status s = PM_OK;
  if (!use_face || !use_curve || !map || !back || !xyz || !region) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t v = 0; v < nvol; ++v) {
    if (!ingroup[v]) continue;
    const pm_cell *vc = &m->cells[PM_VOLUME][v];
    for (int32_t b = 0; b < vc->nbound; ++b) use_face[vc->bound[b].cell] = 1;
    for (int32_t e = 0; e < vc->nembed; ++e) {
      if (vc->embed[e].dim == PM_FACE) use_face[vc->embed[e].index] = 1;
      if (vc->embed[e].dim == PM_CURVE) use_curve[vc->embed[e].index] = 1;
    }
  }
  int32_t ntri = 0, nseg = 0;
  for (int32_t f = 0; f < nf; ++f)
    if (use_face[f]) ntri += ft->start[f + 1] - ft->start[f];
  for (int32_t i = 0; i < mesh->nseg; ++i)
    if (mesh->seg_cell[i] >= 0 && use_curve[mesh->seg_cell[i]]) ++nseg;
  tri = malloc(sizeof(int32_t) * 3 * ((size_t)ntri + 1));
  tag = malloc(sizeof(int32_t) * ((size_t)ntri + 1));
  seg = malloc(sizeof(int32_t) * 2 * ((size_t)nseg + 1));
  if (!tri || !tag || !seg) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t i = 0; i < mesh->nnode; ++i) map[i] = -1;
  int32_t np = 0, k = 0;
#define TAKE(id)                                                                             \
  do {                                                                                       \
    if (map[id] < 0) {                                                                       \
      map[id] = np, back[np] = (id);                                                         \
      memcpy(&xyz[3 * np], &mesh->xyz[3 * (id)], 3 * sizeof(double));                       \
      ++np;                                                                                  \
    }                                                                                        \
  } while (0)
  for (int32_t f = 0; f < nf; ++f) {
    if (!use_face[f]) continue;
    for (int32_t i = ft->start[f]; i < ft->start[f + 1]; ++i, ++k) {
      for (int q = 0; q < 3; ++q) {
        int32_t id = mesh->tri[3 * ft->tri[i] + q];
        TAKE(id);
        tri[3 * k + q] = map[id];
      }
      tag[k] = f;
    }
  }
  k = 0;
  for (int32_t i = 0; i < mesh->nseg; ++i) {
    if (mesh->seg_cell[i] < 0 || !use_curve[mesh->seg_cell[i]]) continue;
    for (int q = 0; q < 2; ++q) {
      int32_t id = mesh->seg[2 * i + q];
      TAKE(id);
      seg[2 * k + q] = map[id];
    }
    ++k;
  }
  int32_t nsurf = np;
  /* Isolated vertices embedded in a volume are interior points. */
  for (int32_t i = 0; i < mesh->nnode; ++i) {
    if (mesh->node_dim[i] != PM_VERTEX || map[i] >= 0) continue;
    const pm_cell *vx = &m->cells[PM_VERTEX][mesh->node_cell[i]];
    for (int32_t h = 0; h < vx->nhost; ++h)
      if (vx->host[h].dim == PM_VOLUME && ingroup[vx->host[h].index]) {
        TAKE(i);
        break;
      }
  }
#undef TAKE
  int32_t nregion = 0;
  for (int32_t v = 0; v < nvol; ++v) {
    if (!ingroup[v]) continue;
    double sd[3];
    if (!region_seed(m, mesh, ft, &m->cells[PM_VOLUME][v], sd)) {
      s = pm_error_setf(err, PM_ERR_GEOM, "volume %d: no point inside its surface mesh was found",
                        m->cells[PM_VOLUME][v].tag);
      goto done;
    }
    region[4 * nregion] = sd[0], region[4 * nregion + 1] = sd[1], region[4 * nregion + 2] = sd[2];
    region[4 * nregion + 3] = v;
    ++nregion;
  }
  pm_selfint_report si = {0};
  s = pm_triangles_self_intersections(xyz, nsurf, tri, ntri, 1, &si, err);
  if (!s && si.count > 0) {
    int32_t ta = si.pairs[0], tb = si.pairs[1];
    s = pm_error_setf(err, PM_ERR_BACKEND,
                      "the surface mesh intersects itself (%lld pairs of triangles; first: a "
                      "triangle of face %d and one of face %d): no tetrahedralization",
                      (long long)si.count, m->cells[PM_FACE][tag[ta]].tag,
                      m->cells[PM_FACE][tag[tb]].tag);
  }
  pm_selfint_report_free(&si);
  if (s) goto done;

  pm_tet_input in = {0};
  in.npts = np, in.xyz = xyz, in.nsurf = nsurf;
  in.ntri = ntri, in.tri = tri, in.tri_tag = tag;
  in.nseg = nseg, in.seg = nseg ? seg : NULL;
  in.nregion = nregion, in.region = region;
  in.mode = PM_TET_REFINE;
  in.radius_edge = radius_edge;
  in.max_volume = 0;
  in.max_points = 0;
  if (max_nodes > 0) {
    int64_t room = max_nodes - (mesh->nnode - np);
    in.max_points = room > INT32_MAX ? INT32_MAX : (int32_t)(room > np ? room : np);
  }
  if ((s = pm_tet_tetrahedralize(&in, &res, err))) goto done;

  /* Cavities that are no volume (tag -1) are dropped, then flat tets removed by edge removal. */
  int32_t kt = 0;
  for (int32_t t = 0; t < res.ntet; ++t)
    if (res.tet_tag[t] >= 0) {
      memmove(&res.tet[4 * kt], &res.tet[4 * t], 4 * sizeof(int32_t));
      res.tet_tag[kt++] = res.tet_tag[t];
    }
  res.ntet = kt;
  pm_tet_flip_input fi = {res.xyz, res.npts, ntri, tri, nseg, nseg ? seg : NULL,
                          100 * PM_DEGENERATE_REL, 10000};
  int32_t remaining = 0, nflip = 0;
  if ((s = pm_tet_remove_flat(&fi, &res.tet, &res.tet_tag, &res.ntet, &remaining, &nflip, err)))
    goto done;
  if (flat_left) *flat_left += remaining;
  if (res.npts > np) {
    int32_t *grown = realloc(back, sizeof(int32_t) * (size_t)res.npts);
    if (!grown) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto done;
    }
    back = grown;
    for (int32_t i = np; i < res.npts; ++i) back[i] = -1;
  }
  if ((s = pm_mesh_reserve(mesh, mesh->nnode + (res.npts - np), mesh->nseg, mesh->ntri,
                           mesh->ntet + res.ntet, err)))
    goto done;
  /* Steiner points used by the kept tets become nodes of the volume of their first tet. */
  for (int32_t t = 0; t < res.ntet && !s; ++t)
    for (int q = 0; q < 4 && !s; ++q) {
      int32_t i = res.tet[4 * t + q];
      if (back[i] >= 0) continue;
      s = pm_mesh_add_node(mesh, &res.xyz[3 * i], PM_VOLUME, res.tet_tag[t], NULL, &back[i], err);
      if (!s && steiner) ++*steiner;
    }
  for (int32_t t = 0; t < res.ntet && !s; ++t)
    s = pm_mesh_add_tet(mesh, back[res.tet[4 * t]], back[res.tet[4 * t + 1]],
                        back[res.tet[4 * t + 2]], back[res.tet[4 * t + 3]], res.tet_tag[t], err);
done:
  pm_tet_result_free(&res);
  free(use_face), free(use_curve), free(map), free(back), free(xyz), free(region);
  free(tri), free(tag), free(seg);
  return s;
}

pm_status peer_volume_tetgen(const pm_model *m, pm_mesh *mesh, double radius_edge,
                             int64_t max_nodes, int32_t *steiner, int32_t *flat_left,
                             pm_error *err) {
  int32_t nvol = m->count[PM_VOLUME], nnode0 = mesh->nnode, ntet0 = mesh->ntet;
  if (steiner) *steiner = 0;
  if (flat_left) *flat_left = 0;
  if (nvol == 0) return PM_OK;
  face_tris ft = {0};
  int32_t *group = malloc(sizeof(int32_t) * (size_t)nvol);
  uint8_t *in = malloc((size_t)nvol);
  pm_status s = PM_OK;
  if (!group || !in || !face_tris_build(m, mesh, &ft)) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  /* Union of volumes through faces: a face's `up` volumes and the volumes it is embedded in. */
  for (int32_t v = 0; v < nvol; ++v) group[v] = v;
  for (int32_t f = 0; f < m->count[PM_FACE]; ++f) {
    const pm_cell *fc = &m->cells[PM_FACE][f];
    int32_t first = -1;
    for (int32_t k = 0; k < fc->nup + fc->nhost; ++k) {
      int32_t v = k < fc->nup ? fc->up[k]
                              : (fc->host[k - fc->nup].dim == PM_VOLUME ? fc->host[k - fc->nup].index : -1);
      if (v < 0) continue;
      while (group[v] != v) v = group[v];
      if (first < 0) {
        first = v;
      } else if (v != first) {
        int32_t lo = v < first ? v : first, hi = v < first ? first : v;
        group[hi] = lo;
        first = lo;
      }
    }
  }
  for (int32_t g = 0; g < nvol && !s; ++g) {
    int32_t root = g;
    while (group[root] != root) root = group[root];
    if (root != g) continue;
    for (int32_t v = 0; v < nvol; ++v) {
      int32_t r = v;
      while (group[r] != r) r = group[r];
      in[v] = r == g;
    }
    s = volume_group(m, mesh, &ft, in, radius_edge, max_nodes, steiner, flat_left, err);
  }
  if (!s && max_nodes > 0 && mesh->nnode > max_nodes)
    s = pm_error_setf(err, PM_ERR_LIMIT, "the volume mesh needs %d nodes, more than the cap %lld",
                      (int)mesh->nnode, (long long)max_nodes);
done:
  if (s) {
    mesh->nnode = nnode0;
    mesh->ntet = ntet0;
  }
  face_tris_free(&ft);
  free(group), free(in);
  return s;
}
