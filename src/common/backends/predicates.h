/* Exact geometric predicates, from CGAL's Exact_predicates_inexact_constructions_kernel
 * (filtered: a floating-point evaluation with a certified error bound, falling back to exact
 * arithmetic only when the sign is in doubt). Every decision that fixes topology (orientation,
 * in-circle, point in a trimming loop, edge flips) goes through these, never through a bare
 * floating-point sign test.
 *
 * Each returns the sign as -1, 0 or +1.
 */
#ifndef PM_PREDICATES_H
#define PM_PREDICATES_H

#ifdef __cplusplus
extern "C" {
#endif

/* +1 when a, b, c turn counter-clockwise, -1 clockwise, 0 collinear. */
int pm_orient2d(const double a[2], const double b[2], const double c[2]);

/* +1 when d lies inside the circle through a, b, c (counter-clockwise), -1 outside, 0 on it.
 * For clockwise a, b, c the sign is reversed (as for Shewchuk's incircle). */
int pm_incircle(const double a[2], const double b[2], const double c[2], const double d[2]);

/* +1 when d lies on the positive side of the plane through a, b, c, i.e. when
 * ((b - a) x (c - a)) . (d - a) > 0 (a positive tet (a, b, c, d)); -1 on the other side; 0 coplanar. */
int pm_orient3d(const double a[3], const double b[3], const double c[3], const double d[3]);

/* +1 when e lies inside the sphere through a, b, c, d, for a positive tet (a, b, c, d) (reversed
 * for a negative one), -1 outside, 0 on it. */
int pm_insphere(const double a[3], const double b[3], const double c[3], const double d[3],
                const double e[3]);

#ifdef __cplusplus
}
#endif

#endif /* PM_PREDICATES_H */
