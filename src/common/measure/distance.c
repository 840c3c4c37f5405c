/* The two-sided mesh-to-model distance (see distance.h for what is measured and how). */
#include "common/measure/distance.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/cdt_cgal.h"
#include "common/backends/closest_embree.h"
#include "common/mesh/mesh_topo.h"
#include "common/geom/trim.h"
#include "common/base/vec3.h"

void pm_distance_params_init(pm_distance_params *p) {
  p->spacing = 0.25;
  p->tri_level = 4;
  p->quadrature = 2;
  p->refine_fit = 1;
  p->refine = 16;
  p->max_face_samples = 250000;
  p->max_samples = 4000000;
  p->ref_tol = 1e-4;
  p->ref_spacing = 0.5;
  p->ref_max_points = 100000;
  p->ref_per_tri = 16;
  p->model_per_tri = 16;
  p->prune = 1;
  p->ref_split = 1;
}

pm_status pm_distance_params_check(const pm_distance_params *p, pm_error *err) {
  if (!(p->spacing > 0 && p->spacing <= 1))
    return pm_error_setf(err, PM_ERR_ARG, "distance: spacing must be in (0, 1], got %g", p->spacing);
  if (p->tri_level < 1 || p->tri_level > 32)
    return pm_error_setf(err, PM_ERR_ARG, "distance: tri_level must be in 1..32, got %d",
                         (int)p->tri_level);
  if (p->quadrature < 0 || p->quadrature > 2)
    return pm_error_setf(err, PM_ERR_ARG, "distance: quadrature must be 0, 1 or 2, got %d",
                         (int)p->quadrature);
  if (p->refine_fit != 0 && p->refine_fit != 1)
    return pm_error_setf(err, PM_ERR_ARG, "distance: refine_fit must be 0 or 1, got %d",
                         (int)p->refine_fit);
  if (p->refine < 0 || p->refine > 256)
    return pm_error_setf(err, PM_ERR_ARG, "distance: refine must be in 0..256, got %d",
                         (int)p->refine);
  if (p->max_face_samples < 16)
    return pm_error_setf(err, PM_ERR_ARG, "distance: max_face_samples must be >= 16, got %lld",
                         (long long)p->max_face_samples);
  if (p->max_samples < 1000)
    return pm_error_setf(err, PM_ERR_ARG, "distance: max_samples must be >= 1000, got %lld",
                         (long long)p->max_samples);
  if (!(p->ref_tol >= 1e-7 && p->ref_tol <= 1e-2))
    return pm_error_setf(err, PM_ERR_ARG, "distance: ref_tol must be in [1e-7, 1e-2], got %g",
                         p->ref_tol);
  if (!(p->ref_spacing > 0 && p->ref_spacing <= 1))
    return pm_error_setf(err, PM_ERR_ARG, "distance: ref_spacing must be in (0, 1], got %g",
                         p->ref_spacing);
  if (p->ref_per_tri < 1 || p->ref_per_tri > 1000000)
    return pm_error_setf(err, PM_ERR_ARG, "distance: ref_per_tri must be in 1..1000000, got %d",
                         (int)p->ref_per_tri);
  if (p->model_per_tri < 1 || p->model_per_tri > 1000000)
    return pm_error_setf(err, PM_ERR_ARG, "distance: model_per_tri must be in 1..1000000, got %d",
                         (int)p->model_per_tri);
  if (p->prune != 0 && p->prune != 1)
    return pm_error_setf(err, PM_ERR_ARG, "distance: prune must be 0 or 1, got %d", (int)p->prune);
  if (p->ref_split != 0 && p->ref_split != 1)
    return pm_error_setf(err, PM_ERR_ARG, "distance: ref_split must be 0 or 1, got %d",
                         (int)p->ref_split);
  if (p->ref_max_points < 100)
    return pm_error_setf(err, PM_ERR_ARG, "distance: ref_max_points must be >= 100, got %lld",
                         (long long)p->ref_max_points);
  return PM_OK;
}

/* ---- projection onto one cell --------------------------------------------------------------- */

/* Gauss-Newton iterations of a projection. From a start within a few mesh edges of the foot the
 * iteration contracts by about (distance x curvature) per step; 40 is a cap for bad cases. Every
 * accepted step decreases the distance (halving the step up to 12 times), so whatever the
 * iteration count the result is a point of the cell at least as close as the start. */
#define FOOT_MAX_IT 40
#define FOOT_BACKTRACK 12
/* Stop when the 3D step falls below this fraction of the model diagonal: far below any distance
 * worth reporting (chordal errors of meshes are 1e-6 .. 1e-2 of the diagonal), and 12% fewer
 * surface evaluations than going on to round-off (1e-14) with the same figures to 15 digits on
 * simple_plane.brep. */
#define FOOT_STEP_TOL 1e-10
/* ... or when the distance at the current point is already within this fraction of the diagonal
 * of the foot's: at a point of the surface whose residual x - S has the tangential part t and
 * the normal part n, the foot's distance is |n| to second order and the current one
 * sqrt(|t|^2 + |n|^2), larger by |t|^2 / (2 d). The distance is stationary at the foot, so it is
 * known to 1e-12 of the diagonal long before the foot is known to 1e-10: a step that would
 * change it by less is not taken. */
#define FOOT_VALUE_TOL 1e-12

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Feet on one face are searched FOOT_BATCH at a time, in lockstep: every round of the
 * iteration evaluates the pending points of all searches in one pm_face_eval_many call. Each
 * search evaluates the same points in the same order as alone, so the batch changes no figure;
 * on a face evaluated by gmsh it shares one lock and one call among the batch (GMSH_API.md: 2 to
 * 6 times cheaper per point than one call each). */
#define FOOT_BATCH 64

/* A foot on a face: the face, the distance d to it, the foot p, Su x Sv there (n), and whether
 * its (u, v) lies in the trimmed region by pm_face_inside (only then is p known to be a point of
 * the model). */
typedef struct fcand {
  int32_t f;
  double d, p[3], n[3];
  int in;
} fcand;

/* One search of face_feet: the current point (uv, fp, d) and, while a step is tried, the trial
 * parameters uvn at lam times the Gauss-Newton step dpar. */
typedef struct foot_search {
  double uv[2], uvn[2], dpar[2], lam, d;
  pm_face_point fp;
  int it, bt;
  enum { FOOT_START, FOOT_TRIAL, FOOT_DONE } stage;
} foot_search;

static void foot_clamp(const pm_cell *f, double uv[2]) {
  for (int k = 0; k < 2; ++k)
    if (!f->periodic[k]) uv[k] = clampd(uv[k], f->lo[k], f->hi[k]);
}

static void foot_trial(const pm_cell *f, foot_search *s) {
  s->uvn[0] = s->uv[0] + s->lam * s->dpar[0], s->uvn[1] = s->uv[1] + s->lam * s->dpar[1];
  foot_clamp(f, s->uvn);
}

/* A new Gauss-Newton step from the current point, or the end of the search. */
static void foot_step(const pm_cell *f, const double x[3], double tol, double vtol, foot_search *s) {
  if (s->it >= FOOT_MAX_IT || !(s->d > 0)) {
    s->stage = FOOT_DONE;
    return;
  }
  /* The parameter step whose image is the tangential part of x - S (the shared papers/001 eq.
   * 7-9 routine, which also handles the singular metric at a pole). */
  double r[3], der[6], img[3];
  s->dpar[0] = s->dpar[1] = 0;
  pm_v3_sub(r, x, s->fp.p);
  pm_v3_copy(der, s->fp.su), pm_v3_copy(der + 3, s->fp.sv);
  pm_cell_param_delta(f, s->uv, der, r, s->dpar);
  /* The step's image Su du + Sv dv is the tangential part of x - S: when it is below the
   * tolerance, S(uv) is already the foot to within it, and evaluating the step would only
   * confirm so. */
  for (int k = 0; k < 3; ++k) img[k] = s->dpar[0] * s->fp.su[k] + s->dpar[1] * s->fp.sv[k];
  const double t2 = pm_v3_dot(img, img);
  if (t2 <= tol * tol || t2 <= 2 * s->d * vtol) {
    s->stage = FOOT_DONE;
    return;
  }
  s->lam = 1, s->bt = 0, s->stage = FOOT_TRIAL;
  foot_trial(f, s);
}

/* Advance search s with the evaluation of its pending point. A trial is accepted when it does
 * not increase the distance; otherwise the step is halved, up to FOOT_BACKTRACK trials. */
static void foot_advance(const pm_cell *f, const double x[3], double tol, double vtol, foot_search *s,
                         const pm_face_point *at) {
  if (s->stage == FOOT_START) {
    s->fp = *at, s->d = pm_v3_dist(x, at->p), s->it = 0;
    foot_step(f, x, tol, vtol, s);
    return;
  }
  const double dn = pm_v3_dist(x, at->p);
  if (dn <= s->d) {
    const double step = pm_v3_dist(at->p, s->fp.p);
    s->uv[0] = s->uvn[0], s->uv[1] = s->uvn[1], s->fp = *at, s->d = dn;
    if (step <= tol) {
      s->stage = FOOT_DONE;
      return;
    }
    ++s->it;
    foot_step(f, x, tol, vtol, s);
    return;
  }
  if (++s->bt >= FOOT_BACKTRACK) {
    s->stage = FOOT_DONE;
    return;
  }
  s->lam *= 0.5;
  foot_trial(f, s);
}

/* The feet out[i] of the n <= FOOT_BATCH points x_i on face f, each from uv_i, by Gauss-Newton
 * iterations. */
static void face_feet(const pm_cell *f, int32_t n, const double *x, const double *uv, fcand *out) {
  const double tol = FOOT_STEP_TOL * f->model->diagonal, vtol = FOOT_VALUE_TOL * f->model->diagonal;
  foot_search s[FOOT_BATCH];
  pm_face_point at[FOOT_BATCH];
  double q[2 * FOOT_BATCH];
  int32_t pending[FOOT_BATCH];
  for (int32_t i = 0; i < n; ++i) {
    s[i].uv[0] = uv[2 * i], s[i].uv[1] = uv[2 * i + 1];
    foot_clamp(f, s[i].uv);
    s[i].stage = FOOT_START;
  }
  for (;;) {
    int32_t m = 0;
    for (int32_t i = 0; i < n; ++i) {
      if (s[i].stage == FOOT_DONE) continue;
      const double *p = s[i].stage == FOOT_START ? s[i].uv : s[i].uvn;
      q[2 * m] = p[0], q[2 * m + 1] = p[1], pending[m++] = i;
    }
    if (!m) break;
    pm_face_eval_many(f, m, q, 1, at);
    for (int32_t k = 0; k < m; ++k)
      foot_advance(f, x + 3 * pending[k], tol, vtol, &s[pending[k]], &at[k]);
  }
  for (int32_t i = 0; i < n; ++i) {
    pm_cell_wrap(f, s[i].uv);
    out[i].f = f->index, out[i].d = s[i].d, out[i].in = pm_face_inside(f, s[i].uv);
    pm_v3_copy(out[i].p, s[i].fp.p);
    pm_v3_cross(out[i].n, s[i].fp.su, s[i].fp.sv);
  }
}

/* The foot of one point (face_feet of one). */
static void face_foot(const pm_cell *f, const double x[3], const double uv[2], fcand *out) {
  face_feet(f, 1, x, uv, out);
}

/* The foot of x on curve c from t (in place); every C(t) with t in range is a model point. */
static double curve_foot(const pm_cell *c, const double x[3], double *t) {
  const double tol = FOOT_STEP_TOL * c->model->diagonal, vtol = FOOT_VALUE_TOL * c->model->diagonal;
  if (!c->periodic[0]) *t = clampd(*t, c->lo[0], c->hi[0]);
  pm_curve_point cp;
  pm_curve_eval(c, *t, 1, &cp);
  double d = pm_v3_dist(x, cp.p);
  if (c->degenerate) return d;
  for (int it = 0; it < FOOT_MAX_IT && d > 0; ++it) {
    double r[3], dt = 0;
    pm_v3_sub(r, x, cp.p);
    pm_cell_param_delta(c, t, cp.d1, r, &dt); /* papers/003 eq. 15 */
    const double img = fabs(dt) * pm_v3_norm(cp.d1);
    if (img <= tol || img * img <= 2 * d * vtol) break; /* as in face_feet */
    double lam = 1, tn = *t, dn = d;
    pm_curve_point cn;
    int ok = 0;
    for (int bt = 0; bt < FOOT_BACKTRACK; ++bt, lam *= 0.5) {
      tn = *t + lam * dt;
      if (!c->periodic[0]) tn = clampd(tn, c->lo[0], c->hi[0]);
      pm_curve_eval(c, tn, 1, &cn);
      dn = pm_v3_dist(x, cn.p);
      if (dn <= d) {
        ok = 1;
        break;
      }
    }
    if (!ok) break;
    double step = pm_v3_dist(cn.p, cp.p);
    *t = tn, cp = cn, d = dn;
    if (step <= tol) break;
  }
  if (c->periodic[0]) pm_cell_wrap(c, t);
  return d;
}

/* ---- growing arrays ---------------------------------------------------------------------------- */

typedef struct dbuf {
  double *v;
  int64_t n, cap;
} dbuf;
typedef struct ibuf {
  int32_t *v;
  int64_t n, cap;
} ibuf;

static int dbuf_push(dbuf *b, const double *x, int64_t k) {
  if (b->n + k > b->cap) {
    int64_t cap = b->cap ? 2 * b->cap : 256;
    while (cap < b->n + k) cap *= 2;
    double *nv = realloc(b->v, sizeof(double) * (size_t)cap);
    if (!nv) return 0;
    b->v = nv, b->cap = cap;
  }
  for (int64_t i = 0; i < k; ++i) b->v[b->n++] = x[i];
  return 1;
}

static int ibuf_push(ibuf *b, const int32_t *x, int64_t k) {
  if (b->n + k > b->cap) {
    int64_t cap = b->cap ? 2 * b->cap : 256;
    while (cap < b->n + k) cap *= 2;
    int32_t *nv = realloc(b->v, sizeof(int32_t) * (size_t)cap);
    if (!nv) return 0;
    b->v = nv, b->cap = cap;
  }
  for (int64_t i = 0; i < k; ++i) b->v[b->n++] = x[i];
  return 1;
}

/* ---- reference tessellation of the faces ---------------------------------------------------------- */

/* A hierarchy built at its first use, by whichever thread needs it first (ref_tree). */
typedef struct lazy_tree {
  pthread_mutex_t lock;
  pm_bvh *_Atomic tree;
  int failed;   /* the build failed: err says why, and pm_mesh_distance returns it */
  pm_error err;
} lazy_tree;

typedef struct ref_faces {
  dbuf xyz, uv;   /* points: 3D and (u, v) on their face */
  ibuf tri, face; /* triangles (global point indices) and their face */
  lazy_tree *lazy; /* their hierarchy, built when a search first needs it: a model whose faces
                      lie apart, and a one-face model, need none (synth_sphere.brep's 65282
                      reference triangles: 40 of the distance's 110 ms) */
  double chord;   /* the largest chordal error bound over curved faces */
  double gap;     /* the widest strip a degraded face's reference leaves along its boundary */
  int32_t degraded;
  int64_t cdt_points; /* points given to the constrained triangulation */
} ref_faces;

/* Probe grid (per direction) for a face's derivative sizes and curvature. */
#define PROBE 17
/* Reference points lifted per evaluation call. */
#define LIFT_BATCH 256
/* Bounds on the subdivision of one trimming-polyline edge. */
#define MAX_EDGE_SPLIT 4096

/* The parameter box of the face's loops (the frame the polylines live in). */
static void loop_box(const pm_cell *f, double box[4]) {
  box[0] = box[1] = INFINITY, box[2] = box[3] = -INFINITY;
  for (int32_t l = 0; l < f->nloop; ++l) {
    box[0] = fmin(box[0], f->loop[l].box[0]), box[1] = fmin(box[1], f->loop[l].box[1]);
    box[2] = fmax(box[2], f->loop[l].box[2]), box[3] = fmax(box[3], f->loop[l].box[3]);
  }
  if (!(box[2] > box[0]) || !(box[3] > box[1]))
    box[0] = f->lo[0], box[1] = f->lo[1], box[2] = f->hi[0], box[3] = f->hi[1];
}

/* What the sampling needs to know of a face, probed once. */
typedef struct face_info {
  double box[4];      /* the loops' parameter box */
  double su, sv;      /* largest |Su|, |Sv| over the probe grid */
  double kappa;       /* largest principal curvature magnitude over the probe grid */
} face_info;

/* Largest |Su|, |Sv| and principal curvature over a probe grid of the box: one batched
 * evaluation to second order (a singular point takes pm_face_curvatures' limit), the same
 * figures as a first-order and a second-order evaluation per point, at a fifth of the gmsh calls
 * (brep__capot.brep's probes: 14 -> 6.6 ms). */
static void face_probe(const pm_cell *f, const double box[4], double *su, double *sv, double *kappa) {
  *su = *sv = *kappa = 0;
  double uv[2 * PROBE * PROBE];
  pm_face_point fp[PROBE * PROBE];
  for (int a = 0; a < PROBE; ++a)
    for (int b = 0; b < PROBE; ++b) {
      double *q = &uv[2 * (a * PROBE + b)];
      q[0] = box[0] + (box[2] - box[0]) * (a + 0.5) / PROBE;
      q[1] = box[1] + (box[3] - box[1]) * (b + 0.5) / PROBE;
    }
  pm_face_eval_many(f, PROBE * PROBE, uv, 2, fp);
  for (int i = 0; i < PROBE * PROBE; ++i) {
    *su = fmax(*su, pm_v3_norm(fp[i].su)), *sv = fmax(*sv, pm_v3_norm(fp[i].sv));
    double k1, k2;
    if (!pm_face_point_curvatures(&fp[i], &k1, &k2, NULL))
      pm_face_curvatures(f, &uv[2 * i], &k1, &k2, NULL);
    if (isfinite(k1)) *kappa = fmax(*kappa, fabs(k1));
  }
}

/* The grid quad (0 .. n - 1 along one axis; quad k spans grid points k and k + 1, at x0 +
 * (k + 0.5) h and x0 + (k + 1.5) h) that holds x, clamped to the grid. */
static int grid_quad(double x, double x0, double h, int n) {
  const double k = floor((x - x0) / h - 0.5);
  return k < 0 ? 0 : (k > n - 1 ? n - 1 : (int)k);
}

/* The states of a grid quad in ref_face. */
enum { QUAD_NEAR = 1, QUAD_SPLIT = 2 };

/* Whether quad (a, b) of a qu x qv grid exists and is split directly (ref_face). */
static int quad_split(const uint8_t *quad, int qu, int qv, int a, int b) {
  return a >= 0 && a < qu && b >= 0 && b < qv && quad[(int64_t)a * qv + b] == QUAD_SPLIT;
}

/* Append face f's reference triangles. The grid spacing h in 3D keeps the chordal error
 * kappa h^2 / 8 (the sagitta of an arc of curvature kappa over a chord h) below eps, and h is at
 * most h_mesh (a fraction of the mesh's edge length, so that the reference's chordal error is a
 * small fraction of the mesh's own, whose edges are longer by 1 / ref_spacing); the trimming
 * polylines are subdivided along their pcurves to the grid's (u, v) spacing so that the
 * triangles along the boundary are no larger than the grid's. */
static pm_status ref_face(ref_faces *rf, const pm_cell *f, const face_info *fi, double eps,
                          double h_mesh, int64_t max_pts, int split, pm_error *err) {
  if (f->nloop <= 0) return PM_OK;
  const double *box = fi->box, su = fi->su, sv = fi->sv, kappa = fi->kappa;
  double Lu = su * (box[2] - box[0]), Lv = sv * (box[3] - box[1]);
  double h = kappa > 0 ? fmin(sqrt(8 * eps / kappa), h_mesh) : INFINITY;
  double nu = fmax(4, ceil(Lu / h)), nv = fmax(4, ceil(Lv / h));
  if (nu * nv > (double)max_pts) {
    double s = sqrt((double)max_pts / (nu * nv));
    nu = fmax(2, floor(nu * s)), nv = fmax(2, floor(nv * s));
  }
  double hu = Lu / nu, hv = Lv / nv, hh = fmax(hu, hv);
  if (kappa > 0) rf->chord = fmax(rf->chord, kappa * hh * hh / 8);
  int inu = (int)nu, inv = (int)nv;
  double du = (box[2] - box[0]) / inu, dv = (box[3] - box[1]) / inv;

  dbuf uv = {0};
  ibuf cons = {0};
  pm_status s = PM_OK;
  /* Loop polylines, subdivided. */
  for (int32_t l = 0; l < f->nloop && !s; ++l) {
    const pm_loop *lp = &f->loop[l];
    int64_t first = uv.n / 2;
    for (int32_t i = 0; i < lp->npts; ++i) {
      int32_t j = (i + 1) % lp->npts;
      const double *a = &lp->uv[2 * i], *b = &lp->uv[2 * j];
      double m = ceil(fmax(fabs(b[0] - a[0]) / du, fabs(b[1] - a[1]) / dv));
      int im = (int)clampd(m, 1, MAX_EDGE_SPLIT);
      for (int q = 0; q < im; ++q) {
        double p[2];
        if (q == 0) {
          p[0] = a[0], p[1] = a[1];
        } else if (j == i + 1 && lp->pt_use[i] == lp->pt_use[j] &&
                   fabs(lp->pt_t[j] - lp->pt_t[i]) <
                       0.5 * (f->model->cells[PM_CURVE][lp->use[lp->pt_use[i]].cell].hi[0] -
                              f->model->cells[PM_CURVE][lp->use[lp->pt_use[i]].cell].lo[0])) {
          /* Within one pcurve (not across the closing point of a closed curve, where t jumps
           * back): the pcurve's own point, closer to the curve than the chord. */
          double t = lp->pt_t[i] + (lp->pt_t[j] - lp->pt_t[i]) * q / im;
          pm_face_curve_uv(f, &lp->use[lp->pt_use[i]], t, p);
        } else {
          p[0] = a[0] + (b[0] - a[0]) * q / im, p[1] = a[1] + (b[1] - a[1]) * q / im;
        }
        if (!dbuf_push(&uv, p, 2)) goto nomem;
      }
    }
    int64_t n = uv.n / 2 - first;
    for (int64_t i = 0; i < n; ++i) {
      int32_t e[2] = {(int32_t)(first + i), (int32_t)(first + (i + 1) % n)};
      if (!ibuf_push(&cons, e, 2)) goto nomem;
    }
  }
  /* Inside grid points (cell centres, in the polylines' frame). A grid quad (the 2 x 2 block of
   * grid points a, a + 1 by b, b + 1) whose corners are inside and which no trimming polyline
   * comes near (no polyline segment's box reaches it or its neighbours) lies wholly inside the
   * face: it is split into two triangles directly. Only the band along the polylines goes
   * through the constrained triangulation, with the outline of the directly split region as
   * extra constraints: by nesting parity that region is then a hole of the constrained
   * triangulation, so the two parts meet edge to edge. A grid of cocircular points gives the
   * constrained triangulation nothing to choose but the diagonals, so the reference is the same
   * kind of mesh as before at a fraction of the cost (test_distance: the torus case 1898 of its
   * 9724 points triangulated). Points: the loops', then the band's, then
   * the split region's (which the constrained triangulation does not see). With split = 0 no
   * quad is split: every point goes through the constrained triangulation (the previous code
   * path, kept for tests and benchmarks). */
  const int64_t ng = (int64_t)inu * inv;
  const int qu = inu - 1, qv = inv - 1;
  const int64_t nq = qu > 0 && qv > 0 ? (int64_t)qu * qv : 0;
  int64_t *gidx = malloc(sizeof(int64_t) * (size_t)ng);
  uint8_t *in = malloc((size_t)ng), *quad = calloc((size_t)(nq > 0 ? nq : 1), 1);
  if (!gidx || !in || !quad) {
    free(gidx), free(in), free(quad);
    goto nomem;
  }
  for (int a = 0; a < inu; ++a)
    for (int b = 0; b < inv; ++b) {
      double p[2] = {box[0] + (a + 0.5) * du, box[1] + (b + 0.5) * dv};
      in[(int64_t)a * inv + b] = (uint8_t)(pm_trim_inside(f, p) != 0);
    }
  for (int64_t e = 0; e < cons.n / 2 && nq > 0; ++e) {
    const double *p = &uv.v[2 * (int64_t)cons.v[2 * e]], *q = &uv.v[2 * (int64_t)cons.v[2 * e + 1]];
    const int a0 = grid_quad(fmin(p[0], q[0]), box[0], du, qu) - 1,
              a1 = grid_quad(fmax(p[0], q[0]), box[0], du, qu) + 1,
              b0 = grid_quad(fmin(p[1], q[1]), box[1], dv, qv) - 1,
              b1 = grid_quad(fmax(p[1], q[1]), box[1], dv, qv) + 1;
    for (int a = a0 > 0 ? a0 : 0; a <= a1 && a < qu; ++a)
      for (int b = b0 > 0 ? b0 : 0; b <= b1 && b < qv; ++b) quad[(int64_t)a * qv + b] = QUAD_NEAR;
  }
  int64_t nsplit = 0;
  for (int a = 0; a < qu; ++a)
    for (int b = 0; b < qv; ++b) {
      uint8_t *qd = &quad[(int64_t)a * qv + b];
      const int64_t g = (int64_t)a * inv + b;
      if (split && *qd != QUAD_NEAR && in[g] && in[g + 1] && in[g + inv] && in[g + inv + 1])
        *qd = QUAD_SPLIT, ++nsplit;
    }
#define SPLIT(a, b) quad_split(quad, qu, qv, a, b)
  /* Band points first (every inside point not surrounded by split quads), then the others. */
  int64_t ncdt = 0;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) ncdt = uv.n / 2; /* the constrained triangulation's points end here */
    for (int a = 0; a < inu; ++a)
      for (int b = 0; b < inv; ++b) {
        const int64_t g = (int64_t)a * inv + b;
        if (pass == 0) gidx[g] = -1;
        if (!in[g]) continue;
        const int deep = SPLIT(a - 1, b - 1) && SPLIT(a - 1, b) && SPLIT(a, b - 1) && SPLIT(a, b);
        if (deep != pass) continue;
        double p[2] = {box[0] + (a + 0.5) * du, box[1] + (b + 0.5) * dv};
        gidx[g] = uv.n / 2;
        if (!dbuf_push(&uv, p, 2)) {
          free(gidx), free(in), free(quad);
          goto nomem;
        }
      }
  }
  const int64_t npts = uv.n / 2;
  if (npts > INT32_MAX / 4) {
    free(gidx), free(in), free(quad), free(uv.v), free(cons.v);
    return pm_error_setf(err, PM_ERR_LIMIT, "distance: reference of face %d too large", f->tag);
  }
  /* The outline of the split region: the sides of split quads whose other side is not split. */
  for (int a = 0; a < qu; ++a)
    for (int b = 0; b < qv; ++b) {
      if (!SPLIT(a, b)) continue;
      const int64_t g = (int64_t)a * inv + b;
      const int32_t c00 = (int32_t)gidx[g], c10 = (int32_t)gidx[g + inv],
                    c01 = (int32_t)gidx[g + 1], c11 = (int32_t)gidx[g + inv + 1];
      const int32_t side[4][2] = {{c00, c10}, {c01, c11}, {c00, c01}, {c10, c11}};
      const int open[4] = {!SPLIT(a, b - 1), !SPLIT(a, b + 1), !SPLIT(a - 1, b), !SPLIT(a + 1, b)};
      for (int k = 0; k < 4; ++k)
        if (open[k] && !ibuf_push(&cons, side[k], 2)) {
          free(gidx), free(in), free(quad);
          goto nomem;
        }
    }
  pm_cdt_result res = {0};
  pm_error cerr = {0};
  int32_t *tris = NULL, ntris = 0;
  rf->cdt_points += ncdt;
  if (pm_cdt_triangulate(uv.v, (int32_t)ncdt, cons.v, (int32_t)(cons.n / 2), 1, 0, &res, &cerr) ==
      PM_OK) {
    tris = malloc(sizeof(int32_t) * 3 * ((size_t)res.ntri + 2 * (size_t)nsplit + 1));
    if (!tris) {
      pm_cdt_result_free(&res);
      free(gidx), free(in), free(quad);
      goto nomem;
    }
    memcpy(tris, res.tri, sizeof(int32_t) * 3 * (size_t)res.ntri);
    ntris = res.ntri;
    pm_cdt_result_free(&res);
    for (int a = 0; a < qu; ++a)
      for (int b = 0; b < qv; ++b) {
        if (!SPLIT(a, b)) continue;
        const int64_t g = (int64_t)a * inv + b;
        int32_t *t = &tris[3 * (size_t)ntris];
        t[0] = (int32_t)gidx[g], t[1] = (int32_t)gidx[g + inv], t[2] = (int32_t)gidx[g + inv + 1];
        t[3] = t[0], t[4] = t[2], t[5] = (int32_t)gidx[g + 1];
        ntris += 2;
      }
  } else {
    /* The constrained triangulation failed (crossing polylines of a damaged face): triangulate
     * the grid cells whose four corners are inside instead, leaving a gap of at most one cell
     * along the boundary, which the curve reference and the projections cover. */
    rf->degraded++;
    /* The strip left uncovered: at most a cell between the polylines and the first inside cell
     * centre, and the cell itself (3D diagonal sqrt(2) hh each). */
    rf->gap = fmax(rf->gap, 3 * hh);
    tris = malloc(sizeof(int32_t) * 6 * (size_t)inu * (size_t)inv);
    if (!tris) {
      free(gidx), free(in), free(quad);
      goto nomem;
    }
    for (int a = 0; a + 1 < inu; ++a)
      for (int b = 0; b + 1 < inv; ++b) {
        int64_t c00 = gidx[(int64_t)a * inv + b], c10 = gidx[(int64_t)(a + 1) * inv + b],
                c01 = gidx[(int64_t)a * inv + b + 1], c11 = gidx[(int64_t)(a + 1) * inv + b + 1];
        if (c00 < 0 || c10 < 0 || c01 < 0 || c11 < 0) continue;
        int32_t *t = &tris[3 * (size_t)ntris];
        t[0] = (int32_t)c00, t[1] = (int32_t)c10, t[2] = (int32_t)c11;
        t[3] = (int32_t)c00, t[4] = (int32_t)c11, t[5] = (int32_t)c01;
        ntris += 2;
      }
  }
#undef SPLIT
  free(gidx), free(in), free(quad);
  /* Lift (in batches: one evaluation call per LIFT_BATCH points) and append. */
  int64_t base = rf->xyz.n / 3;
  for (int64_t i0 = 0; i0 < npts && !s; i0 += LIFT_BATCH) {
    pm_face_point fp[LIFT_BATCH];
    int32_t nb = (int32_t)(npts - i0 < LIFT_BATCH ? npts - i0 : LIFT_BATCH);
    pm_face_eval_many(f, nb, &uv.v[2 * i0], 0, fp);
    for (int32_t i = 0; i < nb && !s; ++i)
      if (!dbuf_push(&rf->xyz, fp[i].p, 3) || !dbuf_push(&rf->uv, &uv.v[2 * (i0 + i)], 2))
        s = PM_ERR_NOMEM;
  }
  for (int32_t t = 0; t < ntris && !s; ++t) {
    int32_t v[3] = {(int32_t)(base + tris[3 * t]), (int32_t)(base + tris[3 * t + 1]),
                    (int32_t)(base + tris[3 * t + 2])};
    int32_t fidx = f->index;
    if (!ibuf_push(&rf->tri, v, 3) || !ibuf_push(&rf->face, &fidx, 1)) s = PM_ERR_NOMEM;
  }
  free(tris);
  free(uv.v), free(cons.v);
  if (s) return pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory (reference)");
  return PM_OK;
nomem:
  free(uv.v), free(cons.v);
  return pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory (reference of face %d)", f->tag);
}

static void ref_faces_free(ref_faces *rf) {
  free(rf->xyz.v), free(rf->uv.v), free(rf->tri.v), free(rf->face.v);
  if (rf->lazy) {
    pm_bvh_destroy(atomic_load(&rf->lazy->tree));
    pthread_mutex_destroy(&rf->lazy->lock);
    free(rf->lazy);
  }
  memset(rf, 0, sizeof *rf);
}

/* The hierarchy of the reference triangles, built on the first call (the others wait for it);
 * NULL when there is no reference or the build failed (then rf->lazy->failed is set). */
static const pm_bvh *ref_tree(const ref_faces *rf) {
  lazy_tree *z = rf->lazy;
  if (!z) return NULL;
  pm_bvh *t = atomic_load_explicit(&z->tree, memory_order_acquire);
  if (t) return t;
  pthread_mutex_lock(&z->lock);
  t = atomic_load_explicit(&z->tree, memory_order_relaxed);
  if (!t && !z->failed) {
    if (pm_bvh_create(rf->xyz.v, (int32_t)(rf->xyz.n / 3), rf->tri.v, (int32_t)(rf->tri.n / 3), &t,
                      &z->err)) {
      pm_error_prefix(&z->err, "distance: reference");
      z->failed = 1, t = NULL;
    } else {
      atomic_store_explicit(&z->tree, t, memory_order_release);
    }
  }
  pthread_mutex_unlock(&z->lock);
  return t;
}

/* ---- reference polylines of the curves ------------------------------------------------------------ */

typedef struct ref_curves {
  dbuf xyz, t;    /* points and their curve parameter */
  ibuf seg, curve; /* segments as (a, b, b) triples, and their curve */
  pm_bvh *bvh;
} ref_curves;

#define CURVE_INITIAL 16
#define CURVE_MAX_DEPTH 14

static int curve_sample(ref_curves *rc, const pm_cell *c, double ta, const double pa[3], double tb,
                        const double pb[3], double eps, int depth) {
  double tm = 0.5 * (ta + tb);
  pm_curve_point cp;
  pm_curve_eval(c, tm, 0, &cp);
  double mid[3] = {0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2])};
  if (depth < CURVE_MAX_DEPTH && pm_v3_dist(mid, cp.p) > eps) {
    if (!curve_sample(rc, c, ta, pa, tm, cp.p, eps, depth + 1)) return 0;
    return curve_sample(rc, c, tm, cp.p, tb, pb, eps, depth + 1);
  }
  return dbuf_push(&rc->xyz, pb, 3) && dbuf_push(&rc->t, &tb, 1);
}

/* Append curve c's polyline: bisected until the chord's midpoint is within eps of the curve. */
static pm_status ref_curve(ref_curves *rc, const pm_cell *c, double eps, pm_error *err) {
  int64_t first = rc->xyz.n / 3;
  pm_curve_point cp;
  double t0 = c->lo[0];
  pm_curve_eval(c, t0, 0, &cp);
  if (!dbuf_push(&rc->xyz, cp.p, 3) || !dbuf_push(&rc->t, &t0, 1)) goto nomem;
  int n = c->degenerate ? 1 : CURVE_INITIAL;
  double pa[3];
  pm_v3_copy(pa, cp.p);
  for (int i = 0; i < n; ++i) {
    double ta = c->lo[0] + (c->hi[0] - c->lo[0]) * i / n;
    double tb = i + 1 == n ? c->hi[0] : c->lo[0] + (c->hi[0] - c->lo[0]) * (i + 1) / n;
    pm_curve_point cb;
    pm_curve_eval(c, tb, 0, &cb);
    if (c->degenerate) {
      if (!dbuf_push(&rc->xyz, cb.p, 3) || !dbuf_push(&rc->t, &tb, 1)) goto nomem;
    } else if (!curve_sample(rc, c, ta, pa, tb, cb.p, eps, 0)) {
      goto nomem;
    }
    pm_v3_copy(pa, cb.p);
  }
  int64_t last = rc->xyz.n / 3;
  for (int64_t i = first; i + 1 < last; ++i) {
    int32_t s[3] = {(int32_t)i, (int32_t)(i + 1), (int32_t)(i + 1)};
    int32_t ci = c->index;
    if (!ibuf_push(&rc->seg, s, 3) || !ibuf_push(&rc->curve, &ci, 1)) goto nomem;
  }
  return PM_OK;
nomem:
  return pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory (reference of curve %d)", c->tag);
}

static void ref_curves_free(ref_curves *rc) {
  free(rc->xyz.v), free(rc->t.v), free(rc->seg.v), free(rc->curve.v);
  pm_bvh_destroy(rc->bvh);
  memset(rc, 0, sizeof *rc);
}

/* See model_dist: the reference's distance to its faces is taken as this many times its chordal
 * bound. */
#define REF_REACH_MARGIN 4

/* What lies near a mesh triangle, measured once from its centroid so that the samples inside it
 * can skip the searches that cannot find anything (model_dist): a sample x of the triangle is
 * |x - g| <= r from the centroid g, so every reference triangle T of another face is farther
 * than other - |x - g| + reach(T) from x (reach: face_reach of T's face), and every boundary
 * curve farther than curve - |x - g|. Both are computed from exact (double) distances, or are
 * lower bounds when nothing was found within the search radius. */
typedef struct tri_nbhd {
  double g[3];   /* the centroid */
  double r;      /* the largest distance from the centroid to a corner */
  double other;  /* the smallest distance from the centroid to a reference triangle of a face
                    other than the triangle's own, less that face's reach */
  double curve;  /* distance from the centroid to the boundary curves' reference polylines */
} tri_nbhd;

/* Bounds compared with a tiny relative slack, so that the rounding of the triangle inequality
 * never turns a search that would find something into a skipped one. */
#define NBHD_SLACK (1 + 1e-9)

/* ---- the context ---------------------------------------------------------------------------------- */

enum { PART_SURF = 0, PART_WIRE = 1 };

typedef struct dctx {
  const pm_mesh *mesh;
  const pm_model *m;
  const pm_sizing *size;
  const pm_distance_params *p;
  int surf, wire;            /* which parts are measured */
  pm_bvh *mesh_tri;          /* the mesh's triangles */
  pm_bvh *mesh_wire;         /* the wire part's segments as (a, b, b), or NULL */
  int32_t nwire;
  int32_t *wire_seg;         /* [nwire] indices of the wire part's mesh segments */
  int8_t *dangling;          /* [count[CURVE]] 1 for curves that bound no face */
  ref_faces rf;              /* faces */
  double band;               /* inside_exact's search radius */
  const struct tri_nbhd *nb; /* [mesh->ntri] neighbourhood bounds of the triangles, or NULL */
  double *face_reach;        /* [nface] how far a point of the face may lie from its reference,
                                but for the gap: REF_REACH_MARGIN x its chordal bound */
  double reach_max;          /* the largest face_reach */
  double *face_box;          /* [6 nface] each face's reference box (lo, hi); a face without
                                a reference has lo = +inf, hi = -inf: every distance to it is
                                infinite */
  double ref_reach;          /* how far a face point may lie from the reference: the largest
                                chordal bound (at least eps) with a margin, and the widest gap */
  ref_curves rc_surf;        /* curves bounding faces */
  ref_curves rc_wire;        /* dangling curves */
  int level;                 /* lattice level */
  int npt_tri, npt_seg;      /* lattice points per triangle / segment */
  uint8_t *par_ok;           /* [mesh->nnode] 1 where a node's parameters put it on its cell */
  double *corner_uv;         /* [6 ntri] a triangle corner's (u, v) on the triangle's face, for a
                                node on one of its boundary curves, through the pcurve */
  uint8_t *corner_ok;        /* [3 ntri] 1 where corner_uv puts the node on the face */
} dctx;

/* A mesh point's classification hint: a cell and a starting parameter, or cell = -1. */
typedef struct hint {
  int32_t cell;
  double par[2];
  int32_t tri;    /* the mesh triangle the point lies in (its neighbourhood bounds), or -1 */
} hint;

/* The trimming polylines cut the corners of curved boundaries (by up to 2e-4 of the parameter
 * box, trim.c): next to a convex piece of boundary the polyline region misses a sliver of the
 * face, next to a concave piece (a hole) it takes in a sliver outside the face. A point of the
 * untrimmed surface close to a boundary curve is therefore judged against the curve itself: it is
 * inside when it lies on the face's side of the curve, along n x T from the curve's closest point,
 * with n = Su x Sv and T the curve's tangent in the loop's direction (the trimmed region lies to
 * the left of its loops in (u, v): outer loops counter-clockwise, holes clockwise). This applies
 * within BOUNDARY_BAND x diagonal of a boundary curve of f that f uses once (a seam is no
 * boundary), at an interior point of the curve (at a corner the tangent says nothing); elsewhere
 * pm_face_inside decides. Returns the corrected verdict. */
#define BOUNDARY_BAND 1e-3

/* inside_exact searching the curves within `radius` (at least c->band) of p: *dcurve (may be
 * NULL) receives the distance to the nearest curve's polyline, or radius when none is within
 * it, so that a caller can skip the searches of points nearer than dcurve - band to p. The
 * verdict is inside_exact's: the nearest polyline within the band is the same in both. */
static int inside_exact_far(const dctx *c, int32_t fi, int poly_in, const double p[3],
                            const double n[3], double radius, double *dcurve) {
  const pm_model *m = c->m;
  if (dcurve) *dcurve = INFINITY;
  if (!c->rc_surf.bvh) return poly_in;
  double band = BOUNDARY_BAND * m->diagonal;
  pm_bvh_hit hit;
  int found = pm_bvh_closest(c->rc_surf.bvh, p, radius, &hit);
  if (dcurve) *dcurve = found ? hit.dist : radius;
  if (!found || hit.dist > c->band) return poly_in;
  int32_t cu = c->rc_surf.curve.v[hit.tri];
  const pm_cell *f = &m->cells[PM_FACE][fi], *cc = &m->cells[PM_CURVE][cu];
  int uses = 0, sense = 0;
  for (int32_t k = 0; k < f->nbound; ++k)
    if (f->bound[k].cell == cu) ++uses, sense = f->bound[k].sense;
  if (uses != 1 || cc->degenerate) return poly_in;
  const int32_t *v = &c->rc_surf.seg.v[3 * (size_t)hit.tri];
  double t = hit.bary[0] * c->rc_surf.t.v[v[0]] + (hit.bary[1] + hit.bary[2]) * c->rc_surf.t.v[v[1]];
  /* C and C' where the polyline's closest point puts the foot, without the Newton iteration to
   * the foot itself (ours). The side is the sign of (p - C) . (n x T): an error delta of the foot
   * along the curve moves C along T, which that product does not see, and turns T by kappa
   * delta, so the product changes by about kappa delta^2; the polyline (chordal error eps)
   * places the foot within a fraction of its segment, which makes that a fraction of eps
   * (below 1e-5 of the diagonal). Only points that near the curve can change sides, where
   * the face's foot and the curve's are as near each other. The iteration cost 2.4 curve
   * evaluations a point, each two gmsh calls (robust/step__U_Joint_2.stp with bubble: 1.0
   * million points, 2.5 million evaluations, a fifth of the distance's time). */
  if (!cc->periodic[0]) t = clampd(t, cc->lo[0], cc->hi[0]);
  pm_curve_point cp;
  pm_curve_eval(cc, t, 1, &cp);
  const double dq = pm_v3_dist(p, cp.p);
  double span = cc->hi[0] - cc->lo[0];
  if (dq > band || (!cc->periodic[0] && (t <= cc->lo[0] + 1e-9 * span || t >= cc->hi[0] - 1e-9 * span)))
    return poly_in;
  double T[3], in_dir[3], off[3];
  pm_v3_scale(T, cp.d1, sense >= 0 ? 1 : -1);
  pm_v3_cross(in_dir, n, T);
  pm_v3_sub(off, p, cp.p);
  return pm_v3_dot(off, in_dir) >= 0;
}

static int inside_exact(const dctx *c, int32_t fi, int poly_in, const double p[3], const double n[3]) {
  return inside_exact_far(c, fi, poly_in, p, n, c->band, NULL);
}

/* Distance from x to the model's faces (surface part) or dangling curves (wire part): the
 * smallest exact candidate (see distance.h). pre (may be NULL) is the foot from the hint's face
 * and parameters, already searched (face_feet). *fallback is set when none existed. */
static double model_dist(const dctx *c, int part, const double x[3], const hint *h,
                         const fcand *pre, int *fallback) {
  const pm_model *m = c->m;
  double best = INFINITY, eps = c->p->ref_tol * m->diagonal;
  *fallback = 0;
  const tri_nbhd *nb = c->nb && h && h->tri >= 0 ? &c->nb[h->tri] : NULL;
  const double rx = nb ? pm_v3_dist(x, nb->g) : 0;
  if (part == PART_SURF) {
    fcand fc[2];
    int nf = 0, poly_in[2] = {0, 0};
    /* How far the reference may be from its faces: a face point nearer to x than reach lies
     * within reach + ref_reach of x's closest reference triangle. */
    double reach = INFINITY;
    if (h && h->cell >= 0) {
      fcand *a = &fc[nf++];
      if (pre)
        *a = *pre;
      else
        face_foot(&m->cells[PM_FACE][h->cell], x, h->par, a);
      poly_in[0] = a->in;
      /* inside_exact searches the curves within its band of the foot, which is within
       * a->d + |x - g| of the centroid: when they are farther, its verdict is poly_in. */
      if (!nb || nb->curve <= (rx + a->d + c->band) * NBHD_SLACK)
        a->in = inside_exact(c, a->f, a->in, a->p, a->n);
      /* The hint's foot is a model point at distance a->d: another face can only do better
       * where the reference comes within a->d + ref_reach of x, so the search stops there
       * (which prunes it to a few boxes where a face is not near another). The unbounded
       * search found the same faces, but where the reference is farther from its face than
       * ref_reach. */
      if (a->in && c->p->prune) reach = a->d + c->ref_reach;
    }
    double dref = INFINITY;
    /* The reference of other faces is beyond their reach (tri_nbhd): the search could only
     * name the hint's own face, whose foot is inside, and so add nothing. */
    if (nb && nf == 1 && poly_in[0] && fc[0].in &&
        nb->other > (rx + fc[0].d) * NBHD_SLACK)
      goto candidates_done;
    const pm_bvh *rtree = ref_tree(&c->rf);
    if (rtree) {
      pm_bvh_hit hit;
      if (pm_bvh_closest(rtree, x, reach, &hit)) {
        dref = hit.dist;
        int32_t f = c->rf.face.v[hit.tri];
        /* The reference names the hint's own face, whose foot was found inside it: a second
         * projection onto that face would land on the same foot. */
        if (nf == 1 && fc[0].f == f && poly_in[0]) goto candidates_done;
        const int32_t *v = &c->rf.tri.v[3 * (size_t)hit.tri];
        double uv[2] = {0, 0};
        for (int k = 0; k < 3; ++k)
          uv[0] += hit.bary[k] * c->rf.uv.v[2 * (size_t)v[k]],
              uv[1] += hit.bary[k] * c->rf.uv.v[2 * (size_t)v[k] + 1];
        fcand *b = &fc[nf++];
        face_foot(&m->cells[PM_FACE][f], x, uv, b);
        b->in = inside_exact(c, b->f, b->in, b->p, b->n);
      }
    }
  candidates_done:
    for (int i = 0; i < nf; ++i)
      if (fc[i].in) best = fmin(best, fc[i].d);
    /* Curves: only points closer than the best face candidate matter (the reference polyline
     * is within eps of its curve), and none is when the triangle's curve bound says so. */
    if (c->rc_surf.bvh && !(nb && best < INFINITY && nb->curve > (rx + best + 2 * eps) * NBHD_SLACK)) {
      pm_bvh_hit hit;
      if (pm_bvh_closest(c->rc_surf.bvh, x, best < INFINITY ? best + 2 * eps : INFINITY, &hit)) {
        int32_t cu = c->rc_surf.curve.v[hit.tri];
        const int32_t *v = &c->rc_surf.seg.v[3 * (size_t)hit.tri];
        double t = hit.bary[0] * c->rc_surf.t.v[v[0]] + (hit.bary[1] + hit.bary[2]) * c->rc_surf.t.v[v[1]];
        best = fmin(best, curve_foot(&m->cells[PM_CURVE][cu], x, &t));
      }
    }
    if (best == INFINITY) {
      *fallback = 1;
      best = dref;
    }
    return best;
  }
  if (h && h->cell >= 0) {
    double t = h->par[0];
    best = curve_foot(&m->cells[PM_CURVE][h->cell], x, &t);
  }
  if (c->rc_wire.bvh) {
    pm_bvh_hit hit;
    if (pm_bvh_closest(c->rc_wire.bvh, x, best < INFINITY ? best + 2 * eps : INFINITY, &hit)) {
      int32_t cu = c->rc_wire.curve.v[hit.tri];
      const int32_t *v = &c->rc_wire.seg.v[3 * (size_t)hit.tri];
      double t = hit.bary[0] * c->rc_wire.t.v[v[0]] + (hit.bary[1] + hit.bary[2]) * c->rc_wire.t.v[v[1]];
      best = fmin(best, curve_foot(&m->cells[PM_CURVE][cu], x, &t));
    }
  }
  if (best == INFINITY) *fallback = 1;
  return best;
}

/* The hint of mesh triangle t: its face when the triangle is classified on it and at least one
 * of its nodes lies on it, with the (u, v) of each node on the face, unwrapped across a
 * periodic face's seam (relative to the first) so that interpolating them stays on one sheet; a
 * node on a curve or vertex (no (u, v) of its own on the face) takes the nearest face node's.
 * The caller interpolates with barycentrics: a start for the projection, which the Newton
 * iteration refines. */
static int tri_hint_nodes(const dctx *c, int32_t t, double par[3][2]) {
  const pm_mesh *me = c->mesh;
  if (!me->tri_cell || !me->node_dim || !me->node_cell || !me->node_par) return -1;
  int32_t f = me->tri_cell[t];
  if (f < 0 || f >= c->m->count[PM_FACE]) return -1;
  const pm_cell *fc = &c->m->cells[PM_FACE][f];
  const int32_t *v = &me->tri[3 * (size_t)t];
  int on[3], first = -1;
  for (int k = 0; k < 3; ++k) {
    on[k] = me->node_dim[v[k]] == PM_FACE && me->node_cell[v[k]] == f && c->par_ok[v[k]];
    const int by_curve = !on[k] && c->corner_ok && c->corner_ok[3 * (size_t)t + k];
    if (!on[k] && !by_curve) continue;
    if (by_curve) {
      on[k] = 1;
      par[k][0] = c->corner_uv[6 * (size_t)t + 2 * k], par[k][1] = c->corner_uv[6 * (size_t)t + 2 * k + 1];
    } else {
      par[k][0] = me->node_par[2 * (size_t)v[k]], par[k][1] = me->node_par[2 * (size_t)v[k] + 1];
    }
    if (first < 0) {
      first = k;
      continue;
    }
    for (int q = 0; q < 2; ++q)
      if (fc->periodic[q] && fc->period[q] > 0)
        par[k][q] += fc->period[q] * round((par[first][q] - par[k][q]) / fc->period[q]);
  }
  if (first < 0) return -1;
  for (int k = 0; k < 3; ++k) {
    if (on[k]) continue;
    int best = first;
    double bd = INFINITY;
    for (int j = 0; j < 3; ++j) {
      if (!on[j]) continue;
      double d = pm_v3_dist(&me->xyz[3 * (size_t)v[k]], &me->xyz[3 * (size_t)v[j]]);
      if (d < bd) bd = d, best = j;
    }
    par[k][0] = par[best][0], par[k][1] = par[best][1];
  }
  return f;
}

static int seg_hint_nodes(const dctx *c, int32_t s, double par[2]) {
  const pm_mesh *me = c->mesh;
  if (!me->seg_cell || !me->node_dim || !me->node_cell || !me->node_par) return -1;
  int32_t cu = me->seg_cell[s];
  if (cu < 0 || cu >= c->m->count[PM_CURVE]) return -1;
  const pm_cell *cc = &c->m->cells[PM_CURVE][cu];
  for (int k = 0; k < 2; ++k) {
    int32_t v = me->seg[2 * (size_t)s + k];
    if (me->node_dim[v] != PM_CURVE || me->node_cell[v] != cu || !c->par_ok[v]) return -1;
    par[k] = me->node_par[2 * (size_t)v];
    if (k == 1 && cc->periodic[0] && cc->period[0] > 0)
      par[1] += cc->period[0] * round((par[0] - par[1]) / cc->period[0]);
  }
  return cu;
}

/* ---- sampling ------------------------------------------------------------------------------------- */

/* A sample of either direction, addressed by (kind, element, parameters). */
enum { S_TRI = 0, S_SEG = 1, S_FACE = 2, S_CURVE = 3 };

/* Model-side sample blocks: a face grid or a curve's points. */
typedef struct mblock {
  int kind;       /* S_FACE or S_CURVE */
  int part;       /* PART_SURF or PART_WIRE */
  int32_t cell;
  int32_t nu, nv; /* grid (curves: nu points, nv = 1) */
  double u0, v0, du, dv;
  int64_t first;  /* global index of the block's first sample */
} mblock;

/* The point x of a mesh-side sample at parameters par (triangle: barycentric (s, t) of vertices
 * 1 and 2; segment: t in [0, 1]) and its hint. Returns 0 outside the element. */
static int mesh_point(const dctx *c, int kind, int32_t e, const double par[2], double x[3],
                      hint *h) {
  const pm_mesh *me = c->mesh;
  if (kind == S_TRI) {
    double s = par[0], t = par[1];
    if (!(s >= 0 && t >= 0 && s + t <= 1)) return 0;
    const int32_t *v = &me->tri[3 * (size_t)e];
    const double w[3] = {1 - s - t, s, t};
    pm_v3_zero(x);
    for (int k = 0; k < 3; ++k) pm_v3_axpy(x, x, w[k], &me->xyz[3 * (size_t)v[k]]);
    double np[3][2];
    *h = (hint){-1, {0, 0}, e};
    int32_t f = tri_hint_nodes(c, e, np);
    if (f >= 0) {
      h->cell = f;
      for (int q = 0; q < 2; ++q) h->par[q] = w[0] * np[0][q] + w[1] * np[1][q] + w[2] * np[2][q];
    }
    return 1;
  }
  double t = par[0];
  if (!(t >= 0 && t <= 1)) return 0;
  int32_t sg = c->wire_seg[e];
  const double *a = &me->xyz[3 * (size_t)me->seg[2 * (size_t)sg]],
               *b = &me->xyz[3 * (size_t)me->seg[2 * (size_t)sg + 1]];
  for (int k = 0; k < 3; ++k) x[k] = (1 - t) * a[k] + t * b[k];
  double np[2];
  *h = (hint){-1, {0, 0}, -1};
  int32_t cu = seg_hint_nodes(c, sg, np);
  if (cu >= 0 && c->dangling[cu]) h->cell = cu, h->par[0] = (1 - t) * np[0] + t * np[1];
  return 1;
}

/* The distance of a mesh-side sample (mesh_point) to the model, NAN outside the element; fills x.
 * The weight is left to the caller. */
static double mesh_eval(const dctx *c, int kind, int32_t e, const double par[2], double x[3],
                        int *fallback) {
  hint h;
  *fallback = 0;
  if (!mesh_point(c, kind, e, par, x, &h)) return NAN;
  return model_dist(c, kind == S_TRI ? PART_SURF : PART_WIRE, x, &h, NULL, fallback);
}

/* Evaluate a model-side sample at parameters par of block b's cell: NAN outside the cell. For
 * a face, *jac (may be NULL) receives |Su x Sv| there (the area weight). */
static double model_eval(const dctx *c, const mblock *b, const double par[2], double x[3],
                         double *jac) {
  if (b->kind == S_FACE) {
    const pm_cell *f = &c->m->cells[PM_FACE][b->cell];
    pm_face_point fp;
    pm_face_eval(f, par, 1, &fp);
    double n[3];
    pm_v3_cross(n, fp.su, fp.sv);
    if (!inside_exact(c, b->cell, pm_face_inside(f, par), fp.p, n)) return NAN;
    pm_v3_copy(x, fp.p);
    if (jac) *jac = pm_v3_norm(n);
  } else {
    const pm_cell *cu = &c->m->cells[PM_CURVE][b->cell];
    double t = par[0];
    if (!cu->periodic[0] && !(t >= cu->lo[0] && t <= cu->hi[0])) return NAN;
    pm_curve_point cp;
    pm_curve_eval(cu, t, 0, &cp);
    pm_v3_copy(x, cp.p);
  }
  const pm_bvh *target = (b->part == PART_WIRE && c->mesh_wire) ? c->mesh_wire : c->mesh_tri;
  if (!target) return NAN;
  pm_bvh_hit hit;
  pm_bvh_closest(target, x, INFINITY, &hit);
  return hit.dist;
}

/* ---- accumulation ------------------------------------------------------------------------------------ */

typedef struct acc {
  double sum_wd, sum_w, sum_wr, max, rel_max;
  double max_at[3];
  int64_t n;
} acc;

/* One of the largest samples, for refinement. */
typedef struct topk {
  double d;
  int kind;
  int32_t elem;    /* triangle / wire segment index, or model block index */
  int64_t key;     /* one entry per key */
  double par[2];
  double step[2];  /* initial pattern-search step per parameter */
} topk;

static void topk_offer(topk *list, int *n, int K, const topk *cand) {
  if (K <= 0 || !(cand->d > 0)) return;
  if (*n == K && cand->d <= list[K - 1].d) return;
  for (int i = 0; i < *n; ++i)
    if (list[i].key == cand->key) {
      if (cand->d <= list[i].d) return;
      /* Replace and bubble up. */
      list[i] = *cand;
      while (i > 0 && list[i - 1].d < list[i].d) {
        topk t = list[i - 1];
        list[i - 1] = list[i], list[i] = t;
        --i;
      }
      return;
    }
  int i = *n < K ? (*n)++ : K - 1;
  list[i] = *cand;
  while (i > 0 && list[i - 1].d < list[i].d) {
    topk t = list[i - 1];
    list[i - 1] = list[i], list[i] = t;
    --i;
  }
}

static void acc_add(acc *a, double d, double w, double rel, const double x[3]) {
  a->sum_wd += w * d, a->sum_w += w, a->sum_wr += w * rel;
  if (d > a->max) a->max = d, pm_v3_copy(a->max_at, x);
  if (rel > a->rel_max) a->rel_max = rel;
  a->n++;
}

static double size_at(const dctx *c, const double x[3]) {
  if (!c->size) return 0;
  double s = pm_sizing_eval(c->size, x);
  return s > 0 && isfinite(s) ? s : 0;
}

/* Pattern search: the local maximum of the distance around a sample, over the element's
 * parameters (8 directions: the axes and diagonals, steps reduced when no neighbour is better,
 * down to 1e-4 of the start step or 400 evaluations). Near a smooth maximum the value found
 * differs from the maximum by the square of the last step: from 1e-7 down, the maxima of 20
 * bubble meshes of both CAD folders moved by at most 2.4e-10 of themselves and no mean moved,
 * for 13 halvings instead of 23 (the search was up to 60% of the distance's time).
 * When no neighbour is better, the nine values around the point define a quadratic (central
 * differences): where it has a maximum within the stencil, that point is evaluated, and if it is
 * better the search moves there and the step is cut by PS_JUMP_CUT instead of halved (the
 * quadratic's vertex is within a small fraction of the step of a smooth maximum; the poll at the
 * smaller step checks it). Where the distance is not smooth (a kink where the nearest face
 * changes) the jump fails and the step is halved as before (refine_fit = 0: always, the previous
 * code path). synth_bspline_patch.brep's psys mesh: the refinements' face evaluations 16792 ->
 * 8484, the same maxima. */
#define PS_MIN_STEP 1e-4
#define PS_MAX_EVAL 400
#define PS_JUMP_CUT 0.125

static double ps_eval(const dctx *c, const mblock *blocks, const topk *e, const double q[2],
                      double x[3]) {
  int fb;
  return e->kind <= S_SEG ? mesh_eval(c, e->kind, e->elem, q, x, &fb)
                          : model_eval(c, &blocks[e->elem], q, x, NULL);
}

/* The vertex of the quadratic through the poll's values (f0 at the centre, f[k] at dirs[k] times
 * step), as an offset from the centre, when it is a maximum within the stencil; 0 otherwise. */
static int ps_vertex(int ndim, double f0, const double f[8], const double step[2], double off[2]) {
  for (int k = 0; k < (ndim == 1 ? 2 : 8); ++k)
    if (!isfinite(f[k])) return 0;
  const double gx = (f[0] - f[1]) / (2 * step[0]), hxx = (f[0] - 2 * f0 + f[1]) / (step[0] * step[0]);
  if (ndim == 1) {
    if (!(hxx < 0)) return 0;
    off[0] = -gx / hxx, off[1] = 0;
    return fabs(off[0]) <= step[0];
  }
  const double gy = (f[2] - f[3]) / (2 * step[1]), hyy = (f[2] - 2 * f0 + f[3]) / (step[1] * step[1]);
  /* dirs 4..7: (1, 1), (-1, -1), (1, -1), (-1, 1) */
  const double hxy = (f[4] + f[5] - f[6] - f[7]) / (4 * step[0] * step[1]);
  const double det = hxx * hyy - hxy * hxy;
  if (!(hxx < 0 && det > 0)) return 0;
  off[0] = -(hyy * gx - hxy * gy) / det, off[1] = -(hxx * gy - hxy * gx) / det;
  return fabs(off[0]) <= step[0] && fabs(off[1]) <= step[1];
}

static double refine_one(const dctx *c, const mblock *blocks, topk *e, double x_best[3]) {
  static const int dirs[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, -1}, {1, -1}, {-1, 1}};
  int ndim = (e->kind == S_SEG || (e->kind == S_CURVE)) ? 1 : 2;
  double par[2] = {e->par[0], e->par[1]}, step[2] = {e->step[0], e->step[1]};
  double best = e->d, x[3];
  /* Re-evaluate the start for its point (and a consistent value). */
  double d0 = ps_eval(c, blocks, e, par, x);
  if (isfinite(d0)) best = d0, pm_v3_copy(x_best, x);
  int evals = 0;
  while (evals < PS_MAX_EVAL && step[0] > PS_MIN_STEP * e->step[0]) {
    int moved = 0, polled = 0;
    double bp[2] = {par[0], par[1]}, f[8];
    const double f0 = best;
    for (int k = 0; k < (ndim == 1 ? 2 : 8) && evals < PS_MAX_EVAL; ++k, ++polled) {
      double q[2] = {par[0] + dirs[k][0] * step[0], par[1] + dirs[k][1] * step[1]};
      ++evals;
      double d = f[k] = ps_eval(c, blocks, e, q, x);
      if (isfinite(d) && d > best) best = d, bp[0] = q[0], bp[1] = q[1], pm_v3_copy(x_best, x), moved = 1;
    }
    if (moved) {
      par[0] = bp[0], par[1] = bp[1];
      continue;
    }
    double off[2];
    if (c->p->refine_fit && polled == (ndim == 1 ? 2 : 8) && isfinite(f0) && evals < PS_MAX_EVAL &&
        ps_vertex(ndim, f0, f, step, off)) {
      double q[2] = {par[0] + off[0], par[1] + off[1]};
      ++evals;
      double d = ps_eval(c, blocks, e, q, x);
      if (isfinite(d) && d > best) {
        best = d, par[0] = q[0], par[1] = q[1], pm_v3_copy(x_best, x);
        step[0] *= PS_JUMP_CUT, step[1] *= PS_JUMP_CUT;
        continue;
      }
    }
    step[0] *= 0.5, step[1] *= 0.5;
  }
  return best;
}

/* The mesh side's lattice points, each once: a triangle's lattice of level L has its corners
 * (shared by the triangles at a node), L - 1 points on each edge (shared by the edge's
 * triangles) and (L - 1)(L - 2) / 2 inside. Sampling the shared points once per mesh rather
 * than once per triangle halves the samples (about 0.5 + 1.5 (L - 1) + (L - 1)(L - 2) / 2 per
 * triangle instead of (L + 1)(L + 2) / 2) and gives every point the weight of all the triangles
 * it stands for, so the area-weighted mean is the one the per-triangle lattices give. A point
 * is evaluated through one of its triangles (the lowest-numbered), whose classification gives
 * the projection's hint; a point on an edge between two faces also through a triangle of the
 * other face, and the smaller distance is kept (each is the distance to a real model point, so
 * the smaller is the nearer to the true one). */
typedef struct lattice {
  int64_t n;
  int32_t *tri;  /* [n] the triangle a point is evaluated through */
  double *par;   /* [2n] its barycentric (s, t) in that triangle */
  int32_t *alt;  /* [n] a triangle of another face at the point, or -1 */
  double *apar;  /* [2n] the point's barycentrics in alt */
  double *w;     /* [n] area weight */
} lattice;

static void lattice_free(lattice *l) {
  free(l->tri), free(l->par), free(l->alt), free(l->apar), free(l->w);
  memset(l, 0, sizeof *l);
}

static int lattice_push(lattice *l, int64_t cap, int32_t t, double s, double u, double w) {
  if (l->n >= cap) return 0;
  l->tri[l->n] = t, l->par[2 * l->n] = s, l->par[2 * l->n + 1] = u, l->w[l->n] = w;
  l->alt[l->n] = -1, l->apar[2 * l->n] = l->apar[2 * l->n + 1] = 0;
  l->n++;
  return 1;
}

/* The weight, as a fraction of its triangle's area, of lattice point (i, j, L - i - j) of a
 * triangle's lattice of level L (i, j >= 0 count steps towards two of the corners).
 *   quadrature 0: every point of the triangle weighs the same, 1 / npt (the previous code path).
 *     Exact for linear functions, but the lattice's boundary points outnumber its inside ones:
 *     a deviation that vanishes at the nodes, as a chordal error does, comes out low (a quadratic
 *     bubble by a quarter at level 4).
 *   quadrature 1: the piecewise-linear rule on the level-L subdivision (1/3 of each small
 *     triangle at each of its corners): every point counts, with a positive weight; low by
 *     about 1 / (2 L^2) of a quadratic bubble (6% at level 4).
 *   quadrature 2, L even: the rule exact for quadratics on each triangle of the level-L/2
 *     subdivision (weight 1/3 at its edge midpoints, 0 at its corners), summed: a point of the
 *     lattice that is not on the coarser one gets 1/3 of each such triangle it is an edge
 *     midpoint of (one on the triangle's boundary, two inside), the others 0. It is rule 1's
 *     Richardson extrapolation from levels L/2 and L, so where the deviation is not smooth
 *     (spikes at a few points) it amplifies them. L odd: rule 1. */
static double lattice_weight(int L, int quadrature, int i, int j) {
  const int k = L - i - j;
  if (quadrature == 0) return 2.0 / ((double)(L + 1) * (L + 2));
  const int boundary = i == 0 || j == 0 || k == 0;
  if (quadrature == 2 && L % 2 == 0) {
    if (i % 2 == 0 && j % 2 == 0) return 0;
    const double m = L / 2;
    return (boundary ? 1 : 2) / (3 * m * m);
  }
  const int corner = (i == L) + (j == L) + (k == L);
  const int small = corner ? 1 : (boundary ? 3 : 6);
  return small / (3.0 * L * L);
}

/* The weight, as a fraction of its segment's length, of point q of the L + 1 points of a
 * segment: equal (quadrature 0), the trapezoidal rule (1, and 2 with L odd) or Simpson's rule
 * over pairs of steps (2, L even). */
static double segment_weight(int L, int quadrature, int q) {
  if (quadrature == 0) return 1.0 / (L + 1);
  const int end = q == 0 || q == L;
  if (quadrature == 2 && L % 2 == 0) return (end ? 1 : (q % 2 ? 4 : 2)) / (3.0 * L);
  return (end ? 0.5 : 1) / L;
}

/* Barycentric (s, t) of corner k of a triangle: the weights of corners 1 and 2. */
static void corner_par(int k, double t, double par[2]) {
  par[0] = k == 1 ? t : 0, par[1] = k == 2 ? t : 0;
}

static pm_status lattice_build(const pm_mesh *me, int level, int quadrature, lattice *l,
                               pm_error *err) {
  memset(l, 0, sizeof *l);
  const int32_t nt = me->ntri;
  pm_edges e = {0};
  pm_status st = pm_edges_build(me->nnode, me->tri, nt, 3, &e, err);
  if (st) return st;
  double *area = malloc(sizeof(double) * (size_t)(nt ? nt : 1));
  double *nw = calloc((size_t)me->nnode + 1, sizeof(double));
  int32_t *owner = malloc(sizeof(int32_t) * ((size_t)me->nnode + 1));
  int64_t cap = (int64_t)me->nnode + e.nedge * (level - 1) +
                (int64_t)nt * ((level - 1) * (level - 2) / 2) + 1;
  l->tri = malloc(sizeof(int32_t) * (size_t)cap);
  l->par = malloc(sizeof(double) * 2 * (size_t)cap);
  l->w = malloc(sizeof(double) * (size_t)cap);
  l->alt = malloc(sizeof(int32_t) * (size_t)cap);
  l->apar = malloc(sizeof(double) * 2 * (size_t)cap);
  if (!area || !nw || !owner || !l->tri || !l->par || !l->w || !l->alt || !l->apar) {
    free(area), free(nw), free(owner), pm_edges_free(&e), lattice_free(l);
    return pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory (lattice)");
  }
  for (int32_t i = 0; i < me->nnode; ++i) owner[i] = -1;
  for (int32_t t = 0; t < nt; ++t) {
    const int32_t *v = &me->tri[3 * (size_t)t];
    double ab[3], ac[3], n[3];
    pm_v3_sub(ab, &me->xyz[3 * (size_t)v[1]], &me->xyz[3 * (size_t)v[0]]);
    pm_v3_sub(ac, &me->xyz[3 * (size_t)v[2]], &me->xyz[3 * (size_t)v[0]]);
    pm_v3_cross(n, ab, ac);
    area[t] = 0.5 * pm_v3_norm(n);
    for (int k = 0; k < 3; ++k) {
      nw[v[k]] += area[t] * lattice_weight(level, quadrature, level, 0);
      if (owner[v[k]] < 0) owner[v[k]] = t;
    }
  }
  int ok = 1;
  /* Corners, in node order. */
  for (int32_t i = 0; i < me->nnode && ok; ++i) {
    int32_t t = owner[i];
    if (t < 0) continue;
    int k = me->tri[3 * (size_t)t] == i ? 0 : (me->tri[3 * (size_t)t + 1] == i ? 1 : 2);
    double par[2];
    corner_par(k, 1, par);
    ok = lattice_push(l, cap, t, par[0], par[1], nw[i]);
  }
  /* Edge points, in edge order. */
  for (int64_t k = 0; k < e.nedge && ok && level > 1; ++k) {
    double a_sum = 0;
    for (int64_t q = e.off[k]; q < e.off[k + 1]; ++q) a_sum += area[e.elem[q]];
    int32_t t = e.elem[e.off[k]], a = e.ends[2 * k], b = e.ends[2 * k + 1];
    const int32_t *v = &me->tri[3 * (size_t)t];
    int ia = v[0] == a ? 0 : (v[1] == a ? 1 : 2), ib = v[0] == b ? 0 : (v[1] == b ? 1 : 2);
    /* A triangle of another face along the edge (a curve between two faces). */
    int32_t t2 = -1;
    for (int64_t q = e.off[k] + 1; q < e.off[k + 1] && t2 < 0 && me->tri_cell; ++q)
      if (me->tri_cell[e.elem[q]] != me->tri_cell[t]) t2 = e.elem[q];
    const int32_t *v2 = t2 >= 0 ? &me->tri[3 * (size_t)t2] : NULL;
    int ja = v2 ? (v2[0] == a ? 0 : (v2[1] == a ? 1 : 2)) : 0;
    int jb = v2 ? (v2[0] == b ? 0 : (v2[1] == b ? 1 : 2)) : 0;
    for (int q = 1; q < level && ok; ++q) {
      double f = (double)q / level, pa[2], pb[2];
      corner_par(ia, 1 - f, pa), corner_par(ib, f, pb);
      ok = lattice_push(l, cap, t, pa[0] + pb[0], pa[1] + pb[1],
                        a_sum * lattice_weight(level, quadrature, level - q, q));
      if (ok && v2) {
        corner_par(ja, 1 - f, pa), corner_par(jb, f, pb);
        l->alt[l->n - 1] = t2;
        l->apar[2 * (l->n - 1)] = pa[0] + pb[0], l->apar[2 * (l->n - 1) + 1] = pa[1] + pb[1];
      }
    }
  }
  /* Interior points, in triangle order. */
  for (int32_t t = 0; t < nt && ok; ++t)
    for (int i = 1; i < level && ok; ++i)
      for (int j = 1; i + j < level && ok; ++j)
        ok = lattice_push(l, cap, t, (double)i / level, (double)j / level,
                          area[t] * lattice_weight(level, quadrature, i, j));
  free(area), free(nw), free(owner);
  pm_edges_free(&e);
  if (!ok) {
    lattice_free(l);
    return pm_error_setf(err, PM_ERR_INTERNAL, "distance: lattice count");
  }
  return PM_OK;
}

/* A run of model-side samples: chunk positions k .. k + len - 1, all of block `block`. */
typedef struct mrun {
  int64_t k;
  int32_t len, block;
} mrun;
#define RUN 64

/* Evaluate a run (the model -> mesh loop): results at chunk position k as in that loop. The
 * figures are model_eval's: a face's points come from one pm_face_eval_many call (the same
 * evaluations, batched), a sample's search of the curves (inside_exact) reaches further than the
 * band and tells how far the curves are, so that the following samples nearer to it than that
 * distance less the band need no search, and the search of the mesh starts from the previous
 * sample's distance plus the distance between the two (a bound on the answer, which is the same
 * exact distance as from an unbounded search). */
static void model_run(const dctx *c, const mblock *blocks, const mrun *run, int64_t s0,
                      double *dres, double *wres, double *rres, double *xres, int *fres) {
  const mblock *b = &blocks[run->block];
  const pm_model *m = c->m;
  const pm_bvh *target = (b->part == PART_WIRE && c->mesh_wire) ? c->mesh_wire : c->mesh_tri;
  if (b->kind != S_FACE) {
    for (int32_t q = 0; q < run->len; ++q) {
      int64_t k = run->k + q, r = s0 + k - b->first;
      double par[2], w = 0, *x = &xres[3 * k];
      par[0] = r + 1 == b->nu ? m->cells[PM_CURVE][b->cell].hi[0] : b->u0 + r * b->du, par[1] = 0;
      dres[k] = model_eval(c, b, par, x, NULL);
      /* Boundary curves of faces carry no area: they count in the maximum only. Dangling
       * curves are the wire part, weighted by length. */
      if (b->part == PART_WIRE && isfinite(dres[k])) {
        pm_curve_point cp;
        pm_curve_eval(&m->cells[PM_CURVE][b->cell], par[0], 1, &cp);
        w = pm_v3_norm(cp.d1) * b->du * ((r == 0 || r + 1 == b->nu) ? 0.5 : 1);
      }
      wres[k] = w;
      fres[k] = run->block;
      double sz = isfinite(dres[k]) ? size_at(c, x) : 0;
      rres[k] = sz > 0 ? dres[k] / sz : 0;
    }
    return;
  }
  const pm_cell *f = &m->cells[PM_FACE][b->cell];
  double uv[2 * RUN];
  pm_face_point fp[RUN];
  for (int32_t q = 0; q < run->len; ++q) {
    int64_t r = s0 + run->k + q - b->first;
    int32_t i = (int32_t)(r / b->nv), j = (int32_t)(r % b->nv);
    uv[2 * q] = b->u0 + i * b->du, uv[2 * q + 1] = b->v0 + j * b->dv;
  }
  pm_face_eval_many(f, run->len, uv, 1, fp);
  double prev[3] = {0, 0, 0}, dprev = INFINITY, cprev[3] = {0, 0, 0}, dcurve = -INFINITY;
  for (int32_t q = 0; q < run->len; ++q) {
    int64_t k = run->k + q;
    double *x = &xres[3 * k], n[3];
    pm_v3_copy(x, fp[q].p);
    pm_v3_cross(n, fp[q].su, fp[q].sv);
    int in = pm_face_inside(f, &uv[2 * q]);
    if (!c->p->prune) {
      in = inside_exact(c, b->cell, in, x, n);
    } else if (dcurve - pm_v3_dist(x, cprev) <= c->band * NBHD_SLACK) {
      in = inside_exact_far(c, b->cell, in, x, n, 4 * c->band, &dcurve);
      pm_v3_copy(cprev, x);
    }
    dres[k] = NAN, wres[k] = 0;
    if (in && target) {
      pm_bvh_hit hit;
      double bound = dprev < INFINITY && c->p->prune ? (dprev + pm_v3_dist(x, prev)) * NBHD_SLACK : INFINITY;
      if (!pm_bvh_closest(target, x, bound, &hit)) pm_bvh_closest(target, x, INFINITY, &hit);
      dres[k] = hit.dist;
      pm_v3_copy(prev, x), dprev = hit.dist;
      wres[k] = pm_v3_norm(n) * b->du * b->dv;
    }
    fres[k] = run->block;
    double sz = isfinite(dres[k]) ? size_at(c, x) : 0;
    rres[k] = sz > 0 ? dres[k] / sz : 0;
  }
}

/* Points allowed on one face: per_tri for each of its triangles, at least FACE_BUDGET_MIN (a
 * face with a handful of triangles still gets a grid that resolves its boundary), at most cap. */
#define FACE_BUDGET_MIN 256
static int64_t face_budget(int64_t cap, int32_t per_tri, int32_t ntri) {
  int64_t b = (int64_t)per_tri * ntri;
  if (b < FACE_BUDGET_MIN) b = FACE_BUDGET_MIN;
  return b < cap ? b : cap;
}

/* The neighbourhood bounds of triangle t (tri_nbhd). The searches reach a quarter of r beyond
 * what a sample needs when its distance to the model is 0 (NBHD_REACH): samples farther from
 * the model than that search as before. */
#define NBHD_REACH 1.25

typedef struct other_ctx {
  const dctx *c;
  const double *p;
  int32_t face;
  double best;  /* the smallest distance less the face's reach so far */
} other_ctx;

/* A reference triangle counts as nearer by its face's reach, so the search goes on to the best
 * value plus the largest reach. The strip that a degraded face's reference leaves uncovered
 * (ref_faces.gap) is not counted: the unbounded search of the reference found such a face only
 * where its reference was the nearest, and so does this one. */
static double other_face_visit(void *user, int32_t t, double radius) {
  other_ctx *o = user;
  const dctx *c = o->c;
  const ref_faces *rf = &c->rf;
  int32_t f = rf->face.v[t];
  if (f == o->face) return radius;
  const int32_t *v = &rf->tri.v[3 * (size_t)t];
  double d = pm_point_triangle_closest(o->p, &rf->xyz.v[3 * (size_t)v[0]], &rf->xyz.v[3 * (size_t)v[1]],
                                       &rf->xyz.v[3 * (size_t)v[2]], NULL, NULL);
  o->best = fmin(o->best, d - c->face_reach[f]);
  return fmin(radius, o->best + c->reach_max);
}

/* Centroid, r and the curve bound of triangle t. */
static void tri_nbhd_near(const dctx *c, int32_t t, tri_nbhd *nb) {
  const pm_mesh *me = c->mesh;
  const int32_t *v = &me->tri[3 * (size_t)t];
  double *g = nb->g;
  pm_v3_zero(g);
  for (int k = 0; k < 3; ++k) pm_v3_axpy(g, g, 1.0 / 3.0, &me->xyz[3 * (size_t)v[k]]);
  nb->r = 0;
  for (int k = 0; k < 3; ++k) nb->r = fmax(nb->r, pm_v3_dist(g, &me->xyz[3 * (size_t)v[k]]));
  nb->curve = INFINITY;
  if (c->rc_surf.bvh) {
    double cap = NBHD_REACH * nb->r + c->band;
    pm_bvh_hit hit;
    nb->curve = pm_bvh_closest(c->rc_surf.bvh, g, cap, &hit) ? hit.dist : cap;
  }
}

/* The other-face bound of a triangle classified on face f (f < 0: unclassified). The
 * boxes of the faces near f's box are looked at first: when none comes within reach, no
 * reference triangle does, and the search of the reference (which visits the triangle's own
 * face's reference too, to no use) is not needed. */
static void tri_nbhd_other(const dctx *c, int32_t f, const int32_t *near_off, const int32_t *near,
                           tri_nbhd *nb) {
  if (!c->rf.lazy) {
    nb->other = INFINITY;
    return;
  }
  if (f < 0) {
    nb->other = -INFINITY; /* no hint, nothing is skipped */
    return;
  }
  const double cap = NBHD_REACH * nb->r;
  int any = 0;
  for (int32_t k = near_off[f]; k < near_off[f + 1] && !any; ++k)
    any = pm_v3_box_dist(nb->g, &c->face_box[6 * (size_t)near[k]]) - c->face_reach[near[k]] <=
          cap;
  if (!any) {
    nb->other = cap;
    return;
  }
  /* The search reaches cap only (its cost stays that of the triangle's surroundings); an
   * unvisited triangle is farther than cap, so its distance less its reach exceeds
   * cap - reach_max. */
  other_ctx o = {c, nb->g, f, cap};
  const pm_bvh *rtree = ref_tree(&c->rf);
  if (!rtree) {
    nb->other = -INFINITY; /* the run fails; nothing is skipped meanwhile */
    return;
  }
  pm_bvh_visit(rtree, nb->g, cap, other_face_visit, &o);
  nb->other = fmin(o.best, cap - c->reach_max);
}

/* ---- driver ---------------------------------------------------------------------------------------------- */

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* The 5th percentile of the edge lengths of the triangles in list (all when list is NULL). */
static double edge_percentile(const pm_mesh *me, const int32_t *list, int64_t n) {
  if (n <= 0) return 0;
  double *len = malloc(sizeof(double) * 3 * (size_t)n);
  if (!len) return 0;
  int64_t k = 0;
  for (int64_t i = 0; i < n; ++i) {
    int32_t t = list ? list[i] : (int32_t)i;
    const int32_t *v = &me->tri[3 * (size_t)t];
    for (int q = 0; q < 3; ++q) {
      double l = pm_v3_dist(&me->xyz[3 * (size_t)v[q]], &me->xyz[3 * (size_t)v[(q + 1) % 3]]);
      if (l > 0) len[k++] = l;
    }
  }
  double r = 0;
  if (k > 0) {
    qsort(len, (size_t)k, sizeof(double), cmp_double);
    r = len[(size_t)(0.05 * (double)(k - 1))];
  }
  free(len);
  return r;
}

static double seg_length_percentile(const pm_mesh *me, const int32_t *list, int64_t n) {
  if (n <= 0) return 0;
  double *len = malloc(sizeof(double) * (size_t)n);
  if (!len) return 0;
  int64_t k = 0;
  for (int64_t i = 0; i < n; ++i) {
    const int32_t *v = &me->seg[2 * (size_t)list[i]];
    double l = pm_v3_dist(&me->xyz[3 * (size_t)v[0]], &me->xyz[3 * (size_t)v[1]]);
    if (l > 0) len[k++] = l;
  }
  double r = 0;
  if (k > 0) {
    qsort(len, (size_t)k, sizeof(double), cmp_double);
    r = len[(size_t)(0.05 * (double)(k - 1))];
  }
  free(len);
  return r;
}

/* Samples evaluated per parallel chunk (results are reduced in index order after each). */
#define CHUNK (1 << 15)

/* ---- the stages of pm_mesh_distance ------------------------------------------------------------ */

/* One call's state: the evaluation context that the samplers share (built by the stages up to
 * dist_tri_bounds, read only after them) and what each stage hands to the next. Zeroed, it holds
 * nothing; every pointer in it is owned and freed by dist_free. */
typedef struct dist_state {
  pm_distance_params p;     /* the parameters in use (c.p points here) */
  dctx c;
  int32_t nface, ncurve;
  double eps;               /* the reference's chordal tolerance: ref_tol x diagonal */
  int32_t *curve_segs;      /* [ncurve] mesh segments on each curve */
  int ndangling;            /* curves that bound no face */
  int32_t *face_tris_off;   /* [nface + 2] offsets into face_tris per face; the unclassified
                               triangles last, as face nface */
  int32_t *face_tris;       /* [mesh->ntri] triangle indices grouped by face */
  int32_t nunclass;         /* unclassified triangles */
  double *Lface;            /* [nface] local edge length of the mesh on each face */
  double Lglobal, Lwire;    /* the same over all triangles, over the wire part's segments */
  face_info *finfo;         /* [nface] */
  tri_nbhd *nbhd;           /* [mesh->ntri] (c.nb), or NULL */
  mblock *blocks;           /* [nblock] the model side's sample blocks */
  int32_t nblock;
  int64_t nmodel;           /* model -> mesh samples */
  lattice lat;              /* the mesh side's triangle samples */
  int64_t ntri_s, nmesh;    /* mesh -> model samples on triangles, and in all */
  double *dres, *wres, *rres; /* [CHUNK] one chunk's distances, weights, relative distances */
  double *xres;             /* [3 CHUNK] its sample points */
  int *fres;                /* [CHUNK] mesh side: the fallback flag; model side: the block */
  mrun *runs;               /* [CHUNK + nblock + 1] one chunk's runs of model samples */
  topk *top;                /* [2 refine + 1] storage of tops */
  topk *tops[2];            /* [dir] the largest samples of a direction, ntop[dir] of them */
  int ntop[2];
  acc A[2][2];              /* [direction: 0 mesh->model, 1 model->mesh][part] */
  int64_t nfallback;
  int64_t nhintless; /* mesh samples on triangles whose element gave no start (mesh_chunk_eval) */
} dist_state;

/* The error of a stage's allocation that has no message of its own naming what was allocated. */
static pm_status dist_nomem(pm_error *err) {
  return pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory");
}

/* Reject what cannot be measured before anything is allocated: a missing mesh or model,
 * parameters out of range, a model with nothing to compare with. */
static pm_status dist_check(dist_state *r, const pm_mesh *mesh, const pm_model *model,
                            const pm_distance_params *pin, pm_error *err) {
  if (!mesh || !model) return pm_error_setf(err, PM_ERR_ARG, "distance: no mesh or no model");
  if (pin)
    r->p = *pin;
  else
    pm_distance_params_init(&r->p);
  pm_status s = pm_distance_params_check(&r->p, err);
  if (s) return s;
  r->nface = model->count[PM_FACE], r->ncurve = model->count[PM_CURVE];
  if (r->nface == 0 && r->ncurve == 0)
    return pm_error_setf(err, PM_ERR_GEOM, "distance: the model %s has neither faces nor curves",
                         model->name);
  return PM_OK;
}

/* Which parts are measured (see distance.h): the surface part when the model has faces, the
 * wire part for the dangling curves and the mesh segments on them (every segment when the model
 * has no face). A mesh without anything to compare with those parts is an argument error. Also
 * counts the mesh segments on each curve (they cap a boundary curve's samples) and allocates the
 * per-face tables that dist_edge_lengths fills. */
/* Which nodes' parameters can start a projection: those whose cell's point at them is the node
 * (within PAR_OK_REL of the diagonal). A mesh read from a file without parameters (a .msh
 * written without --parametric, another tool's file) has zeros there: on a sphere they start
 * Gauss-Newton at a pole, and the foot it finds is a local minimum up to 1.4 radii from the
 * node's true foot. Such nodes take the reference tessellation's pick instead, as untagged
 * ones do, and the figures are those of the mesh as the mesher holds it. */
#define PAR_OK_REL 1e-6
static pm_status dist_check_params(dctx *c, pm_error *err) {
  const pm_mesh *me = c->mesh;
  const pm_model *m = c->m;
  c->par_ok = calloc((size_t)(me->nnode > 0 ? me->nnode : 1), 1);
  if (!c->par_ok) return dist_nomem(err);
  if (!me->node_dim || !me->node_cell || !me->node_par) return PM_OK;
  const double tol = PAR_OK_REL * m->diagonal;
#pragma omp parallel for schedule(static)
  for (int32_t v = 0; v < me->nnode; ++v) {
    const int d = me->node_dim[v];
    const int32_t cell = me->node_cell[v];
    if ((d != PM_CURVE && d != PM_FACE) || cell < 0 || cell >= m->count[d]) continue;
    double at[3];
    pm_cell_point(&m->cells[d][cell], &me->node_par[2 * (size_t)v], at);
    c->par_ok[v] = pm_v3_dist(at, &me->xyz[3 * (size_t)v]) <= tol;
  }
  if (!me->tri_cell || me->ntri == 0) return PM_OK;
  /* The corners of a triangle that lie on a boundary curve of its face: their (u, v) on the face
   * through the curve's pcurve, kept where the face's point there is the node. Without them a
   * triangle whose three nodes are on the boundary has no hint: its samples are searched from
   * the reference and the curves instead (occ__TrimmedSurface.brep's 86-node bubble mesh: 814
   * of its 851 samples). A curve the face uses twice (a seam) gives either side's (u, v): they
   * are one point, and tri_hint_nodes unwraps the periodic direction. */
  c->corner_uv = malloc(sizeof(double) * 6 * (size_t)me->ntri);
  c->corner_ok = calloc(3 * (size_t)me->ntri, 1);
  if (!c->corner_uv || !c->corner_ok) return dist_nomem(err);
#pragma omp parallel for schedule(dynamic, 256)
  for (int32_t t = 0; t < me->ntri; ++t) {
    const int32_t f = me->tri_cell[t];
    if (f < 0 || f >= m->count[PM_FACE]) continue;
    const pm_cell *fc = &m->cells[PM_FACE][f];
    for (int k = 0; k < 3; ++k) {
      const int32_t v = me->tri[3 * (size_t)t + k];
      if (me->node_dim[v] != PM_CURVE || !c->par_ok[v]) continue;
      const pm_use *use = NULL;
      for (int32_t l = 0; l < fc->nloop && !use; ++l)
        for (int32_t u = 0; u < fc->loop[l].nuse && !use; ++u)
          if (fc->loop[l].use[u].cell == me->node_cell[v]) use = &fc->loop[l].use[u];
      if (!use) continue;
      double *uv = &c->corner_uv[6 * (size_t)t + 2 * k], at[3];
      pm_face_curve_uv(fc, use, me->node_par[2 * (size_t)v], uv);
      pm_cell_point(fc, uv, at);
      c->corner_ok[3 * (size_t)t + k] = pm_v3_dist(at, &me->xyz[3 * (size_t)v]) <= tol;
    }
  }
  return PM_OK;
}

static pm_status dist_setup(dist_state *r, const pm_mesh *mesh, const pm_model *m,
                            const pm_sizing *size, pm_error *err) {
  dctx *c = &r->c;
  const int32_t nface = r->nface, ncurve = r->ncurve;
  c->mesh = mesh, c->m = m, c->size = size, c->p = &r->p;
  r->eps = r->p.ref_tol * m->diagonal;

  c->dangling = calloc((size_t)(ncurve > 0 ? ncurve : 1), 1);
  r->face_tris_off = calloc((size_t)nface + 2, sizeof(int32_t));
  r->face_tris = malloc(sizeof(int32_t) * (size_t)(mesh->ntri > 0 ? mesh->ntri : 1));
  r->Lface = malloc(sizeof(double) * (size_t)(nface > 0 ? nface : 1));
  if (!c->dangling || !r->face_tris_off || !r->face_tris || !r->Lface) return dist_nomem(err);
  r->curve_segs = calloc((size_t)(ncurve > 0 ? ncurve : 1), sizeof(int32_t));
  if (!r->curve_segs) return dist_nomem(err);
  for (int32_t i = 0; i < mesh->nseg && mesh->seg_cell; ++i)
    if (mesh->seg_cell[i] >= 0 && mesh->seg_cell[i] < ncurve) r->curve_segs[mesh->seg_cell[i]]++;
  for (int32_t i = 0; i < ncurve; ++i) {
    c->dangling[i] = m->cells[PM_CURVE][i].nup == 0;
    r->ndangling += c->dangling[i];
  }

  c->surf = nface > 0;
  if (c->surf && mesh->ntri == 0)
    return pm_error_setf(err, PM_ERR_ARG, "distance: the mesh has no triangles but the model %s has %d faces",
                         m->name, (int)nface);
  c->wire_seg = malloc(sizeof(int32_t) * (size_t)(mesh->nseg > 0 ? mesh->nseg : 1));
  if (!c->wire_seg) return dist_nomem(err);
  for (int32_t i = 0; i < mesh->nseg; ++i) {
    int32_t cu = mesh->seg_cell ? mesh->seg_cell[i] : -1;
    int known = cu >= 0 && cu < ncurve;
    if ((known && c->dangling[cu]) || (!known && nface == 0)) c->wire_seg[c->nwire++] = i;
  }
  c->wire = r->ndangling > 0;
  if (!c->surf && c->nwire == 0)
    return pm_error_setf(err, PM_ERR_ARG, "distance: the mesh has no segments to compare with the curves of %s",
                         m->name);
  return dist_check_params(c, err);
}

/* BVHs of the mesh, which the model side's samples search: its triangles, and the wire part's
 * segments as degenerate triangles (a, b, b). */
static pm_status dist_mesh_bvhs(dist_state *r, pm_error *err) {
  dctx *c = &r->c;
  const pm_mesh *mesh = c->mesh;
  pm_status s = PM_OK;
  if (mesh->ntri > 0 && (s = pm_bvh_create(mesh->xyz, mesh->nnode, mesh->tri, mesh->ntri, &c->mesh_tri, err))) {
    pm_error_prefix(err, "distance");
    return s;
  }
  if (c->nwire > 0) {
    int32_t *st = malloc(sizeof(int32_t) * 3 * (size_t)c->nwire);
    if (!st) return dist_nomem(err);
    for (int32_t i = 0; i < c->nwire; ++i) {
      const int32_t *v = &mesh->seg[2 * (size_t)c->wire_seg[i]];
      st[3 * i] = v[0], st[3 * i + 1] = v[1], st[3 * i + 2] = v[1];
    }
    s = pm_bvh_create(mesh->xyz, mesh->nnode, st, c->nwire, &c->mesh_wire, err);
    free(st);
    if (s) {
      pm_error_prefix(err, "distance");
      return s;
    }
  }
  return PM_OK;
}

/* The local edge lengths of the mesh (5th percentiles), which set the spacing of both the model
 * samples and the reference: per face from the triangles classified on it (all triangles for a
 * face without any), over all triangles, and over the wire part's segments. */
static pm_status dist_edge_lengths(dist_state *r, pm_error *err) {
  const pm_mesh *mesh = r->c.mesh;
  const int32_t nface = r->nface;
  int32_t *off = r->face_tris_off;
  r->Lglobal = r->c.surf ? edge_percentile(mesh, NULL, mesh->ntri) : 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell ? mesh->tri_cell[t] : -1;
    off[(f >= 0 && f < nface ? f : nface) + 1]++;
  }
  for (int32_t f = 0; f <= nface; ++f) off[f + 1] += off[f];
  int32_t *fill = calloc((size_t)nface + 1, sizeof(int32_t));
  if (!fill) return dist_nomem(err);
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell ? mesh->tri_cell[t] : -1;
    if (!(f >= 0 && f < nface)) f = nface;
    r->face_tris[off[f] + fill[f]++] = t;
  }
  free(fill);
  for (int32_t f = 0; f < nface; ++f) {
    int32_t n = off[f + 1] - off[f];
    r->Lface[f] = n > 0 ? edge_percentile(mesh, &r->face_tris[off[f]], n) : r->Lglobal;
    if (!(r->Lface[f] > 0)) r->Lface[f] = r->Lglobal > 0 ? r->Lglobal : 0.01 * r->c.m->diagonal;
  }
  r->nunclass = off[nface + 1] - off[nface];
  double Lwire = r->c.nwire > 0 ? seg_length_percentile(mesh, r->c.wire_seg, r->c.nwire) : 0;
  if (!(Lwire > 0)) Lwire = r->Lglobal > 0 ? r->Lglobal : 0.01 * r->c.m->diagonal;
  r->Lwire = Lwire;
  return PM_OK;
}

/* Per-face budgets count the face's own triangles, and every unclassified one (a mesh read
 * without tags could have them anywhere). */
static int32_t ntri_face(const dist_state *r, int32_t f) {
  return r->face_tris_off[f + 1] - r->face_tris_off[f] + r->nunclass;
}

/* Probe every face once (derivative sizes and curvature over its parameter box): both the
 * reference grid and the model samples are spaced from what the probes find. */
static pm_status dist_probe_faces(dist_state *r, pm_error *err) {
  const pm_model *m = r->c.m;
  const int32_t nface = r->nface;
  face_info *finfo = r->finfo = malloc(sizeof(face_info) * (size_t)(nface > 0 ? nface : 1));
  if (!finfo) return dist_nomem(err);
#pragma omp parallel for schedule(dynamic, 1)
  for (int32_t f = 0; f < nface; ++f) {
    const pm_cell *fc = &m->cells[PM_FACE][f];
    loop_box(fc, finfo[f].box);
    face_probe(fc, finfo[f].box, &finfo[f].su, &finfo[f].sv, &finfo[f].kappa);
  }
  return PM_OK;
}

/* The reference tessellation of the faces (surface part only) and its BVH: it picks the face and
 * the start of a mesh point's projection (model_dist). Faces are triangulated in parallel, each
 * into its own buffers, then appended in face order, so the result does not depend on the thread
 * count. */
static pm_status dist_face_reference(dist_state *r, pm_error *err) {
  dctx *c = &r->c;
  if (!c->surf) return PM_OK;
  const pm_model *m = c->m;
  const pm_distance_params *p = &r->p;
  const int32_t nface = r->nface;
  const double eps = r->eps;
  ref_faces *part = calloc((size_t)nface, sizeof(ref_faces));
  c->face_reach = calloc((size_t)nface, sizeof(double));
  if (!c->face_reach) {
    free(part);
    return dist_nomem(err);
  }
  pm_status *fst = calloc((size_t)nface, sizeof(pm_status));
  pm_error *ferr = calloc((size_t)nface, sizeof(pm_error));
  if (!part || !fst || !ferr) {
    free(part), free(fst), free(ferr);
    return dist_nomem(err);
  }
#pragma omp parallel for schedule(dynamic, 1)
  for (int32_t f = 0; f < nface; ++f)
    fst[f] = ref_face(&part[f], &m->cells[PM_FACE][f], &r->finfo[f], eps, p->ref_spacing * r->Lface[f],
                      face_budget(p->ref_max_points, p->ref_per_tri, ntri_face(r, f)), p->ref_split,
                      &ferr[f]);
  pm_status s = PM_OK;
  for (int32_t f = 0; f < nface && !s; ++f) {
    if (fst[f]) {
      s = fst[f];
      if (err) *err = ferr[f];
      break;
    }
    int32_t base = (int32_t)(c->rf.xyz.n / 3);
    c->rf.chord = fmax(c->rf.chord, part[f].chord);
    c->rf.degraded += part[f].degraded;
    c->rf.cdt_points += part[f].cdt_points;
    c->rf.gap = fmax(c->rf.gap, part[f].gap);
    /* The chordal bound (0 on a plane: the floor is for rounding). The sliver that the
     * trimming polylines cut off a face along a curved boundary (2e-4 of its parameter box,
     * trim.c) has no reference; its points are within the sliver's width of the boundary
     * curve, which the curve candidates of model_dist measure. */
    c->face_reach[f] = REF_REACH_MARGIN * part[f].chord + 1e-12 * m->diagonal;
    c->reach_max = fmax(c->reach_max, c->face_reach[f]);
    if (!dbuf_push(&c->rf.xyz, part[f].xyz.v, part[f].xyz.n) ||
        !dbuf_push(&c->rf.uv, part[f].uv.v, part[f].uv.n) ||
        !ibuf_push(&c->rf.face, part[f].face.v, part[f].face.n)) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory (reference)");
      break;
    }
    for (int64_t k = 0; k < part[f].tri.n; ++k) part[f].tri.v[k] += base;
    if (!ibuf_push(&c->rf.tri, part[f].tri.v, part[f].tri.n))
      s = pm_error_setf(err, PM_ERR_NOMEM, "distance: out of memory (reference)");
  }
  for (int32_t f = 0; f < nface; ++f) ref_faces_free(&part[f]);
  free(part), free(fst), free(ferr);
  if (s) return s;
  if (c->rf.tri.n > 0) {
    if (!(c->rf.lazy = calloc(1, sizeof(lazy_tree)))) return dist_nomem(err);
    pthread_mutex_init(&c->rf.lazy->lock, NULL);
    atomic_init(&c->rf.lazy->tree, NULL);
  }
  return PM_OK;
}

/* How far the reference may lie from the faces, and each face's reference box: the bounds with
 * which model_dist stops its searches and dist_tri_bounds skips them (surface part only). */
static pm_status dist_face_bounds(dist_state *r, pm_error *err) {
  dctx *c = &r->c;
  if (!c->surf) return PM_OK;
  const int32_t nface = r->nface;
  /* The reference is within its chordal bound of its faces (at least eps; the bound is an
   * estimate from the probed curvature, so REF_REACH_MARGIN times it leaves room for what the
   * probes missed), but for the strip along the boundary that a face whose constrained
   * triangulation failed leaves uncovered. */
  c->ref_reach = REF_REACH_MARGIN * fmax(r->eps, c->rf.chord) + c->rf.gap;
  c->face_box = malloc(sizeof(double) * 6 * (size_t)nface);
  if (!c->face_box) return dist_nomem(err);
  for (int32_t f = 0; f < nface; ++f)
    for (int k = 0; k < 3; ++k) c->face_box[6 * f + k] = INFINITY, c->face_box[6 * f + 3 + k] = -INFINITY;
  for (int64_t t = 0; t < c->rf.tri.n / 3; ++t) {
    double *b = &c->face_box[6 * (size_t)c->rf.face.v[t]];
    for (int q = 0; q < 3; ++q)
      for (int k = 0; k < 3; ++k) {
        double x = c->rf.xyz.v[3 * (size_t)c->rf.tri.v[3 * t + q] + k];
        b[k] = fmin(b[k], x), b[3 + k] = fmax(b[3 + k], x);
      }
  }
  return PM_OK;
}

/* The reference polylines of the curves and their BVHs: the boundary curves (surface part) and
 * the dangling ones (wire part), separately, since each part measures against its own. Then the
 * band within which the curves, not the trimming polylines, decide whether a point of a face is
 * inside it (inside_exact). */
static pm_status dist_curve_reference(dist_state *r, pm_error *err) {
  dctx *c = &r->c;
  const pm_model *m = c->m;
  pm_status s = PM_OK;
  for (int32_t i = 0; i < r->ncurve; ++i) {
    ref_curves *rc = c->dangling[i] ? &c->rc_wire : &c->rc_surf;
    if (!c->dangling[i] && !c->surf) continue;
    if ((s = ref_curve(rc, &m->cells[PM_CURVE][i], r->eps, err))) return s;
  }
  for (int k = 0; k < 2; ++k) {
    ref_curves *rc = k ? &c->rc_wire : &c->rc_surf;
    if (rc->seg.n > 0 &&
        (s = pm_bvh_create(rc->xyz.v, (int32_t)(rc->xyz.n / 3), rc->seg.v, (int32_t)(rc->seg.n / 3),
                           &rc->bvh, err))) {
      pm_error_prefix(err, "distance: reference");
      return s;
    }
  }
  c->band = BOUNDARY_BAND * m->diagonal + 2 * r->eps;
  return PM_OK;
}

/* For each face, the other faces whose boxes come within reach of its box (a triangle's
 * centroid lies in its face's box but for the mesh's distance to it, which the search radius
 * NBHD_REACH r covers where skipping is possible at all): near[near_off[f] .. near_off[f + 1]).
 * rmax[f] is the largest r of f's triangles. Returns 0 when out of memory (*near stays NULL). */
static int near_faces(const dctx *c, int32_t nface, const double *rmax, int32_t *near_off,
                      int32_t **near_out) {
  int32_t *near = NULL;
  int64_t nnear = 0;
  for (int pass = 0; pass < 2; ++pass) {
    nnear = 0;
    for (int32_t f = 0; f < nface; ++f) {
      if (pass) near_off[f] = (int32_t)nnear;
      const double *a = &c->face_box[6 * (size_t)f];
      for (int32_t f2 = 0; f2 < nface; ++f2) {
        if (f2 == f) continue;
        const double *b = &c->face_box[6 * (size_t)f2];
        double s2 = 0;
        for (int k = 0; k < 3; ++k) {
          double e = fmax(fmax(a[k] - b[3 + k], b[k] - a[3 + k]), 0);
          s2 += e * e;
        }
        if (sqrt(s2) - c->face_reach[f2] <= NBHD_REACH * rmax[f] + rmax[f]) {
          if (pass) near[nnear] = f2;
          ++nnear;
        }
      }
    }
    if (pass) near_off[nface] = (int32_t)nnear;
    else if (!(near = malloc(sizeof(int32_t) * (size_t)(nnear > 0 ? nnear : 1)))) break;
  }
  *near_out = near;
  return near != NULL;
}

/* The neighbourhood bounds of the mesh triangles (tri_nbhd), with which the mesh side's
 * samples skip the searches that cannot find anything; only with prune, which leaves every
 * figure as it is. */
static pm_status dist_tri_bounds(dist_state *r, pm_error *err) {
  dctx *c = &r->c;
  const pm_mesh *mesh = c->mesh;
  const int32_t nface = r->nface;
  if (!(c->surf && mesh->ntri > 0 && r->p.prune)) return PM_OK;
  tri_nbhd *nbhd = r->nbhd = malloc(sizeof(tri_nbhd) * (size_t)mesh->ntri);
  double *rmax = calloc((size_t)nface + 1, sizeof(double));
  int32_t *near_off = calloc((size_t)nface + 1, sizeof(int32_t)), *near = NULL;
  if (!nbhd || !rmax || !near_off) {
    free(rmax), free(near_off);
    return dist_nomem(err);
  }
#pragma omp parallel for schedule(dynamic, 256)
  for (int32_t t = 0; t < mesh->ntri; ++t) tri_nbhd_near(c, t, &nbhd[t]);
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell ? mesh->tri_cell[t] : -1;
    if (f >= 0 && f < nface) rmax[f] = fmax(rmax[f], nbhd[t].r);
  }
  if (!near_faces(c, nface, rmax, near_off, &near)) {
    free(rmax), free(near_off);
    return dist_nomem(err);
  }
#pragma omp parallel for schedule(dynamic, 256)
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell ? mesh->tri_cell[t] : -1;
    tri_nbhd_other(c, f >= 0 && f < nface ? f : -1, near_off, near, &nbhd[t]);
  }
  free(rmax), free(near_off), free(near);
  c->nb = nbhd;
  return PM_OK;
}

/* Face f's grid of model samples (model -> mesh) at `spacing` x grow times the local edge
 * length, capped by the face's budget. Fills all of b but `first`. */
static void face_block(const dist_state *r, int32_t f, double grow, mblock *b) {
  const pm_distance_params *p = &r->p;
  const double *box = r->finfo[f].box, su = r->finfo[f].su, sv = r->finfo[f].sv;
  double h = p->spacing * r->Lface[f] * grow;
  double nu = fmax(2, ceil(su * (box[2] - box[0]) / h)), nv = fmax(2, ceil(sv * (box[3] - box[1]) / h));
  const int64_t cap = face_budget(p->max_face_samples, p->model_per_tri, ntri_face(r, f));
  if (nu * nv > (double)cap) {
    double sc = sqrt((double)cap / (nu * nv));
    nu = fmax(2, floor(nu * sc)), nv = fmax(2, floor(nv * sc));
  }
  b->kind = S_FACE, b->part = PART_SURF, b->cell = f;
  b->nu = (int32_t)nu, b->nv = (int32_t)nv;
  b->du = (box[2] - box[0]) / nu, b->dv = (box[3] - box[1]) / nv;
  b->u0 = box[0] + 0.5 * b->du, b->v0 = box[1] + 0.5 * b->dv;
}

/* Curve i's points (model -> mesh) at `spacing` x grow times the local edge length: of the wire
 * part for a dangling curve, else of the finest face the curve bounds. Fills all of b but
 * `first`. */
static void curve_block(const dist_state *r, int32_t i, double grow, mblock *b) {
  const dctx *c = &r->c;
  const pm_distance_params *p = &r->p;
  const pm_cell *cu = &c->m->cells[PM_CURVE][i];
  double h;
  if (c->dangling[i]) {
    h = r->Lwire;
  } else {
    h = INFINITY;
    for (int32_t k = 0; k < cu->nup; ++k) h = fmin(h, r->Lface[cu->up[k]]);
    if (!(h < INFINITY)) h = r->Lglobal;
  }
  h *= p->spacing * grow;
  double n = fmax(3, ceil(pm_curve_length(cu, cu->lo[0], cu->hi[0]) / h) + 1);
  if (n > (double)p->max_face_samples) n = (double)p->max_face_samples;
  /* A boundary curve counts in the maximum only (its largest samples are refined): like a
   * face, at most model_per_tri points per mesh segment on it (at least FACE_BUDGET_MIN),
   * so that a face's shortest edges do not set the sampling of its long curves. */
  if (!c->dangling[i] && r->curve_segs[i] > 0) {
    double cap = (double)face_budget(p->max_face_samples, p->model_per_tri, r->curve_segs[i]);
    if (n > cap) n = cap;
  }
  b->kind = S_CURVE, b->part = c->dangling[i] ? PART_WIRE : PART_SURF, b->cell = i;
  b->nu = (int32_t)n, b->nv = 1;
  b->u0 = cu->lo[0], b->du = (cu->hi[0] - cu->lo[0]) / (n - 1), b->v0 = 0, b->dv = 0;
}

/* The model side's samples (model -> mesh), as blocks: a grid of each face's parameter box and
 * the points of each curve, spaced from the local edge length of the mesh and capped per face /
 * curve by the budgets of distance.h. When the total exceeds max_samples the spacing grows (up
 * to 8 passes) to meet it. */
static pm_status dist_model_samples(dist_state *r, pm_error *err) {
  const dctx *c = &r->c;
  const pm_model *m = c->m;
  const int32_t nface = r->nface, ncurve = r->ncurve;
  int32_t nblock = 0;
  mblock *blocks = r->blocks = malloc(sizeof(mblock) * (size_t)(nface + ncurve + 1));
  if (!blocks) return dist_nomem(err);
  double grow = 1; /* spacing multiplier to meet max_samples */
  for (int pass = 0; pass < 8; ++pass) {
    nblock = 0;
    int64_t total = 0;
    for (int32_t f = 0; f < nface && c->surf; ++f) {
      if (m->cells[PM_FACE][f].nloop <= 0) continue;
      mblock *b = &blocks[nblock++];
      face_block(r, f, grow, b);
      b->first = total;
      total += (int64_t)b->nu * b->nv;
    }
    for (int32_t i = 0; i < ncurve; ++i) {
      if (m->cells[PM_CURVE][i].degenerate) continue;
      if (!c->dangling[i] && !c->surf) continue;
      mblock *b = &blocks[nblock++];
      curve_block(r, i, grow, b);
      b->first = total;
      total += b->nu;
    }
    if (total <= r->p.max_samples) break;
    grow *= sqrt((double)total / (double)r->p.max_samples) * 1.01;
  }
  r->nblock = nblock;
  r->nmodel = nblock > 0 ? blocks[nblock - 1].first + (int64_t)blocks[nblock - 1].nu * blocks[nblock - 1].nv : 0;
  return PM_OK;
}

/* The mesh side's samples (mesh -> model): the lattice of level tri_level on the triangles
 * (lowered, not below 1, until the samples fit in max_samples) and level + 1 points on each
 * wire segment. */
static pm_status dist_mesh_samples(dist_state *r, pm_error *err) {
  dctx *c = &r->c;
  const pm_mesh *mesh = c->mesh;
  c->level = r->p.tri_level;
  while (c->level > 1 && (int64_t)mesh->ntri * ((c->level + 1) * (c->level + 2) / 2) +
                                 (int64_t)c->nwire * (c->level + 1) > r->p.max_samples)
    c->level--;
  c->npt_tri = (c->level + 1) * (c->level + 2) / 2;
  c->npt_seg = c->level + 1;
  pm_status s = PM_OK;
  if (c->surf && (s = lattice_build(mesh, c->level, r->p.quadrature, &r->lat, err))) return s;
  r->ntri_s = c->surf ? r->lat.n : 0;
  r->nmesh = r->ntri_s + (int64_t)c->nwire * c->npt_seg;
  return PM_OK;
}

/* One chunk's result buffers (both directions evaluate CHUNK samples at a time, in parallel, and
 * reduce them in index order), the lists of each direction's largest samples, and the
 * accumulators. */
static pm_status dist_buffers(dist_state *r, pm_error *err) {
  r->dres = malloc(sizeof(double) * CHUNK);
  r->wres = malloc(sizeof(double) * CHUNK);
  r->rres = malloc(sizeof(double) * CHUNK);
  r->xres = malloc(sizeof(double) * 3 * CHUNK);
  r->fres = malloc(sizeof(int) * CHUNK);
  r->runs = malloc(sizeof(mrun) * (CHUNK + (size_t)r->nblock + 1));
  r->top = malloc(sizeof(topk) * (size_t)(2 * r->p.refine + 1));
  if (!r->dres || !r->wres || !r->rres || !r->xres || !r->fres || !r->runs || !r->top)
    return dist_nomem(err);
  r->tops[0] = r->top, r->tops[1] = r->top + r->p.refine;
  return PM_OK;
}

/* Evaluate mesh-side samples s0 .. s0 + n - 1 into the chunk buffers, in parallel, FOOT_BATCH
 * at a time: the lattice points of the triangles, then level + 1 points per wire segment. The
 * feet from the hints of a batch are searched a face at a time (face_feet); the rest of each
 * sample's distance follows one by one (model_dist). A point on an edge between two faces is
 * measured through a triangle of each and keeps the smaller distance (lattice). */
static void mesh_chunk_eval(dist_state *r, int64_t s0, int64_t n) {
  const dctx *c = &r->c;
  const pm_mesh *mesh = c->mesh;
  const lattice *lat = &r->lat;
  const int64_t ntri_s = r->ntri_s;
  double *dres = r->dres, *wres = r->wres, *rres = r->rres, *xres = r->xres;
  int *fres = r->fres;
  int64_t hintless = 0; /* (an integer sum: the same in any order) */
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : hintless)
  for (int64_t b0 = 0; b0 < n; b0 += FOOT_BATCH) {
    const int32_t nb = n - b0 < FOOT_BATCH ? (int32_t)(n - b0) : FOOT_BATCH;
    hint h[FOOT_BATCH];
    fcand pre[FOOT_BATCH];
    int kind[FOOT_BATCH], state[FOOT_BATCH]; /* state: 0 outside, 1 no foot yet, 2 foot in pre */
    for (int32_t j = 0; j < nb; ++j) {
      const int64_t k = b0 + j, sidx = s0 + k;
      int32_t e;
      double par[2], w;
      if (sidx < ntri_s) {
        kind[j] = S_TRI, e = lat->tri[sidx];
        par[0] = lat->par[2 * sidx], par[1] = lat->par[2 * sidx + 1];
        w = lat->w[sidx];
      } else {
        int64_t q = sidx - ntri_s;
        kind[j] = S_SEG, e = (int32_t)(q / c->npt_seg);
        par[0] = (double)(q % c->npt_seg) / c->level, par[1] = 0;
        const int32_t *v = &mesh->seg[2 * (size_t)c->wire_seg[e]];
        w = pm_v3_dist(&mesh->xyz[3 * (size_t)v[0]], &mesh->xyz[3 * (size_t)v[1]]) *
            segment_weight(c->level, r->p.quadrature, (int)(q % c->npt_seg));
      }
      wres[k] = w;
      state[j] = mesh_point(c, kind[j], e, par, &xres[3 * k], &h[j]);
      hintless += state[j] && kind[j] == S_TRI && h[j].cell < 0;
    }
    /* the hints' feet, a face at a time */
    for (int32_t j = 0; j < nb; ++j) {
      if (state[j] != 1 || kind[j] != S_TRI || h[j].cell < 0) continue;
      const int32_t f = h[j].cell;
      int32_t idx[FOOT_BATCH], m = 0;
      double x[3 * FOOT_BATCH], uv[2 * FOOT_BATCH];
      fcand feet[FOOT_BATCH];
      for (int32_t i = j; i < nb; ++i) {
        if (state[i] != 1 || kind[i] != S_TRI || h[i].cell != f) continue;
        pm_v3_copy(x + 3 * m, &xres[3 * (b0 + i)]);
        uv[2 * m] = h[i].par[0], uv[2 * m + 1] = h[i].par[1];
        idx[m++] = i;
      }
      face_feet(&c->m->cells[PM_FACE][f], m, x, uv, feet);
      for (int32_t q = 0; q < m; ++q) pre[idx[q]] = feet[q], state[idx[q]] = 2;
    }
    for (int32_t j = 0; j < nb; ++j) {
      const int64_t k = b0 + j, sidx = s0 + k;
      double *x = &xres[3 * k];
      fres[k] = 0;
      dres[k] = state[j] ? model_dist(c, kind[j] == S_TRI ? PART_SURF : PART_WIRE, x, &h[j],
                                      state[j] == 2 ? &pre[j] : NULL, &fres[k])
                         : NAN;
      if (kind[j] == S_TRI && lat->alt[sidx] >= 0) {
        double x2[3];
        int f2;
        double d2 = mesh_eval(c, S_TRI, lat->alt[sidx], &lat->apar[2 * sidx], x2, &f2);
        if (d2 < dres[k] || !isfinite(dres[k])) dres[k] = d2, fres[k] = f2;
      }
      double sz = size_at(c, x);
      rres[k] = sz > 0 ? dres[k] / sz : 0;
    }
  }
  r->nhintless += hintless;
}

/* Reduce a mesh-side chunk in index order (so the thread count changes no figure): accumulate
 * each finite sample and offer it, with the element and parameters to refine it from, to the
 * list of the largest (one entry per element: the key). */
static void mesh_chunk_reduce(dist_state *r, int64_t s0, int64_t n) {
  const dctx *c = &r->c;
  const lattice *lat = &r->lat;
  for (int64_t k = 0; k < n; ++k) {
    if (!isfinite(r->dres[k])) continue;
    int64_t sidx = s0 + k;
    int part = sidx < r->ntri_s ? PART_SURF : PART_WIRE;
    acc_add(&r->A[0][part], r->dres[k], r->wres[k], r->rres[k], &r->xres[3 * k]);
    r->nfallback += r->fres[k];
    topk t;
    t.d = r->dres[k];
    if (part == PART_SURF) {
      t.kind = S_TRI, t.elem = lat->tri[sidx];
      t.par[0] = lat->par[2 * sidx], t.par[1] = lat->par[2 * sidx + 1];
      t.step[0] = t.step[1] = 0.5 / c->level;
    } else {
      int64_t q = sidx - r->ntri_s;
      t.kind = S_SEG, t.elem = (int32_t)(q / c->npt_seg);
      t.par[0] = (double)(q % c->npt_seg) / c->level, t.par[1] = 0;
      t.step[0] = 0.5 / c->level, t.step[1] = 0;
    }
    t.key = (int64_t)t.kind << 40 | t.elem;
    topk_offer(r->tops[0], &r->ntop[0], r->p.refine, &t);
  }
}

/* The mesh -> model direction: every mesh-side sample's distance to the model, chunk by chunk. */
static void dist_mesh_to_model(dist_state *r) {
  for (int64_t s0 = 0; s0 < r->nmesh; s0 += CHUNK) {
    int64_t n = r->nmesh - s0 < CHUNK ? r->nmesh - s0 : CHUNK;
    mesh_chunk_eval(r, s0, n);
    mesh_chunk_reduce(r, s0, n);
  }
}

/* Cut model-side samples s0 .. s0 + n - 1 into runs of up to RUN consecutive samples of one
 * block (r->runs): a face's run is evaluated in one batch, and each sample's searches start from
 * what the previous one found (model_run). Returns the number of runs. */
static int64_t model_chunk_runs(dist_state *r, int64_t s0, int64_t n) {
  const mblock *blocks = r->blocks;
  int64_t nrun = 0;
  for (int64_t k = 0; k < n;) {
    int64_t sidx = s0 + k;
    /* The block holding sample sidx (binary search on `first`). */
    int32_t lo = 0, hi = r->nblock - 1;
    while (lo < hi) {
      int32_t mid = (lo + hi + 1) / 2;
      if (blocks[mid].first <= sidx)
        lo = mid;
      else
        hi = mid - 1;
    }
    int64_t end = blocks[lo].first + (int64_t)blocks[lo].nu * blocks[lo].nv - s0;
    int64_t len = end - k < RUN ? end - k : RUN;
    if (k + len > n) len = n - k;
    r->runs[nrun].k = k, r->runs[nrun].len = (int32_t)len, r->runs[nrun].block = lo;
    ++nrun, k += len;
  }
  return nrun;
}

/* Reduce a model-side chunk in index order, as mesh_chunk_reduce. A face's largest samples are
 * kept one per 1/64 of its grid, a curve's one per 1/64 of its points (the key), so that the
 * refined ones are spread over the model. */
static void model_chunk_reduce(dist_state *r, int64_t s0, int64_t n) {
  const pm_model *m = r->c.m;
  for (int64_t k = 0; k < n; ++k) {
    if (!isfinite(r->dres[k])) continue;
    const int fk = r->fres[k];
    const mblock *b = &r->blocks[fk];
    acc_add(&r->A[1][b->part], r->dres[k], r->wres[k], r->rres[k], &r->xres[3 * k]);
    int64_t q = s0 + k - b->first;
    topk t;
    t.d = r->dres[k];
    t.kind = b->kind, t.elem = fk;
    if (b->kind == S_FACE) {
      int32_t i = (int32_t)(q / b->nv), j = (int32_t)(q % b->nv);
      t.par[0] = b->u0 + i * b->du, t.par[1] = b->v0 + j * b->dv;
      t.step[0] = 0.5 * b->du, t.step[1] = 0.5 * b->dv;
      t.key = ((int64_t)(S_FACE) << 40) | ((int64_t)fk << 8) | (((int64_t)i * 8 / b->nu) * 8 + (int64_t)j * 8 / b->nv);
    } else {
      t.par[0] = b->u0 + q * b->du, t.par[1] = 0;
      if (q + 1 == b->nu) t.par[0] = m->cells[PM_CURVE][b->cell].hi[0];
      t.step[0] = 0.5 * b->du, t.step[1] = 0;
      t.key = ((int64_t)(S_CURVE) << 40) | ((int64_t)fk << 8) | (q * 64 / b->nu);
    }
    topk_offer(r->tops[1], &r->ntop[1], r->p.refine, &t);
  }
}

/* The model -> mesh direction: every model-side sample's distance to the mesh (the closest-point
 * searches of the mesh's BVHs), chunk by chunk, the runs of a chunk in parallel. */
static void dist_model_to_mesh(dist_state *r) {
  const dctx *c = &r->c;
  for (int64_t s0 = 0; s0 < r->nmodel; s0 += CHUNK) {
    int64_t n = r->nmodel - s0 < CHUNK ? r->nmodel - s0 : CHUNK;
    int64_t nrun = model_chunk_runs(r, s0, n);
    const mblock *blocks = r->blocks;
    const mrun *runs = r->runs;
    double *dres = r->dres, *wres = r->wres, *rres = r->rres, *xres = r->xres;
    int *fres = r->fres;
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t q = 0; q < nrun; ++q) model_run(c, blocks, &runs[q], s0, dres, wres, rres, xres, fres);
    model_chunk_reduce(r, s0, n);
  }
}

/* Refine each direction's largest samples by a pattern search (refine_one), in parallel, so that
 * the maximum is a local maximum of the distance and not just the best sample; a refined value
 * raises its part's maximum (and its point and relative maximum) in list order. */
static void dist_refine(dist_state *r) {
  const dctx *c = &r->c;
  for (int dir = 0; dir < 2; ++dir) {
    double rd[256], rx[256][3];
    const int nt = r->ntop[dir];
    topk *top = r->tops[dir];
    const mblock *blocks = r->blocks;
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < nt; ++i) {
      pm_v3_zero(rx[i]);
      rd[i] = refine_one(c, blocks, &top[i], rx[i]);
    }
    for (int i = 0; i < nt; ++i) {
      int part = (top[i].kind == S_SEG || (top[i].kind == S_CURVE && blocks[top[i].elem].part == PART_WIRE))
                     ? PART_WIRE
                     : PART_SURF;
      acc *a = &r->A[dir][part];
      if (rd[i] > a->max) {
        a->max = rd[i];
        pm_v3_copy(a->max_at, rx[i]);
        double sz = size_at(c, rx[i]);
        if (sz > 0) a->rel_max = fmax(a->rel_max, rd[i] / sz);
      }
    }
  }
}

/* Fill out from the accumulators. The mean is over the surface part when there is one, else over
 * the wire part (distance.h); the maximum over everything. */
static void dist_results(const dist_state *r, pm_distance *out) {
  const dctx *c = &r->c;
  const acc(*A)[2] = r->A;
  out->bbox_diagonal = c->m->diagonal;
  out->has_size = c->size != NULL;
  out->ref_chord = c->rf.chord;
  out->ref_faces_degraded = c->rf.degraded;
  out->ref_triangles = c->rf.tri.n / 3;
  out->ref_cdt_points = c->rf.cdt_points;
  out->ref_tree_built = c->rf.lazy && atomic_load(&c->rf.lazy->tree) != NULL;
  out->tri_level = c->level;
  int mpart = c->surf ? PART_SURF : PART_WIRE;
  out->nsamples_mesh = A[0][0].n + A[0][1].n;
  out->nsamples_model = A[1][0].n + A[1][1].n;
  out->nfallback = r->nfallback;
  out->nhintless = r->nhintless;
  out->mesh_to_model_mean = A[0][mpart].sum_w > 0 ? A[0][mpart].sum_wd / A[0][mpart].sum_w : 0;
  out->model_to_mesh_mean = A[1][mpart].sum_w > 0 ? A[1][mpart].sum_wd / A[1][mpart].sum_w : 0;
  double W = A[0][mpart].sum_w + A[1][mpart].sum_w;
  out->mean = W > 0 ? (A[0][mpart].sum_wd + A[1][mpart].sum_wd) / W : 0;
  out->rel_mean = W > 0 && c->size ? (A[0][mpart].sum_wr + A[1][mpart].sum_wr) / W : 0;
  out->max = -1;
  for (int dir = 0; dir < 2; ++dir)
    for (int part = 0; part < 2; ++part) {
      const acc *a = &A[dir][part];
      if (a->n == 0) continue;
      if (dir == 0) out->mesh_to_model_max = fmax(out->mesh_to_model_max, a->max);
      else out->model_to_mesh_max = fmax(out->model_to_mesh_max, a->max);
      if (a->max > out->max) {
        out->max = a->max;
        pm_v3_copy(out->max_at, a->max_at);
        out->max_from_model = dir == 1;
      }
      if (c->size) out->rel_max = fmax(out->rel_max, a->rel_max);
    }
  if (out->max < 0) out->max = 0;
}

/* Free everything the stages built (any of them may be missing after an error). */
static void dist_free(dist_state *r) {
  dctx *c = &r->c;
  free(r->dres), free(r->wres), free(r->rres), free(r->xres), free(r->fres), free(r->runs), free(r->top);
  lattice_free(&r->lat);
  free(r->blocks), free(r->finfo), free(r->nbhd), free(r->curve_segs);
  free(r->face_tris_off), free(r->face_tris), free(r->Lface);
  free(c->dangling), free(c->wire_seg), free(c->face_reach), free(c->face_box), free(c->par_ok);
  free(c->corner_uv), free(c->corner_ok);
  pm_bvh_destroy(c->mesh_tri), pm_bvh_destroy(c->mesh_wire);
  ref_faces_free(&c->rf);
  ref_curves_free(&c->rc_surf), ref_curves_free(&c->rc_wire);
}

/* The stages in order. The first error stops the sequence; what was built is freed and out is
 * left zeroed (err keeps the stage's message). */
pm_status pm_mesh_distance(const pm_mesh *mesh, const pm_model *model, const pm_sizing *size,
                           const pm_distance_params *pin, pm_distance *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  dist_state r;
  memset(&r, 0, sizeof r);
  pm_status s = dist_check(&r, mesh, model, pin, err);
  if (s) return s;
  s = dist_setup(&r, mesh, model, size, err);
  if (!s) s = dist_mesh_bvhs(&r, err);
  if (!s) s = dist_edge_lengths(&r, err);
  if (!s) s = dist_probe_faces(&r, err);
  if (!s) s = dist_face_reference(&r, err);
  if (!s) s = dist_face_bounds(&r, err);
  if (!s) s = dist_curve_reference(&r, err);
  if (!s) s = dist_tri_bounds(&r, err);
  if (!s) s = dist_model_samples(&r, err);
  if (!s) s = dist_mesh_samples(&r, err);
  if (!s) s = dist_buffers(&r, err);
  if (!s) {
    dist_mesh_to_model(&r);
    dist_model_to_mesh(&r);
    dist_refine(&r);
    dist_results(&r, out);
    if (r.c.rf.lazy && r.c.rf.lazy->failed) {
      s = r.c.rf.lazy->err.code ? r.c.rf.lazy->err.code : PM_ERR_BACKEND;
      if (err) *err = r.c.rf.lazy->err;
    }
  }
  dist_free(&r);
  if (s) {
    pm_error e2 = err ? *err : (pm_error){0};
    memset(out, 0, sizeof *out);
    if (err) *err = e2;
  }
  return s;
}
