/* Edge removal (n-to-m flips) to clear flat tets, and the check that tets tile (see tet_flip.h). */
#include "common/connect/tet_flip.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/hash.h"
#include "common/mesh/mesh_topo.h"
#include "common/backends/predicates.h"
#include "common/base/vec3.h"

#define RING_MAX 7

/* 6 V / l_max^3: 0 for a flat tet, 1/sqrt(2) ~ 0.707 for the regular one. Signed. */
static double tet_shape(const double *xyz, const int32_t *t) {
  const double *a = &xyz[3 * t[0]], *b = &xyz[3 * t[1]], *c = &xyz[3 * t[2]], *d = &xyz[3 * t[3]];
  double e1[3], e2[3], e3[3], n[3];
  pm_v3_sub(e1, b, a), pm_v3_sub(e2, c, a), pm_v3_sub(e3, d, a);
  pm_v3_cross(n, e1, e2);
  double v6 = pm_v3_dot(n, e3), l = 0;
  const double *p[4] = {a, b, c, d};
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) l = fmax(l, pm_v3_dist(p[i], p[j]));
  return l > 0 ? v6 / (l * l * l) : 0;
}

/* ---- a hash set of sorted index tuples (pairs and triples) -------------------------------- */

typedef struct keyset {
  uint64_t *key; /* 0 empty */
  int64_t cap;
} keyset;

static uint64_t key3(int32_t a, int32_t b, int32_t c) {
  int32_t v[3] = {a, b, c};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2 - i; ++j)
      if (v[j] > v[j + 1]) {
        int32_t x = v[j];
        v[j] = v[j + 1], v[j + 1] = x;
      }
  /* 21 bits each would overflow for big meshes: hash the triple, keep collisions impossible by
   * storing a 64-bit mix of a collision-free 96-bit value's two halves. Equal triples give equal
   * keys; distinct triples collide with probability ~2^-64. */
  uint64_t lo = ((uint64_t)(uint32_t)v[0] << 32) | (uint32_t)v[1];
  return pm_mix64(lo ^ pm_mix64((uint64_t)(uint32_t)v[2] + 0x9e3779b97f4a7c15ULL)) | 1;
}

static uint64_t key2(int32_t a, int32_t b) { return key3(a, b, -1); }

static int keyset_init(keyset *s, int64_t n) {
  s->cap = 16;
  while (s->cap < 2 * n + 16) s->cap *= 2;
  s->key = calloc((size_t)s->cap, sizeof(uint64_t));
  return s->key != NULL;
}

static void keyset_add(keyset *s, uint64_t k) {
  int64_t i = (int64_t)(pm_mix64(k) & (uint64_t)(s->cap - 1));
  while (s->key[i] && s->key[i] != k) i = (i + 1) & (s->cap - 1);
  s->key[i] = k;
}

static int keyset_has(const keyset *s, uint64_t k) {
  int64_t i = (int64_t)(pm_mix64(k) & (uint64_t)(s->cap - 1));
  while (s->key[i]) {
    if (s->key[i] == k) return 1;
    i = (i + 1) & (s->cap - 1);
  }
  return 0;
}

/* ---- node -> tets incidence (rebuilt after each flip: flat tets are few) -------------------- */

typedef struct incidence {
  int32_t *off, *tet;
} incidence;

static int incidence_build(const int32_t *tet, const uint8_t *dead, int32_t ntet, int32_t npts,
                           incidence *inc) {
  free(inc->off), free(inc->tet);
  inc->off = calloc((size_t)npts + 1, sizeof(int32_t));
  inc->tet = malloc(sizeof(int32_t) * 4 * (size_t)(ntet ? ntet : 1));
  if (!inc->off || !inc->tet) return 0;
  for (int32_t t = 0; t < ntet; ++t)
    if (!dead[t])
      for (int q = 0; q < 4; ++q) inc->off[tet[4 * t + q] + 1]++;
  for (int32_t v = 0; v < npts; ++v) inc->off[v + 1] += inc->off[v];
  int32_t *fill = malloc(sizeof(int32_t) * ((size_t)npts + 1));
  if (!fill) return 0;
  memcpy(fill, inc->off, sizeof(int32_t) * ((size_t)npts + 1));
  for (int32_t t = 0; t < ntet; ++t)
    if (!dead[t])
      for (int q = 0; q < 4; ++q) inc->tet[fill[tet[4 * t + q]]++] = t;
  free(fill);
  return 1;
}

/* ---- triangulations of a ring polygon ------------------------------------------------------ */

/* Enumerate the triangulations of polygon vertices [i..j] (indices into the ring) recursively;
 * for each complete triangulation call `visit`. */
typedef struct tri_enum {
  int32_t tri[RING_MAX][3];
  int ntri;
  void (*visit)(struct tri_enum *e, void *user);
  void *user;
} tri_enum;

static void enumerate(tri_enum *e, int *stack_i, int *stack_j, int depth) {
  /* Find the first open interval with more than one edge. */
  if (depth == 0) {
    e->visit(e, e->user);
    return;
  }
  int i = stack_i[depth - 1], j = stack_j[depth - 1];
  if (j - i < 2) {
    enumerate(e, stack_i, stack_j, depth - 1);
    return;
  }
  /* Triangle (i, m, j) for every m between. */
  for (int m = i + 1; m < j; ++m) {
    e->tri[e->ntri][0] = i, e->tri[e->ntri][1] = m, e->tri[e->ntri][2] = j;
    e->ntri++;
    int si[2 * RING_MAX], sj[2 * RING_MAX];
    memcpy(si, stack_i, sizeof(int) * (size_t)(depth - 1));
    memcpy(sj, stack_j, sizeof(int) * (size_t)(depth - 1));
    si[depth - 1] = i, sj[depth - 1] = m;
    si[depth] = m, sj[depth] = j;
    enumerate(e, si, sj, depth + 1);
    e->ntri--;
  }
}

typedef struct candidate {
  const double *xyz;
  int32_t p, q, k;
  const int32_t *ring;
  double best;
  int32_t best_tets[2 * (RING_MAX - 2)][4];
  int nbest;
} candidate;

static void try_triangulation(tri_enum *e, void *user) {
  candidate *c = user;
  int32_t tets[2 * (RING_MAX - 2)][4];
  int n = 0;
  double worst = INFINITY;
  int side = 0;
  for (int t = 0; t < e->ntri; ++t) {
    int32_t a = c->ring[e->tri[t][0]], b = c->ring[e->tri[t][1]], d = c->ring[e->tri[t][2]];
    const double *A = &c->xyz[3 * a], *B = &c->xyz[3 * b], *D = &c->xyz[3 * d];
    int sp = pm_orient3d(A, B, D, &c->xyz[3 * c->p]), sq = pm_orient3d(A, B, D, &c->xyz[3 * c->q]);
    /* Each triangle, its corners taken in ring order, must have p strictly on one and the same
     * side and q strictly on the other: then every new tet is positive and they tile the removed
     * ring. A triangle with p on the other side is folded over its neighbours (a reflex corner of
     * the ring); its tets would overlap the rest of the mesh. */
    if (sp == 0 || sq == 0 || sp == sq) return;
    if (side == 0) side = sp;
    else if (sp != side) return;
    int32_t t1[4] = {a, b, d, c->p}, t2[4] = {a, d, b, c->q};
    if (sp < 0) t1[1] = d, t1[2] = b, t2[1] = b, t2[2] = d;
    for (int k = 0; k < 4; ++k) tets[n][k] = t1[k], tets[n + 1][k] = t2[k];
    worst = fmin(worst, fmin(tet_shape(c->xyz, t1), tet_shape(c->xyz, t2)));
    n += 2;
  }
  if (worst > c->best) {
    c->best = worst;
    memcpy(c->best_tets, tets, sizeof tets);
    c->nbest = n;
  }
}

/* ---- the removal ---------------------------------------------------------------------------- */

pm_status pm_tet_remove_flat(const pm_tet_flip_input *in, int32_t **tet_io, int32_t **tag_io,
                             int32_t *ntet_io, int32_t *remaining, int32_t *flips_out,
                             pm_error *err) {
  int32_t ntet = *ntet_io, cap = ntet + 64;
  int32_t *tet = realloc(*tet_io, sizeof(int32_t) * 4 * (size_t)cap);
  if (!tet) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  *tet_io = tet;
  int32_t *tag = realloc(*tag_io, sizeof(int32_t) * (size_t)cap);
  if (!tag) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  *tag_io = tag;
  uint8_t *dead = calloc((size_t)cap, 1);
  keyset faces = {0}, edges = {0};
  incidence inc = {0};
  pm_status s = PM_OK;
  int32_t flips = 0;
  if (!dead || !keyset_init(&faces, in->ntri) || !keyset_init(&edges, in->nseg)) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t i = 0; i < in->ntri; ++i) keyset_add(&faces, key3(in->tri[3 * i], in->tri[3 * i + 1], in->tri[3 * i + 2]));
  for (int32_t i = 0; i < in->nseg; ++i) keyset_add(&edges, key2(in->seg[2 * i], in->seg[2 * i + 1]));

  int changed = 1;
  while (changed && flips < in->max_flips) {
    changed = 0;
    if (!incidence_build(tet, dead, ntet, in->npts, &inc)) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto done;
    }
    for (int32_t t = 0; t < ntet && !changed; ++t) {
      if (dead[t] || fabs(tet_shape(in->xyz, &tet[4 * t])) > in->flat_rel) continue;
      static const int ed[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
      for (int e = 0; e < 6 && !changed; ++e) {
        int32_t p = tet[4 * t + ed[e][0]], q = tet[4 * t + ed[e][1]];
        if (keyset_has(&edges, key2(p, q))) continue;
        /* The tets around edge (p, q). */
        int32_t around[64], k = 0;
        for (int32_t j = inc.off[p]; j < inc.off[p + 1] && k < 64; ++j) {
          int32_t u = inc.tet[j];
          for (int r = 0; r < 4; ++r)
            if (tet[4 * u + r] == q) around[k++] = u;
        }
        if (k < 3 || k > RING_MAX) continue;
        /* The other two vertices of each, chained into a ring. */
        int32_t other[RING_MAX][2];
        int bad = 0;
        for (int i = 0; i < k; ++i) {
          int m = 0;
          for (int r = 0; r < 4; ++r) {
            int32_t v = tet[4 * around[i] + r];
            if (v != p && v != q) other[i][m++] = v;
          }
          if (tag[around[i]] != tag[around[0]]) bad = 1;
        }
        if (bad) continue;
        int32_t ring[RING_MAX];
        uint8_t used[RING_MAX] = {0};
        ring[0] = other[0][0], ring[1] = other[0][1], used[0] = 1;
        int len = 2;
        while (len < k) {
          int found = 0;
          for (int i = 0; i < k && !found; ++i) {
            if (used[i]) continue;
            if (other[i][0] == ring[len - 1]) ring[len++] = other[i][1], used[i] = 1, found = 1;
            else if (other[i][1] == ring[len - 1]) ring[len++] = other[i][0], used[i] = 1, found = 1;
          }
          if (!found) break;
        }
        /* Closed: the last unused tet joins the ring's ends. */
        int closed = 0;
        for (int i = 0; i < k; ++i)
          if (!used[i] && len == k &&
              ((other[i][0] == ring[k - 1] && other[i][1] == ring[0]) ||
               (other[i][1] == ring[k - 1] && other[i][0] == ring[0])))
            closed = 1;
        if (!closed) continue;
        /* The faces (p, q, r) removed with the edge must not be constrained. */
        for (int i = 0; i < k && !bad; ++i) bad = keyset_has(&faces, key3(p, q, ring[i]));
        if (bad) continue;
        double worst_old = INFINITY;
        for (int i = 0; i < k; ++i) worst_old = fmin(worst_old, tet_shape(in->xyz, &tet[4 * around[i]]));
        /* Accept only a triangulation whose worst tet is not flat (and better than before). */
        candidate cand = {in->xyz, p, q, k, ring, fmax(worst_old, in->flat_rel), {{0}}, 0};
        tri_enum en = {{{0}}, 0, try_triangulation, &cand};
        int si[2 * RING_MAX] = {0}, sj[2 * RING_MAX] = {k - 1};
        enumerate(&en, si, sj, 1);
        if (cand.nbest == 0) continue;
        /* Replace the ring. The new tets reuse the removed slots, then grow the arrays. */
        int32_t keep_tag = tag[around[0]];
        for (int i = 0; i < k; ++i) dead[around[i]] = 1;
        for (int i = 0; i < cand.nbest; ++i) {
          int32_t slot;
          if (i < k) {
            slot = around[i];
          } else {
            if (ntet == cap) {
              cap *= 2;
              int32_t *nt = realloc(tet, sizeof(int32_t) * 4 * (size_t)cap);
              int32_t *ng = nt ? realloc(tag, sizeof(int32_t) * (size_t)cap) : NULL;
              uint8_t *nd = ng ? realloc(dead, (size_t)cap) : NULL;
              if (nt) tet = nt, *tet_io = nt;
              if (ng) tag = ng, *tag_io = ng;
              if (!nd) {
                s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
                goto done;
              }
              dead = nd;
            }
            slot = ntet++;
          }
          memcpy(&tet[4 * slot], cand.best_tets[i], 4 * sizeof(int32_t));
          tag[slot] = keep_tag;
          dead[slot] = 0;
        }
        ++flips;
        changed = 1;
      }
    }
  }
  /* Compact the dead slots away (only when the ring shrank). */
  {
    int32_t n = 0, flat = 0;
    for (int32_t t = 0; t < ntet; ++t) {
      if (dead[t]) continue;
      if (n != t) memcpy(&tet[4 * n], &tet[4 * t], 4 * sizeof(int32_t)), tag[n] = tag[t];
      flat += fabs(tet_shape(in->xyz, &tet[4 * n])) <= in->flat_rel;
      ++n;
    }
    ntet = n;
    *remaining = flat;
  }
done:
  *ntet_io = ntet;
  *flips_out = flips;
  free(dead), free(faces.key), free(edges.key), free(inc.off), free(inc.tet);
  return s;
}

pm_status pm_tet_find_overlap(int32_t npts, const int32_t *tet, const uint8_t *keep, int32_t ntet,
                              int *found, int32_t *tet_at, int32_t *node_at, int32_t *count,
                              pm_error *err) {
  *found = 0;
  int32_t *kept = malloc(sizeof(int32_t) * 4 * ((size_t)ntet + 1));
  int32_t *orig = malloc(sizeof(int32_t) * ((size_t)ntet + 1)); /* kept index -> tet */
  if (!kept || !orig) {
    free(kept), free(orig);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  int32_t n = 0;
  for (int32_t t = 0; t < ntet; ++t)
    if (!keep || keep[t]) orig[n] = t, memcpy(&kept[4 * n++], &tet[4 * t], 4 * sizeof(int32_t));
  pm_faces fc = {0};
  pm_status s = pm_faces_build(npts, kept, n, &fc, err);
  for (int64_t f = 0; f < fc.nface && !s && !*found; ++f) {
    int64_t k0 = fc.off[f], nt = fc.off[f + 1] - k0;
    if (nt <= 1 || (nt == 2 && fc.side[k0] != fc.side[k0 + 1])) continue;
    *found = 1, *tet_at = orig[fc.tet[k0]], *node_at = fc.abc[3 * f], *count = (int32_t)nt;
  }
  pm_faces_free(&fc);
  free(kept), free(orig);
  return s;
}
