/* What `packmesh mesh INPUT` and `packmesh quality --geometry INPUT` accept, in one place:
 *   - a built-in case, written "case:NAME" (cases.h);
 *   - a CAD file: .step, .stp, .iges, .igs, .brep (geom_cad.h);
 *   - a case file, .json: a domain and a size field, e.g.
 *       { "name": "plate with hole",
 *         "domain": { "loops": [ [ {"line": [0, 0]}, {"line": [2, 0]}, {"line": [2, 1]},
 *                                  {"line": [0, 1]} ],
 *                                [ {"arc": {"from": [1.2, 0.5], "centre": [1, 0.5], "ccw": false}} ] ] },
 *         "size": "0.05+0.1*abs(x-1)" }
 *     "domain" is either {"loops": [...]} (a planar domain: the first loop is the outer boundary,
 *     the others holes; a piece {"line": [x, y]} is a segment starting at (x, y), a piece
 *     {"arc": {"from": [x, y], "centre": [cx, cy], "ccw": true|false}} an arc starting at
 *     "from"; each piece ends where the next starts), or {"file": "part.step"} (relative to
 *     the case file's folder), or {"case": "qi3"}. "size" (optional) is a number or an
 *     expression string.
 *     Case files are read strictly, each fault one line naming it: the text must be one JSON
 *     object and nothing after it; no key outside those above, none twice; every value of its
 *     type ("ccw" true or false, points two numbers, a piece either "line" or "arc"); and a
 *     planar domain must be well formed (planar_check.h: no zero-length piece, no loop crossing,
 *     touching or running along itself or another, every hole inside the outer loop, coordinates
 *     finite and within +-PM_COORD_MAX).
 */
#ifndef PM_INPUT_H
#define PM_INPUT_H

#include "common/geom/geom.h"
#include "common/sizing/sizing.h"

/* Open `spec`. *model receives the model; *default_size (when the pointer is not NULL) the
 * input's own size field, or NULL when it has none (a CAD file, a case file without "size").
 * Errors name the input and the problem in one line. */
pm_status pm_input_open(const char *spec, pm_model **model, pm_sizing **default_size,
                        pm_error *err);

/* A case file's text: `len` bytes at `text` (borrowed, need not end with '\0'). `path` names it
 * in messages and locates a "file" domain (relative to its folder). Results as pm_input_open;
 * PM_ERR_PARSE for malformed JSON or a key or value the format does not allow, PM_ERR_ARG for a
 * malformed domain, the model's or the size field's own errors otherwise. */
pm_status pm_case_file_parse(const char *path, const char *text, size_t len, pm_model **model,
                             pm_sizing **size, pm_error *err);

#endif /* PM_INPUT_H */
