/* --size for a run (see cli_size.h). */
#include "cli/cli_size.h"

#include <string.h>


pm_status pm_cli_size_parse(const char *text, pm_sizing **out, pm_error *err) {
  *out = NULL;
  if (strcmp(text, "inferred") == 0) return PM_OK;
  pm_status s = pm_sizing_parse(text, out, err);
  if (s) pm_error_prefix(err, "--size");
  return s;
}

pm_status pm_cli_size_resolve(pm_sizing *parsed, const pm_method *method, const pm_model *model,
                              uint64_t seed, int threads, pm_sizing **out, pm_error *err) {
  *out = parsed;
  if (parsed || strcmp(pm_method_name(method), "psys") == 0) return PM_OK; /* psys infers its own field */
  pm_status s = pm_sizing_inferred(model, seed, threads, out, err);
  if (s) pm_error_prefix(err, "--size inferred");
  return s;
}
