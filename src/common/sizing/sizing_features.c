/* The size a model's features ask for (see sizing_features.h). */
#include "common/sizing/sizing_features.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/geom.h"
#include "common/sizing/sizing_private.h"
#include "common/base/vec3.h"

typedef struct feat {
  double a[3], b[3]; /* a segment (a point when a == b) */
  double h;
} feat;

typedef struct bvh_node {
  double box[6];
  double hmin;
  int32_t left, right;  /* children, or -1 for a leaf */
  int32_t first, count; /* leaf: features [first, first + count) */
} bvh_node;

struct pm_feature_size {
  double d0, g, floor;
  feat *f;
  int32_t nf, capf;
  bvh_node *node;
  int32_t nnode;
};

/* Add a feature asking for spacing h. A feature below half the floor adds nothing: refining
 * towards it would pack nodes at the floor's spacing along a strip still narrower than that,
 * every triangle across it a needle (a tangential cusp: about 1 / sqrt(curvature x floor) of them
 * per side); left out, the field grows from where the feature reaches the floor into the region
 * narrower than it, which then holds a few needles, forced by the feature (needles.h).
 * A feature between half the floor and the floor asks for the floor. A width is read at the
 * midpoint of a polyline segment, and a strip that tapers through the floor reads below it there
 * while it is above it a few hundredths further along: robust/step__U_Joint_2.stp has strips
 * 0.0039 to 0.0046 wide against a floor of 0.0041, whose segments were all left out, and the
 * field stayed at 0.037 across them (24 unforced needles with bubble, triangles 0.0041 high).
 * At the floor's spacing a strip half the floor wide is crossed by triangles with angles of 45
 * degrees and more. */
static int feat_push(pm_feature_size *r, const double a[3], const double b[3], double h) {
  if (!(h < r->d0) || !(h >= 0.5 * r->floor)) return 1;
  h = fmax(h, r->floor);
  for (int k = 0; k < 3; ++k)
    if (!isfinite(a[k]) || !isfinite(b[k])) return 1; /* a failed evaluation: no feature */
  if (r->nf == r->capf) {
    int32_t nc = r->capf ? 2 * r->capf : 1024;
    feat *nf = realloc(r->f, sizeof(feat) * (size_t)nc);
    if (!nf) return 0;
    r->f = nf, r->capf = nc;
  }
  feat *f = &r->f[r->nf++];
  pm_v3_copy(f->a, a), pm_v3_copy(f->b, b);
  f->h = h;
  return 1;
}

static double seg_dist(const double p[3], const double a[3], const double b[3]) {
  double ab[3], ap[3];
  pm_v3_sub(ab, b, a);
  pm_v3_sub(ap, p, a);
  double L2 = pm_v3_dot(ab, ab), t = L2 > 0 ? pm_v3_dot(ab, ap) / L2 : 0;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  double q[3];
  pm_v3_axpy(q, a, t, ab);
  return pm_v3_dist(p, q);
}

/* ---- the hierarchy ---------------------------------------------------------------------------- */

static double fcenter(const feat *f, int k) { return 0.5 * (f->a[k] + f->b[k]); }

static int32_t bvh_build(pm_feature_size *r, int32_t first, int32_t count) {
  int32_t id = r->nnode++;
  bvh_node *nd = &r->node[id];
  for (int k = 0; k < 3; ++k) nd->box[k] = INFINITY, nd->box[k + 3] = -INFINITY;
  nd->hmin = INFINITY;
  for (int32_t i = first; i < first + count; ++i) {
    const feat *f = &r->f[i];
    for (int k = 0; k < 3; ++k) {
      nd->box[k] = fmin(nd->box[k], fmin(f->a[k], f->b[k]));
      nd->box[k + 3] = fmax(nd->box[k + 3], fmax(f->a[k], f->b[k]));
    }
    nd->hmin = fmin(nd->hmin, f->h);
  }
  nd->first = first, nd->count = count, nd->left = nd->right = -1;
  if (count <= 4) return id;
  /* Split at the median of the centres along the longest axis (quickselect). */
  int ax = 0;
  double ext = -1;
  for (int k = 0; k < 3; ++k)
    if (nd->box[k + 3] - nd->box[k] > ext) ext = nd->box[k + 3] - nd->box[k], ax = k;
  int32_t lo = first, hi = first + count - 1, mid = first + count / 2;
  while (lo < hi) {
    double pv = fcenter(&r->f[(lo + hi) / 2], ax);
    int32_t i = lo, j = hi;
    while (i <= j) {
      while (fcenter(&r->f[i], ax) < pv) ++i;
      while (fcenter(&r->f[j], ax) > pv) --j;
      if (i <= j) {
        feat t = r->f[i];
        r->f[i] = r->f[j], r->f[j] = t;
        ++i, --j;
      }
    }
    if (mid <= j)
      hi = j;
    else if (mid >= i)
      lo = i;
    else
      break;
  }
  int32_t L = bvh_build(r, first, mid - first);
  int32_t R = bvh_build(r, mid, first + count - mid);
  r->node[id].left = L, r->node[id].right = R;
  return id;
}

double pm_feature_size_eval(const pm_feature_size *r, const double xyz[3]) {
  double best = r->d0;
  if (!r->nnode) return best;
  int32_t stack[128];
  int sp = 0;
  stack[sp++] = 0;
  while (sp) {
    const bvh_node *nd = &r->node[stack[--sp]];
    if (nd->hmin + r->g * pm_v3_box_dist(xyz, nd->box) >= best) continue;
    /* A leaf, or (never below depth 64) a full stack: scan the node's features. */
    if (nd->left < 0 || sp + 2 > 128) {
      for (int32_t i = nd->first; i < nd->first + nd->count; ++i) {
        double v = r->f[i].h + r->g * seg_dist(xyz, r->f[i].a, r->f[i].b);
        if (v < best) best = v;
      }
      continue;
    }
    const bvh_node *L = &r->node[nd->left], *R = &r->node[nd->right];
    double bl = L->hmin + r->g * pm_v3_box_dist(xyz, L->box);
    double br = R->hmin + r->g * pm_v3_box_dist(xyz, R->box);
    /* The nearer child is popped first. */
    if (bl < br) {
      stack[sp++] = nd->right, stack[sp++] = nd->left;
    } else {
      stack[sp++] = nd->left, stack[sp++] = nd->right;
    }
  }
  return best;
}

/* ---- features ----------------------------------------------------------------------------- */

/* Turning angle of a curve: integral of the curvature over arc length (Simpson on 64 pieces). */
static double turning_angle(const pm_cell *c) {
  const int n = 64;
  double sum = 0, h = (c->hi[0] - c->lo[0]) / n;
  for (int k = 0; k <= n; ++k) {
    double t = c->lo[0] + k * h;
    pm_curve_point cp;
    pm_curve_eval(c, t, 1, &cp);
    double w = (k == 0 || k == n) ? 1 : (k % 2 ? 4 : 2);
    sum += w * pm_curve_curvature(c, t) * pm_v3_norm(cp.d1);
  }
  return fabs(sum * h / 3);
}

/* Polyline points per curve: CURVE_PTS evenly in t (plus 4 per 45 degrees of turning), and
 * END_PTS more towards each end at t fractions 2^-k, so that the width of a wedge or a cusp is
 * seen down to a small fraction of the curve next to its vertices. */
#define CURVE_PTS 16
#define END_PTS 24

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* The parameters of curve c's polyline (sorted, distinct); returns their count (<= cap). */
static int curve_params(const pm_cell *c, double turn, double *t, int cap) {
  int n = CURVE_PTS + (int)fmin(4 * ceil(turn / (M_PI / 4)), 256), k = 0;
  for (int i = 0; i <= n && k < cap; ++i) t[k++] = c->lo[0] + (c->hi[0] - c->lo[0]) * i / n;
  for (int e = 1; e <= END_PTS && k + 2 <= cap; ++e) {
    double w = ldexp(1.0, -e) / n;
    t[k++] = c->lo[0] + (c->hi[0] - c->lo[0]) * w;
    t[k++] = c->hi[0] - (c->hi[0] - c->lo[0]) * w;
  }
  qsort(t, (size_t)k, sizeof(double), cmp_double);
  int m = 0;
  for (int i = 0; i < k; ++i)
    if (m == 0 || t[i] > t[m - 1]) t[m++] = t[i];
  return m;
}

/* sin(15 degrees): see the narrow-face features below. */
#define WEDGE_SIN 0.25881904510252074
#define MAX_CURVE_PTS (CURVE_PTS + 256 + 2 * END_PTS + 2)

/* The narrow-face features read a strip's width at most this many times per polyline segment. */
#define WIDTH_PIECES 64

/* What the width of face fc at a point of its boundary curve ca is read against. */
typedef struct width_ctx {
  const pm_model *m;
  const pm_cell *fc;
  int32_t ca;
  const double *pts;   /* the curves' polylines */
  const double *tpar;  /* their points' parameters on their curves */
  const int32_t *poff; /* curve c's points: [poff[c], poff[c + 1]) */
} width_ctx;

/* The width of the face at x, a point of curve ca: the distance to the face's other boundary
 * curves, for two curves that share a vertex only where it is below WEDGE_SIN times the
 * distance to that vertex (a corner narrower than 15 degrees: a wider corner's tip is one
 * triangle whose angle there is the corner's, no needle, and refining it would only add
 * nodes). Against the other curves' polylines, and, when `exact`, against the curves themselves
 * where their polylines come within twice the best width so far (projected on from the nearest
 * chord's middle).
 * INFINITY when no other curve counts. */
static double width_at(const width_ctx *wc, const double x[3], int exact, int32_t *near_curve,
                       int32_t *near_seg) {
  const pm_model *m = wc->m;
  const pm_cell *fc = wc->fc, *cva = pm_model_cell(m, PM_CURVE, wc->ca);
  double w = INFINITY;
  *near_curve = *near_seg = -1;
  for (int32_t b = 0; b < fc->nbound; ++b) {
    int32_t cb = fc->bound[b].cell;
    if (cb == wc->ca) continue;
    const pm_cell *cvb = pm_model_cell(m, PM_CURVE, cb);
    if (cvb->degenerate || wc->poff[cb + 1] - wc->poff[cb] < 2) continue;
    double wb = INFINITY;
    int32_t qb = -1;
    for (int32_t q = wc->poff[cb]; q + 1 < wc->poff[cb + 1]; ++q) {
      const double d = seg_dist(x, &wc->pts[3 * q], &wc->pts[3 * (q + 1)]);
      if (d < wb) wb = d, qb = q;
    }
    if (exact && wb < 2 * w) {
      /* From the nearest chord's middle: the curve's nearest point, not another local one. A
       * chord that passes nearer than its curve keeps its (smaller) distance. */
      double t = 0.5 * (wc->tpar[qb] + wc->tpar[qb + 1]), d;
      if (pm_cell_project(cvb, x, &t, &t, NULL, &d, NULL) == PM_OK && isfinite(d))
        wb = fmin(wb, d);
    }
    double s = INFINITY;
    for (int32_t u = 0; u < cva->nbound; ++u)
      for (int32_t v = 0; v < cvb->nbound; ++v)
        if (cva->bound[u].cell == cvb->bound[v].cell)
          s = fmin(s, pm_v3_dist(x, m->cells[PM_VERTEX][cva->bound[u].cell].xyz));
    if (s < INFINITY && !(wb < WEDGE_SIN * s)) continue;
    if (wb < w) w = wb, *near_curve = cb, *near_seg = qb;
  }
  return w;
}

/* How far curve c strays from the chord of its polyline segment q (points q, q + 1 of pts, at
 * parameters tpar): the distance from the chord's midpoint to the curve's point halfway in t. */
static double chord_sagitta(const pm_cell *c, const double *pts, const double *tpar, int32_t q) {
  double t = 0.5 * (tpar[q] + tpar[q + 1]), x[3], mid[3];
  pm_cell_point(c, &t, x);
  pm_v3_add(mid, &pts[3 * q], &pts[3 * (q + 1)]);
  pm_v3_scale(mid, mid, 0.5);
  return pm_v3_dist(x, mid);
}

static pm_status build(const pm_model *m, unsigned kinds, pm_feature_size *r, pm_error *err) {
  const int32_t ncur = m->count[PM_CURVE];
  /* Per-curve polylines (shared by the curve and the width features). */
  int32_t *poff = malloc(sizeof(int32_t) * ((size_t)ncur + 1));
  double *turn = malloc(sizeof(double) * ((size_t)ncur + 1));
  double *pts = malloc(sizeof(double) * 3 * ((size_t)ncur * MAX_CURVE_PTS + 1));
  double *tpar = malloc(sizeof(double) * ((size_t)ncur * MAX_CURVE_PTS + 1));
  if (!poff || !turn || !pts || !tpar) {
    free(poff), free(turn), free(pts), free(tpar);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  poff[0] = 0;
  int ok = 1;
  for (int32_t c = 0; c < ncur; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    int npts = 0;
    turn[c] = 0;
    if (!cv->degenerate) {
      double t[MAX_CURVE_PTS];
      turn[c] = turning_angle(cv);
      npts = curve_params(cv, turn[c], t, MAX_CURVE_PTS);
      for (int k = 0; k < npts; ++k) {
        pm_cell_point(cv, &t[k], &pts[3 * ((size_t)poff[c] + k)]);
        tpar[poff[c] + k] = t[k];
      }
    }
    poff[c + 1] = poff[c] + npts;
    if (!(kinds & PM_FEATURE_CURVES) || npts < 2) continue;
    /* Short or curved curves: one h for the whole curve, along its even polyline (the points
     * added towards the ends are for the widths below; here they would only multiply the
     * features every evaluation visits). */
    int closed = cv->nbound >= 2 && cv->bound[0].cell == cv->bound[1].cell;
    double nseg = fmax(closed ? 3 : 1, ceil(turn[c] / (M_PI / 4) - 1e-9));
    double h = pm_curve_length(cv, cv->lo[0], cv->hi[0]) / nseg;
    int n = CURVE_PTS + (int)fmin(4 * ceil(turn[c] / (M_PI / 4)), 256);
    double a[3], b[3];
    pm_cell_point(cv, &cv->lo[0], a);
    for (int k = 1; k <= n && ok; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / n;
      pm_cell_point(cv, &t, b);
      ok = feat_push(r, a, b, h);
      pm_v3_copy(a, b);
    }
  }
  /* Narrow faces: along each boundary curve, the width of the face (width_at). */
  for (int32_t f = 0; f < m->count[PM_FACE] && ok && (kinds & PM_FEATURE_WIDTH); ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    for (int32_t a = 0; a < fc->nbound && ok; ++a) {
      int32_t ca = fc->bound[a].cell;
      const pm_cell *cva = pm_model_cell(m, PM_CURVE, ca);
      if (cva->degenerate || poff[ca + 1] - poff[ca] < 2) continue;
      int seen = 0; /* a seam's second use */
      for (int32_t q = 0; q < a; ++q) seen |= fc->bound[q].cell == ca;
      if (seen) continue;
      for (int32_t k = poff[ca]; k + 1 < poff[ca + 1] && ok; ++k) {
        const width_ctx wc = {m, fc, ca, pts, tpar, poff};
        const double *a0 = &pts[3 * k], *a1 = &pts[3 * (k + 1)];
        double mid[3];
        pm_v3_add(mid, a0, a1);
        pm_v3_scale(mid, mid, 0.5);
        int32_t cb, qb;
        const double w = width_at(&wc, mid, 0, &cb, &qb), len = pm_v3_dist(a0, a1);
        /* The strip is narrower than the polyline's segment here and a chord of either side
         * strays from its curve by more than a tenth of the width: read at a chord's midpoint
         * and against the other curves' chords, the width is off by their sagittas, which
         * can be wider than the strip (solid56.step: a circle of radius 24.5 passes 0.0095 from
         * an arc of its face, and its 48 chords, 3.2 long, read 0.06 or more). Read it on the
         * curve itself, at pieces of the segment about as long as the width, against the other
         * curves themselves. Straight strips (sheet metal's sides) read exactly as they are. */
        if (!(w < len) || !(chord_sagitta(cva, pts, tpar, k) > 0.1 * w ||
                            chord_sagitta(pm_model_cell(m, PM_CURVE, cb), pts, tpar, qb) > 0.1 * w)) {
          if (isfinite(w)) ok = feat_push(r, a0, a1, w);
          continue;
        }
        const int n = (int)fmin(WIDTH_PIECES, ceil(len / fmax(w, 1e-300)));
        double p0[3];
        pm_v3_copy(p0, a0);
        for (int q = 0; q < n && ok; ++q) {
          double t = tpar[k] + (tpar[k + 1] - tpar[k]) * (q + 0.5) / n, x[3], p1[3];
          pm_cell_point(cva, &t, x);
          if (q + 1 < n) {
            double te = tpar[k] + (tpar[k + 1] - tpar[k]) * (q + 1) / n;
            pm_cell_point(cva, &te, p1);
          } else {
            pm_v3_copy(p1, a1);
          }
          const double wq = width_at(&wc, x, 1, &cb, &qb);
          if (isfinite(wq)) ok = feat_push(r, p0, p1, wq);
          pm_v3_copy(p0, p1);
        }
      }
    }
  }
  free(pts), free(poff), free(turn), free(tpar);
  /* Curved faces. */
  for (int32_t f = 0; f < m->count[PM_FACE] && ok && (kinds & PM_FEATURE_CURVATURE); ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    if (!(fc->hi[0] > fc->lo[0]) || !(fc->hi[1] > fc->lo[1])) continue;
    /* A coarse look for the largest curvature, then samples every ~2 h in object space. */
    double kmx = 0, su = 0, sv = 0;
    for (int a = 0; a < 9; ++a)
      for (int b = 0; b < 9; ++b) {
        double uv[2] = {fc->lo[0] + (fc->hi[0] - fc->lo[0]) * (a + 0.5) / 9,
                        fc->lo[1] + (fc->hi[1] - fc->lo[1]) * (b + 0.5) / 9};
        double k1, k2;
        pm_face_curvatures(fc, uv, &k1, &k2, NULL);
        if (isfinite(k1)) kmx = fmax(kmx, fabs(k1));
        pm_face_point fp;
        pm_face_eval(fc, uv, 1, &fp);
        su = fmax(su, pm_v3_norm(fp.su)), sv = fmax(sv, pm_v3_norm(fp.sv));
      }
    double h = kmx > 0 ? (M_PI / 4) / kmx : INFINITY;
    if (!(h < r->d0)) continue;
    double Lu = su * (fc->hi[0] - fc->lo[0]), Lv = sv * (fc->hi[1] - fc->lo[1]);
    /* Not below a tenth of the face's smaller extent: the curvature of a cone grows without
     * bound towards its apex (8 edges per turn at every radius would refine forever), while a
     * cylinder or a fillet of radius R, whose smaller extent is its arc, still gets 0.785 R. */
    double hfloor = 0.1 * fmin(Lu, Lv);
    int nu = (int)fmin(fmax(ceil(Lu / (2 * h)), 3), 64), nv = (int)fmin(fmax(ceil(Lv / (2 * h)), 3), 64);
    /* Cell-centred samples: never on a singular side (a pole, an apex), where the curvature is
     * unbounded. */
    for (int a = 0; a < nu && ok; ++a)
      for (int b = 0; b < nv && ok; ++b) {
        double uv[2] = {fc->lo[0] + (fc->hi[0] - fc->lo[0]) * (a + 0.5) / nu,
                        fc->lo[1] + (fc->hi[1] - fc->lo[1]) * (b + 0.5) / nv};
        if (!pm_face_inside(fc, uv)) continue;
        double k1, k2, x[3];
        pm_face_curvatures(fc, uv, &k1, &k2, NULL);
        if (!(fabs(k1) > 0) || !isfinite(k1)) continue;
        pm_cell_point(fc, uv, x);
        ok = feat_push(r, x, x, fmax((M_PI / 4) / fabs(k1), hfloor));
      }
  }
  if (!ok) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  if (r->nf) {
    r->node = malloc(sizeof(bvh_node) * 2 * (size_t)r->nf);
    if (!r->node) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    bvh_build(r, 0, r->nf);
  }
  return PM_OK;
}

pm_status pm_feature_size_create(const pm_model *m, double d0, double grade, unsigned kinds,
                                 pm_feature_size **out, pm_error *err) {
  *out = NULL;
  if (!(d0 > 0)) return pm_error_setf(err, PM_ERR_ARG, "feature size: base size must be > 0, got %g", d0);
  if (!(grade > 0 && grade <= 10))
    return pm_error_setf(err, PM_ERR_ARG, "feature size: grade must be in (0, 10], got %g", grade);
  pm_feature_size *r = calloc(1, sizeof *r);
  if (!r) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  r->d0 = d0, r->g = grade;
  r->floor = PM_FEATURE_FLOOR * (m->diagonal > 0 ? m->diagonal : 1);
  pm_status s = build(m, kinds, r, err);
  if (s) {
    pm_feature_size_destroy(r);
    return s;
  }
  *out = r;
  return PM_OK;
}

int32_t pm_feature_size_count(const pm_feature_size *fs) { return fs ? fs->nf : 0; }

void pm_feature_size_destroy(pm_feature_size *fs) {
  if (!fs) return;
  free(fs->f), free(fs->node);
  free(fs);
}

/* ---- as a size field ------------------------------------------------------------------------- */

pm_status pm_sizing_features(const pm_sizing *base, pm_feature_size *fs, pm_sizing **out,
                             pm_error *err) {
  *out = NULL;
  if (!fs) return pm_error_setf(err, PM_ERR_ARG, "feature size field: no features");
  pm_sizing *s = pm_sizing_alloc(SZ_FEATURES);
  char buf[320];
  if (base)
    snprintf(buf, sizeof buf, "%s, capped at %d features of the model (grade %g)",
             pm_sizing_describe(base), (int)fs->nf, fs->g);
  else
    snprintf(buf, sizeof buf, "%g, capped at %d features of the model (grade %g)", fs->d0,
             (int)fs->nf, fs->g);
  if (!s || !(s->desc = strdup(buf))) {
    free(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  }
  s->features = fs;
  if (base) {
    s->base = (pm_sizing *)base;
    atomic_fetch_add(&s->base->refs, 1);
  }
  *out = s;
  return PM_OK;
}

double sz_features_eval(const pm_sizing *s, const double xyz[3]) {
  double f = pm_feature_size_eval(s->features, xyz);
  if (!s->base) return f;
  double b = pm_sizing_eval(s->base, xyz);
  return b < f ? b : f;
}
