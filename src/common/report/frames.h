/* Snapshots of a particle run (--frames DIR), for teaching and for looking at a run: every
 * snapshot is a ParaView .vtu file of the particles (points with radius and cell dimension), the
 * series is indexed by DIR/frames.pvd, and for planar models each snapshot is also drawn as an
 * SVG picture of the particles as circles over the domain's boundary and the particles'
 * triangulation, with the phase and step, and written as the same picture's numbers for gnuplot,
 * from which `packmesh animate` makes a GIF beside its HTML player of the SVGs. */
#ifndef PM_FRAMES_H
#define PM_FRAMES_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/method/method.h"

typedef struct pm_frames pm_frames;

/* Prepare DIR (created when missing) for the snapshots of a run on `model` (borrowed: it must
 * outlive the frames). */
pm_status pm_frames_create(const char *dir, const pm_model *model, pm_frames **out,
                           pm_error *err);

/* One snapshot (method.h): DIR/frame_NNNNNN.vtu, and for planar models frame_NNNNNN.svg, the
 * picture, and frame_NNNNNN.dat, its numbers for gnuplot (`packmesh animate`). */
pm_status pm_frames_add(pm_frames *f, const pm_run_frame *frame, pm_error *err);

/* Write DIR/frames.pvd listing the snapshots. */
pm_status pm_frames_finish(pm_frames *f, pm_error *err);

/* Number of snapshots written. */
int32_t pm_frames_count(const pm_frames *f);

void pm_frames_destroy(pm_frames *f);

#endif /* PM_FRAMES_H */
