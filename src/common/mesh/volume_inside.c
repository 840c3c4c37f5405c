/* Points and segments against a volume's surface mesh (volume_inside.h): exact sign tests,
 * candidates from an Embree BVH. */
#include "common/mesh/volume_inside.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/closest_embree.h"
#include "common/backends/predicates.h"
#include "common/base/vec3.h"

int pm_segment_triangle_cross(const double p[3], const double q[3], const double a[3],
                              const double b[3], const double c[3]) {
  int s1 = pm_orient3d(a, b, c, p), s2 = pm_orient3d(a, b, c, q);
  if (s1 == 0 || s2 == 0) return s1 == s2 ? 0 : -1;
  if (s1 == s2) return 0;
  int e1 = pm_orient3d(p, q, a, b), e2 = pm_orient3d(p, q, b, c), e3 = pm_orient3d(p, q, c, a);
  if ((e1 > 0 && e2 > 0 && e3 > 0) || (e1 < 0 && e2 < 0 && e3 < 0)) return 1;
  if (e1 == 0 || e2 == 0 || e3 == 0) {
    int pos = (e1 > 0) + (e2 > 0) + (e3 > 0), neg = (e1 < 0) + (e2 < 0) + (e3 < 0);
    if (pos == 0 || neg == 0) return -1;
  }
  return 0;
}

struct pm_volume_shell {
  double *xyz;     /* [3 * nnode] copy of the mesh's nodes */
  int32_t nnode;
  int32_t *tri;    /* [3 * ntri] */
  int8_t *out;     /* [ntri] +1: the triangle's normal points out of the volume, -1: into it,
                      0: a triangle of an embedded face (barrier only) */
  int32_t ntri;
  double diagonal; /* of the shell's bounding box */
  pm_bvh *bvh;
};

pm_status pm_volume_shell_create(const pm_model *m, const pm_mesh *mesh, int32_t volume,
                                 pm_volume_shell **out, pm_error *err) {
  *out = NULL;
  if (volume < 0 || volume >= m->count[PM_VOLUME])
    return pm_error_setf(err, PM_ERR_ARG, "volume index %d out of range (the model has %d)",
                         (int)volume, (int)m->count[PM_VOLUME]);
  const pm_cell *v = pm_model_cell(m, PM_VOLUME, volume);
  int32_t nf = m->count[PM_FACE];
  int8_t *role = calloc((size_t)nf + 1, 1); /* per face: +-1 bounding with that sign, 2 embedded */
  if (!role) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t b = 0; b < v->nbound; ++b) {
    int32_t f = v->bound[b].cell;
    int sense = v->bound[b].sense < 0 ? -1 : 1;
    /* A face used twice by the volume (both sides inside) bounds nothing: a barrier only. */
    role[f] = role[f] ? 2 : (int8_t)(pm_face_mesh_sign(m, f) * sense);
  }
  for (int32_t e = 0; e < v->nembed; ++e)
    if (v->embed[e].dim == PM_FACE) role[v->embed[e].index] = 2;
  pm_volume_shell *s = calloc(1, sizeof *s);
  int32_t nt = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell[t];
    if (f >= 0 && f < nf && role[f]) ++nt;
  }
  if (s) {
    s->xyz = malloc(sizeof(double) * 3 * ((size_t)mesh->nnode + 1));
    s->tri = malloc(sizeof(int32_t) * 3 * ((size_t)nt + 1));
    s->out = malloc((size_t)nt + 1);
  }
  if (!s || !s->xyz || !s->tri || !s->out) {
    free(role);
    pm_volume_shell_destroy(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  memcpy(s->xyz, mesh->xyz, sizeof(double) * 3 * (size_t)mesh->nnode);
  s->nnode = mesh->nnode;
  int nbounding = 0;
  double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    int32_t f = mesh->tri_cell[t];
    if (f < 0 || f >= nf || !role[f]) continue;
    memcpy(&s->tri[3 * s->ntri], &mesh->tri[3 * t], 3 * sizeof(int32_t));
    s->out[s->ntri] = (int8_t)(role[f] == 2 ? 0 : role[f]);
    nbounding += role[f] != 2;
    for (int q = 0; q < 3; ++q)
      for (int k = 0; k < 3; ++k) {
        double c = mesh->xyz[3 * mesh->tri[3 * t + q] + k];
        box[k] = fmin(box[k], c), box[3 + k] = fmax(box[3 + k], c);
      }
    s->ntri++;
  }
  free(role);
  if (nbounding == 0) {
    pm_volume_shell_destroy(s);
    return pm_error_setf(err, PM_ERR_GEOM, "volume %d has no boundary triangle in the mesh", v->tag);
  }
  s->diagonal = sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
                     (box[5] - box[2]) * (box[5] - box[2]));
  pm_status st = pm_bvh_create(s->xyz, s->nnode, s->tri, s->ntri, &s->bvh, err);
  if (st) {
    pm_volume_shell_destroy(s);
    return st;
  }
  *out = s;
  return PM_OK;
}

void pm_volume_shell_destroy(pm_volume_shell *s) {
  if (!s) return;
  pm_bvh_destroy(s->bvh);
  free(s->xyz), free(s->tri), free(s->out);
  free(s);
}

int32_t pm_volume_shell_ntri(const pm_volume_shell *s) { return s->ntri; }

static const double *corner(const pm_volume_shell *s, int32_t t, int q) {
  return &s->xyz[3 * s->tri[3 * t + q]];
}

/* ---- segment ------------------------------------------------------------------------------- */

typedef struct seg_ctx {
  const pm_volume_shell *s;
  const double *p, *q;
  int hit;
} seg_ctx;

static double seg_visit(void *user, int32_t t, double radius) {
  seg_ctx *c = user;
  if (c->hit) return 0;
  if (pm_segment_triangle_cross(c->p, c->q, corner(c->s, t, 0), corner(c->s, t, 1), corner(c->s, t, 2)) != 0) {
    c->hit = 1;
    return 0;
  }
  return radius;
}

/* The ball that contains the segment: centre the midpoint, radius half the length, widened by a
 * relative 1e-9 and an absolute 1e-12 of the diagonal so that rounding never leaves out a
 * triangle touching an end (the BVH visits a superset anyway; the tests are exact). */
static double seg_ball(const pm_volume_shell *s, const double p[3], const double q[3], double mid[3]) {
  pm_v3_add(mid, p, q);
  pm_v3_scale(mid, mid, 0.5);
  double h = 0.5 * pm_v3_dist(p, q);
  return h * (1 + 1e-9) + 1e-12 * s->diagonal;
}

int pm_volume_shell_segment_meets(const pm_volume_shell *s, const double p[3], const double q[3]) {
  double mid[3];
  double r = seg_ball(s, p, q, mid);
  seg_ctx c = {s, p, q, 0};
  pm_bvh_visit(s->bvh, mid, r, seg_visit, &c);
  return c.hit;
}

double pm_volume_shell_distance(const pm_volume_shell *s, const double x[3], double max_radius) {
  pm_bvh_hit hit;
  if (!pm_bvh_closest(s->bvh, x, max_radius, &hit)) return INFINITY;
  return hit.dist;
}

/* ---- inside ---------------------------------------------------------------------------------- */

typedef struct near_ctx {
  const pm_volume_shell *s;
  const double *x;
  int32_t best;
  double dist;
} near_ctx;

/* The nearest bounding triangle (embedded ones do not bound the volume). */
static double near_visit(void *user, int32_t t, double radius) {
  near_ctx *c = user;
  if (!c->s->out[t]) return radius;
  double q[3];
  double d = pm_point_triangle_closest(c->x, corner(c->s, t, 0), corner(c->s, t, 1), corner(c->s, t, 2), q, NULL);
  if (d < c->dist) {
    c->dist = d, c->best = t;
    return d;
  }
  return radius;
}

typedef struct par_ctx {
  const pm_volume_shell *s;
  const double *p, *q;
  int32_t skip;
  int parity, bad;
} par_ctx;

/* Crossings of the segment (p, q] with the bounding triangles other than `skip`, where q is an
 * interior point of `skip`. q lies in no other triangle of a conforming mesh, so q in another
 * triangle's plane (a neighbour in the same planar face) is no crossing. */
static double par_visit(void *user, int32_t t, double radius) {
  par_ctx *c = user;
  if (c->bad || t == c->skip || !c->s->out[t]) return radius;
  const double *a = corner(c->s, t, 0), *b = corner(c->s, t, 1), *d = corner(c->s, t, 2);
  int s1 = pm_orient3d(a, b, d, c->p), s2 = pm_orient3d(a, b, d, c->q);
  if (s2 == 0 && s1 != 0) return radius;
  int h = pm_segment_triangle_cross(c->p, c->q, a, b, d);
  if (h < 0) {
    c->bad = 1;
    return 0;
  }
  c->parity ^= h;
  return radius;
}

/* Long rays over every bounding triangle: the fallback. */
static int inside_by_rays(const pm_volume_shell *s, const double x[3]) {
  static const double dirs[5][3] = {{0.5773, 0.5779, 0.5768}, {-0.3121, 0.8126, 0.4921},
                                    {0.7071, -0.1234, -0.6963}, {-0.6417, -0.5132, 0.5700},
                                    {0.1111, 0.2222, -0.9686}};
  for (int k = 0; k < 5; ++k) {
    double q[3];
    pm_v3_axpy(q, x, 4 * s->diagonal + 4 * pm_v3_norm(x), dirs[k]);
    int parity = 0, bad = 0;
    for (int32_t t = 0; t < s->ntri && !bad; ++t) {
      if (!s->out[t]) continue;
      int h = pm_segment_triangle_cross(x, q, corner(s, t, 0), corner(s, t, 1), corner(s, t, 2));
      if (h < 0) bad = 1;
      parity ^= h > 0;
    }
    if (!bad) return parity;
  }
  return -1;
}

int pm_volume_shell_inside(const pm_volume_shell *s, const double x[3]) {
  if (!isfinite(x[0]) || !isfinite(x[1]) || !isfinite(x[2])) return 0;
  near_ctx nc = {s, x, -1, INFINITY};
  pm_bvh_visit(s->bvh, x, 4 * s->diagonal + 4 * pm_v3_norm(x), near_visit, &nc);
  if (nc.best < 0) return inside_by_rays(s, x);
  if (nc.dist == 0) return 0; /* on the boundary */
  /* Interior points of the nearest triangle to aim at: the centroid, then three others. */
  static const double bary[4][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3}, {0.2, 0.3, 0.5}, {0.5, 0.2, 0.3},
                                    {0.3, 0.5, 0.2}};
  const int32_t t = nc.best;
  const double *A = corner(s, t, 0), *B = corner(s, t, 1), *C = corner(s, t, 2);
  int side = pm_orient3d(A, B, C, x) * s->out[t]; /* +1: x on the outward side of t */
  if (side != 0)
    for (int k = 0; k < 4; ++k) {
      double q[3];
      for (int i = 0; i < 3; ++i) q[i] = bary[k][0] * A[i] + bary[k][1] * B[i] + bary[k][2] * C[i];
      double mid[3];
      double r = seg_ball(s, x, q, mid);
      par_ctx pc = {s, x, q, t, 0, 0};
      pm_bvh_visit(s->bvh, mid, r, par_visit, &pc);
      if (pc.bad) continue;
      /* Just inside t on x's side the point is inside iff that side is the inward one. */
      return (side < 0) ^ pc.parity;
    }
  return inside_by_rays(s, x);
}
