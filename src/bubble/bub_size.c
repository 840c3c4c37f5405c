/* The default size rule of the bubble method, for a model given without a size field.
 *
 *   d(x) = min( D / size_div,  min over features k of ( h_k + g dist(x, k) ) )
 *
 * D is the model's bounding-box diagonal, size_div = 30 and g = size_grade = 0.3 by default. A
 * feature is a piece of the model too small, thin or curved for D / size_div, with the size h_k
 * it needs; the field grows away from it at rate g (so it is g-Lipschitz: neighbouring bubbles
 * differ in size by at most a factor 1 + g, which the packing follows without distortion):
 *   - short curves: a curve of length L carries h = L / n, n = 1 for an open curve, at least 3
 *     for a closed one (a closed chain needs 3 nodes), and at least its turning angle / (pi/4)
 *     (an arc is split every 45 degrees, so a circle gets 8 segments); the feature is the curve's
 *     polyline;
 *   - thin faces: along every boundary curve of a face, the distance w to the nearest boundary
 *     curve of the same face that shares no vertex with it (the width of a strip, of a fillet, of
 *     a rim, of the material between a hole and an outer edge) gives h = w: a strip then gets
 *     one row of near-equilateral triangles across (height 0.87 h <= w) instead of slivers;
 *   - curved faces: at samples of a face, h = (pi/4) / |kmax| (8 edges per full turn of the
 *     largest principal curvature), so that a thin cylinder or a small fillet is not flattened
 *     into a few triangles.
 * Features whose h is not below D / size_div are left out. A model with none gets the uniform
 * D / size_div.
 *
 * Evaluation is a branch-and-bound search in a bounding-volume hierarchy over the features: a
 * node is skipped when h_min(node) + g dist(x, box(node)) cannot beat the best value found, so an
 * evaluation visits a few nodes whatever the number of features. Exact (every feature that can
 * win is examined), deterministic and thread-safe (read-only data).
 *
 * bub_run uses this exact field (a callback freed with the run). bub_default_size, which hands a
 * field to a caller who owns it (pm_sizing has no owned-callback form), returns the same rule
 * sampled on a triangulation of the model: the bubbles of the initial placement under the exact
 * rule, connected by pm_connect, with the exact values at the nodes, interpolated linearly on the
 * triangles (sizing.h, pm_sizing_sampled); when the connection fails, the nodes alone (inverse
 * distance weighting).
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/connect.h"
#include "common/vec3.h"

typedef struct feat {
  double a[3], b[3]; /* a segment (a point when a == b) */
  double h;
} feat;

typedef struct bvh_node {
  double box[6];
  double hmin;
  int32_t left, right; /* children, or -1 for a leaf */
  int32_t first, count; /* leaf: features [first, first + count) */
} bvh_node;

typedef struct size_rule {
  double d0, g;
  feat *f;
  int32_t nf, capf;
  bvh_node *node;
  int32_t nnode;
} size_rule;

static int feat_push(size_rule *r, const double a[3], const double b[3], double h) {
  if (!(h < r->d0)) return 1;
  /* A floor: no feature asks for less than 1e-3 of the base size (a guard against measurements
   * that go to zero, a curvature at a singular point, touching curves). */
  if (!(h > 1e-3 * r->d0)) h = 1e-3 * r->d0;
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

static double box_dist(const double p[3], const double box[6]) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    double e = p[k] < box[k] ? box[k] - p[k] : (p[k] > box[k + 3] ? p[k] - box[k + 3] : 0);
    s += e * e;
  }
  return sqrt(s);
}

/* ---- the hierarchy ---------------------------------------------------------------------------- */

static double fcenter(const feat *f, int k) { return 0.5 * (f->a[k] + f->b[k]); }

static int32_t bvh_build(size_rule *r, int32_t first, int32_t count) {
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
  /* Split at the median of the centres along the longest axis (nth_element by insertion into
   * halves via a partial quicksort). */
  int ax = 0;
  double ext = -1;
  for (int k = 0; k < 3; ++k)
    if (nd->box[k + 3] - nd->box[k] > ext) ext = nd->box[k + 3] - nd->box[k], ax = k;
  int32_t lo = first, hi = first + count - 1, mid = first + count / 2;
  while (lo < hi) { /* quickselect */
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

static double rule_eval(const double xyz[3], void *user) {
  const size_rule *r = user;
  double best = r->d0;
  if (!r->nnode) return best;
  int32_t stack[128];
  int sp = 0;
  stack[sp++] = 0;
  while (sp) {
    const bvh_node *nd = &r->node[stack[--sp]];
    if (nd->hmin + r->g * box_dist(xyz, nd->box) >= best) continue;
    if (nd->left < 0) {
      for (int32_t i = nd->first; i < nd->first + nd->count; ++i) {
        double v = r->f[i].h + r->g * seg_dist(xyz, r->f[i].a, r->f[i].b);
        if (v < best) best = v;
      }
      continue;
    }
    const bvh_node *L = &r->node[nd->left], *R = &r->node[nd->right];
    double bl = L->hmin + r->g * box_dist(xyz, L->box), br = R->hmin + r->g * box_dist(xyz, R->box);
    if (sp + 2 > 128) { /* cannot happen for depth < 64; keep the search exact anyway */
      for (int32_t i = nd->first; i < nd->first + nd->count; ++i) {
        double v = r->f[i].h + r->g * seg_dist(xyz, r->f[i].a, r->f[i].b);
        if (v < best) best = v;
      }
      continue;
    }
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

/* The polyline of a curve with n + 1 points. */
static void curve_points(const pm_cell *c, int n, double *pts) {
  for (int k = 0; k <= n; ++k) {
    double t = c->lo[0] + (c->hi[0] - c->lo[0]) * k / n;
    pm_cell_point(c, &t, &pts[3 * k]);
  }
}

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

#define CURVE_PTS 16 /* polyline points per curve for distances (plus 4 per 45 degrees) */

static pm_status build_rule(const pm_model *m, const bub_params *p, size_rule *r, pm_error *err) {
  memset(r, 0, sizeof *r);
  r->d0 = (m->diagonal > 0 ? m->diagonal : 1) / p->size_div;
  r->g = p->size_grade;
  int32_t ncur = m->count[PM_CURVE];
  /* Per-curve polylines (shared by the curve and the thin-face features). */
  int32_t *poff = malloc(sizeof(int32_t) * ((size_t)ncur + 1));
  if (!poff) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  poff[0] = 0;
  double *turn = malloc(sizeof(double) * ((size_t)ncur + 1));
  double *len = malloc(sizeof(double) * ((size_t)ncur + 1));
  if (!turn || !len) {
    free(poff), free(turn), free(len);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t c = 0; c < ncur; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    int npts = 0;
    turn[c] = len[c] = 0;
    if (!cv->degenerate) {
      turn[c] = turning_angle(cv);
      len[c] = bub_curve_length(cv, cv->lo[0], cv->hi[0]);
      npts = CURVE_PTS + (int)fmin(4 * ceil(turn[c] / (M_PI / 4)), 256);
    }
    poff[c + 1] = poff[c] + npts;
  }
  double *pts = malloc(sizeof(double) * 3 * ((size_t)poff[ncur] + 1));
  if (!pts) {
    free(poff), free(turn), free(len);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  int ok = 1;
  for (int32_t c = 0; c < ncur; ++c) {
    int npts = poff[c + 1] - poff[c];
    if (npts < 2) continue;
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    curve_points(cv, npts - 1, &pts[3 * poff[c]]);
    /* Short or curved curves. */
    int closed = cv->nbound >= 2 && cv->bound[0].cell == cv->bound[1].cell;
    double nseg = fmax(closed ? 3 : 1, ceil(turn[c] / (M_PI / 4) - 1e-9));
    double h = len[c] / nseg;
    for (int k = 0; k + 1 < npts && ok; ++k)
      ok = feat_push(r, &pts[3 * (poff[c] + k)], &pts[3 * (poff[c] + k + 1)], h);
  }
  /* Thin faces: distances between the polylines of non-adjacent boundary curves. */
  for (int32_t f = 0; f < m->count[PM_FACE] && ok; ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    for (int32_t a = 0; a < fc->nbound && ok; ++a) {
      int32_t ca = fc->bound[a].cell;
      const pm_cell *cva = pm_model_cell(m, PM_CURVE, ca);
      if (cva->degenerate || poff[ca + 1] - poff[ca] < 2) continue;
      /* Skip a repeated use (seams) of the same curve. */
      int seen = 0;
      for (int32_t q = 0; q < a; ++q) seen |= fc->bound[q].cell == ca;
      if (seen) continue;
      for (int32_t k = poff[ca]; k + 1 < poff[ca + 1] && ok; ++k) {
        double mid[3];
        pm_v3_add(mid, &pts[3 * k], &pts[3 * (k + 1)]);
        pm_v3_scale(mid, mid, 0.5);
        double w = INFINITY;
        for (int32_t b = 0; b < fc->nbound; ++b) {
          int32_t cb = fc->bound[b].cell;
          if (cb == ca) continue;
          const pm_cell *cvb = pm_model_cell(m, PM_CURVE, cb);
          if (cvb->degenerate || poff[cb + 1] - poff[cb] < 2) continue;
          /* Curves that share a vertex are sides meeting at a corner: not a width. */
          int adj = 0;
          for (int32_t u = 0; u < cva->nbound; ++u)
            for (int32_t v = 0; v < cvb->nbound; ++v) adj |= cva->bound[u].cell == cvb->bound[v].cell;
          if (adj) continue;
          for (int32_t q = poff[cb]; q + 1 < poff[cb + 1]; ++q)
            w = fmin(w, seg_dist(mid, &pts[3 * q], &pts[3 * (q + 1)]));
        }
        if (isfinite(w)) ok = feat_push(r, &pts[3 * k], &pts[3 * (k + 1)], w);
      }
    }
  }
  free(pts), free(poff), free(turn), free(len);
  /* Curved faces. */
  for (int32_t f = 0; f < m->count[PM_FACE] && ok; ++f) {
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
  if (!ok) {
    free(r->f);
    r->f = NULL;
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  if (r->nf) {
    r->node = malloc(sizeof(bvh_node) * 2 * (size_t)r->nf);
    if (!r->node) {
      free(r->f);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    bvh_build(r, 0, r->nf);
  }
  return PM_OK;
}

static void rule_free(size_rule *r) {
  if (!r) return;
  free(r->f), free(r->node);
  free(r);
}

/* The exact rule as a callback field; *rule must be released with bub_size_rule_free after the
 * field. Used by bub_run. */
pm_status bub_size_rule_create(const pm_model *m, const bub_params *p, pm_sizing **field,
                               void **rule, pm_error *err) {
  *field = NULL, *rule = NULL;
  size_rule *r = calloc(1, sizeof *r);
  if (!r) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status st = build_rule(m, p, r, err);
  if (st) {
    free(r);
    return st;
  }
  char desc[160];
  snprintf(desc, sizeof desc, "bubble default size (diagonal/%g, %d small features, grade %g)",
           p->size_div, (int)r->nf, p->size_grade);
  st = pm_sizing_callback(rule_eval, r, desc, field, err);
  if (st) {
    rule_free(r);
    return st;
  }
  *rule = r;
  return PM_OK;
}

void bub_size_rule_free(void *rule) { rule_free(rule); }

pm_status bub_default_size(const pm_model *model, const void *params, uint64_t seed, int threads,
                           pm_sizing **out, pm_error *err) {
  *out = NULL;
  bub_params p;
  if (params)
    p = *(const bub_params *)params;
  else
    bub_params_init(&p);
  pm_sizing *exact = NULL;
  void *rule = NULL;
  pm_status st = bub_size_rule_create(model, &p, &exact, &rule, err);
  if (st) return st;
  /* Samples: the initial placement under the exact rule (no subdivision weights: w1 = w2 = 1,
   * so the samples are at least as dense as the field asks). */
  p.w1 = 1, p.w2 = 1;
  bub_state *s = NULL;
  pm_mesh *mesh = NULL;
  double *val = NULL;
  st = bub_state_create(model, exact, &p, threads, seed, &s, err);
  if (!st) st = bub_place(s, err);
  if (!st && !(mesh = pm_mesh_create())) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < (s ? s->n : 0) && !st; ++i)
    st = pm_mesh_add_node(mesh, &s->x[3 * i], s->kind[i], s->cell[i], &s->par[2 * i], NULL, err);
  if (!st) {
    pm_connect_params cp;
    pm_connect_params_init(&cp);
    cp.flips = PM_FLIP_NONE;
    pm_error ce = {0};
    if (pm_connect(model, mesh, &cp, NULL, &ce) != PM_OK) {
      /* Nodes alone: the sampled field falls back to inverse-distance weighting. */
      mesh->ntri = mesh->nseg = mesh->ntet = 0;
    }
    val = malloc(sizeof(double) * ((size_t)mesh->nnode + 1));
    if (!val) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t i = 0; i < mesh->nnode && !st; ++i) val[i] = rule_eval(&mesh->xyz[3 * i], rule);
  }
  if (!st && mesh->nnode == 0) {
    /* Nothing to sample (a model without curves or faces): the uniform size. */
    st = pm_sizing_constant(((size_rule *)rule)->d0, out, err);
  } else if (!st) {
    st = pm_sizing_sampled(mesh, val, out, err);
  }
  free(val);
  pm_mesh_destroy(mesh);
  bub_state_destroy(s);
  pm_sizing_destroy(exact);
  rule_free(rule);
  return st;
}
