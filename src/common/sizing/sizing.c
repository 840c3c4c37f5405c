/* Node-spacing fields (sizing.h): the generic parts. The desired edge length d(x, y, z) is
 * Shimada's node spacing (papers/003 section 2.2, the bubble diameter); DESIGN.md "Sizing" says
 * every interface speaks of size in this sense.
 *
 * Kinds are dispatched in pm_sizing_eval; expressions live in sizing_expr.c, sampled fields in
 * sizing_sampled.c. A scaled field holds one reference to its base, so a comparison study can
 * make many scaled copies of one expensive field (a sampled one, an expression with its parser
 * pool) without copying it.
 */
#include "common/sizing/sizing_private.h"
#include "common/sizing/sizing_features.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh.h"

pm_sizing *pm_sizing_alloc(sz_kind kind) {
  pm_sizing *s = calloc(1, sizeof *s);
  if (!s) return NULL;
  s->kind = kind;
  atomic_init(&s->refs, 1);
  return s;
}

void sz_format_double(double v, char *buf, size_t len) {
  for (int prec = 15; prec <= 17; ++prec) {
    snprintf(buf, len, "%.*g", prec, v);
    if (strtod(buf, NULL) == v) return;
  }
}

static pm_status bad_value(double d, const char *what, pm_error *err) {
  return pm_error_setf(err, PM_ERR_ARG, "%s must be a finite number > 0, got %g", what, d);
}

static pm_status make_constant(double d, pm_sizing **out, pm_error *err) {
  pm_sizing *s = pm_sizing_alloc(SZ_CONSTANT);
  char buf[40];
  sz_format_double(d, buf, sizeof buf);
  if (!s || !(s->desc = strdup(buf))) {
    free(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  }
  s->value = d;
  *out = s;
  return PM_OK;
}

pm_status pm_sizing_constant(double d, pm_sizing **out, pm_error *err) {
  *out = NULL;
  if (!(isfinite(d) && d > 0)) return bad_value(d, "size", err);
  return make_constant(d, out, err);
}

pm_status pm_sizing_expression(const char *expr, pm_sizing **out, pm_error *err) {
  *out = NULL;
  pm_sizing *s = pm_sizing_alloc(SZ_EXPR);
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  pm_status st = sz_expr_create(expr, &s->expr, &s->desc, err);
  if (st) {
    free(s);
    return st;
  }
  *out = s;
  return PM_OK;
}

pm_status pm_sizing_callback(pm_sizing_fn fn, void *user, const char *description,
                             pm_sizing **out, pm_error *err) {
  *out = NULL;
  if (!fn) return pm_error_setf(err, PM_ERR_ARG, "size callback is NULL");
  pm_sizing *s = pm_sizing_alloc(SZ_CALLBACK);
  if (!s || !(s->desc = strdup(description && *description ? description : "callback"))) {
    free(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  }
  s->fn = fn;
  s->user = user;
  *out = s;
  return PM_OK;
}

pm_status pm_sizing_sampled(const pm_mesh *samples, const double *values, pm_sizing **out,
                            pm_error *err) {
  *out = NULL;
  pm_sizing *s = pm_sizing_alloc(SZ_SAMPLED);
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  pm_status st = sz_sampled_create(samples, values, &s->sampled, err);
  if (st) {
    free(s);
    return st;
  }
  char buf[64];
  snprintf(buf, sizeof buf, "sampled (%d nodes)", (int)samples->nnode);
  if (!(s->desc = strdup(buf))) {
    sz_sampled_destroy(s->sampled);
    free(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  }
  *out = s;
  return PM_OK;
}

pm_status pm_sizing_scaled(const pm_sizing *base, double factor, pm_sizing **out, pm_error *err) {
  *out = NULL;
  if (!base) return pm_error_setf(err, PM_ERR_ARG, "scaled size: no base field");
  if (!(isfinite(factor) && factor > 0)) return bad_value(factor, "size scale factor", err);
  /* A scale of a scale multiplies the factors and shares the innermost field. */
  if (base->kind == SZ_SCALED) {
    factor *= base->value;
    base = base->base;
  }
  /* A scaled constant is a constant (and describes itself as one number, which --size takes). */
  if (base->kind == SZ_CONSTANT) {
    double d = factor * base->value;
    if (!(isfinite(d) && d > 0)) return bad_value(d, "scaled size", err);
    return make_constant(d, out, err);
  }
  pm_sizing *s = pm_sizing_alloc(SZ_SCALED);
  char f[40];
  sz_format_double(factor, f, sizeof f);
  /* An expression scales to an expression that --size takes again; other kinds only say what
   * they are. */
  const char *fmt = base->kind == SZ_EXPR ? "%s*(%s)" : "%s x (%s)";
  size_t len = strlen(f) + strlen(base->desc) + 8;
  if (!s || !(s->desc = malloc(len))) {
    free(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  }
  snprintf(s->desc, len, fmt, f, base->desc);
  s->value = factor;
  s->base = (pm_sizing *)base; /* the reference count is the one mutable part of a field */
  atomic_fetch_add(&s->base->refs, 1);
  *out = s;
  return PM_OK;
}

pm_status pm_sizing_parse(const char *text, pm_sizing **out, pm_error *err) {
  *out = NULL;
  if (!text) return pm_error_setf(err, PM_ERR_PARSE, "size: no text");
  while (isspace((unsigned char)*text)) ++text;
  size_t n = strlen(text);
  while (n > 0 && isspace((unsigned char)text[n - 1])) --n;
  if (n == 0) return pm_error_setf(err, PM_ERR_PARSE, "size: empty text (a number or an expression in x, y, z, r)");
  char *t = strndup(text, n);
  if (!t) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size field");
  /* A plain number, all of the text, is a constant; anything else goes to the expression
   * parser (which also reads numbers, but a constant evaluates faster and describes itself
   * exactly). */
  char *end;
  errno = 0;
  double d = strtod(t, &end);
  pm_status st;
  if (*end == '\0') {
    st = (isfinite(d) && d > 0) ? make_constant(d, out, err)
                                : pm_error_setf(err, PM_ERR_ARG,
                                                "size '%s' must be a finite number > 0", t);
  } else {
    st = pm_sizing_expression(t, out, err);
  }
  free(t);
  return st;
}

double pm_sizing_eval(const pm_sizing *s, const double xyz[3]) {
  switch (s->kind) {
    case SZ_CONSTANT: return s->value;
    case SZ_EXPR: return sz_expr_eval(s->expr, xyz);
    case SZ_CALLBACK: return s->fn(xyz, s->user);
    case SZ_SAMPLED: return sz_sampled_eval(s->sampled, xyz);
    case SZ_SCALED: return s->value * pm_sizing_eval(s->base, xyz);
    case SZ_FEATURES: return sz_features_eval(s, xyz);
  }
  return NAN;
}

const char *pm_sizing_describe(const pm_sizing *s) { return s ? s->desc : "(none)"; }

void pm_sizing_destroy(pm_sizing *s) {
  while (s) {
    if (atomic_fetch_sub(&s->refs, 1) != 1) return;
    pm_sizing *base = s->base;
    if (s->expr) sz_expr_destroy(s->expr);
    if (s->sampled) sz_sampled_destroy(s->sampled);
    if (s->features) pm_feature_size_destroy(s->features);
    free(s->desc);
    free(s);
    s = base; /* release the reference a scaled field held */
  }
}

/* ---- check against a model ---------------------------------------------------------------- */

/* Samples per curve and per face direction. The check guards against a field that is wrong in
 * a region (a sign change, a pole, a division by zero), not against a spike between samples;
 * 33 points per curve and a 17 x 17 grid over each face's parameter box find the regions such
 * mistakes produce without costing more than a few thousand evaluations per face. */
#define CHECK_CURVE_N 33
#define CHECK_FACE_N 17

static pm_status check_at(const pm_sizing *s, const double p[3], const char *where,
                          pm_error *err) {
  double d = pm_sizing_eval(s, p);
  /* PM_COORD_MAX (mesh.h) bounds lengths as it bounds coordinates: beyond it the methods' squared
   * distances overflow. */
  if (isfinite(d) && d > 0 && d <= PM_COORD_MAX) return PM_OK;
  return pm_error_setf(err, PM_ERR_ARG,
                       "size '%s' is %g at %s, point (%.6g, %.6g, %.6g): sizes must be finite, "
                       "> 0 and at most %g",
                       pm_sizing_describe(s), d, where, p[0], p[1], p[2], PM_COORD_MAX);
}

pm_status pm_sizing_check(const pm_sizing *s, const pm_model *m, pm_error *err) {
  if (!s || !m) return pm_error_setf(err, PM_ERR_ARG, "size check: no field or no model");
  char where[160];
  pm_status st;
  for (int32_t i = 0; i < m->count[PM_VERTEX]; ++i) {
    const pm_cell *v = pm_model_cell(m, PM_VERTEX, i);
    snprintf(where, sizeof where, "vertex %d (tag %d)", (int)i, v->tag);
    if ((st = check_at(s, v->xyz, where, err))) return st;
  }
  for (int32_t i = 0; i < m->count[PM_CURVE]; ++i) {
    const pm_cell *c = pm_model_cell(m, PM_CURVE, i);
    for (int k = 0; k < CHECK_CURVE_N; ++k) {
      double t = c->lo[0] + (c->hi[0] - c->lo[0]) * k / (CHECK_CURVE_N - 1);
      pm_curve_point cp;
      pm_curve_eval(c, t, 0, &cp);
      snprintf(where, sizeof where, "curve %d (tag %d) t = %.6g", (int)i, c->tag, t);
      if ((st = check_at(s, cp.p, where, err))) return st;
    }
  }
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, i);
    for (int a = 0; a < CHECK_FACE_N; ++a)
      for (int b = 0; b < CHECK_FACE_N; ++b) {
        /* cell-centred samples: the boundary itself is covered by the curves */
        double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (a + 0.5) / CHECK_FACE_N,
                        f->lo[1] + (f->hi[1] - f->lo[1]) * (b + 0.5) / CHECK_FACE_N};
        if (!pm_face_inside(f, uv)) continue;
        pm_face_point fp;
        pm_face_eval(f, uv, 0, &fp);
        snprintf(where, sizeof where, "face %d (tag %d) (u, v) = (%.6g, %.6g)", (int)i, f->tag,
                 uv[0], uv[1]);
        if ((st = check_at(s, fp.p, where, err))) return st;
      }
  }
  return PM_OK;
}
