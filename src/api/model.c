/* Models, size fields and the built-in cases of the public API (packmesh.h). */
#include <packmesh/packmesh.h>

#include <string.h>

#include "common/backends/gmsh_session.h"
#include "common/geom/geom.h"
#include "common/input/cases.h"
#include "common/input/input.h"
#include "psys/psys.h"

pm_status pm_model_open(const char *spec, pm_model **model, pm_sizing **default_size,
                        pm_error *err) {
  if (!model) return pm_error_setf(err, PM_ERR_ARG, "pm_model_open: no place for the model");
  *model = NULL;
  if (default_size) *default_size = NULL;
  if (!spec || !spec[0]) return pm_error_setf(err, PM_ERR_ARG, "pm_model_open: no input named");
  pm_sizing *size = NULL;
  pm_status s = pm_input_open(spec, model, &size, err);
  if (s) return s;
  if (default_size)
    *default_size = size;
  else
    pm_sizing_destroy(size);
  return PM_OK;
}

const char *pm_model_name(const pm_model *m) { return m ? m->name : NULL; }

int pm_model_dimension(const pm_model *m) { return m ? m->dim : 0; }

int32_t pm_model_cell_count(const pm_model *m, int dim) {
  return m && dim >= 0 && dim <= 3 ? pm_model_count(m, dim) : 0;
}

void pm_model_box(const pm_model *m, double box[6]) {
  for (int k = 0; k < 6; ++k) box[k] = m ? m->box[k] : 0;
}

double pm_model_diagonal(const pm_model *m) { return m ? m->diagonal : 0; }

const char *pm_model_healed(const pm_model *m) { return m ? m->heal : NULL; }

/* ---- the built-in cases --------------------------------------------------------------------- */

static const pm_case_info *case_at(int i) {
  int n;
  const pm_case_info *t = pm_cases(&n);
  return i >= 0 && i < n ? &t[i] : NULL;
}

int pm_case_count(void) {
  int n;
  pm_cases(&n);
  return n;
}

const char *pm_case_name(int i) { return case_at(i) ? case_at(i)->name : NULL; }
const char *pm_case_description(int i) { return case_at(i) ? case_at(i)->description : NULL; }
const char *pm_case_default_size(int i) { return case_at(i) ? case_at(i)->size : NULL; }
const char *pm_case_source(int i) { return case_at(i) ? case_at(i)->source : NULL; }
int pm_case_dimension(int i) { return case_at(i) ? case_at(i)->dim : 0; }

void pm_finalize(void) { pm_gmsh_shutdown(); }

/* ---- the inferred size field --------------------------------------------------------------- */

pm_status pm_sizing_inferred(const pm_model *model, uint64_t seed, int threads, pm_sizing **out,
                             pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_sizing_inferred: no place for the field");
  *out = NULL;
  if (!model) return pm_error_setf(err, PM_ERR_ARG, "pm_sizing_inferred: no model");
  if (threads < 1 || threads > 1024)
    return pm_error_setf(err, PM_ERR_ARG, "threads must be 1 to 1024, got %d", threads);
  /* psys's inference with its default parameters, handed over as a sampled field. */
  return psys_infer_size(model, NULL, seed, threads, out, err);
}
