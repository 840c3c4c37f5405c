/* Trimming loops in parameter space: polylines, orientation, and the inside accelerator
 * (see trim.h for the structure). */
#include "common/geom/trim.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/predicates.h"
#include "common/geom/geom.h"

/* Polyline sampling of a pcurve: an interval is bisected while its midpoint lies farther than
 * SAMPLE_TOL x (diagonal of the face's parameter box) from the chord. At 2e-4 the polyline
 * misplaces the boundary by far less than any mesh size the methods use on a face of one scale
 * (it would need 5000 elements across for it to show), while a circle needs ~100 points.
 * On a large face beside a small feature that is not enough: the mesh next to the boundary is
 * as fine as the feature asks, but the polyline's chords cut off a band as wide as their sag,
 * which no particle may enter. t20_component8.step's face 0 (parameter box 27 wide) lost a
 * band 0.0055 wide along a curve whose nodes are 0.00176 apart (the feature floor); the face's
 * nodes stayed 0.014 off it, and the triangles between were needles. So an interval is also
 * bisected while its chord's midpoint lies farther than tol3d (pm_trim_build's argument) in 3D
 * from the curve's midpoint, both put on the surface: the sag the particles see. */
#define SAMPLE_TOL 2e-4
#define SAMPLE_MAX_DEPTH 10 /* at most 2^10 sub-intervals per initial interval */
#define SAMPLE_INITIAL 8    /* initial intervals per curve (16 for a closed curve) */
/* Consecutive pcurves of a loop must meet in (u, v); they may disagree slightly (pcurves of
 * unsewn models): a gap up to GAP_TOL x diagonal is bridged, a larger one is an error. */
#define GAP_TOL 2e-2

typedef struct pm_trim {
  double u0, v0;      /* grid origin */
  double cw, ch;      /* cell width and height */
  int nu, nv;         /* cells per direction */
  uint8_t *state;     /* [nu*nv] CELL_OUT, CELL_IN or CELL_MIXED */
  double rh;          /* slab height */
  int nrow;           /* slabs */
  int32_t *row_start; /* [nrow+1] CSR into row_edge */
  int32_t *row_edge;  /* edge ids per slab */
  int32_t nedge;
  double *edge;       /* [4*nedge] a.u a.v b.u b.v */
} pm_trim;

enum { CELL_OUT = 0, CELL_IN = 1, CELL_MIXED = 2 };

/* ---- polyline sampling ------------------------------------------------------------------- */

typedef struct pts_buf {
  double *uv;
  int32_t *use;
  double *t;
  int32_t n, cap;
} pts_buf;

static int buf_push(pts_buf *b, const double uv[2], int32_t use, double t) {
  if (b->n == b->cap) {
    int32_t cap = b->cap ? 2 * b->cap : 64;
    double *uvn = realloc(b->uv, sizeof(double) * 2 * (size_t)cap);
    if (!uvn) return 0;
    b->uv = uvn;
    int32_t *usen = realloc(b->use, sizeof(int32_t) * (size_t)cap);
    if (!usen) return 0;
    b->use = usen;
    double *tn = realloc(b->t, sizeof(double) * (size_t)cap);
    if (!tn) return 0;
    b->t = tn;
    b->cap = cap;
  }
  b->uv[2 * b->n] = uv[0];
  b->uv[2 * b->n + 1] = uv[1];
  b->use[b->n] = use;
  b->t[b->n] = t;
  b->n++;
  return 1;
}

/* Whether the chord from uva to uvb sags more than tol (in (u, v)) or tol3d (in 3D, on the
 * surface; 0: not asked) from the pcurve's point uvm between them. */
static int chord_sags(const pm_cell *f, const double uva[2], const double uvb[2],
                      const double uvm[2], double tol, double tol3d) {
  const double mid[2] = {0.5 * (uva[0] + uvb[0]), 0.5 * (uva[1] + uvb[1])};
  if (hypot(mid[0] - uvm[0], mid[1] - uvm[1]) > tol) return 1;
  if (!(tol3d > 0)) return 0;
  pm_face_point on_chord, on_curve;
  pm_face_eval(f, mid, 0, &on_chord);
  pm_face_eval(f, uvm, 0, &on_curve);
  double dx = on_chord.p[0] - on_curve.p[0], dy = on_chord.p[1] - on_curve.p[1],
         dz = on_chord.p[2] - on_curve.p[2];
  return dx * dx + dy * dy + dz * dz > tol3d * tol3d; /* NaN: no */
}

/* Append the samples strictly after ta up to and including tb. */
static int sample_interval(const pm_cell *f, const pm_use *use, int32_t iuse, double ta,
                           const double uva[2], double tb, const double uvb[2], double tol,
                           double tol3d, int depth, pts_buf *b) {
  double tm = 0.5 * (ta + tb), uvm[2];
  pm_face_curve_uv(f, use, tm, uvm);
  if (depth < SAMPLE_MAX_DEPTH && chord_sags(f, uva, uvb, uvm, tol, tol3d)) {
    if (!sample_interval(f, use, iuse, ta, uva, tm, uvm, tol, tol3d, depth + 1, b)) return 0;
    return sample_interval(f, use, iuse, tm, uvm, tb, uvb, tol, tol3d, depth + 1, b);
  }
  return buf_push(b, uvb, iuse, tb);
}

static pm_status sample_loop(const pm_model *m, const pm_cell *f, pm_loop *lp, double diag,
                             double tol3d, pm_error *err) {
  pts_buf b = {0};
  const double tol = SAMPLE_TOL * diag;
  for (int32_t k = 0; k < lp->nuse; ++k) {
    const pm_use *use = &lp->use[k];
    if (use->cell < 0 || use->cell >= m->count[PM_CURVE]) {
      free(b.uv), free(b.use), free(b.t);
      return pm_error_setf(err, PM_ERR_GEOM, "face %d: loop uses curve index %d of %d", f->tag,
                           (int)use->cell, (int)m->count[PM_CURVE]);
    }
    const pm_cell *c = &m->cells[PM_CURVE][use->cell];
    double t0 = use->sense >= 0 ? c->lo[0] : c->hi[0];
    double t1 = use->sense >= 0 ? c->hi[0] : c->lo[0];
    int closed = c->nbound == 2 && c->bound[0].cell == c->bound[1].cell;
    int nint = closed ? 2 * SAMPLE_INITIAL : SAMPLE_INITIAL;
    double uvp[2];
    pm_face_curve_uv(f, use, t0, uvp);
    if (b.n > 0) {
      const double *last = &b.uv[2 * (b.n - 1)];
      double gap = hypot(uvp[0] - last[0], uvp[1] - last[1]);
      if (gap > GAP_TOL * diag) {
        free(b.uv), free(b.use), free(b.t);
        return pm_error_setf(err, PM_ERR_GEOM,
                             "face %d: trimming loop not closed in (u,v): gap %.3g before curve %d "
                             "(parameter box diagonal %.3g)",
                             f->tag, gap, m->cells[PM_CURVE][use->cell].tag, diag);
      }
    }
    if (!buf_push(&b, uvp, k, t0)) goto nomem;
    for (int i = 0; i < nint; ++i) {
      double ta = t0 + (t1 - t0) * i / nint, tb = (i + 1 == nint) ? t1 : t0 + (t1 - t0) * (i + 1) / nint;
      double uvb[2];
      pm_face_curve_uv(f, use, tb, uvb);
      if (!sample_interval(f, use, k, ta, uvp, tb, uvb, tol, tol3d, 0, &b)) goto nomem;
      uvp[0] = uvb[0], uvp[1] = uvb[1];
    }
  }
  /* Closing gap between the last and the first use. */
  if (b.n > 1) {
    double gap = hypot(b.uv[0] - b.uv[2 * (b.n - 1)], b.uv[1] - b.uv[2 * (b.n - 1) + 1]);
    if (gap > GAP_TOL * diag) {
      free(b.uv), free(b.use), free(b.t);
      return pm_error_setf(err, PM_ERR_GEOM,
                           "face %d: trimming loop not closed in (u,v): closing gap %.3g "
                           "(parameter box diagonal %.3g)",
                           f->tag, gap, diag);
    }
  }
  /* Drop exact repeats (junctions of consecutive pcurves, the closing point). */
  const double dup = 1e-12 * diag;
  int32_t n = 0;
  for (int32_t i = 0; i < b.n; ++i) {
    if (n > 0 && hypot(b.uv[2 * i] - b.uv[2 * (n - 1)], b.uv[2 * i + 1] - b.uv[2 * (n - 1) + 1]) <= dup)
      continue;
    b.uv[2 * n] = b.uv[2 * i], b.uv[2 * n + 1] = b.uv[2 * i + 1];
    b.use[n] = b.use[i], b.t[n] = b.t[i];
    ++n;
  }
  while (n > 1 && hypot(b.uv[0] - b.uv[2 * (n - 1)], b.uv[1] - b.uv[2 * (n - 1) + 1]) <= dup) --n;
  if (n < 3) {
    free(b.uv), free(b.use), free(b.t);
    return pm_error_setf(err, PM_ERR_GEOM, "face %d: a trimming loop has zero extent in (u,v)",
                         f->tag);
  }
  lp->uv = b.uv, lp->pt_use = b.use, lp->pt_t = b.t, lp->npts = n;
  lp->box[0] = lp->box[2] = b.uv[0];
  lp->box[1] = lp->box[3] = b.uv[1];
  for (int32_t i = 1; i < n; ++i) {
    lp->box[0] = fmin(lp->box[0], b.uv[2 * i]), lp->box[2] = fmax(lp->box[2], b.uv[2 * i]);
    lp->box[1] = fmin(lp->box[1], b.uv[2 * i + 1]), lp->box[3] = fmax(lp->box[3], b.uv[2 * i + 1]);
  }
  return PM_OK;
nomem:
  free(b.uv), free(b.use), free(b.t);
  return pm_error_setf(err, PM_ERR_NOMEM, "face %d: out of memory sampling a loop", f->tag);
}

/* ---- polyline predicates ----------------------------------------------------------------- */

/* One edge's contribution to the crossing number of a ray from p towards +u. Returns 1 for a
 * crossing, 0 for none, and sets *on when p lies on the edge. Straddling uses the half-open
 * rule (a.v > p.v) != (b.v > p.v), so a ray through a polyline vertex counts once. */
static inline int edge_crossing(const double a[2], const double b[2], const double p[2], int *on) {
  if ((a[0] == p[0] && a[1] == p[1]) || (b[0] == p[0] && b[1] == p[1])) {
    *on = 1;
    return 0;
  }
  if ((a[1] > p[1]) != (b[1] > p[1])) {
    const double *lo = a[1] < b[1] ? a : b, *hi = a[1] < b[1] ? b : a;
    int o = pm_orient2d(lo, hi, p);
    if (o == 0) {
      *on = 1;
      return 0;
    }
    return o > 0; /* p left of the upward edge: the edge lies to the right of p */
  }
  if (a[1] == p[1] && b[1] == p[1] && p[0] >= fmin(a[0], b[0]) && p[0] <= fmax(a[0], b[0]))
    *on = 1;
  return 0;
}

int pm_polyline_inside(const double *uv, int32_t npts, const double p[2]) {
  int parity = 0, on = 0;
  for (int32_t i = 0; i < npts && !on; ++i) {
    const double *a = &uv[2 * i], *b = &uv[2 * ((i + 1) % npts)];
    parity ^= edge_crossing(a, b, p, &on);
  }
  return on || parity;
}

double pm_polyline_area(const double *uv, int32_t npts) {
  double s = 0;
  for (int32_t i = 0; i < npts; ++i) {
    const double *a = &uv[2 * i], *b = &uv[2 * ((i + 1) % npts)];
    s += (a[0] - uv[0]) * (b[1] - uv[1]) - (b[0] - uv[0]) * (a[1] - uv[1]);
  }
  return 0.5 * s;
}

static void reverse_loop(pm_loop *lp) {
  for (int32_t i = 0, j = lp->npts - 1; i < j; ++i, --j) {
    double tu = lp->uv[2 * i], tv = lp->uv[2 * i + 1];
    lp->uv[2 * i] = lp->uv[2 * j], lp->uv[2 * i + 1] = lp->uv[2 * j + 1];
    lp->uv[2 * j] = tu, lp->uv[2 * j + 1] = tv;
    double tt = lp->pt_t[i];
    lp->pt_t[i] = lp->pt_t[j], lp->pt_t[j] = tt;
    int32_t tk = lp->pt_use[i];
    lp->pt_use[i] = lp->pt_use[j], lp->pt_use[j] = tk;
  }
  for (int32_t i = 0, j = lp->nuse - 1; i < j; ++i, --j) {
    pm_use t = lp->use[i];
    lp->use[i] = lp->use[j], lp->use[j] = t;
  }
  for (int32_t k = 0; k < lp->nuse; ++k) lp->use[k].sense = (int8_t)-lp->use[k].sense;
  for (int32_t i = 0; i < lp->npts; ++i) lp->pt_use[i] = lp->nuse - 1 - lp->pt_use[i];
}

/* ---- the accelerator --------------------------------------------------------------------- */

static int clampi(int x, int lo, int hi) { return x < lo ? lo : (x > hi ? hi : x); }

static int cell_of(double x, double x0, double w, int n) {
  double c = floor((x - x0) / w);
  if (c < 0) return 0;
  if (c >= n) return n - 1;
  return (int)c;
}

static int slab_inside(const pm_trim *tr, const double p[2]) {
  int r = cell_of(p[1], tr->v0, tr->rh, tr->nrow);
  int parity = 0, on = 0;
  for (int32_t k = tr->row_start[r]; k < tr->row_start[r + 1] && !on; ++k) {
    const double *e = &tr->edge[4 * tr->row_edge[k]];
    parity ^= edge_crossing(e, e + 2, p, &on);
  }
  return on || parity;
}

static double seg_dist2(const double p[2], const double a[2], const double b[2]) {
  double ab[2] = {b[0] - a[0], b[1] - a[1]}, ap[2] = {p[0] - a[0], p[1] - a[1]};
  double L2 = ab[0] * ab[0] + ab[1] * ab[1], t = L2 > 0 ? (ab[0] * ap[0] + ab[1] * ap[1]) / L2 : 0;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  double dx = ap[0] - t * ab[0], dy = ap[1] - t * ab[1];
  return dx * dx + dy * dy;
}

double pm_trim_clearance(const pm_cell *f, const double uv[2], double rmax) {
  const pm_trim *tr = f->trim;
  if (!tr || !(rmax > 0) || !isfinite(uv[0]) || !isfinite(uv[1])) return 0;
  /* Every edge within rmax of uv overlaps a slab between v - rmax and v + rmax. */
  int r0 = cell_of(uv[1] - rmax, tr->v0, tr->rh, tr->nrow);
  int r1 = cell_of(uv[1] + rmax, tr->v0, tr->rh, tr->nrow);
  double best = rmax * rmax;
  for (int r = r0; r <= r1; ++r)
    for (int32_t k = tr->row_start[r]; k < tr->row_start[r + 1]; ++k) {
      const double *e = &tr->edge[4 * tr->row_edge[k]];
      double d2 = seg_dist2(uv, e, e + 2);
      if (d2 < best) best = d2;
    }
  /* Rounding of the squared distances: a relative margin far above it. */
  return sqrt(best) * (1 - 1e-9);
}

static pm_status build_accelerator(pm_cell *f, pm_error *err) {
  pm_trim *tr = calloc(1, sizeof *tr);
  if (!tr) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t nedge = 0;
  double box[4] = {DBL_MAX, DBL_MAX, -DBL_MAX, -DBL_MAX};
  for (int32_t l = 0; l < f->nloop; ++l) {
    nedge += f->loop[l].npts;
    box[0] = fmin(box[0], f->loop[l].box[0]), box[1] = fmin(box[1], f->loop[l].box[1]);
    box[2] = fmax(box[2], f->loop[l].box[2]), box[3] = fmax(box[3], f->loop[l].box[3]);
  }
  tr->nedge = nedge;
  tr->edge = malloc(sizeof(double) * 4 * (size_t)nedge);
  if (!tr->edge) goto nomem;
  int32_t e = 0;
  for (int32_t l = 0; l < f->nloop; ++l) {
    const pm_loop *lp = &f->loop[l];
    for (int32_t i = 0; i < lp->npts; ++i, ++e) {
      int32_t j = (i + 1) % lp->npts;
      tr->edge[4 * e] = lp->uv[2 * i], tr->edge[4 * e + 1] = lp->uv[2 * i + 1];
      tr->edge[4 * e + 2] = lp->uv[2 * j], tr->edge[4 * e + 3] = lp->uv[2 * j + 1];
    }
  }
  /* Pad the box so that points on its border fall inside the grid. */
  double w = box[2] - box[0], h = box[3] - box[1], pad = 1e-9 * (w + h) + DBL_MIN;
  box[0] -= pad, box[1] -= pad, box[2] += pad, box[3] += pad;
  w = box[2] - box[0], h = box[3] - box[1];
  tr->u0 = box[0], tr->v0 = box[1];

  /* Slabs: about two edges per slab on average; the cap bounds memory on huge loops. */
  tr->nrow = clampi(nedge / 2, 8, 4096);
  tr->rh = h / tr->nrow;
  tr->row_start = calloc((size_t)tr->nrow + 1, sizeof(int32_t));
  if (!tr->row_start) goto nomem;
  for (int pass = 0; pass < 2; ++pass) {
    for (int32_t k = 0; k < nedge; ++k) {
      const double *ed = &tr->edge[4 * k];
      int r0 = cell_of(fmin(ed[1], ed[3]), tr->v0, tr->rh, tr->nrow);
      int r1 = cell_of(fmax(ed[1], ed[3]), tr->v0, tr->rh, tr->nrow);
      for (int r = r0; r <= r1; ++r) {
        if (pass == 0)
          tr->row_start[r + 1]++;
        else
          tr->row_edge[tr->row_start[r]++] = k;
      }
    }
    if (pass == 0) {
      for (int r = 0; r < tr->nrow; ++r) tr->row_start[r + 1] += tr->row_start[r];
      tr->row_edge = malloc(sizeof(int32_t) * ((size_t)tr->row_start[tr->nrow] + 1));
      if (!tr->row_edge) goto nomem;
    } else {
      /* The fill advanced each start to the next row's start: shift back. */
      for (int r = tr->nrow; r > 0; --r) tr->row_start[r] = tr->row_start[r - 1];
      tr->row_start[0] = 0;
    }
  }

  /* Cells: at most 64 x 64 so that thousands of faces stay cheap in memory. */
  int nc = clampi((int)ceil(sqrt((double)nedge)), 4, 64);
  tr->nu = tr->nv = nc;
  tr->cw = w / nc, tr->ch = h / nc;
  tr->state = calloc((size_t)nc * nc, 1);
  if (!tr->state) goto nomem;
  for (int32_t k = 0; k < nedge; ++k) {
    const double *ed = &tr->edge[4 * k];
    int i0 = cell_of(fmin(ed[0], ed[2]), tr->u0, tr->cw, nc), i1 = cell_of(fmax(ed[0], ed[2]), tr->u0, tr->cw, nc);
    int j0 = cell_of(fmin(ed[1], ed[3]), tr->v0, tr->ch, nc), j1 = cell_of(fmax(ed[1], ed[3]), tr->v0, tr->ch, nc);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) tr->state[j * nc + i] = CELL_MIXED;
  }
  for (int j = 0; j < nc; ++j)
    for (int i = 0; i < nc; ++i) {
      if (tr->state[j * nc + i] == CELL_MIXED) continue;
      double c[2] = {tr->u0 + (i + 0.5) * tr->cw, tr->v0 + (j + 0.5) * tr->ch};
      tr->state[j * nc + i] = slab_inside(tr, c) ? CELL_IN : CELL_OUT;
    }
  f->trim = tr;
  return PM_OK;
nomem:
  free(tr->edge), free(tr->row_start), free(tr->row_edge), free(tr->state), free(tr);
  return pm_error_setf(err, PM_ERR_NOMEM, "face %d: out of memory building the inside test",
                       f->tag);
}

int pm_trim_inside(const pm_cell *f, const double uv[2]) {
  const pm_trim *tr = f->trim;
  if (!tr) return 0;
  if (!(uv[0] >= tr->u0 && uv[0] <= tr->u0 + tr->cw * tr->nu && uv[1] >= tr->v0 &&
        uv[1] <= tr->v0 + tr->ch * tr->nv))
    return 0; /* also rejects NaN */
  int i = cell_of(uv[0], tr->u0, tr->cw, tr->nu), j = cell_of(uv[1], tr->v0, tr->ch, tr->nv);
  uint8_t s = tr->state[j * tr->nu + i];
  if (s != CELL_MIXED) return s;
  return slab_inside(tr, uv);
}

/* ---- building ---------------------------------------------------------------------------- */

pm_status pm_trim_build(const pm_model *m, pm_cell *f, double tol3d, pm_error *err) {
  if (f->nloop <= 0)
    return pm_error_setf(err, PM_ERR_GEOM, "face %d has no trimming loop", f->tag);
  double du = f->hi[0] - f->lo[0], dv = f->hi[1] - f->lo[1];
  double diag = sqrt(du * du + dv * dv);
  if (!(diag > 0) || !isfinite(diag))
    return pm_error_setf(err, PM_ERR_GEOM, "face %d has an empty parameter box", f->tag);
  for (int32_t l = 0; l < f->nloop; ++l) {
    pm_status s = sample_loop(m, f, &f->loop[l], diag, tol3d, err);
    if (s) return s;
  }
  /* Outer or hole: a loop is a hole when an odd number of the other loops contain it. */
  for (int32_t l = 0; l < f->nloop; ++l) {
    pm_loop *lp = &f->loop[l];
    if (lp->outer == 0 || lp->outer == 1) continue;
    int depth = 0;
    for (int32_t k = 0; k < f->nloop; ++k) {
      if (k == l) continue;
      /* A vertex of loop l that is not on loop k decides; loops that touch share vertices. */
      for (int32_t i = 0; i < lp->npts; ++i) {
        const double *p = &lp->uv[2 * i];
        int on = 0, parity = 0;
        const pm_loop *lk = &f->loop[k];
        for (int32_t q = 0; q < lk->npts && !on; ++q)
          parity ^= edge_crossing(&lk->uv[2 * q], &lk->uv[2 * ((q + 1) % lk->npts)], p, &on);
        if (on) continue;
        depth += parity;
        break;
      }
    }
    lp->outer = (depth % 2) == 0;
  }
  /* Orientation: outer counter-clockwise, holes clockwise. */
  for (int32_t l = 0; l < f->nloop; ++l) {
    pm_loop *lp = &f->loop[l];
    double a = pm_polyline_area(lp->uv, lp->npts);
    if ((lp->outer && a < 0) || (!lp->outer && a > 0)) reverse_loop(lp);
  }
  /* Outer loops first (geom.h promises it). Stable: insertion by flag. */
  for (int32_t l = 1; l < f->nloop; ++l) {
    pm_loop cur = f->loop[l];
    int32_t k = l;
    while (k > 0 && !f->loop[k - 1].outer && cur.outer) {
      f->loop[k] = f->loop[k - 1];
      --k;
    }
    f->loop[k] = cur;
  }
  return build_accelerator(f, err);
}

void pm_trim_free(pm_cell *f) {
  pm_trim *tr = f->trim;
  if (tr) {
    free(tr->edge), free(tr->row_start), free(tr->row_edge), free(tr->state);
    free(tr);
    f->trim = NULL;
  }
  for (int32_t l = 0; l < f->nloop; ++l) {
    free(f->loop[l].uv), free(f->loop[l].pt_use), free(f->loop[l].pt_t);
    f->loop[l].uv = NULL, f->loop[l].pt_use = NULL, f->loop[l].pt_t = NULL;
    f->loop[l].npts = 0;
  }
}
