/* --size for a run (see cli_size.h). */
#include "cli/cli_size.h"

#include <string.h>

pm_status pm_cli_size_resolve(const char *text, const pm_method *method, const pm_model *model,
                              uint64_t seed, int threads, pm_sizing **out, pm_error *err) {
  *out = NULL;
  (void)model, (void)seed, (void)threads;
  if (strcmp(text, "inferred") == 0) {
    if (strcmp(method->name, "psys") == 0) return PM_OK; /* psys infers its own field */
    return pm_error_setf(err, PM_ERR_ARG,
                         "--size inferred needs the psys method's sizing inference, which this "
                         "build does not have yet");
  }
  pm_status s = pm_sizing_parse(text, out, err);
  if (s) pm_error_prefix(err, "--size");
  return s;
}
