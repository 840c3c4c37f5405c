/* Planar domains of line segments and circular arcs (see geom_analytic.h). */
#include "common/geom/geom_analytic.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Per-curve data: a segment a + t dir, or an arc c + R (cos th, sin th), th = th0 + s t / R. */
typedef struct planar_curve {
  pm_piece_kind kind;
  double a[2], dir[2]; /* line: start and unit direction */
  double c[2], R, th0; /* arc: centre, radius, start angle */
  double s;            /* arc: +1 counter-clockwise, -1 clockwise */
  double len;
} planar_curve;

static void curve_eval(const pm_cell *self, double t, int order, pm_curve_point *out) {
  const planar_curve *pc = self->impl;
  if (pc->kind == PM_PIECE_LINE) {
    out->p[0] = pc->a[0] + t * pc->dir[0], out->p[1] = pc->a[1] + t * pc->dir[1], out->p[2] = 0;
    if (order >= 1) out->d1[0] = pc->dir[0], out->d1[1] = pc->dir[1], out->d1[2] = 0;
    if (order >= 2) out->d2[0] = out->d2[1] = out->d2[2] = 0;
    return;
  }
  double th = pc->th0 + pc->s * t / pc->R, ct = cos(th), st = sin(th);
  out->p[0] = pc->c[0] + pc->R * ct, out->p[1] = pc->c[1] + pc->R * st, out->p[2] = 0;
  if (order >= 1) out->d1[0] = -pc->s * st, out->d1[1] = pc->s * ct, out->d1[2] = 0;
  if (order >= 2) out->d2[0] = -ct / pc->R, out->d2[1] = -st / pc->R, out->d2[2] = 0;
}

static int curve_project(const pm_cell *self, const double xyz[3], const double *guess,
                         double *par) {
  (void)guess;
  const planar_curve *pc = self->impl;
  double t;
  if (pc->kind == PM_PIECE_LINE) {
    t = (xyz[0] - pc->a[0]) * pc->dir[0] + (xyz[1] - pc->a[1]) * pc->dir[1];
  } else {
    double dx = xyz[0] - pc->c[0], dy = xyz[1] - pc->c[1];
    if (dx == 0 && dy == 0) {
      t = 0; /* every point of the circle is equally close to its centre */
    } else {
      /* Angle travelled from the start in the arc's direction, in [0, 2 pi). */
      double a = pc->s * (atan2(dy, dx) - pc->th0);
      a = fmod(a, 2 * M_PI);
      if (a < 0) a += 2 * M_PI;
      t = a * pc->R;
      if (!self->periodic[0] && t > pc->len) {
        /* Beyond the arc's end: the nearer end point is the closest point. */
        double gap_end = t - pc->len, gap_start = 2 * M_PI * pc->R - t;
        t = gap_end < gap_start ? pc->len : 0;
      }
    }
  }
  if (!self->periodic[0]) t = fmin(fmax(t, 0), pc->len);
  *par = t;
  return 0;
}

static void face_eval(const pm_cell *self, const double uv[2], int order, pm_face_point *out) {
  (void)self;
  out->p[0] = uv[0], out->p[1] = uv[1], out->p[2] = 0;
  if (order >= 1) {
    out->su[0] = 1, out->su[1] = 0, out->su[2] = 0;
    out->sv[0] = 0, out->sv[1] = 1, out->sv[2] = 0;
  }
  if (order >= 2)
    for (int k = 0; k < 3; ++k) out->suu[k] = out->suv[k] = out->svv[k] = 0;
}

static void face_curve_uv(const pm_cell *self, const pm_use *use, double t, double uv[2]) {
  const pm_cell *c = &self->model->cells[PM_CURVE][use->cell];
  pm_curve_point cp;
  curve_eval(c, t, 0, &cp);
  uv[0] = cp.p[0], uv[1] = cp.p[1];
}

static int face_project(const pm_cell *self, const double xyz[3], const double *guess,
                        double *par) {
  (void)self, (void)guess;
  par[0] = xyz[0], par[1] = xyz[1];
  return 0;
}

static void destroy_impl(pm_cell *self) {
  free(self->impl);
  self->impl = NULL;
}

static const pm_cell_class line_class = {"segment", curve_eval, NULL, NULL, NULL, curve_project, destroy_impl};
static const pm_cell_class arc_class = {"arc", curve_eval, NULL, NULL, NULL, curve_project, destroy_impl};
static const pm_cell_class plane_class = {"plane", NULL, face_eval, NULL, face_curve_uv, face_project, NULL};

/* Extend an (x, y) box by an arc: its end points and the axis-extreme points within its span. */
static void arc_box(const planar_curve *pc, double box[4]) {
  for (int k = 0; k <= 64; ++k) {
    double th = pc->th0 + pc->s * (pc->len / pc->R) * k / 64.0;
    double x = pc->c[0] + pc->R * cos(th), y = pc->c[1] + pc->R * sin(th);
    box[0] = fmin(box[0], x), box[1] = fmin(box[1], y);
    box[2] = fmax(box[2], x), box[3] = fmax(box[3], y);
  }
}

pm_status pm_planar_model(const char *name, int32_t nloop, const pm_planar_loop *loops,
                          pm_model **out, pm_error *err) {
  *out = NULL;
  if (nloop <= 0) return pm_error_setf(err, PM_ERR_ARG, "a planar domain needs at least one loop");
  int32_t npiece = 0;
  for (int32_t l = 0; l < nloop; ++l) {
    if (loops[l].n <= 0 || !loops[l].piece)
      return pm_error_setf(err, PM_ERR_ARG, "planar domain loop %d is empty", (int)l);
    npiece += loops[l].n;
  }
  /* Scale for the tolerances: the extent of all piece start points and arc radii. */
  double scale = 0;
  for (int32_t l = 0; l < nloop; ++l)
    for (int32_t k = 0; k < loops[l].n; ++k) {
      const pm_planar_piece *p = &loops[l].piece[k];
      if (!isfinite(p->start[0]) || !isfinite(p->start[1]) ||
          (p->kind == PM_PIECE_ARC && (!isfinite(p->centre[0]) || !isfinite(p->centre[1]))))
        return pm_error_setf(err, PM_ERR_ARG, "planar domain loop %d piece %d: non-finite point",
                             (int)l, (int)k);
      scale = fmax(scale, fmax(fabs(p->start[0]), fabs(p->start[1])));
      if (p->kind == PM_PIECE_ARC) scale = fmax(scale, hypot(p->start[0] - p->centre[0], p->start[1] - p->centre[1]));
    }
  if (!(scale > 0)) scale = 1;
  const double tol = 1e-9 * scale;

  int32_t count[4] = {npiece, npiece, 1, 0};
  pm_model *m = NULL;
  pm_status s = pm_model_alloc(count, &m, err);
  if (s) return s;
  snprintf(m->name, sizeof m->name, "%s", name ? name : "planar");

  pm_cell *face = &m->cells[PM_FACE][0];
  face->cls = &plane_class;
  face->loop = calloc((size_t)nloop, sizeof(pm_loop));
  if (!face->loop) {
    pm_model_destroy(m);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  face->nloop = nloop;
  double box[4] = {INFINITY, INFINITY, -INFINITY, -INFINITY};

  int32_t first = 0;
  for (int32_t l = 0; l < nloop; ++l) {
    const pm_planar_loop *lp = &loops[l];
    pm_loop *fl = &face->loop[l];
    fl->outer = l == 0;
    fl->nuse = lp->n;
    fl->use = calloc((size_t)lp->n, sizeof(pm_use));
    if (!fl->use) {
      pm_model_destroy(m);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    for (int32_t k = 0; k < lp->n; ++k) {
      const pm_planar_piece *p = &lp->piece[k];
      const double *end = lp->piece[(k + 1) % lp->n].start;
      int32_t id = first + k, vend = first + (k + 1) % lp->n;
      pm_cell *v = &m->cells[PM_VERTEX][id];
      v->xyz[0] = p->start[0], v->xyz[1] = p->start[1], v->xyz[2] = 0;

      planar_curve *pc = calloc(1, sizeof *pc);
      pm_cell *c = &m->cells[PM_CURVE][id];
      c->bound = calloc(2, sizeof(pm_use));
      if (!pc || !c->bound) {
        free(pc);
        pm_model_destroy(m);
        return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      }
      c->impl = pc;
      c->nbound = 2;
      c->bound[0] = (pm_use){id, -1, 0};
      c->bound[1] = (pm_use){vend, +1, 0};
      pc->kind = p->kind;
      if (p->kind == PM_PIECE_LINE) {
        c->cls = &line_class;
        double dx = end[0] - p->start[0], dy = end[1] - p->start[1], L = hypot(dx, dy);
        if (!(L > tol)) {
          pm_model_destroy(m);
          return pm_error_setf(err, PM_ERR_ARG, "planar domain loop %d piece %d: zero-length line",
                               (int)l, (int)k);
        }
        pc->a[0] = p->start[0], pc->a[1] = p->start[1];
        pc->dir[0] = dx / L, pc->dir[1] = dy / L;
        pc->len = L;
        box[0] = fmin(box[0], fmin(p->start[0], end[0])), box[1] = fmin(box[1], fmin(p->start[1], end[1]));
        box[2] = fmax(box[2], fmax(p->start[0], end[0])), box[3] = fmax(box[3], fmax(p->start[1], end[1]));
      } else {
        c->cls = &arc_class;
        double R = hypot(p->start[0] - p->centre[0], p->start[1] - p->centre[1]);
        double Re = hypot(end[0] - p->centre[0], end[1] - p->centre[1]);
        if (!(R > tol) || fabs(R - Re) > 1e-7 * scale) {
          pm_model_destroy(m);
          return pm_error_setf(err, PM_ERR_ARG,
                               "planar domain loop %d piece %d: arc start and end are not on one "
                               "circle (radii %g and %g)",
                               (int)l, (int)k, R, Re);
        }
        pc->c[0] = p->centre[0], pc->c[1] = p->centre[1], pc->R = R;
        pc->s = p->ccw ? 1.0 : -1.0;
        pc->th0 = atan2(p->start[1] - p->centre[1], p->start[0] - p->centre[0]);
        double th1 = atan2(end[1] - p->centre[1], end[0] - p->centre[0]);
        double span = pc->s * (th1 - pc->th0);
        span = fmod(span, 2 * M_PI);
        if (span < 0) span += 2 * M_PI;
        if (lp->n == 1 || span * R <= tol) {
          span = 2 * M_PI; /* the piece closes on itself: a full circle */
          c->periodic[0] = lp->n == 1;
        }
        pc->len = span * R;
        if (c->periodic[0]) c->period[0] = pc->len;
        arc_box(pc, box);
      }
      c->lo[0] = 0, c->hi[0] = pc->len;
      fl->use[k] = (pm_use){id, +1, 0};
    }
    first += lp->n;
  }
  face->lo[0] = box[0], face->lo[1] = box[1];
  face->hi[0] = box[2], face->hi[1] = box[3];
  m->tol = tol;
  s = pm_model_finish(m, err);
  if (s) {
    pm_model_destroy(m);
    return pm_error_prefix(err, "planar domain '%s'", name ? name : "planar");
  }
  *out = m;
  return PM_OK;
}
