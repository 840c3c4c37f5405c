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
 */
#ifndef PM_INPUT_H
#define PM_INPUT_H

#include "common/geom.h"
#include "common/sizing.h"

/* Open `spec`. *model receives the model; *default_size (when the pointer is not NULL) the
 * input's own size field, or NULL when it has none (a CAD file, a case file without "size").
 * Errors name the input and the problem in one line. */
pm_status pm_input_open(const char *spec, pm_model **model, pm_sizing **default_size,
                        pm_error *err);

#endif /* PM_INPUT_H */
