/* The size a model's own features ask for: the node spacing below which a mesh of the model
 * would have needles (needles.h) or flatten what it should show.
 *
 *   f(x) = min( d0,  min over features k of ( h_k + g dist(x, k) ) )
 *
 * d0 is a base size (INFINITY for none), g the grade (growth per unit distance: the field is
 * g-Lipschitz, so neighbouring nodes differ in spacing by at most a factor 1 + g). A feature is a
 * piece of the model with the spacing h_k it needs, a point or a segment:
 *   - PM_FEATURE_CURVES, short curves: a curve of length L carries h = L / n with n = 1 for an
 *     open curve, at least 3 for a closed one, and at least its turning angle / (pi/4);
 *   - PM_FEATURE_WIDTH, narrow faces: along every boundary curve of a face, the distance w to
 *     the other boundary curves of the face (the width of a strip, of the material between a hole
 *     and an edge) gives h = w, so that a strip gets near-equilateral triangles across instead of
 *     needles. Two curves that meet at a vertex form a corner: their distance counts only where
 *     it is below sin(15 deg) times the distance to the vertex (the corner is narrower than 15
 *     degrees there: a wedge or a cusp), so that an ordinary corner is not refined while a sharp
 *     wedge is, down to its tip. The width is read at the midpoints of the curves' polylines,
 *     and, where it is below a polyline segment's length and a chord on either side strays from
 *     its curve by more than a tenth of it (a curved strip, a circle passing close to an edge),
 *     on the curve itself at pieces as long as the width (at most 64 per segment), against the
 *     nearest other curve itself;
 *   - PM_FEATURE_CURVATURE, curved faces: h = (pi/4) / |kmax| (8 edges per turn of the largest
 *     principal curvature), at least a tenth of the face's smaller extent.
 * A feature that would ask for less than half of PM_FEATURE_FLOOR (geom.h) times the model's
 * diagonal is left out: the mesh does not resolve the model below that floor, and a needle there
 * is counted as forced. One between half the floor and the floor asks for the floor (its width is
 * sampled: a strip that tapers through the floor must not lose its features where a sample reads
 * just below it).
 *
 * Evaluation is a branch-and-bound search in a bounding-volume hierarchy of the features (a node
 * is skipped when h_min + g dist(x, box) cannot beat the best value found): exact,
 * deterministic, thread-safe, a few nodes visited per evaluation.
 */
#ifndef PM_SIZING_FEATURES_H
#define PM_SIZING_FEATURES_H

#include <packmesh/packmesh.h>

#include "common/geom/geom.h"
#include "common/sizing/sizing.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
  PM_FEATURE_CURVES = 1,
  PM_FEATURE_WIDTH = 2,
  PM_FEATURE_CURVATURE = 4,
  PM_FEATURE_ALL = 7
};

typedef struct pm_feature_size pm_feature_size;

/* Build the features of `kinds` of model m (borrowed; it must outlive the result).
 * d0 > 0 (INFINITY: none), grade in (0, 10]. Errors: PM_ERR_ARG, PM_ERR_NOMEM. */
pm_status pm_feature_size_create(const pm_model *m, double d0, double grade, unsigned kinds,
                                 pm_feature_size **out, pm_error *err);

/* f(xyz) as above. Thread-safe. */
double pm_feature_size_eval(const pm_feature_size *fs, const double xyz[3]);

/* The number of features (for descriptions and tests). */
int32_t pm_feature_size_count(const pm_feature_size *fs);

/* Release. Accepts NULL. */
void pm_feature_size_destroy(pm_feature_size *fs);

/* A size field: min(base(x), f(x)), where base may be NULL (then f alone, with its d0). The
 * field owns fs (it is destroyed with the field) and holds a reference to base. The text
 * describes both ("0.1, capped at 12 features of the model"). */
pm_status pm_sizing_features(const pm_sizing *base, pm_feature_size *fs, pm_sizing **out,
                             pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_SIZING_FEATURES_H */
