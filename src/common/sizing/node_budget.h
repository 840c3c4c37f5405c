/* The node count a size field asks for, estimated before any method grows a mesh, so that a
 * field beyond a run's cap (the node budget --max-nodes, a method's own cap such as bubble's
 * max_bubbles) is refused at once, naming the cap and the count the field would need, instead of
 * being found out after minutes of growth and gigabytes of memory. Every method calls
 * pm_node_budget_check before it places or splits anything.
 */
#ifndef PM_NODE_BUDGET_H
#define PM_NODE_BUDGET_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/sizing/sizing.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Estimated node count of a surface mesh of m under field s: the integral over every face of
 * dA / (sqrt(3)/2 d^2) (the area per node of a lattice of equilateral triangles of edge d), by
 * the midpoint rule on each face's parameter box: a 16 x 16 grid of cells, a cell split in four
 * while the field is finer than the cell (d at its centre below the cell's extent in space), 14
 * times at most, cells whose centre lies outside the trimming loops left out. Boundary effects
 * make real meshes some 5-20% larger. The integration stops once the sum exceeds `stop` (a field
 * that tends to 0 somewhere would otherwise run on). A value of d that is not finite and > 0 at
 * a sample inside a face is PM_ERR_ARG naming the point. */
pm_status pm_node_estimate_surface(const pm_model *m, const pm_sizing *s, double stop,
                                   double *estimate, pm_error *err);

/* Refuse a run the field makes hopeless before the method spends its time and memory on it:
 * PM_ERR_LIMIT when the estimate exceeds 1.5 x cap (the mesh would exceed the cap for certain;
 * between 1 and 1.5 x cap the method's own count check decides), naming `cap_name` ("node cap",
 * "cap max_bubbles"), the cap and the estimate ("about N", or "more than N" when the integration
 * stopped early: at 1.5 x cap, and not before 1e5 nodes); PM_ERR_ARG for a field that is not > 0
 * inside a face. Messages start with `method`. cap <= 0 checks the field only. */
pm_status pm_node_budget_check(const pm_model *m, const pm_sizing *s, int64_t cap,
                               const char *cap_name, const char *method, pm_error *err);

/* Estimated count of the nodes inside the volumes of m under field s, given the surface mesh
 * that bounds them (triangles tagged with face indices and oriented as connect.h leaves them:
 * volume_inside.h decides what is inside): the integral over every volume of
 * dV / (d^3 / sqrt(2)) (the volume per node of a face-centred cubic lattice of edge d), by the
 * midpoint rule on each volume's bounding box: an 8 x 8 x 8 grid of cells, a cell split in eight
 * while the field is finer than the cell, 10 times at most, cells whose centre lies outside left
 * out (a cell clear of the shell needs no further inside test). Stops once the sum exceeds
 * `stop`. A volume with no boundary triangle is skipped. A value of d that is not finite and > 0
 * at a sample inside is PM_ERR_ARG naming the point. */
pm_status pm_node_estimate_volume(const pm_model *m, const pm_mesh *surface, const pm_sizing *s,
                                  double stop, double *estimate, pm_error *err);

/* pm_node_budget_check for a volume mesh about to be grown from `surface`: its nodes plus the
 * volume estimate against 1.5 x cap. Called between a surface mesh and its volume mesh, so that
 * a field that is fine on the surfaces but far too fine inside is refused before the volume
 * mesher runs. */
pm_status pm_node_budget_check_volume(const pm_model *m, const pm_mesh *surface,
                                      const pm_sizing *s, int64_t cap, const char *cap_name,
                                      const char *method, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_NODE_BUDGET_H */
