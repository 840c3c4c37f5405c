// Exact predicates through CGAL (see predicates.h). C++ only behind the extern "C" header.
#include "common/backends/predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P2 = K::Point_2;
using P3 = K::Point_3;

inline P2 p2(const double *a) { return P2(a[0], a[1]); }
inline P3 p3(const double *a) { return P3(a[0], a[1], a[2]); }

// CGAL::Sign and CGAL::Oriented_side both map to -1, 0, +1.
template <class S> inline int sign_of(S s) { return static_cast<int>(s); }
}  // namespace

extern "C" int pm_orient2d(const double a[2], const double b[2], const double c[2]) {
  return sign_of(CGAL::orientation(p2(a), p2(b), p2(c)));
}

extern "C" int pm_incircle(const double a[2], const double b[2], const double c[2],
                           const double d[2]) {
  // side_of_oriented_circle: positive inside for a counter-clockwise circle, reversed for a
  // clockwise one -- the convention of Shewchuk's incircle.
  return sign_of(CGAL::side_of_oriented_circle(p2(a), p2(b), p2(c), p2(d)));
}

extern "C" int pm_orient3d(const double a[3], const double b[3], const double c[3],
                           const double d[3]) {
  // CGAL::orientation(a, b, c, d) is POSITIVE when d is on the positive side of the plane
  // through a, b, c whose normal is (b - a) x (c - a).
  return sign_of(CGAL::orientation(p3(a), p3(b), p3(c), p3(d)));
}

extern "C" int pm_insphere(const double a[3], const double b[3], const double c[3],
                           const double d[3], const double e[3]) {
  return sign_of(CGAL::side_of_oriented_sphere(p3(a), p3(b), p3(c), p3(d), p3(e)));
}
