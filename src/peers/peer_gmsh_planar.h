/* A planar analytic domain (geom_analytic.h) rebuilt as a gmsh OpenCASCADE geometry, so that
 * gmsh's surface algorithms mesh the same domain our methods see, with gmsh's points, curves and
 * surface in one-to-one correspondence with the model's vertices, curves and face. Internal to
 * src/peers.
 */
#ifndef PM_PEER_GMSH_PLANAR_H
#define PM_PEER_GMSH_PLANAR_H

#include <packmesh/packmesh.h>

#include "common/geom/geom.h"
#include "peers/peer_common.h"

/* Build m's geometry in gmsh's current model, which must be empty (a fresh model made current
 * by a gmsh_session scope, whose lock the caller holds), synchronize it, and fill `map` with the
 * cell of every gmsh point, curve and surface.
 *   segments      OpenCASCADE lines between the shared end points;
 *   arcs < 162 deg  circle arcs (gmshModelOccAddCircleArc takes the shorter arc, which is ours);
 *   longer arcs   rational quadratic B-splines of at most 90 degrees per span (an exact circle:
 *                 the middle control point of a span of angle phi lies at R / cos(phi/2) on the
 *                 bisector, with weight cos(phi/2)), between the shared end points;
 *   full circles  gmshModelOccAddCircle from the model's start angle, so its one vertex is ours;
 *   the face      a plane surface of the loops, outer loop first.
 * The correspondence is verified, not assumed: the entity counts must equal the model's, every
 * gmsh point must sit on a distinct model vertex and every gmsh curve's end points and middle
 * must lie on a distinct model curve with those end vertices (within 1e-9 of the diagonal);
 * otherwise PM_ERR_BACKEND names the entity. m must satisfy peer_is_planar_domain. */
pm_status peer_gmsh_build_planar(const pm_model *m, peer_tagmap *map, pm_error *err);

#endif /* PM_PEER_GMSH_PLANAR_H */
