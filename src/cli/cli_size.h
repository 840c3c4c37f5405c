/* What --size means for a run: a number or an expression (sizing.h), or "inferred": the field
 * psys infers from curvature, gap size and its Lipschitz bound (papers/001 section 3.1). For the
 * psys method "inferred" is its own default; for any other method the field is inferred by psys
 * first and handed over as a sampled field, so that both methods run on the same field.
 *
 * The text is read in two steps so that a command line that cannot be read is a usage error
 * found before the input is opened, and a field that fails on the input is a failure. */
#ifndef PM_CLI_SIZE_H
#define PM_CLI_SIZE_H

#include <packmesh/packmesh.h>

/* Read the text: *out receives a number's or an expression's field, or NULL for "inferred".
 * Fails (a usage error for the caller) when the text is neither. */
pm_status pm_cli_size_parse(const char *text, pm_sizing **out, pm_error *err);

/* The field of the run: `parsed` (from pm_cli_size_parse; its reference moves to *out) or, for
 * "inferred", NULL when the method is psys (its own default) and psys's inference otherwise. */
pm_status pm_cli_size_resolve(pm_sizing *parsed, const pm_method *method, const pm_model *model,
                              uint64_t seed, int threads, pm_sizing **out, pm_error *err);

#endif /* PM_CLI_SIZE_H */
