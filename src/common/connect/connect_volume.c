/* The volume step of the connection (connect.h, pm_connect_volumes): TetGen tetrahedralizes the
 * closed surface mesh of each group of face-sharing volumes, keeping its triangles, with the
 * method's own interior nodes and no Steiner point (papers/003 section 3) or with TetGen's quality
 * refinement (papers/001 section 4.4); region seeds found by exact ray parity tag the tets; flat
 * tets left by nearly cospherical nodes are removed. */
#include "common/connect/connect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/base/hash.h"
#include "common/mesh/mesh_topo.h"
#include "common/backends/predicates.h"
#include "common/mesh/element_measure.h"
#include "common/mesh/self_intersect.h"
#include "common/connect/tet_flip.h"
#include "common/backends/tet_tetgen.h"
#include "common/base/vec3.h"
#include "common/mesh/volume_inside.h"

/* The triangles of each face: tri[start[f] .. start[f+1]) are indices into mesh->tri. */
typedef struct face_tris {
  int32_t *start, *tri;
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
  memcpy(fill, ft->start, sizeof(int32_t) * ((size_t)nf + 1));
  for (int32_t t = 0; t < mesh->ntri; ++t)
    if (mesh->tri_cell[t] >= 0 && mesh->tri_cell[t] < nf) ft->tri[fill[mesh->tri_cell[t]]++] = t;
  free(fill);
  return 1;
}

static void face_tris_free(face_tris *ft) {
  free(ft->start), free(ft->tri);
  ft->start = ft->tri = NULL;
}


/* Parity of crossings of rays from x with the triangles of volume v's shell: 1 inside, 0 outside,
 * -1 undecided (every ray touched an edge). */
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
        int h = pm_segment_triangle_cross(x, q, &mesh->xyz[3 * t[0]], &mesh->xyz[3 * t[1]], &mesh->xyz[3 * t[2]]);
        if (h < 0) bad = 1;
        parity ^= h > 0;
      }
    }
    if (!bad) return parity;
  }
  return -1;
}

/* A point strictly inside volume v: a small step inward from the centroid of one of its boundary
 * triangles, checked by ray parity against its shell. */
static int region_seed(const pm_model *m, const pm_mesh *mesh, const face_tris *ft,
                       const pm_cell *v, double seed[3]) {
  for (int32_t b = 0; b < v->nbound; ++b) {
    int32_t fi = v->bound[b].cell, nft = ft->start[fi + 1] - ft->start[fi];
    /* Triangles are oriented outward of the face's first volume; for the others the sense
     * tells: inward = -(outward normal) x (this volume's sense relative to the stored one). */
    const pm_cell *f = &m->cells[PM_FACE][v->bound[b].cell];
    int stored = pm_face_mesh_sign(m, f->index), here = v->bound[b].sense < 0 ? -1 : 1;
    for (int32_t t = 0; t < nft; t += 1 + nft / 8) {
      const int32_t *tv = &mesh->tri[3 * ft->tri[ft->start[fi] + t]];
      const double *A = &mesh->xyz[3 * tv[0]], *B = &mesh->xyz[3 * tv[1]], *C = &mesh->xyz[3 * tv[2]];
      double ab[3], ac[3], n[3], ctr[3];
      pm_v3_sub(ab, B, A), pm_v3_sub(ac, C, A);
      pm_v3_cross(n, ab, ac);
      double area2 = pm_v3_normalize(n);
      if (!(area2 > 0)) continue;
      for (int k = 0; k < 3; ++k) ctr[k] = (A[k] + B[k] + C[k]) / 3;
      double h = 0.1 * sqrt(area2);
      double sgn = -(double)(stored * here);
      for (int tries = 0; tries < 4; ++tries, h *= 0.25) {
        double x[3];
        pm_v3_axpy(x, ctr, sgn * h, n);
        if (inside_shell(m, mesh, ft, v, x) == 1) {
          pm_v3_copy(seed, x);
          return 1;
        }
      }
    }
  }
  return 0;
}

/* A flat tet under a planar face: TetGen may leave a tet of (near) zero volume whose four corners
 * are boundary nodes of one planar face -- two of its faces are the face's triangles over a
 * quadrilateral of nearly cocircular nodes, the other two the quadrilateral's other diagonal
 * pair. Such a tet is removed and the face's two triangles are replaced by its two other faces
 * (the same planar quadrilateral split along the other diagonal), so the surface stays a
 * triangulation of the face and the tets' boundary still matches it exactly. Returns the number
 * of tets removed; `keep[t]` is cleared for them. */
static int32_t repair_flat_tets(pm_mesh *mesh, const int32_t *rtet, int32_t rntet,
                                const int32_t *back, int32_t tri_first, uint8_t *keep,
                                pm_error *err) {
  int32_t ntri = mesh->ntri - tri_first;
  /* Hash of the surface triangles by their sorted node triple. */
  int64_t cap = 16;
  while (cap < 4 * (int64_t)ntri + 16) cap *= 2;
  int64_t *slot = malloc(sizeof(int64_t) * (size_t)cap);
  if (!slot) return -pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int64_t i = 0; i < cap; ++i) slot[i] = -1;
#define TRI_KEY(a, b, c) (pm_mix64(((uint64_t)(uint32_t)(a) * 0x9E3779B97F4A7C15ULL) ^ ((uint64_t)(uint32_t)(b) << 21) ^ ((uint64_t)(uint32_t)(c) << 42) ^ (uint64_t)(uint32_t)(c)))
  for (int32_t t = 0; t < ntri; ++t) {
    int32_t v[3];
    memcpy(v, &mesh->tri[3 * (tri_first + t)], sizeof v);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2 - i; ++j)
        if (v[j] > v[j + 1]) { int32_t x = v[j]; v[j] = v[j + 1]; v[j + 1] = x; }
    int64_t h = (int64_t)(TRI_KEY(v[0], v[1], v[2]) & (uint64_t)(cap - 1));
    while (slot[h] >= 0) h = (h + 1) & (cap - 1);
    slot[h] = t;
  }
  int32_t removed = 0;
  for (int32_t t = 0; t < rntet; ++t) {
    if (!keep[t]) continue;
    int32_t n[4];
    for (int q = 0; q < 4; ++q) n[q] = back[rtet[4 * t + q]];
    const double *X[4];
    for (int q = 0; q < 4; ++q) X[q] = &mesh->xyz[3 * n[q]];
    double e1[3], e2[3], e3[3], c[3], lmax = 0;
    pm_v3_sub(e1, X[1], X[0]), pm_v3_sub(e2, X[2], X[0]), pm_v3_sub(e3, X[3], X[0]);
    pm_v3_cross(c, e1, e2);
    double vol6 = fabs(pm_v3_dot(c, e3));
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) lmax = fmax(lmax, pm_v3_dist(X[a], X[b]));
    /* 100 times the checker's flatness (PM_DEGENERATE_REL): what is repaired is surely flat. */
    if (!(vol6 <= 100 * PM_DEGENERATE_REL * lmax * lmax * lmax)) continue;
    /* Its faces on the surface: face q is the one opposite corner q. */
    int32_t found[4], nfound = 0;
    for (int q = 0; q < 4; ++q) {
      int32_t v[3], k = 0;
      for (int r = 0; r < 4; ++r)
        if (r != q) v[k++] = n[r];
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2 - i; ++j)
          if (v[j] > v[j + 1]) { int32_t x = v[j]; v[j] = v[j + 1]; v[j + 1] = x; }
      int64_t h = (int64_t)(TRI_KEY(v[0], v[1], v[2]) & (uint64_t)(cap - 1));
      found[q] = -1;
      for (; slot[h] >= 0; h = (h + 1) & (cap - 1)) {
        int32_t tt = slot[h], w[3];
        memcpy(w, &mesh->tri[3 * (tri_first + tt)], sizeof w);
        for (int i = 0; i < 2; ++i)
          for (int j = 0; j < 2 - i; ++j)
            if (w[j] > w[j + 1]) { int32_t x = w[j]; w[j] = w[j + 1]; w[j + 1] = x; }
        if (w[0] == v[0] && w[1] == v[1] && w[2] == v[2]) {
          found[q] = tt;
          break;
        }
      }
      nfound += found[q] >= 0;
    }
    if (nfound != 2) continue;
    int qa = -1, qb = -1, qc = -1, qd = -1; /* faces on the surface (opposite qa, qb), others */
    for (int q = 0; q < 4; ++q) {
      if (found[q] >= 0) (qa < 0 ? (qa = q) : (qb = q));
      else (qc < 0 ? (qc = q) : (qd = q));
    }
    int32_t ta = tri_first + found[qa], tb = tri_first + found[qb];
    if (mesh->tri_cell[ta] != mesh->tri_cell[tb]) continue;
    /* The outward direction: the normal of the surface triangles being replaced. */
    double nout[3] = {0, 0, 0};
    for (int k = 0; k < 2; ++k) {
      const int32_t *v = &mesh->tri[3 * (k ? tb : ta)];
      double u1[3], u2[3], nn[3];
      pm_v3_sub(u1, &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[0]]);
      pm_v3_sub(u2, &mesh->xyz[3 * v[2]], &mesh->xyz[3 * v[0]]);
      pm_v3_cross(nn, u1, u2);
      pm_v3_add(nout, nout, nn);
    }
    int qs[2] = {qc, qd};
    int32_t slots[2] = {ta, tb};
    for (int k = 0; k < 2; ++k) {
      int32_t v[3], m3 = 0;
      for (int r = 0; r < 4; ++r)
        if (r != qs[k]) v[m3++] = n[r];
      double u1[3], u2[3], nn[3];
      pm_v3_sub(u1, &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[0]]);
      pm_v3_sub(u2, &mesh->xyz[3 * v[2]], &mesh->xyz[3 * v[0]]);
      pm_v3_cross(nn, u1, u2);
      if (pm_v3_dot(nn, nout) < 0) { int32_t x = v[1]; v[1] = v[2]; v[2] = x; }
      memcpy(&mesh->tri[3 * slots[k]], v, sizeof v);
    }
    keep[t] = 0;
    ++removed;
    /* The hash still holds the old triples at these slots; a second flat tet on the same
     * triangles cannot exist (each surface triangle bounds one tet), so it is not rebuilt. */
  }
#undef TRI_KEY
  free(slot);
  return removed;
}

/* The tets that leave the volume step must tile their volumes (pm_tet_find_overlap). TetGen's
 * output does; the flips and repairs after it are meant to keep that, and this is the proof
 * before the tets become the mesh's -- a failure is an error naming the place, never an invalid
 * mesh handed on as valid. */
static pm_status check_tets_tile(const pm_model *m, const pm_tet_result *res, const uint8_t *keep,
                                 pm_error *err) {
  int found = 0;
  int32_t t = -1, node = -1, count = 0;
  pm_status s = pm_tet_find_overlap(res->npts, res->tet, keep, res->ntet, &found, &t, &node,
                                    &count, err);
  if (s || !found) return s;
  const double *a = &res->xyz[3 * node];
  return pm_error_setf(err, PM_ERR_BACKEND,
                       "the volume mesh of volume %d overlaps itself near (%.6g, %.6g, %.6g) (%d "
                       "tets on one face): no valid tetrahedralization",
                       m->cells[PM_VOLUME][res->tet_tag[t]].tag, a[0], a[1], a[2], (int)count);
}

/* Tetrahedralize one group of volumes (those with ingroup[v] set): volumes joined by shared or
 * embedded faces go to TetGen together, so their tets conform across the shared faces. */
/* Region tags by flood fill. TetGen tags tets by region seeds, but a tet it creates after its
 * region pass (its optimization flips) can come out with no region although it lies inside the
 * volume -- a hole in the mesh once untagged tets are dropped as cavities. So the tags TetGen
 * gives are only starting points: a tag spreads to every untagged tet reachable through faces
 * that are not input facets, and only tets reachable from no tagged one (a true cavity enclosed
 * by facets) stay untagged. Returns the tets retagged, or -(status) on failure. */
static int64_t spread_region_tags(const pm_tet_result *res, const int32_t *tri, int32_t ntri,
                                  pm_error *err) {
  pm_faces fc = {0};
  pm_status s = pm_faces_build(res->npts, res->tet, res->ntet, &fc, err);
  if (s) return -(int64_t)s;
  uint8_t *facet = calloc((size_t)fc.nface + 1, 1);
  int32_t *queue = malloc(sizeof(int32_t) * ((size_t)res->ntet + 1));
  if (!facet || !queue) {
    free(facet), free(queue), pm_faces_free(&fc);
    return -(int64_t)pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t t = 0; t < ntri; ++t) {
    int64_t f = pm_faces_find(&fc, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2], NULL);
    if (f >= 0) facet[f] = 1;
  }
  int64_t head = 0, tail = 0, retagged = 0;
  for (int32_t t = 0; t < res->ntet; ++t)
    if (res->tet_tag[t] >= 0) queue[tail++] = t;
  static const int opp[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  while (head < tail) {
    int32_t t = queue[head++];
    for (int q = 0; q < 4; ++q) {
      const int32_t *v = &res->tet[4 * t];
      int64_t f = pm_faces_find(&fc, v[opp[q][0]], v[opp[q][1]], v[opp[q][2]], NULL);
      if (f < 0 || facet[f]) continue;
      for (int64_t k = fc.off[f]; k < fc.off[f + 1]; ++k) {
        int32_t u = fc.tet[k];
        if (res->tet_tag[u] >= 0) continue;
        res->tet_tag[u] = res->tet_tag[t];
        queue[tail++] = u;
        ++retagged;
      }
    }
  }
  free(facet), free(queue), pm_faces_free(&fc);
  return retagged;
}

static pm_status connect_volume_group(const pm_model *m, pm_mesh *mesh, const face_tris *ft,
                                      const uint8_t *ingroup, const pm_connect_params *p,
                                      pm_connect_report *rep, pm_error *err) {
  int32_t nf = m->count[PM_FACE];
  /* Faces that go to TetGen: bounding or embedded in a volume. */
  uint8_t *use_face = calloc((size_t)nf + 1, 1);
  int32_t *map = malloc(sizeof(int32_t) * ((size_t)mesh->nnode + 1));
  if (!use_face || !map) {
    free(use_face), free(map);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t v = 0; v < m->count[PM_VOLUME]; ++v) {
    if (!ingroup[v]) continue;
    const pm_cell *vc = &m->cells[PM_VOLUME][v];
    for (int32_t b = 0; b < vc->nbound; ++b) use_face[vc->bound[b].cell] = 1;
    for (int32_t e = 0; e < vc->nembed; ++e)
      if (vc->embed[e].dim == PM_FACE) use_face[vc->embed[e].index] = 1;
  }
  int32_t ntri = 0, nseg = 0;
  for (int32_t f = 0; f < nf; ++f)
    if (use_face[f]) ntri += ft->start[f + 1] - ft->start[f];
  /* Dangling curves inside volumes become segments TetGen must keep. */
  for (int32_t v = 0; v < m->count[PM_VOLUME]; ++v) {
    if (!ingroup[v]) continue;
    const pm_cell *vc = &m->cells[PM_VOLUME][v];
    for (int32_t e = 0; e < vc->nembed; ++e)
      if (vc->embed[e].dim == PM_CURVE)
        for (int32_t s = 0; s < mesh->nseg; ++s) nseg += mesh->seg_cell[s] == vc->embed[e].index;
  }
  int32_t *tri = malloc(sizeof(int32_t) * 3 * (size_t)(ntri ? ntri : 1));
  int32_t *tag = malloc(sizeof(int32_t) * (size_t)(ntri ? ntri : 1));
  int32_t *seg = malloc(sizeof(int32_t) * 2 * (size_t)(nseg ? nseg : 1));
  double *xyz = malloc(sizeof(double) * 3 * ((size_t)mesh->nnode + 1));
  int32_t *back = malloc(sizeof(int32_t) * ((size_t)mesh->nnode + 1));
  double *region = malloc(sizeof(double) * 4 * (size_t)m->count[PM_VOLUME]);
  pm_tet_result res = {0};
  uint8_t *keep = NULL;
  pm_status s = PM_OK;
  if (!tri || !tag || !seg || !xyz || !back || !region) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t i = 0; i < mesh->nnode; ++i) map[i] = -1;
  int32_t np = 0, k = 0;
  for (int32_t f = 0; f < nf; ++f) {
    if (!use_face[f]) continue;
    for (int32_t i = ft->start[f]; i < ft->start[f + 1]; ++i, ++k) {
      for (int q = 0; q < 3; ++q) {
        int32_t id = mesh->tri[3 * ft->tri[i] + q];
        if (map[id] < 0) map[id] = np, back[np] = id, memcpy(&xyz[3 * np], &mesh->xyz[3 * id], 3 * sizeof(double)), ++np;
        tri[3 * k + q] = map[id];
      }
      tag[k] = f;
    }
  }
  k = 0;
  for (int32_t v = 0; v < m->count[PM_VOLUME]; ++v) {
    if (!ingroup[v]) continue;
    const pm_cell *vc = &m->cells[PM_VOLUME][v];
    for (int32_t e = 0; e < vc->nembed; ++e)
      if (vc->embed[e].dim == PM_CURVE)
        for (int32_t sg = 0; sg < mesh->nseg; ++sg) {
          if (mesh->seg_cell[sg] != vc->embed[e].index) continue;
          for (int q = 0; q < 2; ++q) {
            int32_t id = mesh->seg[2 * sg + q];
            if (map[id] < 0) map[id] = np, back[np] = id, memcpy(&xyz[3 * np], &mesh->xyz[3 * id], 3 * sizeof(double)), ++np;
            seg[2 * k + q] = map[id];
          }
          ++k;
        }
  }
  int32_t nsurf = np;
  /* Interior points: the volumes' own nodes and isolated vertices embedded in a volume. */
  for (int32_t i = 0; i < mesh->nnode; ++i) {
    int interior = mesh->node_dim[i] == PM_VOLUME && ingroup[mesh->node_cell[i]];
    if (mesh->node_dim[i] == PM_VERTEX && map[i] < 0) {
      const pm_cell *vx = &m->cells[PM_VERTEX][mesh->node_cell[i]];
      for (int32_t h = 0; h < vx->nhost; ++h)
        interior |= vx->host[h].dim == PM_VOLUME && ingroup[vx->host[h].index];
    }
    if (interior && map[i] < 0) map[i] = np, back[np] = i, memcpy(&xyz[3 * np], &mesh->xyz[3 * i], 3 * sizeof(double)), ++np;
  }
  int32_t nregion = 0;
  for (int32_t v = 0; v < m->count[PM_VOLUME]; ++v) {
    if (!ingroup[v]) continue;
    double seed[3];
    if (!region_seed(m, mesh, ft, &m->cells[PM_VOLUME][v], seed)) {
      s = pm_error_setf(err, PM_ERR_GEOM, "volume %d: no point inside its surface mesh was found",
                        m->cells[PM_VOLUME][v].tag);
      goto done;
    }
    region[4 * nregion] = seed[0], region[4 * nregion + 1] = seed[1], region[4 * nregion + 2] = seed[2];
    region[4 * nregion + 3] = v;
    ++nregion;
  }
  if (p->check_surface) {
    pm_selfint_report si = {0};
    s = pm_triangles_self_intersections(xyz, nsurf, tri, ntri, 1, &si, err);
    if (!s && si.count > 0) {
      int32_t ta = si.pairs[0], tb = si.pairs[1];
      s = pm_error_setf(err, PM_ERR_BACKEND,
                        "the surface mesh intersects itself (%lld pairs of triangles; first: a "
                        "triangle of face %d and one of face %d): no tetrahedralization",
                        (long long)si.count, m->cells[PM_FACE][tag[ta]].tag, m->cells[PM_FACE][tag[tb]].tag);
    }
    pm_selfint_report_free(&si);
    if (s) goto done;
  }
  pm_tet_input in = {0};
  in.npts = np, in.xyz = xyz, in.nsurf = nsurf;
  in.ntri = ntri, in.tri = tri, in.tri_tag = tag;
  in.nseg = nseg, in.seg = nseg ? seg : NULL;
  in.nregion = nregion, in.region = region;
  in.mode = p->volume == PM_VOLUME_GIVEN ? PM_TET_GIVEN_POINTS : PM_TET_REFINE;
  in.radius_edge = p->radius_edge;
  in.max_volume = p->max_volume;
  in.max_points = p->max_nodes > 0 ? p->max_nodes - (mesh->nnode - np) : 0;
  in.allow_recovery_points = p->recovery_points;
  s = pm_tet_tetrahedralize(&in, &res, err);
  if (s && res.lost_tri >= 0 && res.lost_tri < ntri) {
    /* Name the model face: TetGen's own numbers mean nothing to a user. A face TetGen cannot keep
     * is almost always a thin feature sampled too coarsely, its triangles nearly touching
     * another face's. */
    const pm_cell *fc = &m->cells[PM_FACE][tag[res.lost_tri]];
    const double *a = &xyz[3 * tri[3 * res.lost_tri]];
    s = pm_error_setf(err, PM_ERR_BACKEND,
                      "TetGen could not keep a surface triangle of face %d near (%.6g, %.6g, %.6g) "
                      "(a thin or sharp feature sampled too coarsely for it: a smaller size there "
                      "helps)",
                      fc->tag, a[0], a[1], a[2]);
  }
  if (s) goto done;
  /* Steiner points become volume nodes of the volume of their first tet. */
  if (res.npts > np) {
    int32_t *grown = realloc(back, sizeof(int32_t) * (size_t)res.npts);
    if (!grown) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto done;
    }
    back = grown;
    for (int32_t i = np; i < res.npts; ++i) back[i] = -1;
  }

  {
    int64_t r = spread_region_tags(&res, tri, ntri, err);
    if (r < 0) {
      s = (pm_status)-r;
      goto done;
    }
    rep->retagged_tets += (int32_t)r;
  }
  /* A cavity that is no volume has tag -1: its tets are dropped. Then flat tets (nearly
   * coplanar and cospherical nodes, which TetGen's flips leave) are removed: inside the volume
   * by edge removal (tet_flip.h), against a planar face by flipping its diagonal. */
  int32_t kt = 0;
  for (int32_t t = 0; t < res.ntet; ++t)
    if (res.tet_tag[t] >= 0) {
      memmove(&res.tet[4 * kt], &res.tet[4 * t], 4 * sizeof(int32_t));
      res.tet_tag[kt++] = res.tet_tag[t];
    }
  res.ntet = kt;
  if (!s) {
    pm_tet_flip_input fi = {res.xyz, res.npts, ntri, tri, nseg, nseg ? seg : NULL,
                            100 * PM_DEGENERATE_REL, 10000};
    int32_t remaining = 0, nflip = 0;
    s = pm_tet_remove_flat(&fi, &res.tet, &res.tet_tag, &res.ntet, &remaining, &nflip, err);
    rep->flat_tet_flips += nflip;
  }
  /* Steiner points used by the tets (all in a volume now) become volume nodes of the volume of
   * their first tet; a point in a dropped cavity never becomes a node. */
  for (int32_t t = 0; t < res.ntet && !s; ++t)
    for (int q = 0; q < 4 && !s; ++q) {
      int32_t i = res.tet[4 * t + q];
      if (back[i] >= 0) continue;
      s = pm_mesh_add_node(mesh, &res.xyz[3 * i], PM_VOLUME, res.tet_tag[t], NULL, &back[i], err);
      rep->steiner++;
    }
  if (!s) {
    keep = malloc((size_t)res.ntet + 1);
    if (!keep) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  if (!s) {
    for (int32_t t = 0; t < res.ntet; ++t) keep[t] = 1;
    int32_t removed = repair_flat_tets(mesh, res.tet, res.ntet, back, 0, keep, err);
    if (removed < 0) s = (pm_status)-removed;
    else rep->flat_tets_repaired += removed;
  }
  if (!s) s = check_tets_tile(m, &res, keep, err);
  for (int32_t t = 0; t < res.ntet && !s; ++t) {
    if (!keep[t]) continue;
    s = pm_mesh_add_tet(mesh, back[res.tet[4 * t]], back[res.tet[4 * t + 1]], back[res.tet[4 * t + 2]],
                        back[res.tet[4 * t + 3]], res.tet_tag[t], err);
  }
done:
  pm_tet_result_free(&res);
  free(keep);
  free(use_face), free(map), free(tri), free(tag), free(seg), free(xyz), free(back), free(region);
  return s;
}

/* Volumes joined through shared faces (or a face embedded in both) form one group for TetGen;
 * groups that share no face -- the solids of an assembly that merely touch or overlap -- are
 * tetrahedralized separately, as gmsh does, so one solid's surface is never checked against
 * another's. */
pm_status pm_connect_volumes(const pm_model *m, pm_mesh *mesh, const pm_connect_params *p,
                             pm_connect_report *rep, pm_error *err) {
  int32_t nv = m->count[PM_VOLUME];
  if (nv == 0) return PM_OK;
  pm_connect_report local;
  if (!rep) memset(&local, 0, sizeof local), rep = &local;
  double t0 = pm_seconds();
  int32_t nnode0 = mesh->nnode, ntet0 = mesh->ntet;
  face_tris ft = {0};
  int32_t *group = malloc(sizeof(int32_t) * (size_t)nv);
  uint8_t *in = malloc((size_t)nv);
  pm_status s = PM_OK;
  if (!group || !in || !face_tris_build(m, mesh, &ft)) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t v = 0; v < nv; ++v) group[v] = v;
  /* Union of volumes through faces: a face's `up` volumes and the volumes it is embedded in. */
  for (int32_t f = 0; f < m->count[PM_FACE]; ++f) {
    const pm_cell *fc = &m->cells[PM_FACE][f];
    int32_t first = -1;
    for (int32_t k = 0; k < fc->nup + fc->nhost; ++k) {
      int32_t v = k < fc->nup ? fc->up[k] : (fc->host[k - fc->nup].dim == PM_VOLUME ? fc->host[k - fc->nup].index : -1);
      if (v < 0) continue;
      while (group[v] != v) v = group[v];
      if (first < 0) first = v;
      else if (v != first) group[v > first ? v : first] = v > first ? first : v, first = v < first ? v : first;
    }
  }
  for (int32_t g = 0; g < nv && !s; ++g) {
    int32_t root = g;
    while (group[root] != root) root = group[root];
    if (root != g) continue;
    for (int32_t v = 0; v < nv; ++v) {
      int32_t r = v;
      while (group[r] != r) r = group[r];
      in[v] = r == g;
    }
    s = connect_volume_group(m, mesh, &ft, in, p, rep, err);
  }
  if (!s && p->max_nodes > 0 && mesh->nnode > p->max_nodes)
    s = pm_error_setf(err, PM_ERR_LIMIT, "the volume mesh needs %d nodes, more than the cap %d",
                      (int)mesh->nnode, (int)p->max_nodes);
done:
  if (s) mesh->nnode = nnode0, mesh->ntet = ntet0; /* the surface mesh stays as it was given */
  rep->time_volumes += pm_seconds() - t0;
  free(group), free(in), face_tris_free(&ft);
  return s;
}
