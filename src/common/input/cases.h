/* The built-in cases (DESIGN.md, "Built-in cases"): named models with a default size field,
 * needing no file. Planar domains come from geom_analytic (papers/004 section 3, papers/003
 * eq. 17); solids and surfaces are built in-process with gmsh's OpenCASCADE kernel (geom_cad).
 */
#ifndef PM_CASES_H
#define PM_CASES_H

#include "common/geom/geom.h"
#include "common/sizing/sizing.h"

typedef struct pm_case_info {
  const char *name;        /* what `case:NAME` names */
  int dim;                 /* 2: planar domain; 3: a solid or surface model */
  const char *description; /* one line */
  const char *size;        /* default edge length: a NUMBER or an EXPR in x, y, z, r */
  const char *source;      /* where the case comes from */
} pm_case_info;

/* The table of cases, the planar ones first; *n (may be NULL) receives its length. Static
 * storage. */
const pm_case_info *pm_cases(int *n);

/* The case named `name` (without the "case:" prefix), or NULL. */
const pm_case_info *pm_case_find(const char *name);

/* Build the case's model, named "case:NAME", and, when size is not NULL, its default size field.
 * The solids:
 *   sphere       radius 1 at the origin: 2 vertices, 3 curves (a seam and two pole curves),
 *                1 face, 1 volume;
 *   torus        R = 1, r = 0.35 about the z axis: 1 vertex, 2 seam curves, 1 face, 1 volume;
 *   cylinder     radius 0.5, height 2 (z from -1 to 1), solid: 2 vertices, 3 curves, 3 faces,
 *                1 volume;
 *   boxhole      box [-1,1] x [-0.5,0.5] x [-0.3,0.3] minus a cylinder of radius 0.25 along z
 *                through its centre: 10 vertices, 15 curves, 7 faces, 1 volume;
 *   nonmanifold  the unit cube [0,1]^3 with an internal triangle (0,0,0), (0,0,1), (0.5,0.5,0.5)
 *                hanging from the cube edge x = y = 0 and a dangling segment from (0.5,0.5,0.5) to
 *                (0.8,0.6,0.5), fragmented so that the topology is shared: 10 vertices, 15 curves,
 *                7 faces, 1 volume; the triangle, the segment and its two vertices are embedded in
 *                the volume. (papers/003 Fig. 11 shows 7 vertices, 9 edges, 5 faces and 1 volume
 *                for its own non-manifold example; the counts differ because the cube has 8
 *                corners, 12 edges and 6 faces.)
 * An unknown name is PM_ERR_ARG listing the known ones. */
pm_status pm_case_open(const char *name, pm_model **model, pm_sizing **size, pm_error *err);

#endif /* PM_CASES_H */
