/* Built-in analytic geometry: planar domains bounded by line segments and circular arcs, with
 * holes (the 2D test domains of papers/004 section 3 and papers/003 eq. 17).
 *
 * A domain is a list of closed loops in the plane z = 0; the first loop is the outer boundary,
 * the others are holes. A loop is a chain of pieces; each piece starts at its `start` point and
 * ends where the next piece of the loop starts (the last piece ends at the first one's start).
 * A loop of one arc piece is a full circle.
 *
 * The model has one vertex per piece start, one curve per piece (parametrized by arc length, so
 * |C'| = 1), and one face S(u, v) = (u, v, 0), so that (u, v) = (x, y): the parameter
 * displacement of geom.h is then the identity, as it should be in the plane.
 */
#ifndef PM_GEOM_ANALYTIC_H
#define PM_GEOM_ANALYTIC_H

#include "common/geom/geom.h"

typedef enum pm_piece_kind { PM_PIECE_LINE = 0, PM_PIECE_ARC = 1 } pm_piece_kind;

typedef struct pm_planar_piece {
  pm_piece_kind kind;
  double start[2];  /* where the piece starts */
  double centre[2]; /* arcs: the circle's centre (the start and the end must be equidistant) */
  int ccw;          /* arcs: 1 to run counter-clockwise from start to end, 0 clockwise */
} pm_planar_piece;

typedef struct pm_planar_loop {
  int32_t n;
  const pm_planar_piece *piece; /* [n], borrowed */
} pm_planar_loop;

/* Build the model. Loops must have a positive extent, arcs consistent radii, lines a positive
 * length; violations are PM_ERR_ARG with the loop and piece named. The model is named `name`. */
pm_status pm_planar_model(const char *name, int32_t nloop, const pm_planar_loop *loops,
                          pm_model **out, pm_error *err);

#endif /* PM_GEOM_ANALYTIC_H */
