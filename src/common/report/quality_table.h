/* The readable table of a mesh's measures that `packmesh quality` prints: counts, the checker's
 * verdict and shells, per-kind summaries (radius ratio, aspect ratio, angles), eps_t and eps_g,
 * the size conformity, the angle histograms, the needles, R/l_min by site, and the distance to the
 * model. */
#ifndef PM_QUALITY_TABLE_H
#define PM_QUALITY_TABLE_H

#include <stdio.h>

#include "common/measure/distance.h"
#include "common/measure/needles.h"
#include "common/measure/quality.h"
#include "common/mesh/mesh_check.h"
#include "common/report/stats.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Write the table of a mesh's measures (all in) to f: the mesh's name, its counts and the time
 * the measuring took from st (its input, counts and time total); geometry (may be NULL) names the
 * model it was checked against; d (may be NULL) is the distance to it. */
void pm_quality_table_write(FILE *f, const char *geometry, const pm_stats *st,
                            const pm_quality *q, const pm_check_report *r, const pm_needles *nd,
                            const pm_distance *d);

#ifdef __cplusplus
}
#endif

#endif /* PM_QUALITY_TABLE_H */
