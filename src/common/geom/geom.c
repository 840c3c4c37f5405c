/* The generic half of the geometry interface (geom.h): model lifecycle, evaluation dispatch,
 * curvatures from the fundamental forms, the parameter displacement of a particle
 * (papers/001 eq. 7-9, papers/003 eq. 15), the shared rule for a step that leaves a cell, and
 * projection by Newton iteration. Backends provide only evaluation (pm_cell_class). */
#include "common/geom/geom.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/trim.h"
#include "common/base/vec3.h"

/* ---- model lifecycle --------------------------------------------------------------------- */

pm_status pm_model_alloc(const int32_t count[4], pm_model **out, pm_error *err) {
  *out = NULL;
  pm_model *m = calloc(1, sizeof *m);
  if (!m) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory allocating a model");
  for (int d = 0; d < 4; ++d) {
    if (count[d] < 0) {
      free(m);
      return pm_error_setf(err, PM_ERR_ARG, "negative cell count");
    }
    m->count[d] = count[d];
    if (count[d] == 0) continue;
    m->cells[d] = calloc((size_t)count[d], sizeof(pm_cell));
    if (!m->cells[d]) {
      pm_model_destroy(m);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory allocating %d cells", (int)count[d]);
    }
    for (int32_t i = 0; i < count[d]; ++i) {
      m->cells[d][i].dim = d;
      m->cells[d][i].index = i;
      m->cells[d][i].tag = (int)i + 1;
      m->cells[d][i].model = m;
    }
  }
  *out = m;
  return PM_OK;
}

void pm_model_destroy(pm_model *m) {
  if (!m) return;
  for (int d = 0; d < 4; ++d) {
    for (int32_t i = 0; i < m->count[d] && m->cells[d]; ++i) {
      pm_cell *c = &m->cells[d][i];
      if (d == PM_FACE) pm_trim_free(c);
      if (c->cls && c->cls->destroy) c->cls->destroy(c);
      for (int32_t l = 0; l < c->nloop; ++l) free(c->loop[l].use);
      free(c->loop);
      free(c->bound);
      free(c->up);
      free(c->embed);
      free(c->host);
    }
    free(m->cells[d]);
  }
  if (m->destroy_impl) m->destroy_impl(m);
  free(m);
}

static void box_add(double box[6], const double p[3]) {
  for (int k = 0; k < 3; ++k) {
    box[k] = fmin(box[k], p[k]);
    box[k + 3] = fmax(box[k + 3], p[k]);
  }
}

static void box_union(double box[6], const double other[6]) {
  box_add(box, other);
  box_add(box, other + 3);
}

static void box_empty(double box[6]) {
  for (int k = 0; k < 3; ++k) box[k] = DBL_MAX, box[k + 3] = -DBL_MAX;
}

/* Derive `up` of dimension d-1 cells from the `bound` lists of dimension d cells. */
static pm_status derive_up(pm_model *m, int d, pm_error *err) {
  int32_t nlow = m->count[d - 1];
  if (nlow == 0) return PM_OK;
  int32_t *cnt = calloc((size_t)nlow, sizeof(int32_t));
  if (!cnt) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < m->count[d]; ++i) {
    const pm_cell *c = &m->cells[d][i];
    for (int32_t k = 0; k < c->nbound; ++k) {
      int32_t b = c->bound[k].cell;
      if (b < 0 || b >= nlow) {
        free(cnt);
        return pm_error_setf(err, PM_ERR_GEOM, "cell (%d,%d) lists boundary cell %d of %d", d,
                             c->tag, (int)b, (int)nlow);
      }
      /* A seam curve appears twice in its face; list the face once. */
      int seen = 0;
      for (int32_t q = 0; q < k; ++q) seen |= c->bound[q].cell == b;
      if (!seen) cnt[b]++;
    }
  }
  for (int32_t b = 0; b < nlow; ++b) {
    pm_cell *lc = &m->cells[d - 1][b];
    free(lc->up);
    lc->up = cnt[b] ? malloc(sizeof(int32_t) * (size_t)cnt[b]) : NULL;
    lc->nup = 0;
    if (cnt[b] && !lc->up) {
      free(cnt);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
  }
  for (int32_t i = 0; i < m->count[d]; ++i) {
    const pm_cell *c = &m->cells[d][i];
    for (int32_t k = 0; k < c->nbound; ++k) {
      int32_t b = c->bound[k].cell;
      int seen = 0;
      for (int32_t q = 0; q < k; ++q) seen |= c->bound[q].cell == b;
      if (!seen) m->cells[d - 1][b].up[m->cells[d - 1][b].nup++] = i;
    }
  }
  free(cnt);
  return PM_OK;
}

/* Derive `host` lists from `embed` lists. */
static pm_status derive_hosts(pm_model *m, pm_error *err) {
  for (int d = 0; d < 4; ++d)
    for (int32_t i = 0; i < m->count[d]; ++i) {
      const pm_cell *c = &m->cells[d][i];
      for (int32_t k = 0; k < c->nembed; ++k) {
        pm_cellref r = c->embed[k];
        if (r.dim < 0 || r.dim >= d || r.index < 0 || r.index >= m->count[r.dim])
          return pm_error_setf(err, PM_ERR_GEOM, "cell (%d,%d) embeds an invalid cell (%d,%d)", d,
                               c->tag, (int)r.dim, (int)r.index);
        pm_cell *e = &m->cells[r.dim][r.index];
        pm_cellref *h = realloc(e->host, sizeof(pm_cellref) * ((size_t)e->nhost + 1));
        if (!h) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        e->host = h;
        e->host[e->nhost++] = (pm_cellref){d, i};
      }
    }
  return PM_OK;
}

/* Faces: `bound` is the concatenation of the loops' uses (after trim.c oriented the loops). */
static pm_status face_bound_from_loops(pm_cell *f, pm_error *err) {
  int32_t n = 0;
  for (int32_t l = 0; l < f->nloop; ++l) n += f->loop[l].nuse;
  pm_use *b = malloc(sizeof(pm_use) * (size_t)(n ? n : 1));
  if (!b) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  n = 0;
  for (int32_t l = 0; l < f->nloop; ++l)
    for (int32_t k = 0; k < f->loop[l].nuse; ++k) b[n++] = f->loop[l].use[k];
  free(f->bound);
  f->bound = b;
  f->nbound = n;
  return PM_OK;
}

/* Whether point x lies on a curve of m (within tol): the curves whose sampled box, widened by a
 * hundredth of its diagonal for what the samples miss, holds x are projected on. */
static int on_some_curve(const pm_model *m, const double x[3], double tol) {
  for (int32_t i = 0; i < m->count[PM_CURVE]; ++i) {
    const pm_cell *c = &m->cells[PM_CURVE][i];
    if (c->degenerate) continue;
    const double margin = tol + 1e-2 * pm_v3_dist(c->box, c->box + 3);
    int inside = 1;
    for (int k = 0; k < 3 && inside; ++k)
      inside = x[k] >= c->box[k] - margin && x[k] <= c->box[k + 3] + margin;
    double t, d;
    if (inside && pm_cell_project(c, x, NULL, &t, NULL, &d, NULL) == PM_OK && d <= tol) return 1;
  }
  return 0;
}

/* Stray vertices (geom.h): isolated points on another vertex or on a curve. Quadratic in the
 * isolated vertices only, of which a model has few. */
static void mark_stray_vertices(pm_model *m) {
  int32_t nv = m->count[PM_VERTEX];
  for (int32_t v = 0; v < nv; ++v) {
    pm_cell *a = &m->cells[PM_VERTEX][v];
    a->stray = 0;
    if (a->nup || a->nhost) continue;
    for (int32_t u = 0; u < nv && !a->stray; ++u) {
      const pm_cell *b = &m->cells[PM_VERTEX][u];
      /* Of two coincident isolated points the first one is kept. */
      if (u != v && (b->nup || b->nhost || u < v) && pm_v3_dist(a->xyz, b->xyz) <= 1e3 * m->tol)
        a->stray = 1;
    }
    if (!a->stray) a->stray = on_some_curve(m, a->xyz, 1e3 * m->tol);
  }
}

/* Sample count per parameter direction for 3D bounding boxes of curves and faces. */
#define BOX_SAMPLES 16

pm_status pm_model_finish(pm_model *m, pm_error *err) {
  pm_status s;
  for (int32_t i = 0; i < m->count[PM_VERTEX]; ++i) {
    pm_cell *v = &m->cells[PM_VERTEX][i];
    for (int k = 0; k < 3; ++k) v->box[k] = v->box[k + 3] = v->xyz[k];
  }
  for (int32_t i = 0; i < m->count[PM_CURVE]; ++i) {
    pm_cell *c = &m->cells[PM_CURVE][i];
    if (!c->cls || !c->cls->curve_eval)
      return pm_error_setf(err, PM_ERR_INTERNAL, "curve %d has no evaluator", c->tag);
    if (!(c->hi[0] > c->lo[0]) && !c->degenerate)
      return pm_error_setf(err, PM_ERR_GEOM, "curve %d has an empty parameter range", c->tag);
    box_empty(c->box);
    for (int k = 0; k <= 4 * BOX_SAMPLES; ++k) {
      pm_curve_point cp;
      pm_curve_eval(c, c->lo[0] + (c->hi[0] - c->lo[0]) * k / (4.0 * BOX_SAMPLES), 0, &cp);
      box_add(c->box, cp.p);
    }
  }
  /* The trimming polylines sag at most a quarter of the feature floor from their curves in 3D
   * (trim.c): a particle may come as near a boundary as the finest spacing the sizes ask for.
   * The floor's diagonal is the vertices' and curves' box (the model's is known only once the
   * faces' boxes are, which need the trimming). */
  double wire[6];
  box_empty(wire);
  for (int d = 0; d < 2; ++d)
    for (int32_t i = 0; i < m->count[d]; ++i) box_union(wire, m->cells[d][i].box);
  const double wire_diag = wire[3] >= wire[0] ? pm_v3_dist(wire, wire + 3) : 0;
  const double trim_tol3d = 0.25 * PM_FEATURE_FLOOR * (isfinite(wire_diag) ? wire_diag : 0);
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    pm_cell *f = &m->cells[PM_FACE][i];
    if (!f->cls || !f->cls->face_eval || !f->cls->face_curve_uv)
      return pm_error_setf(err, PM_ERR_INTERNAL, "face %d has no evaluator", f->tag);
    if ((s = pm_trim_build(m, f, trim_tol3d, err))) return s;
    if ((s = face_bound_from_loops(f, err))) return s;
    /* 3D box: the boundary curves' boxes and the inside samples of a grid over (u, v). */
    box_empty(f->box);
    for (int32_t k = 0; k < f->nbound; ++k) box_union(f->box, m->cells[PM_CURVE][f->bound[k].cell].box);
    for (int a = 0; a <= BOX_SAMPLES; ++a)
      for (int b = 0; b <= BOX_SAMPLES; ++b) {
        double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * a / BOX_SAMPLES,
                        f->lo[1] + (f->hi[1] - f->lo[1]) * b / BOX_SAMPLES};
        if (!pm_face_inside(f, uv)) continue;
        pm_face_point fp;
        pm_face_eval(f, uv, 0, &fp);
        box_add(f->box, fp.p);
      }
  }
  for (int d = 1; d <= 3; ++d)
    if ((s = derive_up(m, d, err))) return s;
  if ((s = derive_hosts(m, err))) return s;
  for (int32_t i = 0; i < m->count[PM_VOLUME]; ++i) {
    pm_cell *v = &m->cells[PM_VOLUME][i];
    box_empty(v->box);
    for (int32_t k = 0; k < v->nbound; ++k) box_union(v->box, m->cells[PM_FACE][v->bound[k].cell].box);
    for (int k = 0; k < 3; ++k) v->lo[k] = v->box[k], v->hi[k] = v->box[k + 3];
  }
  box_empty(m->box);
  m->dim = -1;
  for (int d = 0; d < 4; ++d)
    for (int32_t i = 0; i < m->count[d]; ++i) {
      box_union(m->box, m->cells[d][i].box);
      m->dim = d;
    }
  if (m->dim < 0) return pm_error_setf(err, PM_ERR_GEOM, "the model has no cells");
  m->diagonal = pm_v3_dist(m->box, m->box + 3);
  if (!(m->diagonal > 0)) return pm_error_setf(err, PM_ERR_GEOM, "the model has zero extent");
  if (!(m->tol > 0)) m->tol = 1e-9 * m->diagonal;
  mark_stray_vertices(m);
  return PM_OK;
}

/* ---- evaluation -------------------------------------------------------------------------- */

void pm_curve_eval(const pm_cell *c, double t, int order, pm_curve_point *out) {
  c->cls->curve_eval(c, t, order, out);
}

void pm_face_eval(const pm_cell *f, const double uv[2], int order, pm_face_point *out) {
  f->cls->face_eval(f, uv, order, out);
}

void pm_face_eval_many(const pm_cell *f, int32_t n, const double *uv, int order,
                       pm_face_point *out) {
  if (f->cls->face_eval_many) {
    f->cls->face_eval_many(f, n, uv, order, out);
    return;
  }
  for (int32_t i = 0; i < n; ++i) f->cls->face_eval(f, uv + 2 * i, order, out + i);
}

int pm_face_point_normal(const pm_face_point *fp, double min_sin, double n[3]) {
  pm_v3_cross(n, fp->su, fp->sv);
  double nn = pm_v3_norm(n);
  /* Written as !(a > b) so that a NaN derivative also counts as singular. */
  if (!(nn > min_sin * pm_v3_norm(fp->su) * pm_v3_norm(fp->sv))) {
    pm_v3_zero(n);
    return 0;
  }
  pm_v3_scale(n, n, 1.0 / nn);
  return 1;
}

void pm_face_curve_uv(const pm_cell *f, const pm_use *use, double t, double uv[2]) {
  f->cls->face_curve_uv(f, use, t, uv);
}

void pm_cell_point(const pm_cell *c, const double *par, double xyz[3]) {
  switch (c->dim) {
    case PM_VERTEX: pm_v3_copy(xyz, c->xyz); return;
    case PM_CURVE: {
      pm_curve_point cp;
      pm_curve_eval(c, par[0], 0, &cp);
      pm_v3_copy(xyz, cp.p);
      return;
    }
    case PM_FACE: {
      pm_face_point fp;
      pm_face_eval(c, par, 0, &fp);
      pm_v3_copy(xyz, fp.p);
      return;
    }
    default: pm_v3_copy(xyz, par); return;
  }
}

double pm_curve_length(const pm_cell *c, double t1, double t2) {
  static const double gx[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                               0.9061798459386640};
  static const double gw[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                               0.4786286704993665, 0.2369268850561891};
  if (c->degenerate) return 0;
  double len = 0, h = (t2 - t1) / 4;
  for (int piece = 0; piece < 4; ++piece) {
    double mid = t1 + (piece + 0.5) * h;
    for (int k = 0; k < 5; ++k) {
      pm_curve_point cp;
      pm_curve_eval(c, mid + 0.5 * h * gx[k], 1, &cp);
      len += 0.5 * fabs(h) * gw[k] * pm_v3_norm(cp.d1);
    }
  }
  return len;
}

double pm_curve_curvature(const pm_cell *c, double t) {
  if (c->degenerate) return 0;
  pm_curve_point cp;
  pm_curve_eval(c, t, 2, &cp);
  double s = pm_v3_norm(cp.d1);
  if (!(s > 0)) return 0;
  double x[3];
  pm_v3_cross(x, cp.d1, cp.d2);
  return pm_v3_norm(x) / (s * s * s);
}

/* Principal curvatures at a regular point; returns 0 where Su x Sv vanishes. */
int pm_face_point_curvatures(const pm_face_point *fp, double *kmax, double *kmin, double normal[3]) {
  double n[3];
  pm_v3_cross(n, fp->su, fp->sv);
  double E = pm_v3_dot(fp->su, fp->su), F = pm_v3_dot(fp->su, fp->sv), G = pm_v3_dot(fp->sv, fp->sv);
  double nn = pm_v3_norm(n);
  /* |Su x Sv|^2 = EG - F^2: relative to EG it measures how far from singular the chart is. */
  if (!(nn > 0) || nn * nn <= 1e-20 * E * G) {
    if (normal) pm_v3_zero(normal);
    return 0;
  }
  pm_v3_scale(n, n, 1.0 / nn);
  double L = pm_v3_dot(fp->suu, n), M = pm_v3_dot(fp->suv, n), N = pm_v3_dot(fp->svv, n);
  double det = E * G - F * F;
  /* Mean and Gaussian curvature from the first (E, F, G) and second (L, M, N) forms;
   * the principal curvatures are H +- sqrt(H^2 - K). */
  double H = (E * N + G * L - 2 * F * M) / (2 * det);
  double K = (L * N - M * M) / det;
  double disc = sqrt(fmax(0.0, H * H - K));
  double k1 = H + disc, k2 = H - disc;
  if (fabs(k2) > fabs(k1)) {
    double t = k1;
    k1 = k2, k2 = t;
  }
  *kmax = k1, *kmin = k2;
  if (normal) pm_v3_copy(normal, n);
  return 1;
}

static int curvatures_at(const pm_cell *f, const double uv[2], double *kmax, double *kmin,
                         double normal[3]) {
  pm_face_point fp;
  pm_face_eval(f, uv, 2, &fp);
  return pm_face_point_curvatures(&fp, kmax, kmin, normal);
}

void pm_face_curvatures(const pm_cell *f, const double uv[2], double *kmax, double *kmin,
                        double normal[3]) {
  if (curvatures_at(f, uv, kmax, kmin, normal)) return;
  /* A singular point (a pole, an apex): take the limit from regular points nearby, stepping
   * towards the centre of the parameter box by growing fractions of its size. */
  double cu = 0.5 * (f->lo[0] + f->hi[0]), cv = 0.5 * (f->lo[1] + f->hi[1]);
  for (double s = 1e-6; s < 0.5; s *= 10) {
    double q[2] = {uv[0] + s * (cu - uv[0]), uv[1] + s * (cv - uv[1])};
    if (curvatures_at(f, q, kmax, kmin, normal)) return;
  }
  *kmax = *kmin = 0;
}

int pm_face_mesh_sign(const pm_model *m, int32_t face) {
  const pm_cell *f = &m->cells[PM_FACE][face];
  if (f->nup == 0) return 1;
  const pm_cell *v = &m->cells[PM_VOLUME][f->up[0]];
  for (int32_t q = 0; q < v->nbound; ++q)
    if (v->bound[q].cell == face) return v->bound[q].sense < 0 ? -1 : 1;
  return 1;
}

/* ---- wrapping and the inside test ---------------------------------------------------------- */

void pm_cell_wrap(const pm_cell *c, double *par) {
  int np = c->dim == PM_CURVE ? 1 : (c->dim == PM_FACE ? 2 : 0);
  for (int k = 0; k < np; ++k) {
    if (!c->periodic[k] || !(c->period[k] > 0)) continue;
    double P = c->period[k], x = par[k] - c->lo[k];
    if (x >= 0 && x < P) continue;
    x = fmod(x, P);
    if (x < 0) x += P;
    if (x >= P) x = 0; /* fmod of a value just below -P*k can round up to P */
    par[k] = c->lo[k] + x;
  }
}

int pm_face_inside(const pm_cell *f, const double uv[2]) {
  double q[2] = {uv[0], uv[1]};
  pm_cell_wrap(f, q);
  if (pm_trim_inside(f, q)) return 1;
  /* A periodic face's loops may reach the top of the period exactly (the seam pcurve at
   * u = lo + P): a point wrapped to lo lies on the other copy of the seam. */
  for (int k = 0; k < 2; ++k)
    if (f->periodic[k] && q[k] == f->lo[k]) {
      double r[2] = {q[0], q[1]};
      r[k] += f->period[k];
      if (pm_trim_inside(f, r)) return 1;
    }
  return 0;
}

/* ---- moving a particle --------------------------------------------------------------------- */

/* Solve M x = b for the symmetric positive semi-definite 2x2 M = [[E, F], [F, G]] by its
 * pseudo-inverse: eigen-directions whose eigenvalue is below 1e-12 of the largest are dropped
 * (at a pole Su = 0, so E = F = 0 and only the v component is kept). */
static void solve_metric(double E, double F, double G, const double b[2], double x[2]) {
  double tr = E + G, det = E * G - F * F;
  if (!(tr > 0)) {
    x[0] = x[1] = 0;
    return;
  }
  if (det > 1e-12 * tr * tr) {
    x[0] = (G * b[0] - F * b[1]) / det;
    x[1] = (E * b[1] - F * b[0]) / det;
    return;
  }
  /* Rank one: M ~ l1 e e^T with l1 = tr; x = (e . b / l1) e. */
  double l1 = 0.5 * tr + sqrt(fmax(0.0, 0.25 * tr * tr - det));
  double e[2];
  if (fabs(F) > 1e-300 || E != G) {
    e[0] = F, e[1] = l1 - E;
    if (fabs(e[0]) + fabs(e[1]) < 1e-300 * tr) e[0] = l1 - G, e[1] = F;
  } else {
    e[0] = 1, e[1] = 0;
  }
  double ne = hypot(e[0], e[1]);
  if (!(ne > 0)) {
    x[0] = x[1] = 0;
    return;
  }
  e[0] /= ne, e[1] /= ne;
  double s = (e[0] * b[0] + e[1] * b[1]) / l1;
  x[0] = s * e[0], x[1] = s * e[1];
}

void pm_cell_param_delta(const pm_cell *c, const double *par, const double *d, const double dx[3],
                         double *dpar) {
  switch (c->dim) {
    case PM_VERTEX: return;
    case PM_CURVE: {
      /* papers/003 eq. 15: the tangential part of dx, in units of t. */
      double tmp[3];
      const double *d1 = d;
      if (!d1) {
        pm_curve_point cp;
        pm_curve_eval(c, par[0], 1, &cp);
        pm_v3_copy(tmp, cp.d1);
        d1 = tmp;
      }
      double g = pm_v3_dot(d1, d1);
      dpar[0] = g > 0 ? pm_v3_dot(dx, d1) / g : 0;
      return;
    }
    case PM_FACE: {
      /* papers/001 eq. 7-9: du = M^-1 J dx, the least-squares parameter step whose image
       * Su du + Sv dv is the tangential projection of dx. */
      double su[3], sv[3];
      if (d) {
        pm_v3_copy(su, d), pm_v3_copy(sv, d + 3);
      } else {
        pm_face_point fp;
        pm_face_eval(c, par, 1, &fp);
        pm_v3_copy(su, fp.su), pm_v3_copy(sv, fp.sv);
      }
      double b[2] = {pm_v3_dot(su, dx), pm_v3_dot(sv, dx)};
      solve_metric(pm_v3_dot(su, su), pm_v3_dot(su, sv), pm_v3_dot(sv, sv), b, dpar);
      return;
    }
    default: pm_v3_copy(dpar, dx); return;
  }
}

int pm_cell_move(const pm_cell *c, const double *par, const double *dpar, double *par_out) {
  switch (c->dim) {
    case PM_VERTEX: return PM_MOVE_FREE;
    case PM_CURVE: {
      double t = par[0], dt = dpar[0], tn = t + dt;
      if (c->periodic[0]) {
        par_out[0] = tn;
        pm_cell_wrap(c, par_out);
        return PM_MOVE_FREE;
      }
      if ((tn >= c->lo[0] && tn <= c->hi[0]) || dt == 0 || t < c->lo[0] || t > c->hi[0]) {
        par_out[0] = tn;
        return PM_MOVE_FREE;
      }
      /* Stop just inside the end the step would pass: the crossing fraction less the backoff. */
      double end = tn > c->hi[0] ? c->hi[0] : c->lo[0];
      double s = (end - t) / dt - PM_CLIP_BACKOFF;
      par_out[0] = s > 0 ? t + s * dt : t;
      return PM_MOVE_CLIPPED;
    }
    case PM_FACE: {
      double start[2] = {par[0], par[1]};
      double end[2] = {par[0] + dpar[0], par[1] + dpar[1]};
      if (pm_face_inside(c, end) || !pm_face_inside(c, start)) {
        par_out[0] = end[0], par_out[1] = end[1];
        pm_cell_wrap(c, par_out);
        return PM_MOVE_FREE;
      }
      /* Bisection for the crossing: [s_in, s_out] brackets it with start + s_in dpar inside.
       * Bisection on the inside test (rather than intersecting the segment with the polylines)
       * works unchanged across the seams of periodic faces. 40 halvings reach 1e-12 of the
       * step. */
      double s_in = 0, s_out = 1;
      for (int it = 0; it < 40; ++it) {
        double s = 0.5 * (s_in + s_out);
        double q[2] = {start[0] + s * dpar[0], start[1] + s * dpar[1]};
        if (pm_face_inside(c, q))
          s_in = s;
        else
          s_out = s;
      }
      double s = s_in - PM_CLIP_BACKOFF;
      double q[2] = {start[0], start[1]};
      for (int it = 0; it < 60 && s > 0; ++it, s *= 0.5) {
        double r[2] = {start[0] + s * dpar[0], start[1] + s * dpar[1]};
        if (pm_face_inside(c, r)) {
          q[0] = r[0], q[1] = r[1];
          break;
        }
      }
      par_out[0] = q[0], par_out[1] = q[1];
      pm_cell_wrap(c, par_out);
      return PM_MOVE_CLIPPED;
    }
    default:
      for (int k = 0; k < 3; ++k) par_out[k] = par[k] + dpar[k];
      return PM_MOVE_FREE;
  }
}

int pm_cell_displace(const pm_cell *c, const double *par, const double dx[3], double *par_out) {
  double dpar[3] = {0, 0, 0};
  pm_cell_param_delta(c, par, NULL, dx, dpar);
  return pm_cell_move(c, par, dpar, par_out);
}

/* ---- projection ------------------------------------------------------------------------------ */

/* Newton iterations of the projection. Quadratic convergence from a sampled start needs a
 * handful; 50 is a cap for pathological cases. */
#define PROJ_MAX_IT 50
#define PROJ_SAMPLES 24

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Curve: minimize |C(t) - x|^2 over [lo, hi] (or the period). Returns the squared distance. */
static double curve_newton(const pm_cell *c, const double x[3], double t, double *t_out) {
  const double lo = c->lo[0], hi = c->hi[0];
  for (int it = 0; it < PROJ_MAX_IT; ++it) {
    pm_curve_point cp;
    pm_curve_eval(c, t, 2, &cp);
    double r[3];
    pm_v3_sub(r, cp.p, x);
    double g = pm_v3_dot(r, cp.d1);
    double h = pm_v3_dot(cp.d1, cp.d1) + pm_v3_dot(r, cp.d2);
    if (!(h > 0)) h = pm_v3_dot(cp.d1, cp.d1); /* Gauss-Newton where the Hessian is not convex */
    if (!(h > 0)) break;
    double dt = -g / h, tn = t + dt;
    if (!c->periodic[0]) tn = clampd(tn, lo, hi);
    if (fabs(tn - t) <= 1e-14 * (hi - lo + fabs(t))) {
      t = tn;
      break;
    }
    t = tn;
  }
  if (c->periodic[0]) pm_cell_wrap(c, &t);
  pm_curve_point cp;
  pm_curve_eval(c, t, 0, &cp);
  *t_out = t;
  return pm_v3_dist2(cp.p, x);
}

static double curve_project(const pm_cell *c, const double x[3], const double *guess,
                            double *t_best) {
  double best = DBL_MAX;
  *t_best = c->lo[0];
  if (c->degenerate) {
    pm_curve_point cp;
    pm_curve_eval(c, c->lo[0], 0, &cp);
    return pm_v3_dist2(cp.p, x);
  }
  if (c->cls->project) {
    double t;
    if (c->cls->project(c, x, guess, &t) == 0) {
      if (!c->periodic[0]) t = clampd(t, c->lo[0], c->hi[0]);
      double tt, d2 = curve_newton(c, x, t, &tt);
      *t_best = tt;
      return d2;
    }
  }
  /* Start from the guess and from the best samples. */
  double starts[4];
  int ns = 0;
  if (guess) starts[ns++] = guess[0];
  double d_s[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, t_s[3] = {0, 0, 0};
  const int n = 4 * PROJ_SAMPLES;
  for (int k = 0; k <= n; ++k) {
    double t = c->lo[0] + (c->hi[0] - c->lo[0]) * k / n;
    pm_curve_point cp;
    pm_curve_eval(c, t, 0, &cp);
    double d2 = pm_v3_dist2(cp.p, x);
    for (int q = 0; q < 3; ++q)
      if (d2 < d_s[q]) {
        for (int r = 2; r > q; --r) d_s[r] = d_s[r - 1], t_s[r] = t_s[r - 1];
        d_s[q] = d2, t_s[q] = t;
        break;
      }
  }
  for (int q = 0; q < 3; ++q)
    if (d_s[q] < DBL_MAX) starts[ns++] = t_s[q];
  for (int k = 0; k < ns; ++k) {
    double t, d2 = curve_newton(c, x, starts[k], &t);
    if (d2 < best) best = d2, *t_best = t;
  }
  return best;
}

double pm_face_project_from(const pm_cell *f, const double x[3], const double start[2],
                            double uv_out[2]) {
  double uv[2] = {start[0], start[1]};
  for (int it = 0; it < PROJ_MAX_IT; ++it) {
    pm_face_point fp;
    pm_face_eval(f, uv, 2, &fp);
    double r[3];
    pm_v3_sub(r, fp.p, x);
    double g[2] = {pm_v3_dot(r, fp.su), pm_v3_dot(r, fp.sv)};
    double E = pm_v3_dot(fp.su, fp.su), F = pm_v3_dot(fp.su, fp.sv), G = pm_v3_dot(fp.sv, fp.sv);
    double Huu = E + pm_v3_dot(r, fp.suu), Huv = F + pm_v3_dot(r, fp.suv),
           Hvv = G + pm_v3_dot(r, fp.svv);
    /* Newton when the Hessian is positive definite, Gauss-Newton (the metric) otherwise. */
    if (!(Huu > 0 && Huu * Hvv - Huv * Huv > 1e-14 * (Huu + Hvv) * (Huu + Hvv)))
      Huu = E, Huv = F, Hvv = G;
    double mg[2] = {-g[0], -g[1]}, d[2];
    solve_metric(Huu, Huv, Hvv, mg, d);
    double n[2] = {uv[0] + d[0], uv[1] + d[1]};
    for (int k = 0; k < 2; ++k)
      if (!f->periodic[k]) n[k] = clampd(n[k], f->lo[k], f->hi[k]);
    double step = fabs(n[0] - uv[0]) + fabs(n[1] - uv[1]);
    uv[0] = n[0], uv[1] = n[1];
    if (step <= 1e-14 * (f->hi[0] - f->lo[0] + f->hi[1] - f->lo[1])) break;
  }
  pm_cell_wrap(f, uv);
  pm_face_point fp;
  pm_face_eval(f, uv, 0, &fp);
  uv_out[0] = uv[0], uv_out[1] = uv[1];
  return pm_v3_dist2(fp.p, x);
}

static double face_project_untrimmed(const pm_cell *f, const double x[3], const double *guess,
                                     double uv_best[2]) {
  double best = DBL_MAX;
  if (f->cls->project) {
    double uv[2];
    if (f->cls->project(f, x, guess, uv) == 0) {
      best = pm_face_project_from(f, x, uv, uv_best);
      return best;
    }
  }
  double starts[4][2];
  int ns = 0;
  if (guess) starts[ns][0] = guess[0], starts[ns][1] = guess[1], ++ns;
  double d_s[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, uv_s[3][2] = {{0, 0}, {0, 0}, {0, 0}};
  for (int a = 0; a <= PROJ_SAMPLES; ++a)
    for (int b = 0; b <= PROJ_SAMPLES; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * a / PROJ_SAMPLES,
                      f->lo[1] + (f->hi[1] - f->lo[1]) * b / PROJ_SAMPLES};
      pm_face_point fp;
      pm_face_eval(f, uv, 0, &fp);
      double d2 = pm_v3_dist2(fp.p, x);
      for (int q = 0; q < 3; ++q)
        if (d2 < d_s[q]) {
          for (int r = 2; r > q; --r) d_s[r] = d_s[r - 1], uv_s[r][0] = uv_s[r - 1][0], uv_s[r][1] = uv_s[r - 1][1];
          d_s[q] = d2, uv_s[q][0] = uv[0], uv_s[q][1] = uv[1];
          break;
        }
    }
  for (int q = 0; q < 3; ++q)
    if (d_s[q] < DBL_MAX) starts[ns][0] = uv_s[q][0], starts[ns][1] = uv_s[q][1], ++ns;
  for (int k = 0; k < ns; ++k) {
    double uv[2], d2 = pm_face_project_from(f, x, starts[k], uv);
    if (d2 < best) best = d2, uv_best[0] = uv[0], uv_best[1] = uv[1];
  }
  return best;
}

pm_status pm_cell_project(const pm_cell *c, const double xyz[3], const double *guess, double *par,
                          double closest[3], double *dist, pm_error *err) {
  const pm_model *m = c->model;
  if (!(isfinite(xyz[0]) && isfinite(xyz[1]) && isfinite(xyz[2])))
    return pm_error_setf(err, PM_ERR_ARG, "projection of a non-finite point");
  double d2 = 0, p[3];
  switch (c->dim) {
    case PM_VERTEX:
      pm_v3_copy(p, c->xyz);
      d2 = pm_v3_dist2(p, xyz);
      break;
    case PM_CURVE:
      d2 = curve_project(c, xyz, guess, par);
      pm_cell_point(c, par, p);
      break;
    case PM_FACE: {
      double uv[2];
      d2 = face_project_untrimmed(c, xyz, guess, uv);
      par[0] = uv[0], par[1] = uv[1];
      if (!pm_face_inside(c, uv) && m) {
        /* The foot point is trimmed away: the closest point of the trimmed face lies on its
         * boundary; take the closest boundary-curve point, in this face's (u, v). */
        double best = DBL_MAX;
        for (int32_t k = 0; k < c->nbound; ++k) {
          const pm_cell *cv = &m->cells[PM_CURVE][c->bound[k].cell];
          double t, dc = curve_project(cv, xyz, NULL, &t);
          if (dc < best) {
            best = dc;
            pm_face_curve_uv(c, &c->bound[k], t, par);
          }
        }
        d2 = best;
      } else if (!pm_face_inside(c, uv)) {
        /* Without the model, fall back to the closest loop polyline vertex's boundary point. */
        double best = DBL_MAX;
        for (int32_t l = 0; l < c->nloop; ++l)
          for (int32_t i = 0; i < c->loop[l].npts; ++i) {
            const double *q = &c->loop[l].uv[2 * i];
            pm_face_point fp;
            pm_face_eval(c, q, 0, &fp);
            double dq = pm_v3_dist2(fp.p, xyz);
            if (dq < best) best = dq, par[0] = q[0], par[1] = q[1];
          }
        d2 = best;
      }
      pm_cell_point(c, par, p);
      d2 = pm_v3_dist2(p, xyz);
      break;
    }
    default:
      pm_v3_copy(par, xyz);
      pm_v3_copy(p, xyz);
      d2 = 0;
      break;
  }
  if (closest) pm_v3_copy(closest, p);
  if (dist) *dist = sqrt(d2);
  return PM_OK;
}
