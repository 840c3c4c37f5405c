/* The overlap ratio (papers/003 eq. 16, papers/000 section 3.1.3) and the layer of outside
 * bubbles (papers/000 section 4.2.1).
 *
 * alpha_i = (2 / d_i) sum_j (d_i + d_j / 2 - |x_i x_j|): the depth to which the double-sized
 * bubble i (radius d_i, the thesis's overlap boundary) penetrates each neighbour (radius d_j / 2),
 * over the radius of i. In a hexagonal packing of equal bubbles at distance d every one of the 6
 * neighbours contributes 1 and the next ring (at sqrt3 d > 1.5 d) nothing, so alpha = 6 on a
 * face, 2 on a curve (003 section 3.5). 003 sums over the "adjacent" bubbles, which Shimada took
 * from a Delaunay triangulation; we sum over every bubble the overlap boundary penetrates (only
 * positive terms), which needs no triangulation and agrees with it for a packing near
 * equilibrium, where no adjacent bubble is farther than 1.5 d. The bubbles counted are those
 * bubble i feels (bub_related: a curve bubble counts curve and vertex bubbles of its curve, a face
 * bubble every bubble of its face's closure, 000 section 4.2.2) plus, for face bubbles, the
 * outside layer of its face.
 *
 * Outside layer (000 section 4.2.1: "a layer of outside bubbles around the border of the face ...
 * only used to calculate the overlap"). The thesis does not say where they go; we put one
 * outside every pair of consecutive boundary bubbles of a face (along each loop: vertex and curve
 * bubbles ordered by the curves' parameters), at the apex of the equilateral triangle on the pair
 * on the outer side, in the tangent plane of the face: where a face bubble would sit if the packing
 * went on across the border. So a bubble next to a straight border sees the same 6 neighbours as
 * one inside, and one at a convex corner is not taken for open. They need no parameters (the
 * overlap ratio uses object-space distances), so faces whose surface is not defined outside their
 * trim get them too; they are rebuilt at every population control from the current boundary
 * bubbles. Seams and degenerate curves are not borders and get none.
 *
 * Volume bubbles (the volume phase). The standard value in a close packing is 12, the face-centred
 * cubic (or hexagonal close) packing's 12 nearest neighbours at d. But there the second shell lies
 * at sqrt2 d = 1.41 d, inside the 2D formula's reach of 1.5 d, and would add 6 x 0.17 = 1.03. So
 * a volume bubble's overlap boundary has radius 0.9 d_i instead of d_i (our choice: the smallest
 * round radius that leaves the second shell out with a margin, 1.4 d < 1.41 d), and each
 * penetration is normalized by 0.4 d_i, its value for a neighbour at d:
 *     alpha_i = sum_j max(0, 0.9 d_i + d_j / 2 - |x_i x_j|) / (0.4 d_i),
 * exactly 12 in the perfect packing, 1 per neighbour at the stable distance as on faces. The
 * bubbles counted are those a volume bubble feels: its volume's and the closure's (face, curve and
 * vertex bubbles of its walls and embedded cells), which play the part the outside layer plays for
 * faces, so a bubble next to a wall is not taken for open.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"

/* The overlap boundary and normalization of a volume bubble (above). */
#define VOL_REACH 0.9
#define VOL_NORM 0.4

static double alpha_with(const bub_state *s, const double x[3], double d, int kind, int32_t cell,
                         int32_t self, pm_idbuf *buf) {
  pm_error e = {0};
  if (kind == BUB_KVOLUME) {
    /* Grid radius >= d_j: dist < 0.9 d + d_j covers dist < 0.9 d + d_j / 2. */
    if (pm_grid_query_overlap(s->grid, x, VOL_REACH * d, buf, &e)) return 0;
    double sum = 0;
    for (int32_t k = 0; k < buf->n; ++k) {
      int32_t j = buf->ids[k];
      if (j == self || (s->flags[j] & BUB_FDEAD) || !bub_related_cell(s, kind, cell, j)) continue;
      double pen = VOL_REACH * d + 0.5 * s->d[j] - pm_v3_dist(x, &s->x[3 * j]);
      if (pen > 0) sum += pen;
    }
    return sum / (VOL_NORM * d);
  }
  /* Grid radius d_j: dist < d + d_j covers dist < d + d_j / 2. */
  if (pm_grid_query_overlap(s->grid, x, d, buf, &e)) return 0;
  double sum = 0;
  for (int32_t k = 0; k < buf->n; ++k) {
    int32_t j = buf->ids[k];
    if (j == self || (s->flags[j] & BUB_FDEAD)) continue;
    if (s->kind[j] == BUB_KOUT) {
      if (kind != BUB_KFACE || s->cell[j] != cell) continue;
    } else if (!bub_related_cell(s, kind, cell, j)) {
      continue;
    }
    double pen = d + 0.5 * s->d[j] - pm_v3_dist(x, &s->x[3 * j]);
    if (pen > 0) sum += pen;
  }
  return 2 * sum / d;
}

double bub_alpha_at(const bub_state *s, const double x[3], double d, int kind, int32_t cell,
                    int32_t self) {
  pm_idbuf buf = PM_IDBUF_INIT;
  double a = alpha_with(s, x, d, kind, cell, self, &buf);
  pm_idbuf_free(&buf);
  return a;
}

double bub_alpha(const bub_state *s, int32_t i) {
  return bub_alpha_at(s, &s->x[3 * i], s->d[i], s->kind[i], s->cell[i], i);
}

void bub_alpha_all(bub_state *s) {
  const int32_t n = s->n;
  const int vp = s->volume_phase;
#pragma omp parallel num_threads(bub_threads_for(s, n))
  {
    pm_idbuf buf = PM_IDBUF_INIT;
#pragma omp for schedule(static)
    for (int32_t i = 0; i < n; ++i) {
      int k = s->kind[i];
      int moving = vp ? k == BUB_KVOLUME : (k == BUB_KCURVE || k == BUB_KFACE);
      if (moving && !(s->flags[i] & BUB_FDEAD))
        s->alpha[i] = alpha_with(s, &s->x[3 * i], s->d[i], k, s->cell[i], i, &buf);
      else
        s->alpha[i] = 0;
    }
    pm_idbuf_free(&buf);
  }
}

/* ---- the outside layer ------------------------------------------------------------------------ */

typedef struct tid {
  double t;
  int32_t id;
} tid;

static int cmp_tid(const void *a, const void *b) {
  const tid *x = a, *y = b;
  if (x->t != y->t) return x->t < y->t ? -1 : 1;
  return (x->id > y->id) - (x->id < y->id);
}

typedef bub_chord chord;

pm_status bub_for_each_chord(bub_state *s, bub_chord_fn fn, void *user, pm_error *err) {
  const pm_model *m = s->model;
  pm_status st = PM_OK;
  /* Live curve bubbles per curve, sorted by t; the bubble of each vertex. */
  int32_t nc = m->count[PM_CURVE], nv = m->count[PM_VERTEX];
  int32_t *coff = calloc((size_t)nc + 2, sizeof(int32_t));
  int32_t *vb = malloc(sizeof(int32_t) * ((size_t)nv + 1));
  tid *ct = malloc(sizeof(tid) * ((size_t)s->n + 1));
  if (!coff || !vb || !ct) {
    free(coff), free(vb), free(ct);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t v = 0; v < nv; ++v) vb[v] = -1;
  for (int32_t i = 0; i < s->n; ++i) {
    if (s->flags[i] & BUB_FDEAD) continue;
    if (s->kind[i] == BUB_KVERTEX) vb[s->cell[i]] = i;
    if (s->kind[i] == BUB_KCURVE) coff[s->cell[i] + 2]++;
  }
  for (int32_t c = 0; c < nc; ++c) coff[c + 2] += coff[c + 1];
  for (int32_t i = 0; i < s->n; ++i)
    if (!(s->flags[i] & BUB_FDEAD) && s->kind[i] == BUB_KCURVE)
      ct[coff[s->cell[i] + 1]++] = (tid){s->par[2 * i], i};
  for (int32_t c = 0; c < nc; ++c) qsort(&ct[coff[c]], (size_t)(coff[c + 1] - coff[c]), sizeof(tid), cmp_tid);

  int32_t *chain = NULL;
  double *chain_t = NULL;
  int32_t chain_cap = 0;
  for (int32_t f = 0; f < m->count[PM_FACE] && !st; ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    for (int32_t l = 0; l < fc->nloop && !st; ++l) {
      const pm_loop *lp = &fc->loop[l];
      for (int32_t u = 0; u < lp->nuse && !st; ++u) {
        const pm_use *use = &lp->use[u];
        const pm_cell *cv = pm_model_cell(m, PM_CURVE, use->cell);
        if (cv->degenerate || s->seam[use->cell] || cv->nbound < 1) continue;
        int32_t cnt = coff[use->cell + 1] - coff[use->cell];
        if (cnt + 2 > chain_cap) {
          chain_cap = cnt + 64;
          int32_t *nch = realloc(chain, sizeof(int32_t) * (size_t)chain_cap);
          double *nt = realloc(chain_t, sizeof(double) * (size_t)chain_cap);
          if (nch) chain = nch;
          if (nt) chain_t = nt;
          if (!nch || !nt) {
            st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
            break;
          }
        }
        /* The chain along increasing t, then reversed for sense -1. */
        int32_t len = 0;
        int32_t v0 = vb[cv->bound[0].cell], v1 = vb[cv->bound[cv->nbound > 1 ? 1 : 0].cell];
        if (v0 >= 0) chain[len] = v0, chain_t[len++] = cv->lo[0];
        for (int32_t k = 0; k < cnt; ++k)
          chain[len] = ct[coff[use->cell] + k].id, chain_t[len++] = ct[coff[use->cell] + k].t;
        if (v1 >= 0) chain[len] = v1, chain_t[len++] = cv->hi[0];
        if (use->sense < 0)
          for (int32_t k = 0; k < len / 2; ++k) {
            int32_t ti = chain[k];
            double tt = chain_t[k];
            chain[k] = chain[len - 1 - k], chain_t[k] = chain_t[len - 1 - k];
            chain[len - 1 - k] = ti, chain_t[len - 1 - k] = tt;
          }
        for (int32_t k = 0; k + 1 < len && !st; ++k) {
          chord c;
          c.face = f, c.A = chain[k], c.B = chain[k + 1], c.curve = use->cell;
          double uva[2], uvb[2];
          pm_face_curve_uv(fc, use, chain_t[k], uva);
          pm_face_curve_uv(fc, use, chain_t[k + 1], uvb);
          double uvm[2] = {0.5 * (uva[0] + uvb[0]), 0.5 * (uva[1] + uvb[1])};
          c.uv[0] = uvm[0], c.uv[1] = uvm[1];
          pm_face_point fp;
          pm_face_eval(fc, uvm, 1, &fp);
          /* Loops keep the face on their left in (u, v): outward is the right normal. */
          double du = uvb[0] - uva[0], dv = uvb[1] - uva[1], nrm[3];
          for (int q = 0; q < 3; ++q) c.w[q] = fp.su[q] * dv - fp.sv[q] * du;
          pm_v3_sub(c.e, &s->x[3 * c.B], &s->x[3 * c.A]);
          c.len = pm_v3_normalize(c.e);
          if (!(c.len > 0)) continue;
          pm_v3_cross(nrm, fp.su, fp.sv);
          if (pm_v3_normalize(nrm) > 0) pm_v3_axpy(c.w, c.w, -pm_v3_dot(c.w, nrm), nrm);
          pm_v3_axpy(c.w, c.w, -pm_v3_dot(c.w, c.e), c.e);
          if (!(pm_v3_normalize(c.w) > 0)) continue;
          st = fn(s, &c, user, err);
        }
      }
    }
  }
  free(chain), free(chain_t);
  free(coff), free(vb), free(ct);
  return st;
}

static pm_status add_outside(bub_state *s, const chord *c, void *user, pm_error *err) {
  (void)user;
  double apex[3], mid[3];
  pm_v3_add(mid, &s->x[3 * c->A], &s->x[3 * c->B]);
  pm_v3_scale(mid, mid, 0.5);
  pm_v3_axpy(apex, mid, 0.86602540378443865 * c->len, c->w);
  int32_t id;
  pm_status st = bub_state_add(s, BUB_KOUT, c->face, NULL, apex, 0.5 * (s->d[c->A] + s->d[c->B]), &id, err);
  if (!st) st = pm_grid_insert(s->grid, id, apex, s->grid_factor * s->d[id], err);
  return st;
}

pm_status bub_outside_layer(bub_state *s, pm_error *err) {
  pm_status st = PM_OK;
  for (int32_t i = 0; i < s->n && !st; ++i)
    if (s->kind[i] == BUB_KOUT && !(s->flags[i] & BUB_FDEAD)) {
      s->flags[i] |= BUB_FDEAD;
      st = pm_grid_remove(s->grid, i, err);
    }
  if (!st) st = bub_for_each_chord(s, add_outside, NULL, err);
  s->grid_valid = !st; /* bub_state_add marks it invalid; the grid was updated alongside */
  return st;
}

/* ---- face bubbles on the border --------------------------------------------------------------- */

typedef struct border_ctx {
  pm_idbuf buf;
  int32_t dropped;
} border_ctx;

static pm_status drop_near_chord(bub_state *s, const chord *c, void *user, pm_error *err) {
  border_ctx *bc = user;
  const double *xa = &s->x[3 * c->A];
  double mid[3];
  pm_v3_axpy(mid, xa, 0.5 * c->len, c->e);
  pm_status st = pm_grid_query_ball(s->grid, mid, 0.5 * c->len + 0.5 * (s->d[c->A] + s->d[c->B]), &bc->buf, err);
  for (int32_t k = 0; k < bc->buf.n && !st; ++k) {
    int32_t i = bc->buf.ids[k];
    if (s->kind[i] != BUB_KFACE || s->cell[i] != c->face || (s->flags[i] & BUB_FDEAD)) continue;
    double r[3];
    pm_v3_sub(r, &s->x[3 * i], xa);
    double t = pm_v3_dot(r, c->e) / c->len, o = pm_v3_dot(r, c->w);
    double l0 = 0.5 * (s->d[i] + 0.5 * (s->d[c->A] + s->d[c->B]));
    if (t < 0 || t > 1 || o < -0.25 * l0 || o > l0) continue;
    s->flags[i] |= BUB_FDEAD;
    st = pm_grid_remove(s->grid, i, err);
    bc->dropped++;
  }
  return st;
}

/* A face bubble closer than half the stable distance to a vertex or curve bubble it feels: one
 * the packing squeezed against a corner (a cone's apex, a pole) that no chord covers. */
static pm_status drop_near_boundary_bubbles(bub_state *s, border_ctx *bc, pm_error *err) {
  pm_status st = PM_OK;
  for (int32_t i = s->nc; i < s->nf && !st; ++i) {
    if (s->kind[i] != BUB_KFACE || (s->flags[i] & BUB_FDEAD)) continue;
    st = pm_grid_query_overlap(s->grid, &s->x[3 * i], 0.25 * s->d[i], &bc->buf, err);
    for (int32_t k = 0; k < bc->buf.n && !st; ++k) {
      int32_t j = bc->buf.ids[k];
      if (s->kind[j] > BUB_KCURVE || !bub_related(s, i, j)) continue;
      if (pm_v3_dist(&s->x[3 * i], &s->x[3 * j]) < 0.25 * (s->d[i] + s->d[j])) {
        s->flags[i] |= BUB_FDEAD;
        st = pm_grid_remove(s->grid, i, err);
        bc->dropped++;
        break;
      }
    }
  }
  return st;
}

pm_status bub_border_cleanup(bub_state *s, int32_t *dropped, pm_error *err) {
  *dropped = 0;
  pm_status st = bub_state_grid_rebuild(s, err);
  border_ctx bc = {PM_IDBUF_INIT, 0};
  if (!st) st = bub_for_each_chord(s, drop_near_chord, &bc, err);
  if (!st) st = drop_near_boundary_bubbles(s, &bc, err);
  pm_idbuf_free(&bc.buf);
  *dropped = bc.dropped;
  if (!st && bc.dropped) st = bub_state_compact(s, err);
  return st;
}
