/* Snapshots of a particle run (--frames DIR), for teaching and for looking at a run: every
 * snapshot is a ParaView .vtu file of the particles (points with radius and cell dimension), the
 * series is indexed by DIR/frames.pvd, and for planar models each snapshot is also drawn as an
 * SVG picture of the particles as circles over the domain's boundary. */
#ifndef PM_FRAMES_H
#define PM_FRAMES_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"

typedef struct pm_frames pm_frames;

/* Prepare DIR (created when missing) for the snapshots of a run on `model` (borrowed: it must
 * outlive the frames). */
pm_status pm_frames_create(const char *dir, const pm_model *model, pm_frames **out,
                           pm_error *err);

/* One snapshot at `step`: n particles at xyz[3n] with radius[n] (what the method calls the
 * particle's size: a bubble's radius, a psys particle's sigma) on cells of dimension dim[n]. */
pm_status pm_frames_add(pm_frames *f, int64_t step, int32_t n, const double *xyz,
                        const double *radius, const int8_t *dim, pm_error *err);

/* Write DIR/frames.pvd listing the snapshots. */
pm_status pm_frames_finish(pm_frames *f, pm_error *err);

/* Number of snapshots written. */
int32_t pm_frames_count(const pm_frames *f);

void pm_frames_destroy(pm_frames *f);

#endif /* PM_FRAMES_H */
