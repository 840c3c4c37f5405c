/* Evaluation classes of the geom_cad backend (the pm_cell_class functions of geom.h): each
 * function takes the closed form of the cell when it has one (geom_cad_fast.c) and gmsh
 * otherwise, under the gmsh lock with the cell's gmsh model made current (cad_enter).
 *
 * gmsh never aborts the caller: a call that sets ierr or returns a non-finite value is replaced
 * by the cell's fallback output (the point at the centre of its parameter box, zero derivatives)
 * and counted in cad_model.failures.
 */
#include <gmshc.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/geom_cad_private.h"
#include "common/base/vec3.h"

/* ---- raw gmsh calls ---------------------------------------------------------------------- */

/* One gmsh evaluation call into `out` (n * width doubles); 0 on success. */
typedef void (*gmsh_eval_fn)(const int dim, const int tag, double *par, size_t npar, double **res,
                             size_t *nres, int *ierr);

static int call(gmsh_eval_fn fn, int dim, int tag, const double *par, size_t npar, size_t nexp,
                double **res) {
  int ierr = 0;
  size_t nres = 0;
  *res = NULL;
  /* gmsh's C API takes non-const input arrays; it does not write to them. */
  fn(dim, tag, (double *)par, npar, res, &nres, &ierr);
  if (ierr || nres != nexp || !*res) {
    if (*res) gmshFree(*res);
    *res = NULL;
    return -1;
  }
  for (size_t i = 0; i < nres; ++i)
    if (!isfinite((*res)[i])) {
      gmshFree(*res);
      *res = NULL;
      return -1;
    }
  return 0;
}

/* Curve second derivatives: gmsh 4.8.4's gmshModelGetSecondDerivative on a curve is a one-sided
 * difference of first derivatives with a step of 1e-3 (a circle of radius 1.3 gets C''(0) =
 * (-1.3, -6.5e-4, 0) instead of (-1.3, 0, 0)), so C'' is taken here as the central difference
 * of gmsh's exact first derivatives with the step CURVE_D2_STEP x span: truncation error about
 * (1e-5)^2 of the scale, rounding about 1e-16 / 1e-5, both far below what curvature needs. */
#define CURVE_D2_STEP 1e-5
#define CHUNK 128

int cad_gmsh_curve(int tag, int32_t n, const double *t, int order, double span,
                   pm_curve_point *out) {
  double *r;
  const size_t nn = (size_t)n;
  if (call(gmshModelGetValue, 1, tag, t, nn, 3 * nn, &r)) return -1;
  for (size_t i = 0; i < nn; ++i) pm_v3_copy(out[i].p, r + 3 * i);
  gmshFree(r);
  if (order == 1) {
    if (call(gmshModelGetDerivative, 1, tag, t, nn, 3 * nn, &r)) return -1;
    for (size_t i = 0; i < nn; ++i) pm_v3_copy(out[i].d1, r + 3 * i);
    gmshFree(r);
  }
  if (order >= 2) {
    const double h = CURVE_D2_STEP * (span > 0 ? span : 1.0);
    double q[3 * CHUNK];
    for (size_t i0 = 0; i0 < nn; i0 += CHUNK) {
      size_t m = nn - i0 < CHUNK ? nn - i0 : CHUNK;
      for (size_t i = 0; i < m; ++i)
        q[3 * i] = t[i0 + i], q[3 * i + 1] = t[i0 + i] - h, q[3 * i + 2] = t[i0 + i] + h;
      if (call(gmshModelGetDerivative, 1, tag, q, 3 * m, 9 * m, &r)) return -1;
      for (size_t i = 0; i < m; ++i) {
        pm_v3_copy(out[i0 + i].d1, r + 9 * i);
        for (int k = 0; k < 3; ++k)
          out[i0 + i].d2[k] = (r[9 * i + 6 + k] - r[9 * i + 3 + k]) / (2 * h);
      }
      gmshFree(r);
    }
  }
  return 0;
}

int cad_gmsh_face(int tag, int32_t n, const double *uv, int order, pm_face_point *out) {
  double *r;
  const size_t nn = (size_t)n;
  if (call(gmshModelGetValue, 2, tag, uv, 2 * nn, 3 * nn, &r)) return -1;
  for (size_t i = 0; i < nn; ++i) pm_v3_copy(out[i].p, r + 3 * i);
  gmshFree(r);
  if (order >= 1) {
    if (call(gmshModelGetDerivative, 2, tag, uv, 2 * nn, 6 * nn, &r)) return -1;
    for (size_t i = 0; i < nn; ++i)
      pm_v3_copy(out[i].su, r + 6 * i), pm_v3_copy(out[i].sv, r + 6 * i + 3);
    gmshFree(r);
  }
  if (order >= 2) {
    /* gmsh's order per point: Suu, Svv, Suv. */
    if (call(gmshModelGetSecondDerivative, 2, tag, uv, 2 * nn, 9 * nn, &r)) return -1;
    for (size_t i = 0; i < nn; ++i) {
      pm_v3_copy(out[i].suu, r + 9 * i);
      pm_v3_copy(out[i].svv, r + 9 * i + 3);
      pm_v3_copy(out[i].suv, r + 9 * i + 6);
    }
    gmshFree(r);
  }
  return 0;
}

/* ---- fallbacks --------------------------------------------------------------------------- */

static void curve_fallback(const cad_cell *cc, int order, pm_curve_point *out) {
  atomic_fetch_add(&cc->cm->failures, 1);
  pm_v3_copy(out->p, cc->fallback);
  if (order >= 1) pm_v3_zero(out->d1);
  if (order >= 2) pm_v3_zero(out->d2);
}

static void face_fallback(const cad_cell *cc, int order, pm_face_point *out) {
  atomic_fetch_add(&cc->cm->failures, 1);
  pm_v3_copy(out->p, cc->fallback);
  if (order >= 1) pm_v3_zero(out->su), pm_v3_zero(out->sv);
  if (order >= 2) pm_v3_zero(out->suu), pm_v3_zero(out->suv), pm_v3_zero(out->svv);
}

/* ---- the class functions ----------------------------------------------------------------- */

static void curve_eval(const pm_cell *self, double t, int order, pm_curve_point *out) {
  const cad_cell *cc = self->impl;
  if (cc->form.kind != CAD_GMSH) {
    cad_form_curve(&cc->form, t, order, out);
    return;
  }
  /* gmsh extrapolates outside [lo, hi]; a closed curve must wrap instead. */
  if (self->periodic[0] && (t < self->lo[0] || t > self->hi[0])) pm_cell_wrap(self, &t);
  cad_guard g;
  int bad = cad_enter(cc->cm, &g) ||
            cad_gmsh_curve(self->tag, 1, &t, order, self->hi[0] - self->lo[0], out);
  cad_leave(&g);
  if (bad) curve_fallback(cc, order, out);
}

static void face_eval(const pm_cell *self, const double uv[2], int order, pm_face_point *out) {
  const cad_cell *cc = self->impl;
  if (cc->form.kind != CAD_GMSH) {
    cad_form_face(&cc->form, uv, order, out);
    return;
  }
  /* A closed B-spline surface need not be periodic in OCC's sense: wrap ourselves. */
  double q[2] = {uv[0], uv[1]};
  pm_cell_wrap(self, q);
  cad_guard g;
  int bad = cad_enter(cc->cm, &g) || cad_gmsh_face(self->tag, 1, q, order, out);
  cad_leave(&g);
  if (bad) face_fallback(cc, order, out);
}

/* Batches of at most BATCH points per gmsh call: GMSH_API.md measured 64..1024 as the range
 * where the fixed cost per call is amortized (2-6x faster than one point per call) while the
 * output arrays stay in cache. */
#define BATCH 256

static void face_eval_many(const pm_cell *self, int32_t n, const double *uv, int order,
                           pm_face_point *out) {
  const cad_cell *cc = self->impl;
  if (cc->form.kind != CAD_GMSH) {
    for (int32_t i = 0; i < n; ++i) cad_form_face(&cc->form, uv + 2 * i, order, out + i);
    return;
  }
  double q[2 * BATCH];
  cad_guard g;
  if (cad_enter(cc->cm, &g)) {
    for (int32_t i = 0; i < n; ++i) face_fallback(cc, order, out + i);
    cad_leave(&g);
    return;
  }
  for (int32_t i0 = 0; i0 < n; i0 += BATCH) {
    int32_t m = n - i0 < BATCH ? n - i0 : BATCH;
    for (int32_t i = 0; i < m; ++i) {
      q[2 * i] = uv[2 * (i0 + i)], q[2 * i + 1] = uv[2 * (i0 + i) + 1];
      pm_cell_wrap(self, q + 2 * i);
    }
    if (cad_gmsh_face(self->tag, m, q, order, out + i0) == 0) continue;
    /* One bad point spoils the batch: redo it point by point to isolate the failures. */
    for (int32_t i = 0; i < m; ++i)
      if (cad_gmsh_face(self->tag, 1, q + 2 * i, order, out + i0 + i))
        face_fallback(cc, order, out + i0 + i);
  }
  cad_leave(&g);
}

/* Projection starts for gmsh-evaluated cells. gmshModelGetParametrization costs 180-240 us on a
 * B-spline face of the shared models (bench/bench_geom.c), where the particle methods need a
 * few microseconds: the start is the nearest point of a grid sampled once at load (the same
 * 25 x 25 samples geom.c's generic projection takes on every call), or the caller's guess when
 * its point is nearer; geom.c's Newton iteration then converges from there. gmsh's projection
 * remains the fallback for a cell without a grid. */
#define GRID_FACE 25
#define GRID_CURVE 65

static double grid_param(double lo, double hi, int32_t i, int32_t n) {
  return lo + (hi - lo) * (double)i / (double)(n - 1);
}

static int32_t grid_nearest(const cad_cell *cc, int32_t n, const double xyz[3], double *d2) {
  int32_t best = 0;
  double bd = 1e300;
  for (int32_t i = 0; i < n; ++i) {
    double d = pm_v3_dist2(cc->grid + 3 * i, xyz);
    if (d < bd) bd = d, best = i;
  }
  *d2 = bd;
  return best;
}

static int face_project(const pm_cell *self, const double xyz[3], const double *guess,
                        double *par) {
  const cad_cell *cc = self->impl;
  if (cc->form.kind != CAD_GMSH) {
    double ref[2] = {0.5 * (self->lo[0] + self->hi[0]), 0.5 * (self->lo[1] + self->hi[1])};
    if (guess) ref[0] = guess[0], ref[1] = guess[1];
    return cad_form_project(&cc->form, xyz, ref, par);
  }
  if (cc->grid) {
    double d2;
    int32_t i = grid_nearest(cc, cc->gn[0] * cc->gn[1], xyz, &d2);
    par[0] = grid_param(self->lo[0], self->hi[0], i % cc->gn[0], cc->gn[0]);
    par[1] = grid_param(self->lo[1], self->hi[1], i / cc->gn[0], cc->gn[1]);
    if (guess) {
      pm_face_point p;
      face_eval(self, guess, 0, &p);
      if (pm_v3_dist2(p.p, xyz) <= d2) par[0] = guess[0], par[1] = guess[1];
    }
    return 0;
  }
  /* gmshModelGetParametrization, not gmshModelGetClosestPoint: the latter's (u, v) is always
   * (0, 0) in gmsh 4.8.4 (GMSH_API.md). Both project onto the untrimmed surface. */
  double *r;
  cad_guard g;
  int bad = cad_enter(cc->cm, &g) || call(gmshModelGetParametrization, 2, self->tag, xyz, 3, 2, &r);
  cad_leave(&g);
  if (bad) return -1;
  par[0] = r[0], par[1] = r[1];
  gmshFree(r);
  return 0;
}

static int curve_project(const pm_cell *self, const double xyz[3], const double *guess,
                         double *par) {
  const cad_cell *cc = self->impl;
  if (cc->form.kind != CAD_GMSH) {
    double ref = guess ? guess[0] : 0.5 * (self->lo[0] + self->hi[0]);
    return cad_form_project(&cc->form, xyz, &ref, par);
  }
  if (cc->grid) {
    double d2;
    int32_t i = grid_nearest(cc, cc->gn[0], xyz, &d2);
    par[0] = grid_param(self->lo[0], self->hi[0], i, cc->gn[0]);
    if (guess) {
      pm_curve_point p;
      curve_eval(self, guess[0], 0, &p);
      if (pm_v3_dist2(p.p, xyz) <= d2) par[0] = guess[0];
    }
    return 0;
  }
  double *r;
  cad_guard g;
  int bad = cad_enter(cc->cm, &g) || call(gmshModelGetParametrization, 1, self->tag, xyz, 3, 1, &r);
  cad_leave(&g);
  if (bad) return -1;
  par[0] = r[0];
  gmshFree(r);
  return 0;
}

pm_status cad_build_grids(pm_model *m, pm_error *err) {
  for (int d = PM_CURVE; d <= PM_FACE; ++d)
    for (int32_t i = 0; i < m->count[d]; ++i) {
      pm_cell *c = &m->cells[d][i];
      cad_cell *cc = c->impl;
      if (cc->form.kind != CAD_GMSH || c->degenerate) continue;
      const int32_t nu = d == PM_FACE ? GRID_FACE : GRID_CURVE, nv = d == PM_FACE ? GRID_FACE : 1;
      double *par = malloc(sizeof(double) * 2 * (size_t)(nu * nv));
      cc->grid = malloc(sizeof(double) * 3 * (size_t)(nu * nv));
      void *pts = malloc((d == PM_FACE ? sizeof(pm_face_point) : sizeof(pm_curve_point)) *
                         (size_t)(nu * nv));
      if (!par || !cc->grid || !pts) {
        free(par), free(pts);
        return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      }
      for (int32_t b = 0; b < nv; ++b)
        for (int32_t a = 0; a < nu; ++a) {
          par[2 * (b * nu + a)] = grid_param(c->lo[0], c->hi[0], a, nu);
          par[2 * (b * nu + a) + 1] = d == PM_FACE ? grid_param(c->lo[1], c->hi[1], b, nv) : 0;
        }
      if (d == PM_FACE) {
        pm_face_point *fp = pts;
        face_eval_many(c, nu * nv, par, 0, fp);
        for (int32_t k = 0; k < nu * nv; ++k) pm_v3_copy(cc->grid + 3 * k, fp[k].p);
      } else {
        pm_curve_point *cp = pts;
        for (int32_t k = 0; k < nu; ++k) {
          curve_eval(c, par[2 * k], 0, &cp[k]);
          pm_v3_copy(cc->grid + 3 * k, cp[k].p);
        }
      }
      cc->gn[0] = nu, cc->gn[1] = nv;
      free(par), free(pts);
    }
  return PM_OK;
}

/* ---- pcurves off their curves ------------------------------------------------------------
 *
 * A boundary curve's pcurve on a face should map onto the curve: S(p(t)) = C(t) to within the
 * file's tolerance. Some files carry pcurves that do not (an edge not "same parameter" in
 * OpenCASCADE's terms): fusee.stp's curve 413 lies on face 84's surface within 4e-4, but the
 * face's pcurve for it is a straight line in (u, v) whose image strays up to 0.079 from it. The
 * face's trimming polyline then cuts a band that wide off the face, no particle can enter it, and
 * the connection fills it with needles between the curve's nodes and the face's first row (bubble:
 * 4 unforced needles there, the face's nodes 0.1 from a curve spaced 0.017). gmsh has the same
 * check behind Geometry.ReparamOnFaceRobust (off by default); here it runs at load, once per use:
 * at PCURVE_SAMPLES interior parameters the pcurve's point is compared with the curve's, and a
 * use is marked when some point strays more than the feature floor while the curve's own point
 * lies on the surface (its projection is at most a quarter as far). A marked use's (u, v) at t
 * is the curve's point projected onto the surface by Newton's iteration from the pcurve's
 * point, kept on the pcurve's side of a seam, and only when the projection is the nearer. */
#define PCURVE_SAMPLES 31

static int reprojected(const cad_cell *cc, const pm_use *use) {
  const int32_t key = 2 * use->cell + (use->side ? 1 : 0);
  for (int32_t k = 0; k < cc->nreproj; ++k)
    if (cc->reproj[k] == key) return 1;
  return 0;
}

/* The projection of point p onto face f's surface from uv, into w, kept on uv's side of a seam;
 * returns its squared distance. */
static double project_near(const pm_cell *f, const double p[3], const double uv[2], double w[2]) {
  const double d2 = pm_face_project_from(f, p, uv, w);
  for (int k = 0; k < 2; ++k)
    if (f->periodic[k] && f->period[k] > 0) w[k] += f->period[k] * nearbyint((uv[k] - w[k]) / f->period[k]);
  return d2;
}

/* uv (the pcurve's point of C(t)) := the projection of C(t) onto face f, when that is nearer. */
static void onto_surface(const pm_cell *f, const pm_cell *curve, double t, double uv[2]) {
  pm_curve_point cp;
  pm_face_point fp;
  pm_curve_eval(curve, t, 0, &cp);
  pm_face_eval(f, uv, 0, &fp);
  double w[2];
  if (project_near(f, cp.p, uv, w) < pm_v3_dist2(fp.p, cp.p)) uv[0] = w[0], uv[1] = w[1];
}

static void face_curve_uv(const pm_cell *self, const pm_use *use, double t, double uv[2]);

pm_status cad_check_pcurves(pm_model *m, double tol, pm_error *err) {
  cad_model *cm = m->impl;
  cm->reprojected = 0, cm->reproj_worst = 0;
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    pm_cell *f = &m->cells[PM_FACE][i];
    cad_cell *fc = f->impl;
    for (int32_t l = 0; l < f->nloop; ++l)
      for (int32_t u = 0; u < f->loop[l].nuse; ++u) {
        const pm_use *use = &f->loop[l].use[u];
        const pm_cell *c = &m->cells[PM_CURVE][use->cell];
        const cad_cell *ccv = c->impl;
        if (c->degenerate || ccv->synthetic || reprojected(fc, use)) continue;
        double worst = 0;
        for (int k = 1; k <= PCURVE_SAMPLES; ++k) {
          const double t = c->lo[0] + (c->hi[0] - c->lo[0]) * k / (PCURVE_SAMPLES + 1);
          double uv[2], w[2];
          pm_curve_point cp;
          pm_face_point fp;
          face_curve_uv(f, use, t, uv);
          pm_curve_eval(c, t, 0, &cp);
          pm_face_eval(f, uv, 0, &fp);
          const double d2_pc = pm_v3_dist2(fp.p, cp.p);
          if (!(d2_pc > tol * tol)) continue;
          if (project_near(f, cp.p, uv, w) <= d2_pc / 16) worst = fmax(worst, sqrt(d2_pc));
        }
        if (!(worst > 0)) continue;
        int32_t *r = realloc(fc->reproj, sizeof(int32_t) * ((size_t)fc->nreproj + 1));
        if (!r) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        fc->reproj = r;
        fc->reproj[fc->nreproj++] = 2 * use->cell + (use->side ? 1 : 0);
        cm->reprojected++;
        cm->reproj_worst = fmax(cm->reproj_worst, worst);
      }
  }
  return PM_OK;
}

static void face_curve_uv(const pm_cell *self, const pm_use *use, double t, double uv[2]) {
  const cad_cell *cc = self->impl;
  const pm_cell *curve = &self->model->cells[PM_CURVE][use->cell];
  const cad_cell *ccurve = curve->impl;
  if (ccurve->synthetic) {
    const double w = (t - curve->lo[0]) / (curve->hi[0] - curve->lo[0]);
    uv[0] = ccurve->synth_uv[0] + w * (ccurve->synth_uv[2] - ccurve->synth_uv[0]);
    uv[1] = ccurve->synth_uv[1] + w * (ccurve->synth_uv[3] - ccurve->synth_uv[1]);
    return;
  }
  /* Wrap only outside [lo, hi]: at t = hi the pcurve of a closed curve is at the end of its
   * run in (u, v) (u = 2 pi on a cylinder's circle), not back at its start. */
  if (curve->periodic[0] && (t < curve->lo[0] || t > curve->hi[0])) pm_cell_wrap(curve, &t);
  int ierr = 0;
  size_t n = 0;
  double *r = NULL;
  cad_guard g;
  if (cad_enter(cc->cm, &g) == 0)
    gmshModelReparametrizeOnSurface(1, curve->tag, &t, 1, self->tag, &r, &n, use->side, &ierr);
  else
    ierr = 1;
  cad_leave(&g);
  if (!ierr && n == 2 && r && isfinite(r[0]) && isfinite(r[1])) {
    uv[0] = r[0], uv[1] = r[1];
    gmshFree(r);
    if (cc->nreproj && reprojected(cc, use)) onto_surface(self, curve, t, uv);
    return;
  }
  if (r) gmshFree(r);
  /* No pcurve: the projection of the curve's point, else the centre of the box. */
  atomic_fetch_add(&cc->cm->failures, 1);
  pm_curve_point cp;
  pm_curve_eval(curve, t, 0, &cp);
  if (face_project(self, cp.p, NULL, uv) != 0) {
    uv[0] = 0.5 * (self->lo[0] + self->hi[0]);
    uv[1] = 0.5 * (self->lo[1] + self->hi[1]);
  }
}

/* ---- classes ----------------------------------------------------------------------------- */

#define FACE_CLASS(nm) \
  { nm, NULL, face_eval, face_eval_many, face_curve_uv, face_project, NULL }
#define CURVE_CLASS(nm) \
  { nm, curve_eval, NULL, NULL, NULL, curve_project, NULL }

static const pm_cell_class face_classes[] = {
    FACE_CLASS("plane"),     FACE_CLASS("cylinder"), FACE_CLASS("cone"),   FACE_CLASS("sphere"),
    FACE_CLASS("torus"),     FACE_CLASS("bspline"),  FACE_CLASS("bezier"), FACE_CLASS("revolution"),
    FACE_CLASS("extrusion"), FACE_CLASS("offset"),   FACE_CLASS("other"),
};
static const pm_cell_class curve_classes[] = {
    CURVE_CLASS("line"),    CURVE_CLASS("circle"),     CURVE_CLASS("ellipse"),
    CURVE_CLASS("bspline"), CURVE_CLASS("bezier"),     CURVE_CLASS("trimmed"),
    CURVE_CLASS("offset"),  CURVE_CLASS("degenerate"), CURVE_CLASS("other"),
};
static const pm_cell_class point_class = {"point", NULL, NULL, NULL, NULL, NULL, NULL};
static const pm_cell_class volume_class = {"volume", NULL, NULL, NULL, NULL, NULL, NULL};

const pm_cell_class *cad_class(int dim, const char *name) {
  if (dim == PM_VERTEX) return &point_class;
  if (dim == PM_VOLUME) return &volume_class;
  const pm_cell_class *t = dim == PM_FACE ? face_classes : curve_classes;
  size_t n = dim == PM_FACE ? sizeof face_classes / sizeof face_classes[0]
                            : sizeof curve_classes / sizeof curve_classes[0];
  for (size_t i = 0; i < n; ++i)
    if (strcmp(t[i].name, name) == 0) return &t[i];
  return &t[n - 1]; /* "other" */
}
