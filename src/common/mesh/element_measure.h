/* The shape measures of one triangle or tetrahedron: what the quality module (measure/quality.h)
 * summarizes over a mesh, what the checker uses to find flat and inverted elements, and what the
 * mesh files carry per element for colouring in ParaView and gmsh.
 *
 * Per triangle (papers/004 section 2.5 for q; papers/001 Fig. 11 for R / l_min):
 *   radius ratio  q = 2 r_in / R            1 for an equilateral triangle, 0 when flat
 *   aspect ratio  R / l_min                 1/sqrt(3) = 0.577 for an equilateral triangle
 *   min and max angle, in degrees
 * Per tetrahedron:
 *   radius ratio  q = 3 r_in / R            1 for a regular tet, 0 when flat
 *   aspect ratio  R / l_min                 sqrt(6)/4 = 0.612 for a regular tet
 *   min and max dihedral angle, in degrees  acos(1/3) = 70.53 for a regular tet
 * (r_in: inscribed radius, R: circumscribed radius, l_min: shortest edge.)
 *
 * Degenerate elements: a triangle is degenerate when twice its area is at most
 * PM_DEGENERATE_REL l_max^2 (its height is below 1e-12 of its longest edge), a tet when six times
 * its volume is at most PM_DEGENERATE_REL l_max^3. A degenerate element gets radius ratio 0,
 * aspect ratio PM_QUALITY_HUGE, min angle 0 and max angle 180 (the limits of a flattened
 * element), r/R = 0 in eps_g, and is counted; no NaN or infinity ever reaches a summary.
 * Tet measures use |volume|: an inverted tet is measured by its shape (the checker of
 * mesh_check.h reports inversion).
 */
#ifndef PM_ELEMENT_MEASURE_H
#define PM_ELEMENT_MEASURE_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PM_DEGENERATE_REL 1e-12 /* flatness below which an element is degenerate (see above) */
#define PM_QUALITY_HUGE 1e100   /* the aspect ratio of a degenerate element: larger than any real
                                   one, and small enough that 2^31 of them still sum finitely */

typedef struct pm_tri_measure {
  double radius_ratio; /* 2 r_in / R */
  double aspect_ratio; /* R / l_min */
  double min_angle, max_angle; /* degrees */
  double area;
  double rr;           /* r_in / R, the ratio of papers/003 eq. 9 */
  int degenerate;
} pm_tri_measure;

typedef struct pm_tet_measure {
  double radius_ratio; /* 3 r_in / R */
  double aspect_ratio; /* R / l_min */
  double min_dihedral, max_dihedral; /* degrees */
  double volume;       /* signed: > 0 for a positive tet (mesh.h) */
  double rr;           /* r_in / R */
  int degenerate;
} pm_tet_measure;

void pm_tri_measure_eval(const double a[3], const double b[3], const double c[3],
                         pm_tri_measure *out);
/* Whether triangle (a, b, c) is degenerate (the test of pm_tri_measure_eval, without the
 * measures). */
int pm_tri_degenerate(const double a[3], const double b[3], const double c[3]);
void pm_tet_measure_eval(const double a[3], const double b[3], const double c[3],
                         const double d[3], pm_tet_measure *out);

/* The three measures the mesh files carry per element (mesh_io.h): radius ratio, aspect ratio
 * and smallest angle (a tet's smallest dihedral angle), the same values quality.h summarizes. */
enum { PM_ELEMENT_VALUES = 3 };
extern const char *const pm_element_value_names[PM_ELEMENT_VALUES]; /* "radius_ratio", ... */

typedef struct pm_element_values {
  double *tri[PM_ELEMENT_VALUES]; /* [ntri] each, in triangle order */
  double *tet[PM_ELEMENT_VALUES]; /* [ntet] each, in tet order */
} pm_element_values;

/* Measure every triangle and tet of m (element indices must be in range; the caller checks).
 * On success v owns its arrays (pm_element_values_clear); on failure v is left cleared. */
pm_status pm_element_values_compute(const pm_mesh *m, pm_element_values *v, pm_error *err);
void pm_element_values_clear(pm_element_values *v);

#ifdef __cplusplus
}
#endif

#endif /* PM_ELEMENT_MEASURE_H */
