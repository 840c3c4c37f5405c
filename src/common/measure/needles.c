/* Needles and whether the model forces them (see needles.h). */
#include "common/measure/needles.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/measure/quality.h"
#include "common/base/vec3.h"

/* The part of v in the plane normal to the unit vector n. */
static void tangential(double out[3], const double v[3], const double n[3]) {
  pm_v3_axpy(out, v, -pm_v3_dot(v, n), n);
}

/* Oriented angle from a to b about the unit normal n, in [0, 2 pi). */
static double angle_about(const double a[3], const double b[3], const double n[3]) {
  double c[3];
  pm_v3_cross(c, a, b);
  double t = atan2(pm_v3_dot(c, n), pm_v3_dot(a, b));
  return t < 0 ? t + 2 * M_PI : t;
}

/* The point of curve c at distance L (in space) from its end `end` (0: t = lo, 1: t = hi), or
 * its other end when the curve is shorter: bisection on t after a march in 16 steps (a curve
 * may come back towards its start, the first crossing of L is taken). */
static void point_at_distance(const pm_cell *c, int end, double L, double out[3]) {
  pm_curve_point p0, p;
  double t0 = end ? c->hi[0] : c->lo[0], t1 = end ? c->lo[0] : c->hi[0];
  pm_curve_eval(c, t0, 0, &p0);
  double a = t0, b = t1;
  int found = 0;
  for (int i = 1; i <= 16 && !found; ++i) {
    double t = t0 + (t1 - t0) * i / 16;
    pm_curve_eval(c, t, 0, &p);
    if (pm_v3_dist(p.p, p0.p) >= L) b = t, found = 1;
    else a = t;
  }
  if (!found) {
    pm_curve_eval(c, t1, 0, &p);
    pm_v3_copy(out, p.p);
    return;
  }
  for (int i = 0; i < 40; ++i) {
    double t = 0.5 * (a + b);
    pm_curve_eval(c, t, 0, &p);
    if (pm_v3_dist(p.p, p0.p) >= L) b = t;
    else a = t;
  }
  pm_curve_eval(c, b, 0, &p);
  pm_v3_copy(out, p.p);
}

/* |Su| below this share of |Sv|, or the reverse: the parametrization collapses there. */
#define POLE_RATIO 1e-6

/* A boundary curve leaving a vertex, seen from the vertex. */
typedef struct ray {
  double angle;  /* about the normal, from the first ray */
  int outgoing;  /* the loop leaves the vertex along it (the face is on its left) */
} ray;

static int ray_cmp(const void *a, const void *b) {
  double x = ((const ray *)a)->angle, y = ((const ray *)b)->angle;
  return (x > y) - (x < y);
}

/* The corner of face f at vertex v that a triangle with corner P at v and other corners Q, R
 * lies in, measured at the triangle's scale: the boundary curves of f that end at v (seams and
 * poles left out: they are no boundary in space) are seen as rays from v to their points at the
 * triangle's size, projected onto the tangent plane; sorted round the normal they cut the plane
 * into wedges, and a wedge is inside the face when the ray that opens it (counter-clockwise) is
 * one the loop leaves along (the trimmed region lies to the left of its loops: trim.c).
 * Measuring at the triangle's scale rather than by tangents tells a cusp between two tangent
 * curves (angle 0 at the vertex: robust/brep__test_11551.brep) from a smooth junction.
 * Returns the angle of the inside wedge holding the triangle, or -1 (no corner there: fewer
 * than two rays, a pole, the triangle in an outside wedge). */
static double corner_angle_at(const pm_cell *f, int32_t v, const double P[3], const double Q[3],
                              const double R[3], double sliver) {
  const pm_model *m = f->model;
  double L = 0.5 * (pm_v3_dist(P, Q) + pm_v3_dist(P, R));
  if (!(L > 0)) return -1;
  /* The normal: from the face at v's position (the foot of P). Where v is the image of a side
   * of the (u, v) box that collapses to a point (|Sv| ~ 0 against |Su|: the tip of a lens-shaped
   * face, robust/step__U_Joint_2.stp), Su x Sv there points wherever round-off sends it, and
   * the normal is taken at the foot of the triangle's centroid instead, inside the face. */
  double uv[2], foot[3];
  if (pm_cell_project(f, P, NULL, uv, foot, NULL, NULL) != PM_OK) return -1;
  pm_face_point fp;
  pm_face_eval(f, uv, 1, &fp);
  const double lu = pm_v3_norm(fp.su), lv = pm_v3_norm(fp.sv);
  if (!(lu > POLE_RATIO * lv && lv > POLE_RATIO * lu)) {
    double g[3];
    for (int k = 0; k < 3; ++k) g[k] = (P[k] + Q[k] + R[k]) / 3;
    if (pm_cell_project(f, g, uv, uv, foot, NULL, NULL) != PM_OK) return -1;
    pm_face_eval(f, uv, 1, &fp);
  }
  double n[3];
  pm_v3_cross(n, fp.su, fp.sv);
  double nn = pm_v3_norm(n);
  if (!(nn > 1e-12 * pm_v3_norm(fp.su) * pm_v3_norm(fp.sv))) return -1;
  pm_v3_scale(n, n, 1.0 / nn);
  ray rays[64];
  double first[3] = {0, 0, 0};
  int nr = 0;
  for (int32_t l = 0; l < f->nloop; ++l)
    for (int32_t k = 0; k < f->loop[l].nuse && nr < 62; ++k) {
      const pm_use *u = &f->loop[l].use[k];
      const pm_cell *c = &m->cells[PM_CURVE][u->cell];
      if (c->degenerate || c->nbound != 2) continue;
      int uses = 0;
      for (int32_t q = 0; q < f->nbound; ++q) uses += f->bound[q].cell == u->cell;
      if (uses > 1) continue; /* a seam */
      for (int end = 0; end < 2; ++end) {
        if (c->bound[end].cell != v) continue;
        double x[3], d[3], dt[3];
        point_at_distance(c, end, L, x);
        pm_v3_sub(d, x, P);
        tangential(dt, d, n);
        if (!(pm_v3_norm(dt) > 0)) continue;
        if (nr == 0) pm_v3_copy(first, dt);
        rays[nr].angle = nr == 0 ? 0 : angle_about(first, dt, n);
        /* The loop runs lo -> hi for sense +1: it leaves the lo end and arrives at the hi end. */
        rays[nr].outgoing = (end == 0) == (u->sense >= 0);
        ++nr;
      }
    }
  if (nr < 2) return -1;
  qsort(rays, (size_t)nr, sizeof(ray), ray_cmp);
  double e1[3], e2[3], d[3], dt[3];
  pm_v3_sub(e1, Q, P), pm_v3_sub(e2, R, P);
  pm_v3_scale(e1, e1, 1.0 / pm_v3_norm(e1)), pm_v3_scale(e2, e2, 1.0 / pm_v3_norm(e2));
  pm_v3_add(d, e1, e2);
  tangential(dt, d, n);
  if (!(pm_v3_norm(dt) > 0)) return -1;
  double phi = angle_about(first, dt, n);
  for (int i = 0; i < nr; ++i) {
    double a = rays[i].angle, b = i + 1 < nr ? rays[i + 1].angle : rays[0].angle + 2 * M_PI;
    double ph = phi < a ? phi + 2 * M_PI : phi;
    if (ph >= a && ph <= b) {
      if (rays[i].outgoing) return b - a;
      break;
    }
  }
  /* A triangle whose own angle at v is below `sliver` and overlaps an inside wedge below it
   * fills that corner, though its bisector may lie just outside: a triangle on nodes of one of
   * the corner's curves, in a cusp where the curve bows towards the other (the chords from v
   * to its nodes then lie outside the curve by less than the wedge is wide:
   * robust/step__U_Joint_2.stp, two curves tangent at their vertex, 0.14 degrees apart at
   * 0.2 from it). */
  double tq[3], tr[3];
  tangential(tq, e1, n), tangential(tr, e2, n);
  if (!(pm_v3_norm(tq) > 0 && pm_v3_norm(tr) > 0)) return -1;
  double lo = angle_about(first, tq, n), w = angle_about(tq, tr, n);
  if (w > M_PI) lo = angle_about(first, tr, n), w = 2 * M_PI - w;
  if (!(w < sliver)) return -1;
  for (int i = 0; i < nr; ++i) {
    double a = rays[i].angle, b = i + 1 < nr ? rays[i + 1].angle : rays[0].angle + 2 * M_PI;
    if (!rays[i].outgoing || !(b - a < sliver)) continue;
    double l = lo < a ? lo + 2 * M_PI : lo; /* the arc [l, l + w] against [a, b] */
    if (l < b || l + w > a + 2 * M_PI) return b - a;
  }
  return -1;
}

/* Node n (dimension d, cell c) lies on curve `curve` or on one of its end vertices. */
static int in_curve_closure(const pm_model *m, int32_t d, int32_t c, int32_t curve) {
  if (d == PM_CURVE) return c == curve;
  if (d != PM_VERTEX) return 0;
  const pm_cell *cc = &m->cells[PM_CURVE][curve];
  for (int32_t u = 0; u < cc->nbound; ++u)
    if (cc->bound[u].cell == c) return 1;
  return 0;
}

/* The feature rule by height: all three nodes on curves or vertices, not all on one curve and
 * its ends, and a node nearer than `floor` to the line through the other two -- the two model
 * cells it joins there are closer than the floor (a strip face that tapers below it: between
 * its two long curves there is no room for a face node at any spacing the CAD resolves).
 * The shortest-edge rule alone reads the same strip as forced or unforced by how the nodes on
 * its two sides happen to be staggered. */
static int below_floor_across_cells(const pm_mesh *mesh, const pm_model *m, const int32_t *v,
                                    const double *const P[3], double floor) {
  for (int j = 0; j < 3; ++j)
    if (mesh->node_dim[v[j]] < 0 || mesh->node_dim[v[j]] >= PM_FACE) return 0;
  for (int j = 0; j < 3; ++j)
    if (mesh->node_dim[v[j]] == PM_CURVE) {
      int all = 1;
      for (int k = 0; k < 3 && all; ++k)
        all = in_curve_closure(m, mesh->node_dim[v[k]], mesh->node_cell[v[k]], mesh->node_cell[v[j]]);
      if (all) return 0;
    }
  double e1[3], e2[3], n[3];
  pm_v3_sub(e1, P[1], P[0]);
  pm_v3_sub(e2, P[2], P[0]);
  pm_v3_cross(n, e1, e2);
  double twice_area = pm_v3_norm(n);
  for (int j = 0; j < 3; ++j) {
    int32_t p = v[j], q = v[(j + 1) % 3], r = v[(j + 2) % 3];
    int same = (mesh->node_dim[p] == mesh->node_dim[q] && mesh->node_cell[p] == mesh->node_cell[q]) ||
               (mesh->node_dim[p] == mesh->node_dim[r] && mesh->node_cell[p] == mesh->node_cell[r]);
    double base = pm_v3_dist(P[(j + 1) % 3], P[(j + 2) % 3]);
    if (!same && base > 0 && twice_area < floor * base) return 1;
  }
  return 0;
}

/* The distance from vertex `vert` to curve `curve`, -1 when the projection fails. */
static double vertex_gap(const pm_model *m, int32_t curve, int32_t vert) {
  double at[3], t, g;
  pm_cell_point(&m->cells[PM_VERTEX][vert], NULL, at);
  if (pm_cell_project(&m->cells[PM_CURVE][curve], at, NULL, &t, NULL, &g, NULL) != PM_OK)
    return -1;
  return g;
}

/* Part of the gap rule: the base's curve misses one of its end vertices by g wider than the
 * floor, the corner lies on a cell of that vertex's (another curve ending there), and the whole
 * triangle lies within 2 g of the vertex. The face's boundary is not defined at a finer scale
 * than the gap there: it runs along one curve to the vertex, jumps g, and goes on along the
 * other, and a triangle that spans the jump cannot be judged by its angles
 * (robust/step__SampleCrankshaft4A.stp: two curves end 0.056 from their vertex 11, where a third
 * ends, and the triangle between the two sides has 9.9 degrees). */
static int within_vertex_gap(const pm_mesh *mesh, const pm_model *m, int32_t curve,
                             const int32_t *v, const double *const P[3], double floor) {
  const pm_cell *cc = &m->cells[PM_CURVE][curve];
  for (int32_t u = 0; u < cc->nbound; ++u) {
    const int32_t vert = cc->bound[u].cell;
    int corner_at_vertex = 0;
    for (int k = 0; k < 3 && !corner_at_vertex; ++k)
      corner_at_vertex = mesh->node_dim[v[k]] == PM_CURVE && mesh->node_cell[v[k]] != curve &&
                         in_curve_closure(m, PM_VERTEX, vert, mesh->node_cell[v[k]]);
    if (!corner_at_vertex) continue;
    const double g = vertex_gap(m, curve, vert);
    if (!(g > floor)) continue;
    double at[3];
    pm_cell_point(&m->cells[PM_VERTEX][vert], NULL, at);
    int near = 1;
    for (int k = 0; k < 3; ++k) near = near && pm_v3_dist(P[k], at) < 2 * g;
    if (near) return 1;
  }
  return 0;
}

/* The gap rule at the vertex itself: a corner of the triangle is vertex V's node, another lies on
 * a curve that ends at V but misses it by g wider than the floor, and the whole triangle lies
 * within 2 g of V. The face's boundary jumps g between that curve's end and V, and a triangle
 * that spans the jump cannot be judged by its angles (robust/step__SampleCrankshaft4A.stp:
 * curves 34 and 323 both end 0.11 from their vertex 33; psys's triangle of the vertex and the
 * two curves' nodes nearest it, 0.019 apart, has 7.3 degrees). */
static int spans_vertex_gap(const pm_mesh *mesh, const pm_model *m, const int32_t *v,
                            const double *const P[3], double floor) {
  for (int j = 0; j < 3; ++j) {
    if (mesh->node_dim[v[j]] != PM_VERTEX) continue;
    const int32_t vert = mesh->node_cell[v[j]];
    if (vert < 0 || vert >= m->count[PM_VERTEX]) continue;
    for (int k = 0; k < 3; ++k) {
      const int32_t curve = mesh->node_cell[v[k]];
      if (mesh->node_dim[v[k]] != PM_CURVE || curve < 0 || curve >= m->count[PM_CURVE] ||
          !in_curve_closure(m, PM_VERTEX, vert, curve))
        continue;
      const double g = vertex_gap(m, curve, vert);
      if (!(g > floor)) continue;
      int near = 1;
      for (int i = 0; i < 3; ++i) near = near && pm_v3_dist(P[i], P[j]) < 2 * g;
      if (near) return 1;
    }
  }
  return 0;
}

/* The gap rule: the triangle stands on an edge of curve-closure nodes (a curve's nodes and its
 * end vertices), and a CAD gap wider than the floor keeps its third corner at least g from the
 * curve: face f's surface stays g away from the curve there (the face does not reach its
 * boundary curve: the edge's tolerance is that wide), or the corner is an end vertex of the
 * curve that the curve misses by g. A base shorter than 2 g tan(limit / 2) then gives an angle
 * below the limit wherever the face's nodes are: forced at the curve's spacing, which the
 * curve's other faces and features set (robust/step__SampleCrankshaft4A.stp: a cylinder 0.13
 * from a B-spline curve whose other face asks for nodes 0.016 apart, and the curve's end 0.146
 * from its vertex).
 * g is measured at the base's midpoint, by Newton from the corner's (u, v) on f (the surface
 * near the corner, untrimmed: the trimmed face ends at the pcurve's image, the point sought). */
static int below_gap_to_curve(const pm_mesh *mesh, const pm_model *m, const pm_cell *f,
                              const int32_t *v, const double *const P[3], int base, double rad,
                              double floor) {
  const int32_t a = v[base], b = v[(base + 1) % 3], c = v[(base + 2) % 3];
  if (mesh->node_dim[c] < 0) return 0;
  int32_t curve = -1;
  if (mesh->node_dim[a] == PM_CURVE) curve = mesh->node_cell[a];
  else if (mesh->node_dim[b] == PM_CURVE) curve = mesh->node_cell[b];
  if (curve < 0 || curve >= m->count[PM_CURVE] ||
      !in_curve_closure(m, mesh->node_dim[a], mesh->node_cell[a], curve) ||
      !in_curve_closure(m, mesh->node_dim[b], mesh->node_cell[b], curve))
    return 0;
  double g;
  if (in_curve_closure(m, mesh->node_dim[c], mesh->node_cell[c], curve)) {
    /* The corner is an end vertex of the curve: the gap is the vertex's distance from the
     * curve (the curve's end misses its vertex). */
    if (mesh->node_dim[c] != PM_VERTEX) return 0;
    double t;
    if (pm_cell_project(&m->cells[PM_CURVE][curve], P[(base + 2) % 3], NULL, &t, NULL, &g,
                        NULL) != PM_OK)
      return 0;
  } else {
    if (within_vertex_gap(mesh, m, curve, v, P, floor)) return 1;
    /* The corner's (u, v): its own when it is a node of f, else its projection onto f. */
    double start[2], uv[2];
    if (mesh->node_par && mesh->node_dim[c] == PM_FACE && mesh->node_cell[c] == f->index)
      start[0] = mesh->node_par[2 * (size_t)c], start[1] = mesh->node_par[2 * (size_t)c + 1];
    else if (pm_cell_project(f, P[(base + 2) % 3], NULL, start, NULL, NULL, NULL) != PM_OK)
      return 0;
    double mid[3];
    pm_v3_add(mid, P[base], P[(base + 1) % 3]);
    pm_v3_scale(mid, mid, 0.5);
    g = sqrt(pm_face_project_from(f, mid, start, uv));
  }
  return g > floor && pm_v3_dist(P[base], P[(base + 1) % 3]) < 2 * g * tan(0.5 * rad);
}

pm_status pm_needles_classify(const pm_mesh *mesh, const pm_model *model, double limit,
                              pm_needles *out, uint8_t *kind, pm_error *err) {
  memset(out, 0, sizeof *out);
  out->first_unforced = -1;
  out->min_angle = 180;
  if (!(limit > 0 && limit <= 60))
    return pm_error_setf(err, PM_ERR_ARG, "needles: the angle limit must be in (0, 60], got %g",
                         limit);
  for (int64_t i = 0; i < 3 * (int64_t)mesh->ntri; ++i)
    if (mesh->tri[i] < 0 || mesh->tri[i] >= mesh->nnode)
      return pm_error_setf(err, PM_ERR_ARG, "needles: triangle %lld uses node %d of %d",
                           (long long)(i / 3), (int)mesh->tri[i], (int)mesh->nnode);
  const double rad = limit * M_PI / 180;
  const double floor = model ? PM_FEATURE_FLOOR * model->diagonal : 0;
  const int classified = model && mesh->node_dim && mesh->node_cell && mesh->tri_cell;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    const int32_t *v = &mesh->tri[3 * (size_t)t];
    const double *P[3] = {&mesh->xyz[3 * (size_t)v[0]], &mesh->xyz[3 * (size_t)v[1]],
                          &mesh->xyz[3 * (size_t)v[2]]};
    pm_tri_measure q;
    pm_tri_measure_eval(P[0], P[1], P[2], &q);
    out->min_angle = fmin(out->min_angle, q.min_angle);
    uint8_t k = PM_NEEDLE_NONE;
    if (q.min_angle < limit) {
      k = PM_NEEDLE_UNFORCED;
      int32_t f = classified ? mesh->tri_cell[t] : -1;
      if (f >= 0 && f < model->count[PM_FACE]) {
        const pm_cell *fc = &model->cells[PM_FACE][f];
        for (int j = 0; j < 3 && k == PM_NEEDLE_UNFORCED; ++j) {
          if (mesh->node_dim[v[j]] != PM_VERTEX) continue;
          double a = corner_angle_at(fc, mesh->node_cell[v[j]], P[j], P[(j + 1) % 3], P[(j + 2) % 3],
                                     rad);
          if (a >= 0 && a < rad) k = PM_NEEDLE_CORNER;
        }
        if (k == PM_NEEDLE_UNFORCED) {
          int j = 0;
          double lmin = INFINITY;
          for (int e = 0; e < 3; ++e) {
            double l = pm_v3_dist(P[e], P[(e + 1) % 3]);
            if (l < lmin) lmin = l, j = e;
          }
          int32_t a = v[j], b = v[(j + 1) % 3];
          if (lmin < floor && mesh->node_dim[a] >= 0 && mesh->node_dim[a] < PM_FACE &&
              mesh->node_dim[b] >= 0 && mesh->node_dim[b] < PM_FACE &&
              (mesh->node_dim[a] != mesh->node_dim[b] || mesh->node_cell[a] != mesh->node_cell[b]))
            k = PM_NEEDLE_FEATURE;
          else if (below_floor_across_cells(mesh, model, v, P, floor))
            k = PM_NEEDLE_FEATURE;
          else if (below_gap_to_curve(mesh, model, fc, v, P, j, rad, floor))
            k = PM_NEEDLE_FEATURE;
          else if (spans_vertex_gap(mesh, model, v, P, floor))
            k = PM_NEEDLE_FEATURE;
        }
      }
      out->count++;
      if (k == PM_NEEDLE_CORNER) out->corner++;
      else if (k == PM_NEEDLE_FEATURE) out->feature++;
      else if (out->unforced++ == 0) out->first_unforced = t;
    }
    if (kind) kind[t] = k;
  }
  return PM_OK;
}
