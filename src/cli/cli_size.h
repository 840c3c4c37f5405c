/* What --size means for a run: a number or an expression (sizing.h), or "inferred": the field
 * psys infers from curvature, gap size and its Lipschitz bound (papers/001 section 3.1). For the
 * psys method "inferred" is its own default; for any other method the field is inferred by psys
 * first and handed over as a sampled field, so that both methods run on the same field. */
#ifndef PM_CLI_SIZE_H
#define PM_CLI_SIZE_H

#include "common/method.h"

/* *out receives the field, or NULL when the method should use its own default. */
pm_status pm_cli_size_resolve(const char *text, const pm_method *method, const pm_model *model,
                              uint64_t seed, int threads, pm_sizing **out, pm_error *err);

#endif /* PM_CLI_SIZE_H */
