/* Trimming loops of a face in parameter space: their polylines and the inside test.
 *
 * pm_model_finish() calls pm_trim_build() for every face: it samples each loop's boundary-curve
 * uses through the face's pcurves into a closed polyline, classifies loops as outer or hole
 * (when the backend did not say) and orients them (outer counter-clockwise, holes clockwise),
 * then builds an accelerator for pm_face_inside():
 *   - a coarse grid of cells over the loops' (u, v) box, each cell marked IN, OUT, or MIXED
 *     (touched by a polyline edge); a point in an IN or OUT cell is answered at once;
 *   - horizontal slabs (rows) listing the polyline edges whose v-range overlaps them; a point in a
 *     MIXED cell is answered by counting the crossings of a ray towards +u with the edges of its
 *     slab, each crossing decided by the exact orient2d of predicates.h.
 * Points on the polyline count as inside (the trimmed region is closed).
 */
#ifndef PM_TRIM_H
#define PM_TRIM_H

#include <packmesh/packmesh.h>

#include <stdint.h>

/* The cell complex's types (geom.h), declared here rather than included: geom.c builds every
 * face's trimming through this header, and the two must not include each other. */
typedef struct pm_cell pm_cell;
typedef struct pm_model pm_model;

/* Sample the loops of face f (whose loop->use arrays the backend filled) into polylines, fix
 * their orientation and outer flags, and build f->trim. Each curve interval is bisected, up
 * to 2^10 times, while its chord sags more than tol3d from the curve in 3D (on the surface; 0:
 * not asked) or more than 2e-4 of the parameter box's diagonal in (u, v). */
pm_status pm_trim_build(const pm_model *m, pm_cell *f, double tol3d, pm_error *err);

/* Release f->trim and the loops' polylines (not the use arrays). */
void pm_trim_free(pm_cell *f);

/* The inside test on unwrapped (u, v): 1 inside or on the boundary, 0 outside. */
int pm_trim_inside(const pm_cell *f, const double uv[2]);

/* A lower bound on the distance in (u, v) from uv (unwrapped) to the loop polylines of face f,
 * at most rmax (returned when no polyline point is nearer). Every point nearer to an inside uv
 * than that is inside too (pm_trim_inside), so a particle that stays within it needs no inside
 * test. Cost: the edges of the slabs between v - rmax and v + rmax. */
double pm_trim_clearance(const pm_cell *f, const double uv[2], double rmax);

/* Even-odd inside test of (u, v) against one closed polyline (no accelerator; exact
 * predicates). 1 inside or on it, 0 outside. */
int pm_polyline_inside(const double *uv, int32_t npts, const double p[2]);

/* Signed area of a closed polyline (positive when counter-clockwise). */
double pm_polyline_area(const double *uv, int32_t npts);

#endif /* PM_TRIM_H */
