/* Fast paths of the geom_cad backend: closed-form evaluation and projection of the elementary
 * OpenCASCADE surfaces and curves, fitted to gmsh and checked against it.
 *
 * gmsh 4.8.4 exposes no surface parameters (origin, axes, radii), but it evaluates the exact OCC
 * parametrization, so the parameters follow from one evaluation with second derivatives at a
 * point where the formulas simplify (u = 0, where e(u) = X). A fitted form is used only when it
 * reproduces gmsh at 20 random parameters of the cell's box: positions within 1e-9 x diagonal,
 * first derivatives within 1e-9 of their scale, second derivatives within 1e-6 (see cad_fit).
 * Anything else — B-splines, offsets, forms that do not validate — stays on gmsh.
 * One gmsh surface evaluation costs 0.1 - 0.6 us per call plus the lock; a closed form costs
 * a few sines and cosines (bench/bench_geom.c prints both).
 */
#include <math.h>
#include <string.h>

#include "common/geom/geom_cad_private.h"
#include "common/base/rng.h"
#include "common/base/vec3.h"

/* ---- evaluation -------------------------------------------------------------------------- */

void cad_form_curve(const cad_form *f, double t, int order, pm_curve_point *out) {
  double c, s;
  switch (f->kind) {
    case CAD_LINE:
      pm_v3_axpy(out->p, f->o, t, f->x);
      if (order >= 1) pm_v3_copy(out->d1, f->x);
      if (order >= 2) pm_v3_zero(out->d2);
      return;
    case CAD_CIRCLE:
    case CAD_ELLIPSE: {
      const double a = f->r, b = f->kind == CAD_CIRCLE ? f->r : f->r2;
      c = cos(t), s = sin(t);
      for (int k = 0; k < 3; ++k) {
        out->p[k] = f->o[k] + a * c * f->x[k] + b * s * f->y[k];
        if (order >= 1) out->d1[k] = -a * s * f->x[k] + b * c * f->y[k];
        if (order >= 2) out->d2[k] = -a * c * f->x[k] - b * s * f->y[k];
      }
      return;
    }
    default: /* CAD_POINT: a degenerate curve does not move */
      pm_v3_copy(out->p, f->o);
      if (order >= 1) pm_v3_zero(out->d1);
      if (order >= 2) pm_v3_zero(out->d2);
      return;
  }
}

void cad_form_face(const cad_form *f, const double uv[2], int order, pm_face_point *out) {
  const double u = uv[0], v = uv[1];
  if (f->kind == CAD_PLANE) {
    for (int k = 0; k < 3; ++k) {
      out->p[k] = f->o[k] + u * f->x[k] + v * f->y[k];
      if (order >= 1) out->su[k] = f->x[k], out->sv[k] = f->y[k];
      if (order >= 2) out->suu[k] = out->suv[k] = out->svv[k] = 0;
    }
    return;
  }
  /* The surfaces of revolution share e(u) = cos u X + sin u Y and e'(u) = -sin u X + cos u Y. */
  const double cu = cos(u), su = sin(u);
  double e[3], ep[3];
  for (int k = 0; k < 3; ++k)
    e[k] = cu * f->x[k] + su * f->y[k], ep[k] = -su * f->x[k] + cu * f->y[k];
  switch (f->kind) {
    case CAD_CYLINDER:
      for (int k = 0; k < 3; ++k) {
        out->p[k] = f->o[k] + f->r * e[k] + v * f->z[k];
        if (order >= 1) out->su[k] = f->r * ep[k], out->sv[k] = f->z[k];
        if (order >= 2) out->suu[k] = -f->r * e[k], out->suv[k] = 0, out->svv[k] = 0;
      }
      return;
    case CAD_CONE: {
      const double rho = f->r + v * f->sa;
      for (int k = 0; k < 3; ++k) {
        out->p[k] = f->o[k] + rho * e[k] + v * f->ca * f->z[k];
        if (order >= 1) out->su[k] = rho * ep[k], out->sv[k] = f->sa * e[k] + f->ca * f->z[k];
        if (order >= 2) out->suu[k] = -rho * e[k], out->suv[k] = f->sa * ep[k], out->svv[k] = 0;
      }
      return;
    }
    case CAD_SPHERE: {
      const double cv = cos(v), sv = sin(v), r = f->r;
      for (int k = 0; k < 3; ++k) {
        out->p[k] = f->o[k] + r * (cv * e[k] + sv * f->z[k]);
        if (order >= 1) out->su[k] = r * cv * ep[k], out->sv[k] = r * (-sv * e[k] + cv * f->z[k]);
        if (order >= 2) {
          out->suu[k] = -r * cv * e[k];
          out->suv[k] = -r * sv * ep[k];
          out->svv[k] = -r * (cv * e[k] + sv * f->z[k]);
        }
      }
      return;
    }
    case CAD_TORUS: {
      const double cv = cos(v), sv = sin(v), rho = f->r + f->r2 * cv, r2 = f->r2;
      for (int k = 0; k < 3; ++k) {
        out->p[k] = f->o[k] + rho * e[k] + r2 * sv * f->z[k];
        if (order >= 1) out->su[k] = rho * ep[k], out->sv[k] = r2 * (-sv * e[k] + cv * f->z[k]);
        if (order >= 2) {
          out->suu[k] = -rho * e[k];
          out->suv[k] = -r2 * sv * ep[k];
          out->svv[k] = -r2 * (cv * e[k] + sv * f->z[k]);
        }
      }
      return;
    }
    default: /* not a face form: never reached through the classes */
      memset(out, 0, sizeof *out);
      pm_v3_copy(out->p, f->o);
      return;
  }
}

/* ---- projection -------------------------------------------------------------------------- */

/* The representative of angle a (mod 2 pi) nearest to ref. */
static double near_angle(double a, double ref) {
  const double P = 2 * M_PI;
  return a + P * round((ref - a) / P);
}

int cad_form_project(const cad_form *f, const double xyz[3], const double *ref, double *par) {
  double d[3];
  pm_v3_sub(d, xyz, f->o);
  const double a = pm_v3_dot(d, f->x), b = pm_v3_dot(d, f->y), h = pm_v3_dot(d, f->z);
  const double rho = hypot(a, b);
  /* On the axis every angle is as close as any other: keep the reference one. */
  const double ang = rho > 0 ? atan2(b, a) : ref[0];
  switch (f->kind) {
    case CAD_PLANE: {
      /* Least squares in the (X, Y) frame (orthonormal for OCC planes, solved generally). */
      double xx = pm_v3_dot(f->x, f->x), xy = pm_v3_dot(f->x, f->y), yy = pm_v3_dot(f->y, f->y);
      double det = xx * yy - xy * xy;
      if (!(det > 0)) return -1;
      par[0] = (yy * a - xy * b) / det;
      par[1] = (xx * b - xy * a) / det;
      return 0;
    }
    case CAD_CYLINDER:
      par[0] = near_angle(ang, ref[0]);
      par[1] = h;
      return 0;
    case CAD_CONE: {
      /* In the half-plane of angle u the generator is (r + v sin a, v cos a) in (radial, axial)
       * coordinates, a unit-speed line: the foot is v = (rho - r) sin a + h cos a. The opposite
       * half-plane (u + pi, radial coordinate -rho) holds the other nappe. */
      double v1 = (rho - f->r) * f->sa + h * f->ca;
      double v2 = (-rho - f->r) * f->sa + h * f->ca;
      double e1 = hypot(f->r + v1 * f->sa - rho, v1 * f->ca - h);
      double e2 = hypot(f->r + v2 * f->sa + rho, v2 * f->ca - h);
      if (e1 <= e2) {
        par[0] = near_angle(ang, ref[0]);
        par[1] = v1;
      } else {
        par[0] = near_angle(ang + M_PI, ref[0]);
        par[1] = v2;
      }
      return 0;
    }
    case CAD_SPHERE:
      par[0] = near_angle(ang, ref[0]);
      par[1] = atan2(h, rho);
      return 0;
    case CAD_TORUS:
      par[0] = near_angle(ang, ref[0]);
      par[1] = near_angle(atan2(h, rho - f->r), ref[1]);
      return 0;
    case CAD_LINE: {
      double xx = pm_v3_dot(f->x, f->x);
      if (!(xx > 0)) return -1;
      par[0] = pm_v3_dot(d, f->x) / xx;
      return 0;
    }
    case CAD_CIRCLE: par[0] = near_angle(ang, ref[0]); return 0;
    case CAD_ELLIPSE:
      /* The eccentric anomaly of the point scaled onto the circle: exact on the ellipse, a
       * start for geom.c's Newton refinement elsewhere. */
      par[0] = near_angle((a != 0 || b != 0) ? atan2(b / f->r2, a / f->r) : ref[0], ref[0]);
      return 0;
    case CAD_POINT: par[0] = ref[0]; return 0;
    default: return -1;
  }
}

const char *cad_form_name(cad_kind k) {
  switch (k) {
    case CAD_PLANE: return "plane";
    case CAD_CYLINDER: return "cylinder";
    case CAD_CONE: return "cone";
    case CAD_SPHERE: return "sphere";
    case CAD_TORUS: return "torus";
    case CAD_LINE: return "line";
    case CAD_CIRCLE: return "circle";
    case CAD_ELLIPSE: return "ellipse";
    case CAD_POINT: return "degenerate";
    default: return "other";
  }
}

/* ---- fitting ----------------------------------------------------------------------------- */

/* Unit vector a / |a|; 0 when |a| is not above `tiny`. */
static int unit(double out[3], const double a[3], double tiny, double *len) {
  double n = pm_v3_norm(a);
  if (len) *len = n;
  if (!(n > tiny)) return 0;
  pm_v3_scale(out, a, 1.0 / n);
  return 1;
}

static int fit_face(cad_kind kind, int tag, const double lo[2], const double hi[2], double diag,
                    cad_form *F) {
  memset(F, 0, sizeof *F);
  F->kind = kind;
  const double tiny = 1e-12 * diag;
  double uv[2] = {0, 0};
  /* The cone's reference radius may be zero (the apex at v = 0): fit at the middle of the box.
   * A plane is fitted at the centre of the box too, where a disguised plane (a bilinear B-spline
   * patch) is defined; the elementary OCC surfaces are defined for every (u, v). */
  if (kind == CAD_CONE) uv[1] = 0.5 * (lo[1] + hi[1]);
  if (kind == CAD_PLANE) uv[0] = 0.5 * (lo[0] + hi[0]), uv[1] = 0.5 * (lo[1] + hi[1]);
  pm_face_point p;
  if (cad_gmsh_face(tag, 1, uv, 2, &p)) return 0;
  double rho;
  switch (kind) {
    case CAD_PLANE: /* S = O + u X + v Y: X = Su, Y = Sv, O = S - u X - v Y */
      pm_v3_copy(F->x, p.su), pm_v3_copy(F->y, p.sv);
      for (int k = 0; k < 3; ++k) F->o[k] = p.p[k] - uv[0] * F->x[k] - uv[1] * F->y[k];
      return pm_v3_norm(F->x) > 0 && pm_v3_norm(F->y) > 0;
    case CAD_CYLINDER: /* at u = v = 0: S = O + r X, Su = r Y, Sv = Z, Suu = -r X */
      if (!unit(F->y, p.su, tiny, &F->r)) return 0;
      pm_v3_scale(F->x, p.suu, -1.0 / F->r);
      pm_v3_copy(F->z, p.sv);
      pm_v3_axpy(F->o, p.p, -F->r, F->x);
      return 1;
    case CAD_CONE: /* at u = 0: Su = rho Y, Suu = -rho X, Sv = sin a X + cos a Z */
      if (!unit(F->x, p.suu, tiny, &rho)) return 0;
      pm_v3_scale(F->x, F->x, -1.0);
      pm_v3_scale(F->y, p.su, 1.0 / rho);
      F->sa = pm_v3_dot(p.sv, F->x);
      {
        double zc[3];
        pm_v3_axpy(zc, p.sv, -F->sa, F->x);
        if (!unit(F->z, zc, 1e-12, &F->ca)) return 0;
      }
      F->r = rho - uv[1] * F->sa;
      for (int k = 0; k < 3; ++k) F->o[k] = p.p[k] - rho * F->x[k] - uv[1] * F->ca * F->z[k];
      return 1;
    case CAD_SPHERE: /* at u = v = 0: S = O + r X, Su = r Y, Sv = r Z, Suu = -r X */
      if (!unit(F->z, p.sv, tiny, &F->r)) return 0;
      pm_v3_scale(F->y, p.su, 1.0 / F->r);
      pm_v3_scale(F->x, p.suu, -1.0 / F->r);
      pm_v3_axpy(F->o, p.p, -F->r, F->x);
      return 1;
    case CAD_TORUS: /* at u = v = 0: S = O + (R + r) X, Su = (R + r) Y, Sv = r Z, Svv = -r X */
      if (!unit(F->z, p.sv, tiny, &F->r2)) return 0;
      if (!unit(F->y, p.su, tiny, &rho)) return 0;
      pm_v3_scale(F->x, p.svv, -1.0 / F->r2);
      F->r = rho - F->r2;
      pm_v3_axpy(F->o, p.p, -rho, F->x);
      return 1;
    default: return 0;
  }
}

static int fit_curve(cad_kind kind, int tag, double diag, cad_form *F) {
  memset(F, 0, sizeof *F);
  F->kind = kind;
  const double tiny = 1e-12 * diag;
  /* From C(0), C'(0) and C(pi) only: gmsh's curve second derivatives are finite differences
   * (see cad_gmsh_curve). */
  double t[2] = {0, M_PI};
  pm_curve_point p[2];
  if (cad_gmsh_curve(tag, 2, t, 1, 1, p)) return 0;
  switch (kind) {
    case CAD_LINE: /* C = O + t X */
      pm_v3_copy(F->o, p[0].p), pm_v3_copy(F->x, p[0].d1);
      return pm_v3_norm(F->x) > 0;
    case CAD_CIRCLE:  /* C(0) = O + r X, C(pi) = O - r X, C'(0) = r Y */
    case CAD_ELLIPSE: /* C(0) = O + a X, C(pi) = O - a X, C'(0) = b Y */
      for (int k = 0; k < 3; ++k) F->o[k] = 0.5 * (p[0].p[k] + p[1].p[k]);
      {
        double ox[3];
        pm_v3_sub(ox, p[0].p, F->o);
        if (!unit(F->x, ox, tiny, &F->r)) return 0;
      }
      if (!unit(F->y, p[0].d1, tiny, &F->r2)) return 0;
      if (kind == CAD_CIRCLE) F->r2 = 0;
      return 1;
    default: return 0;
  }
}

/* Validation: 20 parameters, uniform in the box. The tolerances: positions 1e-9 x diag (the
 * brief's bar, far below any mesh size); a first derivative 1e-9 x (|d| + diag / span), i.e. the
 * same relative error in the position change across the box; second derivatives 1e-6 of their
 * scale (gmsh evaluates them through OCC's D2, which is as exact as D0, but their only use is
 * curvature, where 1e-6 is invisible). */
#define FIT_SAMPLES 20
#define FIT_TOL_P 1e-9
#define FIT_TOL_D1 1e-9
#define FIT_TOL_D2 1e-6

static int near3(const double a[3], const double b[3], double tol) {
  return pm_v3_dist(a, b) <= tol;
}

static int check_face(const cad_form *F, int tag, const double lo[2], const double hi[2],
                      double diag, pm_rng *rng) {
  double uv[2 * FIT_SAMPLES];
  for (int i = 0; i < FIT_SAMPLES; ++i) {
    uv[2 * i] = pm_rng_range(rng, lo[0], hi[0]);
    uv[2 * i + 1] = pm_rng_range(rng, lo[1], hi[1]);
  }
  pm_face_point g[FIT_SAMPLES];
  if (cad_gmsh_face(tag, FIT_SAMPLES, uv, 2, g)) return 0;
  const double su = fmax(hi[0] - lo[0], 1e-300), sv = fmax(hi[1] - lo[1], 1e-300);
  for (int i = 0; i < FIT_SAMPLES; ++i) {
    pm_face_point c;
    cad_form_face(F, uv + 2 * i, 2, &c);
    if (!near3(c.p, g[i].p, FIT_TOL_P * diag)) return 0;
    if (!near3(c.su, g[i].su, FIT_TOL_D1 * (pm_v3_norm(g[i].su) + diag / su))) return 0;
    if (!near3(c.sv, g[i].sv, FIT_TOL_D1 * (pm_v3_norm(g[i].sv) + diag / sv))) return 0;
    if (!near3(c.suu, g[i].suu, FIT_TOL_D2 * (pm_v3_norm(g[i].suu) + diag / (su * su)))) return 0;
    if (!near3(c.suv, g[i].suv, FIT_TOL_D2 * (pm_v3_norm(g[i].suv) + diag / (su * sv)))) return 0;
    if (!near3(c.svv, g[i].svv, FIT_TOL_D2 * (pm_v3_norm(g[i].svv) + diag / (sv * sv)))) return 0;
  }
  return 1;
}

static int check_curve(const cad_form *F, int tag, double lo, double hi, double diag, pm_rng *rng,
                       int positions_only) {
  double t[FIT_SAMPLES];
  for (int i = 0; i < FIT_SAMPLES; ++i) t[i] = pm_rng_range(rng, lo, hi);
  pm_curve_point g[FIT_SAMPLES];
  if (cad_gmsh_curve(tag, FIT_SAMPLES, t, positions_only ? 0 : 1, hi - lo, g)) return 0;
  const double s = fmax(hi - lo, 1e-300);
  /* Second derivatives are not compared: gmsh's are finite differences (cad_gmsh_curve) and
   * the closed form's are exact. */
  for (int i = 0; i < FIT_SAMPLES; ++i) {
    pm_curve_point c;
    cad_form_curve(F, t[i], 1, &c);
    if (!near3(c.p, g[i].p, FIT_TOL_P * diag)) return 0;
    if (positions_only) continue;
    if (!near3(c.d1, g[i].d1, FIT_TOL_D1 * (pm_v3_norm(g[i].d1) + diag / s))) return 0;
  }
  return 1;
}

int cad_fit(const pm_cell *c, const char *gtype, double diag, cad_form *out) {
  memset(out, 0, sizeof *out);
  out->kind = CAD_GMSH;
  pm_rng rng;
  pm_rng_init(&rng, 0x6361645f666974ULL /* "cad_fit" */, (uint64_t)(c->dim * 1000003 + c->tag));
  cad_form F;
  if (c->dim == PM_CURVE) {
    if (c->degenerate) {
      /* A pole or an apex: the point itself, checked for position only (gmsh's derivative of a
       * zero-length curve is meaningless; the true one is zero). */
      memset(&F, 0, sizeof F);
      F.kind = CAD_POINT;
      pm_curve_point p;
      double t = c->lo[0];
      if (cad_gmsh_curve(c->tag, 1, &t, 0, 1, &p)) return 0;
      pm_v3_copy(F.o, p.p);
      if (!check_curve(&F, c->tag, c->lo[0], c->hi[0], diag, &rng, 1)) return 0;
      *out = F;
      return 1;
    }
    cad_kind cand[3];
    int n = 0;
    if (strcmp(gtype, "Line") == 0)
      cand[n++] = CAD_LINE;
    else if (strcmp(gtype, "Circle") == 0)
      cand[n++] = CAD_CIRCLE;
    else if (strcmp(gtype, "Ellipse") == 0)
      cand[n++] = CAD_ELLIPSE;
    else
      cand[n++] = CAD_LINE, cand[n++] = CAD_CIRCLE, cand[n++] = CAD_ELLIPSE;
    for (int k = 0; k < n; ++k)
      if (fit_curve(cand[k], c->tag, diag, &F) &&
          check_curve(&F, c->tag, c->lo[0], c->hi[0], diag, &rng, 0)) {
        *out = F;
        return 1;
      }
    return 0;
  }
  if (c->dim != PM_FACE) return 0;
  cad_kind cand[5];
  int n = 0;
  if (strcmp(gtype, "Plane") == 0)
    cand[n++] = CAD_PLANE;
  else if (strcmp(gtype, "Cylinder") == 0)
    cand[n++] = CAD_CYLINDER;
  else if (strcmp(gtype, "Cone") == 0)
    cand[n++] = CAD_CONE;
  else if (strcmp(gtype, "Sphere") == 0)
    cand[n++] = CAD_SPHERE;
  else if (strcmp(gtype, "Torus") == 0)
    cand[n++] = CAD_TORUS;
  else
    /* Other types (B-splines, surfaces of revolution, "Unknown") may still be one of these
     * in disguise: a planar bilinear patch, a revolved line; the check decides. */
    cand[n++] = CAD_PLANE, cand[n++] = CAD_CYLINDER, cand[n++] = CAD_CONE, cand[n++] = CAD_SPHERE,
    cand[n++] = CAD_TORUS;
  for (int k = 0; k < n; ++k)
    if (fit_face(cand[k], c->tag, c->lo, c->hi, diag, &F) &&
        check_face(&F, c->tag, c->lo, c->hi, diag, &rng)) {
      *out = F;
      return 1;
    }
  return 0;
}
