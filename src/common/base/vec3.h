/* Small inline 3-vector helpers (double[3]). */
#ifndef PM_VEC3_H
#define PM_VEC3_H

#include <math.h>

/* The largest coordinate magnitude packmesh takes from a file (a mesh file or a case file).
 * The measures square edge lengths and multiply up to three of them (a tet's volume, its
 * circumradius formula): at 1e30 the largest product, about 1e180, is far from the 1.8e308 at
 * which a double overflows, while at 1e308 a single squared length is already infinite. No
 * physical model needs more: 1e30 metres is a thousand times the observable universe. */
#define PM_COORD_MAX 1e30

static inline void pm_v3_copy(double r[3], const double a[3]) { r[0] = a[0], r[1] = a[1], r[2] = a[2]; }
static inline void pm_v3_zero(double r[3]) { r[0] = r[1] = r[2] = 0; }
static inline void pm_v3_set(double r[3], double x, double y, double z) { r[0] = x, r[1] = y, r[2] = z; }
static inline void pm_v3_add(double r[3], const double a[3], const double b[3]) {
  r[0] = a[0] + b[0], r[1] = a[1] + b[1], r[2] = a[2] + b[2];
}
static inline void pm_v3_sub(double r[3], const double a[3], const double b[3]) {
  r[0] = a[0] - b[0], r[1] = a[1] - b[1], r[2] = a[2] - b[2];
}
static inline void pm_v3_scale(double r[3], const double a[3], double s) {
  r[0] = a[0] * s, r[1] = a[1] * s, r[2] = a[2] * s;
}
/* r = a + s b */
static inline void pm_v3_axpy(double r[3], const double a[3], double s, const double b[3]) {
  r[0] = a[0] + s * b[0], r[1] = a[1] + s * b[1], r[2] = a[2] + s * b[2];
}
static inline double pm_v3_dot(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void pm_v3_cross(double r[3], const double a[3], const double b[3]) {
  double x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
  r[0] = x, r[1] = y, r[2] = z;
}
static inline double pm_v3_norm(const double a[3]) { return sqrt(pm_v3_dot(a, a)); }
static inline double pm_v3_dist2(const double a[3], const double b[3]) {
  double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  return pm_v3_dot(d, d);
}
static inline double pm_v3_dist(const double a[3], const double b[3]) { return sqrt(pm_v3_dist2(a, b)); }
/* Distance from p to the axis-aligned box (xmin, ymin, zmin, xmax, ymax, zmax); 0 inside. */
static inline double pm_v3_box_dist(const double p[3], const double box[6]) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    double e = p[k] < box[k] ? box[k] - p[k] : (p[k] > box[k + 3] ? p[k] - box[k + 3] : 0);
    s += e * e;
  }
  return sqrt(s);
}
/* Normalize in place; returns the former length (0 leaves a zero vector). */
static inline double pm_v3_normalize(double a[3]) {
  double n = pm_v3_norm(a);
  if (n > 0) a[0] /= n, a[1] /= n, a[2] /= n;
  return n;
}

#endif /* PM_VEC3_H */
