/* Checking a planar domain given as loops of pieces (a case file's "loops", geom_analytic.h)
 * before it is built: the faults that would otherwise surface later as a wrong mesh or as an
 * obscure message from the triangulation are named here, with the loop and piece.
 *
 * The domain must be: pieces of positive length (a line that ends where it starts, an arc of
 * radius 0 or whose end is not on its circle are refused); finite coordinates within
 * +-PM_COORD_MAX; at most PM_PLANAR_MAX_PIECES pieces; each loop enclosing an area (not all on
 * one line) and simple (no piece crossing, touching or running along another of its loop
 * beyond the vertex two consecutive pieces share); loops pairwise apart (neither crossing nor
 * touching, not even at a single point); every hole (loops 1, 2, ...) inside the outer loop
 * (loop 0), and no hole inside another. Loops may run either way round.
 *
 * Distances are judged with the tolerance pm_planar_model uses, 1e-9 times the domain's extent
 * (a hole that comes closer than that to the outer loop touches it); orientation decisions
 * between lines use exact predicates (predicates.h).
 */
#ifndef PM_PLANAR_CHECK_H
#define PM_PLANAR_CHECK_H

#include "common/geom/geom_analytic.h"

/* More pieces than a case file may hold: the pairwise checks stay well under a second. */
#define PM_PLANAR_MAX_PIECES 20000

/* PM_OK, or PM_ERR_ARG with one line naming the fault, its loop and piece (numbered from 0, as
 * in the file) and, for crossings and contacts, the point. */
pm_status pm_planar_check(int32_t nloop, const pm_planar_loop *loops, pm_error *err);

#endif /* PM_PLANAR_CHECK_H */
