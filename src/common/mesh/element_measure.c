/* Element measures (element_measure.h). */
#include "common/mesh/element_measure.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RAD2DEG 57.295779513082320876798154814105


static inline void sub3(const double a[3], const double b[3], double o[3]) {
  o[0] = a[0] - b[0];
  o[1] = a[1] - b[1];
  o[2] = a[2] - b[2];
}
static inline double dot3(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void cross3(const double a[3], const double b[3], double o[3]) {
  o[0] = a[1] * b[2] - a[2] * b[1];
  o[1] = a[2] * b[0] - a[0] * b[2];
  o[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double norm3(const double a[3]) { return sqrt(dot3(a, a)); }

/* The angle between u and w in degrees, as atan2(|u x w|, u . w): accurate near 0 and 180
 * degrees, where acos of the normalized dot product loses half the digits. */
static double angle_deg(const double u[3], const double w[3]) {
  double c[3];
  cross3(u, w, c);
  return atan2(norm3(c), dot3(u, w)) * RAD2DEG;
}

/* ---- single elements ---------------------------------------------------------------------- */

/* Twice the area of triangle (a, b, c), and its edge lengths l[0..2] opposite a, b, c: the cross
 * product at the vertex opposite the longest edge, whose two edges are the shortest, which keeps
 * cancellation smallest for thin triangles. */
static double tri_area2(const double a[3], const double b[3], const double c[3], double l[3]) {
  double ab[3], bc[3], ca[3];
  sub3(b, a, ab);
  sub3(c, b, bc);
  sub3(a, c, ca);
  l[0] = norm3(bc), l[1] = norm3(ca), l[2] = norm3(ab);
  double u[3], w[3], x[3];
  if (l[0] >= l[1] && l[0] >= l[2]) {
    sub3(b, a, u);
    sub3(c, a, w);
  } else if (l[1] >= l[2]) {
    sub3(c, b, u);
    sub3(a, b, w);
  } else {
    sub3(a, c, u);
    sub3(b, c, w);
  }
  cross3(u, w, x);
  return norm3(x);
}

/* Written as !(a > b) so that NaN coordinates also count as degenerate. */
static int flat(double a2, double lmax) {
  return !(a2 > PM_DEGENERATE_REL * lmax * lmax) || !isfinite(a2);
}

int pm_tri_degenerate(const double a[3], const double b[3], const double c[3]) {
  double l[3];
  double a2 = tri_area2(a, b, c, l);
  return flat(a2, fmax(l[0], fmax(l[1], l[2])));
}

void pm_tri_measure_eval(const double a[3], const double b[3], const double c[3],
                         pm_tri_measure *out) {
  double l[3];
  double a2 = tri_area2(a, b, c, l);
  double la = l[0], lb = l[1], lc = l[2]; /* opposite a, b, c */
  double lmin = fmin(la, fmin(lb, lc)), lmax = fmax(la, fmax(lb, lc));
  out->area = isfinite(a2) ? 0.5 * a2 : 0.0;
  if (flat(a2, lmax)) {
    out->degenerate = 1;
    out->radius_ratio = 0.0;
    out->rr = 0.0;
    out->aspect_ratio = PM_QUALITY_HUGE;
    out->min_angle = 0.0;
    out->max_angle = 180.0;
    return;
  }
  out->degenerate = 0;
  double abc = la * lb * lc;
  /* q = 2 r / R with r = A / s (s the half perimeter) and R = abc / (4 A):
   * q = 8 A^2 / (s abc) = 4 (2A)^2 / ((a + b + c) abc), papers/004 section 2.5. */
  out->radius_ratio = 4.0 * a2 * a2 / ((la + lb + lc) * abc);
  out->rr = 0.5 * out->radius_ratio;
  double R = abc / (2.0 * a2);
  out->aspect_ratio = fmin(R / lmin, PM_QUALITY_HUGE);
  /* The smallest angle faces the shortest edge and the largest the longest one; both are
   * atan2(2A, dot) at their vertex (|cross| = 2A at every vertex), so two atan2 calls suffice. */
  double e1[3], e2[3];
  const double *pv[3] = {a, b, c};
  const double lv[3] = {la, lb, lc};
  int imin = 0, imax = 0;
  for (int k = 1; k < 3; ++k) {
    if (lv[k] < lv[imin]) imin = k;
    if (lv[k] > lv[imax]) imax = k;
  }
  if (imin == imax) imax = (imin + 1) % 3; /* equilateral: any two vertices */
  sub3(pv[(imin + 1) % 3], pv[imin], e1);
  sub3(pv[(imin + 2) % 3], pv[imin], e2);
  out->min_angle = atan2(a2, dot3(e1, e2)) * RAD2DEG;
  sub3(pv[(imax + 1) % 3], pv[imax], e1);
  sub3(pv[(imax + 2) % 3], pv[imax], e2);
  out->max_angle = atan2(a2, dot3(e1, e2)) * RAD2DEG;
  if (out->min_angle > out->max_angle) { /* ties broken the other way round */
    double t = out->min_angle;
    out->min_angle = out->max_angle;
    out->max_angle = t;
  }
}

void pm_tet_measure_eval(const double a[3], const double b[3], const double c[3],
                         const double d[3], pm_tet_measure *out) {
  const double *p[4] = {a, b, c, d};
  static const int edge[6][4] = {/* i, j, then the other two */
                                 {0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                 {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  double lmin = INFINITY, lmax = 0.0;
  for (int k = 0; k < 6; ++k) {
    double e[3];
    sub3(p[edge[k][1]], p[edge[k][0]], e);
    double l = norm3(e);
    lmin = fmin(lmin, l);
    lmax = fmax(lmax, l);
  }
  double u[3], v[3], w[3], vw[3], wu[3], uv[3];
  sub3(b, a, u);
  sub3(c, a, v);
  sub3(d, a, w);
  cross3(v, w, vw);
  cross3(w, u, wu);
  cross3(u, v, uv);
  double vol6 = dot3(u, vw);
  out->volume = isfinite(vol6) ? vol6 / 6.0 : 0.0;
  if (!(fabs(vol6) > PM_DEGENERATE_REL * lmax * lmax * lmax) || !isfinite(vol6)) {
    out->degenerate = 1;
    out->radius_ratio = 0.0;
    out->rr = 0.0;
    out->aspect_ratio = PM_QUALITY_HUGE;
    out->min_dihedral = 0.0;
    out->max_dihedral = 180.0;
    return;
  }
  out->degenerate = 0;
  /* Sum of the face areas: faces (a,b,c), (a,b,d), (a,c,d) from the cross products above,
   * (b,c,d) from its own. */
  double bc[3], bd[3], x[3];
  sub3(c, b, bc);
  sub3(d, b, bd);
  cross3(bc, bd, x);
  double area = 0.5 * (norm3(uv) + norm3(wu) + norm3(vw) + norm3(x));
  /* r_in = 3 V / area; circumcentre - a = (|u|^2 (v x w) + |v|^2 (w x u) + |w|^2 (u x v)) / (2 u.(v x w)). */
  double r = 0.5 * fabs(vol6) / area;
  double uu = dot3(u, u), vv = dot3(v, v), ww = dot3(w, w), o[3];
  for (int k = 0; k < 3; ++k) o[k] = (uu * vw[k] + vv * wu[k] + ww * uv[k]) / (2.0 * vol6);
  double R = norm3(o);
  out->rr = r / R;
  out->radius_ratio = 3.0 * r / R;
  out->aspect_ratio = fmin(R / lmin, PM_QUALITY_HUGE);
  /* The dihedral angle along edge (i, j) is the angle between the normals e x (p_k - p_i) and
   * e x (p_l - p_i) of its two faces: both are the components of p_k - p_i and p_l - p_i across
   * e, turned by the same quarter turn about e. */
  double dmin = 180.0, dmax = 0.0;
  for (int k = 0; k < 6; ++k) {
    const double *pi = p[edge[k][0]];
    double e[3], vk[3], vl[3], n1[3], n2[3];
    sub3(p[edge[k][1]], pi, e);
    sub3(p[edge[k][2]], pi, vk);
    sub3(p[edge[k][3]], pi, vl);
    cross3(e, vk, n1);
    cross3(e, vl, n2);
    double ang = angle_deg(n1, n2);
    dmin = fmin(dmin, ang);
    dmax = fmax(dmax, ang);
  }
  out->min_dihedral = dmin;
  out->max_dihedral = dmax;
}

/* ---- every element of a mesh -------------------------------------------------------------- */

const char *const pm_element_value_names[PM_ELEMENT_VALUES] = {"radius_ratio", "aspect_ratio",
                                                                "min_angle_deg"};

void pm_element_values_clear(pm_element_values *v) {
  for (int a = 0; a < PM_ELEMENT_VALUES; ++a) {
    free(v->tri[a]);
    free(v->tet[a]);
  }
  memset(v, 0, sizeof *v);
}

pm_status pm_element_values_compute(const pm_mesh *m, pm_element_values *v, pm_error *err) {
  memset(v, 0, sizeof *v);
  int ok = 1;
  for (int a = 0; a < PM_ELEMENT_VALUES; ++a) {
    v->tri[a] = malloc(((size_t)m->ntri + 1) * sizeof(double));
    v->tet[a] = malloc(((size_t)m->ntet + 1) * sizeof(double));
    ok = ok && v->tri[a] && v->tet[a];
  }
  if (!ok) {
    pm_element_values_clear(v);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring elements");
  }
  /* Each element writes its own slots: the values do not depend on the thread count. */
#pragma omp parallel for schedule(static)
  for (int32_t t = 0; t < m->ntri; ++t) {
    const int32_t *c = m->tri + 3 * (size_t)t;
    pm_tri_measure me;
    pm_tri_measure_eval(m->xyz + 3 * (size_t)c[0], m->xyz + 3 * (size_t)c[1],
                        m->xyz + 3 * (size_t)c[2], &me);
    v->tri[0][t] = me.radius_ratio;
    v->tri[1][t] = me.aspect_ratio;
    v->tri[2][t] = me.min_angle;
  }
#pragma omp parallel for schedule(static)
  for (int32_t t = 0; t < m->ntet; ++t) {
    const int32_t *c = m->tet + 4 * (size_t)t;
    pm_tet_measure me;
    pm_tet_measure_eval(m->xyz + 3 * (size_t)c[0], m->xyz + 3 * (size_t)c[1],
                        m->xyz + 3 * (size_t)c[2], m->xyz + 3 * (size_t)c[3], &me);
    v->tet[0][t] = me.radius_ratio;
    v->tet[1][t] = me.aspect_ratio;
    v->tet[2][t] = me.min_dihedral;
  }
  return PM_OK;
}
