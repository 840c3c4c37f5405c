/* Initial bubble placement by hierarchical spatial subdivision (papers/003 section 3.2,
 * papers/000 section 4.1.1, with the weights w1 and w2 of papers/004 section 2.3).
 *
 * Vertices: one bubble on every vertex that bounds or lies in something (an isolated point of a
 * CAD file is left to the connection step).
 *
 * Curves: bubbles at the two ends (the vertex bubbles); a bubble at the parameter midpoint of a
 * segment [t1, t2] while w1 L(t1, t2) > r1 + r2, recursively (003: "the length of the curve
 * between the end points ... compared to the sum of the two radii"; 004 sec. 2.3: "the distance
 * along the curve segment"). L is the arc length, so a closed curve (both ends on one vertex) is
 * subdivided like any other. Degenerate curves (poles, apexes) carry no bubbles.
 *
 * Faces: the rhombic quadtree of 000 section 4.1.1 in parameter space. A cell of side l centred at
 * (u, v) has the corners (u - 3l/4, v - sqrt3 l/4), (u + l/4, v - sqrt3 l/4),
 * (u + 3l/4, v + sqrt3 l/4), (u - l/4, v + sqrt3 l/4) (a 60 degree rhombus); it is split into four
 * when for some side (pi, pj) w2 |PiPj| > ri + rj in object space (eq. 4.1; the diagonals are not
 * checked), which adds bubbles at the four edge midpoints and the centre; the sub-cells have
 * centres (u - 3l/8, v - sqrt3 l/8), (u + l/8, v - sqrt3 l/8), (u + 3l/8, v + sqrt3 l/8),
 * (u - l/8, v + sqrt3 l/8). Cells are IN, OUT or BOUNDARY against the trimming loops: OUT cells
 * are dropped, the sub-cells of an IN cell are IN, those of a BOUNDARY cell are classified again
 * (a cell is BOUNDARY when a loop polyline segment meets it, else IN or OUT by its centre).
 * The bubbles are the corners of the leaf cells that lie inside the face.
 * Lattice points are named by integer coordinates on the finest level, so a corner shared by
 * several cells is one bubble.
 *
 * Choices where the papers are silent:
 *   - the quadtree is laid out in a parameter space scaled by the mean |Su| and |Sv| over the
 *     face, so that a cell is roughly a rhombus in object space too; the thesis assumes
 *     parameters of comparable scale (000 section 4.2.4), which a cylinder's angle and height are
 *     not, and an unscaled quadtree would split until the short side fits and so overfill the
 *     long one;
 *   - a face point closer than half the stable distance to a vertex or curve bubble, or closer
 *     than a quarter of its diameter to the trimming polyline (in the scaled parameter space), is
 *     not used: it would start almost on a boundary bubble, where the saturated force (003
 *     section 3.3) has no useful direction, or on the boundary itself, where the connection step
 *     needs no face node; a face point closer than a quarter of the stable distance to another
 *     face point is not used either (points on both copies of a seam);
 *   - a corner outside the face takes the mean diameter of the face's boundary bubbles when the
 *     size field is not positive there (the field may be defined on the domain only);
 *   - depth is capped at 28 levels below the root and the number of bubbles at the run's cap;
 *   - w2 defaults to 0.5, the low end of 004's recommended [0.5, 0.8]: population control only
 *     removes a bubble above the excess cut-off 8 (a packing about 38% denser than the ideal one)
 *     and inserts below the open cut-off 5 (about 15% sparser), so a dense start settles
 *     overfilled and unevenly compressed, while a sparse start that insertions fill ends near
 *     the ideal count (qi3: 647 nodes and mean radius ratio 0.971 from w2 = 0.5; 732 and 0.948
 *     from w2 = 0.6, close to 004's own 712 and 0.945; bench_bubble).
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/keyindex.h"
#include "common/base/vec3.h"

/* ---- curves ------------------------------------------------------------------------------- */

typedef struct tvec {
  double *t;
  int32_t n, cap;
} tvec;

static int tvec_push(tvec *v, double t) {
  if (v->n == v->cap) {
    int32_t nc = v->cap ? 2 * v->cap : 64;
    double *nt = realloc(v->t, sizeof(double) * (size_t)nc);
    if (!nt) return 0;
    v->t = nt, v->cap = nc;
  }
  v->t[v->n++] = t;
  return 1;
}

typedef struct curve_ctx {
  const bub_state *s;
  const pm_cell *c;
  tvec out;
  int64_t cap;
  pm_status st;
  pm_error *err;
} curve_ctx;

static void curve_split(curve_ctx *cx, double t1, double d1, double t2, double d2, int depth) {
  if (cx->st) return;
  double len = pm_curve_length(cx->c, t1, t2);
  if (!(cx->s->p.w1 * len > 0.5 * (d1 + d2)) || depth >= 40) return;
  double tm = 0.5 * (t1 + t2), xm[3], dm;
  pm_cell_point(cx->c, &tm, xm);
  cx->st = bub_size_at(cx->s, xm, &dm, cx->err);
  if (cx->st) return;
  if (cx->out.n >= cx->cap) {
    cx->st = pm_error_setf(cx->err, PM_ERR_LIMIT,
                           "bubble placement exceeds the cap of %lld bubbles on curve %d",
                           (long long)cx->cap, cx->c->tag);
    return;
  }
  curve_split(cx, t1, d1, tm, dm, depth + 1);
  if (!tvec_push(&cx->out, tm)) {
    cx->st = pm_error_setf(cx->err, PM_ERR_NOMEM, "out of memory");
    return;
  }
  curve_split(cx, tm, dm, t2, d2, depth + 1);
}

pm_status bub_place_curve(const bub_state *s, int32_t curve, double **t, int32_t *nt,
                          pm_error *err) {
  *t = NULL, *nt = 0;
  const pm_cell *c = pm_model_cell(s->model, PM_CURVE, curve);
  if (c->degenerate) return PM_OK;
  double lo = c->lo[0], hi = c->hi[0], x1[3], x2[3], d1, d2;
  pm_cell_point(c, &lo, x1);
  pm_cell_point(c, &hi, x2);
  pm_status st = bub_size_at(s, x1, &d1, err);
  if (!st) st = bub_size_at(s, x2, &d2, err);
  if (st) return st;
  curve_ctx cx = {s, c, {0}, (int64_t)fmin(s->p.max_bubbles, 2e9), PM_OK, err};
  curve_split(&cx, lo, d1, hi, d2, 0);
  if (cx.st) {
    free(cx.out.t);
    return cx.st;
  }
  *t = cx.out.t, *nt = cx.out.n;
  return PM_OK;
}

/* ---- faces: the rhombic quadtree ------------------------------------------------------------ */

#define QT_LEVELS 28 /* depth cap below the root */

typedef struct qpoint {
  uint64_t key;   /* lattice coordinates (i << 32 | j) on the finest level */
  double uv[2];   /* face parameters */
  double x[3];
  double d;
} qpoint;

typedef struct face_ctx {
  bub_state *s;
  const pm_cell *f;
  int32_t face;
  double scale[2];      /* scaled parameter = (par - lo) * scale */
  double origin[2];     /* scaled coordinates of the root's corner p1 */
  double h;             /* scaled length of one finest-level lattice step */
  double dref;          /* diameter for corners where the field is not positive */
  /* loop segments in scaled coordinates */
  double *seg;          /* [4 * nseg] */
  int32_t nseg;
  /* lattice point hash */
  qpoint *pts;
  int32_t npts, cap_pts;
  pm_keyindex index;     /* lattice key -> point */
  /* leaf corners collected: indices into pts, with the segment list of the leaf */
  uint8_t *used;        /* [cap_pts] corner of a kept leaf */
  double *near_seg;     /* [cap_pts] scaled distance to the nearest crossing segment seen */
  /* scratch for segment lists per depth */
  int32_t *segstack;
  int64_t segstack_n, segstack_cap;
  int64_t budget;       /* lattice points allowed */
  pm_status st;
  pm_error *err;
} face_ctx;

static void scaled_to_uv(const face_ctx *fx, double U, double V, double uv[2]) {
  uv[0] = fx->f->lo[0] + U / fx->scale[0];
  uv[1] = fx->f->lo[1] + V / fx->scale[1];
}

static void lattice_scaled(const face_ctx *fx, int64_t i, int64_t j, double *U, double *V) {
  *U = fx->origin[0] + ((double)i + 0.5 * (double)j) * fx->h;
  *V = fx->origin[1] + (double)j * 0.86602540378443865 * fx->h;
}

/* The lattice point (i, j): its index in pts, evaluated on first use; -1 on failure. */
static int32_t lattice_point(face_ctx *fx, int64_t i, int64_t j) {
  if (fx->st) return -1;
  uint64_t key = ((uint64_t)(uint32_t)i << 32) | (uint64_t)(uint32_t)j;
  if (!pm_keyindex_reserve(&fx->index, fx->npts + 1)) {
    fx->st = pm_error_setf(fx->err, PM_ERR_NOMEM, "out of memory");
    return -1;
  }
  int32_t found = pm_keyindex_get(&fx->index, key);
  if (found >= 0) return found;
  if (fx->npts >= fx->budget) {
    fx->st = pm_error_setf(fx->err, PM_ERR_LIMIT,
                           "bubble placement on face %d: the quadtree exceeds %lld lattice points "
                           "(the bubble cap is %lld)",
                           fx->f->tag, (long long)fx->budget, (long long)((fx->budget - 4096) / 8 + fx->s->n));
    return -1;
  }
  if (fx->npts == fx->cap_pts) {
    int32_t nc = fx->cap_pts ? 2 * fx->cap_pts : 1024;
    qpoint *np = realloc(fx->pts, sizeof(qpoint) * (size_t)nc);
    uint8_t *nu = realloc(fx->used, (size_t)nc);
    double *nd = realloc(fx->near_seg, sizeof(double) * (size_t)nc);
    if (np) fx->pts = np;
    if (nu) fx->used = nu;
    if (nd) fx->near_seg = nd;
    if (!np || !nu || !nd) {
      fx->st = pm_error_setf(fx->err, PM_ERR_NOMEM, "out of memory");
      return -1;
    }
    fx->cap_pts = nc;
  }
  int32_t id = fx->npts++;
  qpoint *q = &fx->pts[id];
  q->key = key;
  double U, V;
  lattice_scaled(fx, i, j, &U, &V);
  scaled_to_uv(fx, U, V, q->uv);
  pm_face_point fp;
  pm_face_eval(fx->f, q->uv, 0, &fp);
  pm_v3_copy(q->x, fp.p);
  double d = pm_sizing_eval(fx->s->size, q->x);
  q->d = (d > 0 && isfinite(d)) ? d : fx->dref;
  fx->used[id] = 0;
  fx->near_seg[id] = INFINITY;
  pm_keyindex_put(&fx->index, key, id);
  return id;
}

/* Segment [a, b] against the convex quad q[4][2] (counter-clockwise): 1 if they meet. */
static double cross2(const double o[2], const double a[2], const double b[2]) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

static int point_in_quad(const double q[4][2], const double p[2]) {
  for (int k = 0; k < 4; ++k)
    if (cross2(q[k], q[(k + 1) & 3], p) < 0) return 0;
  return 1;
}

/* Closed segments [a, b] and [c, d] meet (touching counts; collinear pairs are reported as
 * meeting, which only makes a cell BOUNDARY that could have been IN or OUT: safe). */
static int segs_cross(const double a[2], const double b[2], const double c[2], const double d[2]) {
  double d1 = cross2(a, b, c), d2 = cross2(a, b, d), d3 = cross2(c, d, a), d4 = cross2(c, d, b);
  return d1 * d2 <= 0 && d3 * d4 <= 0;
}

static int seg_meets_quad(const double q[4][2], const double a[2], const double b[2]) {
  if (point_in_quad(q, a) || point_in_quad(q, b)) return 1;
  for (int k = 0; k < 4; ++k)
    if (segs_cross(a, b, q[k], q[(k + 1) & 3])) return 1;
  return 0;
}

static double point_seg_dist(const double p[2], const double a[2], const double b[2]) {
  double ab[2] = {b[0] - a[0], b[1] - a[1]}, ap[2] = {p[0] - a[0], p[1] - a[1]};
  double L2 = ab[0] * ab[0] + ab[1] * ab[1], t = L2 > 0 ? (ab[0] * ap[0] + ab[1] * ap[1]) / L2 : 0;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  double dx = ap[0] - t * ab[0], dy = ap[1] - t * ab[1];
  return sqrt(dx * dx + dy * dy);
}

static int segstack_push(face_ctx *fx, int32_t v) {
  if (fx->segstack_n == fx->segstack_cap) {
    int64_t nc = fx->segstack_cap ? 2 * fx->segstack_cap : 4096;
    int32_t *ns = realloc(fx->segstack, sizeof(int32_t) * (size_t)nc);
    if (!ns) return 0;
    fx->segstack = ns, fx->segstack_cap = nc;
  }
  fx->segstack[fx->segstack_n++] = v;
  return 1;
}

enum { CELL_IN = 0, CELL_BOUNDARY = 1 };

/* The cell with corner p1 at lattice (i, j) and side 2^k lattice steps; its loop segments are
 * segstack[sbeg, send) (BOUNDARY cells). */
static void quad_cell(face_ctx *fx, int64_t i, int64_t j, int k, int state, int64_t sbeg,
                      int64_t send) {
  if (fx->st) return;
  int64_t sz = (int64_t)1 << k;
  int32_t c[4] = {lattice_point(fx, i, j), lattice_point(fx, i + sz, j),
                  lattice_point(fx, i + sz, j + sz), lattice_point(fx, i, j + sz)};
  if (fx->st) return;
  /* 000 eq. 4.1 with 004's weight: split while some side is longer than the radii cover. */
  int split = 0;
  for (int e = 0; e < 4 && !split; ++e) {
    const qpoint *a = &fx->pts[c[e]], *b = &fx->pts[c[(e + 1) & 3]];
    if (fx->s->p.w2 * pm_v3_dist(a->x, b->x) > 0.5 * (a->d + b->d)) split = 1;
  }
  if (!split || k == 0) {
    for (int e = 0; e < 4; ++e) {
      fx->used[c[e]] = 1;
      if (state == CELL_BOUNDARY) {
        double U, V, P[2];
        int64_t ci = (e == 1 || e == 2) ? i + sz : i, cj = (e >= 2) ? j + sz : j;
        lattice_scaled(fx, ci, cj, &U, &V);
        P[0] = U, P[1] = V;
        for (int64_t q = sbeg; q < send; ++q) {
          const double *sg = &fx->seg[4 * fx->segstack[q]];
          double dd = point_seg_dist(P, sg, sg + 2);
          if (dd < fx->near_seg[c[e]]) fx->near_seg[c[e]] = dd;
        }
      }
    }
    return;
  }
  int64_t half = sz >> 1;
  const int64_t sub[4][2] = {{i, j}, {i + half, j}, {i + half, j + half}, {i, j + half}};
  for (int q = 0; q < 4 && !fx->st; ++q) {
    int64_t si = sub[q][0], sj = sub[q][1];
    if (state == CELL_IN) {
      quad_cell(fx, si, sj, k - 1, CELL_IN, 0, 0);
      continue;
    }
    /* Classify the sub-cell: its segments among the parent's. */
    double quad[4][2];
    const int64_t cc[4][2] = {{si, sj}, {si + half, sj}, {si + half, sj + half}, {si, sj + half}};
    for (int e = 0; e < 4; ++e) lattice_scaled(fx, cc[e][0], cc[e][1], &quad[e][0], &quad[e][1]);
    int64_t mybeg = fx->segstack_n;
    for (int64_t t = sbeg; t < send; ++t) {
      const double *sg = &fx->seg[4 * fx->segstack[t]];
      if (seg_meets_quad(quad, sg, sg + 2) && !segstack_push(fx, fx->segstack[t])) {
        fx->st = pm_error_setf(fx->err, PM_ERR_NOMEM, "out of memory");
        return;
      }
    }
    int64_t myend = fx->segstack_n;
    if (myend > mybeg) {
      quad_cell(fx, si, sj, k - 1, CELL_BOUNDARY, mybeg, myend);
    } else {
      double Uc = 0.25 * (quad[0][0] + quad[1][0] + quad[2][0] + quad[3][0]);
      double Vc = 0.25 * (quad[0][1] + quad[1][1] + quad[2][1] + quad[3][1]);
      double uv[2];
      scaled_to_uv(fx, Uc, Vc, uv);
      if (pm_face_inside(fx->f, uv)) quad_cell(fx, si, sj, k - 1, CELL_IN, 0, 0);
    }
    fx->segstack_n = mybeg; /* pop */
  }
}

static void face_ctx_free(face_ctx *fx) {
  free(fx->seg), free(fx->pts), pm_keyindex_free(&fx->index), free(fx->used), free(fx->near_seg);
  free(fx->segstack);
}

/* Mean |Su| and |Sv| over a 5 x 5 grid of the face's parameter box. */
static void face_scales(const pm_cell *f, double scale[2]) {
  double su = 0, sv = 0, msu = 0, msv = 0;
  for (int a = 0; a < 5; ++a)
    for (int b = 0; b < 5; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (a + 0.5) / 5,
                      f->lo[1] + (f->hi[1] - f->lo[1]) * (b + 0.5) / 5};
      pm_face_point fp;
      pm_face_eval(f, uv, 1, &fp);
      double nu = pm_v3_norm(fp.su), nv = pm_v3_norm(fp.sv);
      if (isfinite(nu)) su += nu, msu = fmax(msu, nu);
      if (isfinite(nv)) sv += nv, msv = fmax(msv, nv);
    }
  su /= 25, sv /= 25;
  scale[0] = su > 0 ? su : (msu > 0 ? msu : 1);
  scale[1] = sv > 0 ? sv : (msv > 0 ? msv : 1);
}

static pm_status place_face(bub_state *s, int32_t face, int64_t cap, pm_error *err) {
  const pm_cell *f = pm_model_cell(s->model, PM_FACE, face);
  if (f->nloop == 0) return PM_OK;
  face_ctx fx;
  memset(&fx, 0, sizeof fx);
  fx.s = s, fx.f = f, fx.face = face, fx.err = err;
  /* Lattice points include corners outside the face: allow several per bubble left (a guard
   * against runaway refinement; the cap itself is checked on the bubbles kept). */
  fx.budget = 8 * (cap - s->n) + 4096;
  face_scales(f, fx.scale);

  /* Loop segments in scaled coordinates. */
  int32_t nseg = 0;
  for (int32_t l = 0; l < f->nloop; ++l) nseg += f->loop[l].npts;
  fx.seg = malloc(sizeof(double) * 4 * (size_t)(nseg ? nseg : 1));
  if (!fx.seg) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  double box[4] = {INFINITY, INFINITY, -INFINITY, -INFINITY};
  for (int32_t l = 0; l < f->nloop; ++l) {
    const pm_loop *lp = &f->loop[l];
    for (int32_t k = 0; k < lp->npts; ++k) {
      int32_t k2 = (k + 1) % lp->npts;
      double *sg = &fx.seg[4 * fx.nseg++];
      sg[0] = (lp->uv[2 * k] - f->lo[0]) * fx.scale[0];
      sg[1] = (lp->uv[2 * k + 1] - f->lo[1]) * fx.scale[1];
      sg[2] = (lp->uv[2 * k2] - f->lo[0]) * fx.scale[0];
      sg[3] = (lp->uv[2 * k2 + 1] - f->lo[1]) * fx.scale[1];
      box[0] = fmin(box[0], sg[0]), box[1] = fmin(box[1], sg[1]);
      box[2] = fmax(box[2], sg[0]), box[3] = fmax(box[3], sg[1]);
    }
  }
  if (!(box[2] > box[0] && box[3] > box[1])) {
    face_ctx_free(&fx);
    return PM_OK; /* a face without area in parameter space carries no face bubbles */
  }
  /* The root rhombus (horizontal sides, 60 degrees) containing the box W x H: side
   * l >= W + H / sqrt3 and height sqrt3 l / 2 >= H, corner p1 at (U0 - H / sqrt3, V0). */
  double W = box[2] - box[0], H = box[3] - box[1], pad = 1e-6 * (W + H);
  W += 2 * pad, H += 2 * pad;
  double l = fmax(W + H / sqrt(3.0), 2 * H / sqrt(3.0));
  fx.origin[0] = box[0] - pad - H / sqrt(3.0);
  fx.origin[1] = box[1] - pad;
  fx.h = l / (double)((int64_t)1 << QT_LEVELS);

  /* The reference diameter: mean over the face's boundary bubbles (vertex and curve bubbles
   * already placed), else the field at the box centre, else the model's diagonal / 30. */
  double sum = 0;
  int32_t cnt = 0;
  for (int32_t i = 0; i < s->n; ++i)
    if ((s->kind[i] == BUB_KVERTEX || s->kind[i] == BUB_KCURVE) &&
        bub_related_cell(s, BUB_KFACE, face, i))
      sum += s->d[i], ++cnt;
  if (cnt) {
    fx.dref = sum / cnt;
  } else {
    double uv[2] = {0.5 * (f->lo[0] + f->hi[0]), 0.5 * (f->lo[1] + f->hi[1])}, x[3];
    pm_cell_point(f, uv, x);
    double d = pm_sizing_eval(s->size, x);
    fx.dref = (d > 0 && isfinite(d)) ? d : s->model->diagonal / 30;
  }

  /* The root is a BOUNDARY cell with every segment. */
  for (int32_t k = 0; k < fx.nseg; ++k)
    if (!segstack_push(&fx, k)) {
      face_ctx_free(&fx);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
  quad_cell(&fx, 0, 0, QT_LEVELS, CELL_BOUNDARY, 0, fx.segstack_n);
  if (fx.st) {
    pm_status st = fx.st;
    face_ctx_free(&fx);
    return st;
  }

  /* Keep the leaf corners inside the face, in lattice order (deterministic), away from the
   * boundary bubbles, the trimming polyline and each other. */
  pm_status st = PM_OK;
  pm_idbuf buf = PM_IDBUF_INIT;
  int32_t *order = malloc(sizeof(int32_t) * (size_t)(fx.npts ? fx.npts : 1));
  if (!order) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t nord = 0;
  for (int32_t k = 0; k < fx.npts && !st; ++k)
    if (fx.used[k]) order[nord++] = k;
  for (int32_t q = 0; q < nord && !st; ++q) {
    const qpoint *pt = &fx.pts[order[q]];
    if (fx.near_seg[order[q]] < 0.25 * pt->d) continue;
    if (!pm_face_inside(f, pt->uv)) continue;
    double d;
    st = bub_size_at(s, pt->x, &d, err);
    if (st) break;
    int skip = 0;
    st = bub_place_crowded(s, BUB_KFACE, face, pt->x, d, &buf, &skip, err);
    if (st || skip) continue;
    if (s->n >= cap) {
      st = pm_error_setf(err, PM_ERR_LIMIT,
                         "bubble placement exceeds the cap of %lld bubbles (face %d)",
                         (long long)cap, f->tag);
      break;
    }
    int32_t id;
    st = bub_state_add(s, BUB_KFACE, face, pt->uv, NULL, 0, &id, err);
    if (!st) st = pm_grid_insert(s->grid, id, &s->x[3 * id], s->grid_factor * s->d[id], err);
  }
  pm_idbuf_free(&buf);
  free(order);
  face_ctx_free(&fx);
  return st;
}

/* ---- all cells ---------------------------------------------------------------------------- */

pm_status bub_place_crowded(const bub_state *s, int kind, int32_t cell, const double x[3], double d,
                            pm_idbuf *buf, int *crowded, pm_error *err) {
  *crowded = 0;
  /* Neighbours within reach: grid radius is d_j, query radius d covers dist < d + d_j. */
  pm_status st = pm_grid_query_overlap(s->grid, x, 0.5 * d, buf, err);
  for (int32_t b = 0; b < buf->n && !st && !*crowded; ++b) {
    int32_t j = buf->ids[b];
    double dist = pm_v3_dist(x, &s->x[3 * j]), l0 = 0.5 * (d + s->d[j]);
    if (s->kind[j] == kind && s->cell[j] == cell) {
      if (dist < 0.25 * l0) *crowded = 1;
    } else if (bub_related_cell(s, kind, cell, j)) {
      if (dist < 0.5 * l0) *crowded = 1;
    }
  }
  return st;
}

/* The bubble count a size field asks for, from samples: the integral of ds / d over every curve
 * (16 samples) and of dA / (sqrt3 / 2 d^2) over every face (the hexagonal packing's density; 16 x
 * 16 samples of the parameter box, those inside the trimmed face). A field too fine for the cap
 * fails here, before any bubble is placed; one that only the samples miss (a narrow refinement)
 * is caught by the checks as bubbles are added. */
static double count_estimate(const bub_state *s) {
  const pm_model *m = s->model;
  double total = m->count[PM_VERTEX];
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    if (cv->degenerate) continue;
    const double h = (cv->hi[0] - cv->lo[0]) / 16;
    for (int k = 0; k < 16; ++k) {
      pm_curve_point cp;
      pm_curve_eval(cv, cv->lo[0] + (k + 0.5) * h, 1, &cp);
      double d = pm_sizing_eval(s->size, cp.p);
      if (d > 0 && isfinite(d)) total += pm_v3_norm(cp.d1) * h / d;
    }
  }
  for (int32_t f = 0; f < m->count[PM_FACE]; ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    const double hu = (fc->hi[0] - fc->lo[0]) / 16, hv = (fc->hi[1] - fc->lo[1]) / 16;
    for (int a = 0; a < 16; ++a)
      for (int b = 0; b < 16; ++b) {
        double uv[2] = {fc->lo[0] + (a + 0.5) * hu, fc->lo[1] + (b + 0.5) * hv}, n[3];
        if (!pm_face_inside(fc, uv)) continue;
        pm_face_point fp;
        pm_face_eval(fc, uv, 1, &fp);
        pm_v3_cross(n, fp.su, fp.sv);
        double d = pm_sizing_eval(s->size, fp.p);
        if (d > 0 && isfinite(d)) total += pm_v3_norm(n) * hu * hv / (0.86602540378443865 * d * d);
      }
  }
  return total;
}

pm_status bub_place(bub_state *s, pm_error *err) {
  const pm_model *m = s->model;
  int64_t cap = (int64_t)fmin(s->p.max_bubbles, 2e9);
  pm_status st = PM_OK;
  s->n = 0;
  /* The cap before growth: a size field asking for clearly more than it fails at once (a margin
   * of 1.5 for the samples' error; the quadtree starts sparser, by up to 4). */
  double want = count_estimate(s), margin = s->p.place == BUB_PLACE_LATTICE ? 1.5 : 6;
  if (!(want <= margin * (double)cap))
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "bubble: the size field asks for about %.3g bubbles, above the cap of %lld",
                         want, (long long)cap);
  pm_grid_clear(s->grid);
  for (int32_t v = 0; v < m->count[PM_VERTEX] && !st; ++v) {
    const pm_cell *c = pm_model_cell(m, PM_VERTEX, v);
    if (!c->nup && !c->nhost) continue;
    st = bub_state_add(s, BUB_KVERTEX, v, NULL, NULL, 0, NULL, err);
  }
  for (int32_t c = 0; c < m->count[PM_CURVE] && !st; ++c) {
    double *t = NULL;
    int32_t nt = 0;
    st = s->p.place == BUB_PLACE_LATTICE ? bub_place_curve_lattice(s, c, cap - s->n, &t, &nt, err)
                                         : bub_place_curve(s, c, &t, &nt, err);
    if (!st && s->n + (int64_t)nt > cap)
      st = pm_error_setf(err, PM_ERR_LIMIT,
                         "bubble placement exceeds the cap of %lld bubbles (curve %d)",
                         (long long)cap, pm_model_cell(m, PM_CURVE, c)->tag);
    for (int32_t k = 0; k < nt && !st; ++k) st = bub_state_add(s, BUB_KCURVE, c, &t[k], NULL, 0, NULL, err);
    free(t);
  }
  if (st) return st;
  /* Boundary bubbles into the grid, so that faces can keep their points away from them. */
  st = bub_state_grid_rebuild(s, err);
  if (!st && s->p.place == BUB_PLACE_LATTICE) st = bub_place_lattice(s, cap, err);
  /* The quadtree for every face with place=quadtree, and with place=lattice for a face the
   * lattice left empty: one where no border chord gave a seed inside the face (the sphere of
   * robust/occ__cube-sphere-cube-compound.brep, cut by two solids: without a face bubble its
   * triangles wrapped round the seam and the mesh came out with duplicate nodes). */
  uint8_t *empty = NULL;
  if (!st && s->p.place == BUB_PLACE_LATTICE) {
    empty = malloc((size_t)m->count[PM_FACE] + 1);
    if (!empty) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    memset(empty, 1, (size_t)m->count[PM_FACE] + 1);
    for (int32_t i = 0; i < s->n; ++i)
      if (s->kind[i] == BUB_KFACE && !(s->flags[i] & BUB_FDEAD)) empty[s->cell[i]] = 0;
  }
  for (int32_t f = 0; f < m->count[PM_FACE] && !st; ++f)
    if (s->p.place == BUB_PLACE_QUADTREE || (empty && empty[f]))
      st = place_face(s, f, cap, err);
  free(empty);
  if (st) return st;
  /* Arrays are in (kind, cell) order already; ordering sets the ranges and sorts each cell's
   * bubbles in space. */
  return bub_state_order(s, err);
}
