/* Quality and validity of a mesh for the public API (packmesh.h): the quality module
 * (measure/quality.h) and the checker (mesh/mesh_check.h) behind opaque handles. */
#include <packmesh/packmesh.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/measure/quality.h"
#include "common/mesh/mesh_check.h"

pm_status pm_quality_measure(const pm_mesh *m, const pm_sizing *size, pm_quality **out,
                             pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_quality_measure: no place for the result");
  *out = NULL;
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_quality_measure: no mesh");
  pm_quality *q = calloc(1, sizeof *q);
  if (!q) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status s = pm_quality_compute(m, size, q, err);
  if (s) {
    free(q);
    return s;
  }
  *out = q;
  return PM_OK;
}

void pm_quality_destroy(pm_quality *q) {
  if (!q) return;
  pm_quality_clear(q);
  free(q);
}

static const pm_kind_quality *kind_of(const pm_quality *q, int dim) {
  return !q ? NULL : dim == 2 ? &q->tri : dim == 3 ? &q->tet : NULL;
}

pm_status pm_quality_summary(const pm_quality *q, int dim, pm_measure what, pm_summary *out,
                             pm_error *err) {
  const pm_kind_quality *k = kind_of(q, dim);
  if (!k || !out)
    return pm_error_setf(err, PM_ERR_ARG, "pm_quality_summary: dimension %d (2 triangles, 3 tets)",
                         dim);
  switch (what) {
    case PM_MEASURE_RADIUS_RATIO: *out = k->s_radius_ratio; return PM_OK;
    case PM_MEASURE_ASPECT_RATIO: *out = k->s_aspect_ratio; return PM_OK;
    case PM_MEASURE_MIN_ANGLE: *out = k->s_min_angle; return PM_OK;
    case PM_MEASURE_MAX_ANGLE: *out = k->s_max_angle; return PM_OK;
    default: break;
  }
  return pm_error_setf(err, PM_ERR_ARG, "pm_quality_summary: unknown measure %d", (int)what);
}

const double *pm_quality_values(const pm_quality *q, int dim, pm_measure what, int32_t *n) {
  const pm_kind_quality *k = kind_of(q, dim);
  if (n) *n = k ? k->n : 0;
  if (!k) return NULL;
  switch (what) {
    case PM_MEASURE_RADIUS_RATIO: return k->radius_ratio;
    case PM_MEASURE_ASPECT_RATIO: return k->aspect_ratio;
    case PM_MEASURE_MIN_ANGLE: return k->min_angle;
    case PM_MEASURE_MAX_ANGLE: return k->max_angle;
    default: break;
  }
  if (n) *n = 0;
  return NULL;
}

double pm_quality_eps_t(const pm_quality *q, int dim) {
  return kind_of(q, dim) ? kind_of(q, dim)->eps_t : 0;
}

double pm_quality_eps_g(const pm_quality *q, int dim) {
  return kind_of(q, dim) ? kind_of(q, dim)->eps_g : 0;
}

pm_summary pm_quality_size_ratio(const pm_quality *q, int dim) {
  const pm_kind_quality *k = kind_of(q, dim);
  pm_summary none = {0};
  return k && k->has_size ? k->size_ratio : none;
}

pm_status pm_mesh_validate(const pm_mesh *m, const pm_model *model, pm_check_result *out,
                           pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_validate: no place for the result");
  memset(out, 0, sizeof *out);
  pm_check_report *r = calloc(1, sizeof *r);
  if (!r) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status s = pm_mesh_check(m, model, r, err);
  if (!s) {
    out->valid = r->valid;
    const int cap = (int)(sizeof out->problem / sizeof out->problem[0]);
    for (int i = 0; i < r->nproblem && i < cap; ++i)
      snprintf(out->problem[out->nproblem++], sizeof out->problem[0], "%s", r->problem[i]);
  }
  pm_check_report_clear(r);
  free(r);
  return s;
}
