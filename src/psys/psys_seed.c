/* Bootstrap seeding of the faces (ours; papers/001 section 5.2.1 names it as the way to fewer
 * iterations: "a heuristic to bootstrap initial samplings could provide large speedups for
 * models that require fine samplings"). The paper seeds k random particles per face and lets
 * them split until the density is right (psys_seed_face, seeding = 0); a face needing N particles
 * then takes about log2(N / k) rounds of splits, and the grains grown from the k seeds meet in
 * lattice defects that the relaxation rarely repairs.
 *
 * Here each face is filled once its curves are done, by an advancing front in the face's
 * inferred field, so that phase 3 starts near its final count with a lattice aligned with the
 * boundary:
 *   1. the first row: for every frozen particle on the face's boundary (its curves' and vertices'
 *      particles, both sides of a seam), a point at the height of an equilateral triangle inside
 *      the face, half a spacing along the boundary;
 *   2. then, breadth first, from every placed particle the six points of a hexagonal lattice at
 *      its spacing, the lattice turned to follow the bond by which the particle was placed;
 *   3. a point is kept when it lies in the face's trimmed region and no particle of the face or
 *      of its boundary lies within SEED_KEEP of a spacing of it.
 * The spacing at a point is edge_per_sigma x sigma, with sigma the bound of eq. 11 there
 * (curvature and limits) closed with the Lipschitz bound along the front: the parent's sigma +
 * L x the distance (eq. 15 along the path the front took, which starts at the boundary's sigma).
 * The gap is estimated from the face's own boundary (the width through the face, as
 * psys_sizing.c's gap of a face particle); the cells across a thin wall have no particles yet.
 * So the faces are filled twice (psys_phases.c): the first front's particles get the field of a
 * sizing update (the gap across walls from the other faces' particles, the Lipschitz closure over
 * the whole model), which the second front takes as a hint: sigma is at most hint_j + L |x -
 * x_j| for the first front's particles j near x.
 *
 * The front of a face sees that face and its boundary only (particles of other faces are left
 * to the relaxation), so faces are filled independently, in parallel, and appended in face order:
 * the result does not depend on the thread count.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"
#include "psys/psys_private.h"

/* A candidate is kept when no particle lies within SEED_KEEP x its spacing: below 1, so that a
 * front meeting another at a slightly smaller spacing still closes the gap between them (a
 * missing particle costs more iterations than a spare one, which population control deletes). */
#define SEED_KEEP 0.8
/* The first row sits at the height of an equilateral triangle on the boundary spacing. */
#define ROW_HEIGHT 0.8660254037844386

typedef struct fpt {
  double uv[2], x[3];
  double sigma;
  double dir[3]; /* the lattice direction (unit, tangent) */
  int32_t key;   /* boundary particles: the key of their cell; placed ones: -1 */
} fpt;

typedef struct front {
  const psys_sys *s;
  const psys_hint *hint; /* may be NULL */
  const pm_cell *f;
  pm_grid *grid;   /* every point of the face so far (boundary then placed), radius = spacing */
  fpt *pt;
  int32_t n, cap;
  int32_t nbound;  /* pt[0 .. nbound) are the boundary particles */
} front;

static int push(front *F, const fpt *p, pm_error *err) {
  if (F->n == F->cap) {
    int32_t cap = F->cap ? 2 * F->cap : 256;
    fpt *q = realloc(F->pt, sizeof(fpt) * (size_t)cap);
    if (!q) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory"), -1;
    F->pt = q, F->cap = cap;
  }
  F->pt[F->n] = *p;
  if (pm_grid_insert(F->grid, F->n, p->x, F->s->p.edge_per_sigma * p->sigma, err)) return -1;
  F->n++;
  return 0;
}

/* The face's unit normal and tangent frame at uv. */
static int frame(const pm_cell *f, const double uv[2], double x[3], double nrm[3]) {
  pm_face_point fp;
  pm_face_eval(f, uv, 1, &fp);
  pm_v3_copy(x, fp.p);
  pm_v3_cross(nrm, fp.su, fp.sv);
  return pm_v3_normalize(nrm) > 0;
}

/* The width of the face through x, from its boundary particles within R: the least d_A + d_B
 * over pairs of boundary cells that share no vertex (psys_sizing.c's gap of a face particle,
 * from the particles alone). INFINITY when no such pair is near. */
static double width_at(const front *F, const double x[3], double R, pm_idbuf *buf) {
  enum { MAXC = 16 };
  int32_t key[MAXC];
  double d[MAXC];
  int nk = 0;
  if (pm_grid_query(F->grid, x, R, PM_GRID_BALL, buf, NULL)) return INFINITY;
  for (int32_t q = 0; q < buf->n; ++q) {
    const int32_t j = buf->ids[q];
    if (j >= F->nbound) break; /* sorted: the boundary particles come first */
    const double dj = pm_v3_dist(x, F->pt[j].x);
    int a = 0;
    while (a < nk && key[a] != F->pt[j].key) ++a;
    if (a < nk) {
      if (dj < d[a]) d[a] = dj;
    } else if (nk < MAXC) {
      key[nk] = F->pt[j].key, d[nk++] = dj;
    }
  }
  double w = INFINITY;
  for (int a = 0; a < nk; ++a)
    for (int b = a + 1; b < nk; ++b)
      if (d[a] + d[b] < w && !psys_touch(F->s, key[a], key[b])) w = d[a] + d[b];
  return w;
}

/* sigma at a point of the face: the given field, or the inferred field's bound (eq. 11: the
 * curvature, the limits, s_tau x the width through the face) closed with the Lipschitz bound
 * from the parent at distance r. */
static double sigma_at(const front *F, const double uv[2], const double x[3], const fpt *parent,
                       double r, pm_idbuf *buf) {
  const psys_sys *s = F->s;
  if (s->size) return pm_sizing_eval(s->size, x) / s->p.edge_per_sigma;
  const double geom = psys_geometry_sigma(s, PM_FACE, F->f->index, uv, x);
  double sg = fmin(geom, s->sigma_max);
  sg = fmin(sg, parent->sigma + s->p.lipschitz * r);
  sg = fmin(sg, s->p.s_tau * width_at(F, x, sg / s->p.s_tau, buf));
  if (F->hint && !pm_grid_query(F->hint->grid, x, 2 * sg, PM_GRID_BALL, buf, NULL))
    for (int32_t q = 0; q < buf->n; ++q) {
      const int32_t j = buf->ids[q];
      sg = fmin(sg, F->hint->sigma[j] + s->p.lipschitz * pm_v3_dist(x, &F->hint->xyz[3 * j]));
    }
  return fmin(fmax(sg, s->sigma_min), geom); /* a narrow place may ask for less: bound_of */
}

/* No point of the face within SEED_KEEP x the larger spacing of x (spacing h) and of it. */
static int room(const front *F, const double x[3], double h, pm_idbuf *buf) {
  if (pm_grid_query(F->grid, x, SEED_KEEP * h, PM_GRID_MUTUAL, buf, NULL)) return 0;
  for (int32_t q = 0; q < buf->n; ++q) {
    const fpt *o = &F->pt[buf->ids[q]];
    const double ho = F->s->p.edge_per_sigma * o->sigma;
    const double lim = SEED_KEEP * (h > ho ? h : ho);
    if (psys_d2(x, o->x) < lim * lim) return 0;
  }
  return 1;
}

/* Try a point of the face at 3D displacement dx from point p (uv, x); kept when it is in the
 * face, moved nearly as far as asked (a step clipped at the boundary is not) and has room. */
static int try_point(front *F, const fpt *p, const double dx[3], pm_idbuf *buf, pm_error *err) {
  const psys_sys *s = F->s;
  double uv[2], x[3], nrm[3];
  const double want = pm_v3_norm(dx);
  if (pm_cell_displace(F->f, p->uv, dx, uv) != PM_MOVE_FREE) return 0;
  if (!pm_face_inside(F->f, uv) || !frame(F->f, uv, x, nrm)) return 0;
  const double got = pm_v3_dist(x, p->x);
  if (!(got > 0.7 * want && got < 1.3 * want)) return 0;
  /* Most candidates fall where the lattice has a point already: room at a spacing of 0 (no
   * point o within SEED_KEEP x its own spacing of x) is necessary for room at any spacing, and
   * spares those the sigma they would not use (the width and hint queries, the curvature). */
  if (!room(F, x, 0, buf)) return 0;
  const double sg = sigma_at(F, uv, x, p, got, buf);
  if (!(sg > 0) || !isfinite(sg) || !room(F, x, s->p.edge_per_sigma * sg, buf)) return 0;
  fpt c;
  c.uv[0] = uv[0], c.uv[1] = uv[1];
  pm_v3_copy(c.x, x);
  c.sigma = sg;
  c.key = -1;
  /* the lattice direction: the bond, in the new tangent plane */
  double b[3];
  pm_v3_sub(b, x, p->x);
  pm_v3_axpy(c.dir, b, -pm_v3_dot(b, nrm), nrm);
  if (!(pm_v3_normalize(c.dir) > 0)) pm_v3_copy(c.dir, p->dir);
  return push(F, &c, err) ? -1 : 1;
}

/* The boundary particles of face f with their (u, v) on it: the chains of its curves (outer and
 * inner loops, both sides of a seam) and of the curves embedded in it. */
static pm_status add_boundary(front *F, pm_error *err) {
  const psys_sys *s = F->s;
  const pm_cell *f = F->f;
  for (int32_t l = 0; l < f->nloop; ++l)
    for (int32_t u = 0; u < f->loop[l].nuse; ++u) {
      const pm_use *use = &f->loop[l].use[u];
      const pm_cell *cv = pm_model_cell(s->model, PM_CURVE, use->cell);
      const int32_t a = s->chain_off[use->cell], b = s->chain_off[use->cell + 1];
      for (int32_t k = a; k < b; ++k) {
        const int32_t j = s->chain[k];
        double t = s->dim[j] == PM_CURVE ? s->par[2 * j] : (k == a ? cv->lo[0] : cv->hi[0]);
        fpt p;
        pm_face_curve_uv(f, use, t, p.uv);
        pm_v3_copy(p.x, &s->xyz[3 * j]);
        p.sigma = s->sigma[j];
        p.key = psys_key(s, s->dim[j], s->cell[j]);
        /* the boundary's direction at the particle, from its chain neighbours */
        const double *xa = &s->xyz[3 * s->chain[k > a ? k - 1 : k]];
        const double *xb = &s->xyz[3 * s->chain[k + 1 < b ? k + 1 : k]];
        pm_v3_sub(p.dir, xb, xa);
        if (!(pm_v3_normalize(p.dir) > 0)) pm_v3_zero(p.dir); /* an obstacle only (a pole) */
        if (push(F, &p, err)) return PM_ERR_NOMEM;
      }
    }
  F->nbound = F->n;
  return PM_OK;
}

/* The first row: from boundary particle b, a point at the row height inside the face, half a
 * spacing along the boundary (both ways along it, the second kept only where the first found no
 * room). */
static int first_row(front *F, int32_t k, pm_idbuf *buf, pm_error *err) {
  const fpt p = F->pt[k];
  double x[3], nrm[3];
  if (!(pm_v3_dot(p.dir, p.dir) > 0) || !frame(F->f, p.uv, x, nrm)) return 0;
  double in[3];
  pm_v3_cross(in, nrm, p.dir); /* left of the boundary's direction */
  const double h = F->s->p.edge_per_sigma * p.sigma;
  for (int side = 0; side < 2; ++side) {
    double dx[3];
    for (int c = 0; c < 3; ++c) dx[c] = (side ? -1 : 1) * ROW_HEIGHT * h * in[c] + 0.5 * h * p.dir[c];
    int r = try_point(F, &p, dx, buf, err);
    if (r) return r;
  }
  return 0;
}

pm_status psys_seed_front(const psys_sys *s, int32_t f, const psys_hint *hint, double **out_uv,
                          double **out_sigma, int32_t *count, pm_error *err) {
  *out_uv = NULL, *out_sigma = NULL, *count = 0;
  front F;
  memset(&F, 0, sizeof F);
  F.s = s;
  F.hint = hint;
  F.f = pm_model_cell(s->model, PM_FACE, f);
  pm_idbuf buf = PM_IDBUF_INIT;
  pm_status st = pm_grid_create(1e-2 * s->sigma_min * s->p.edge_per_sigma, &F.grid, err);
  if (st) return st;
  if ((st = add_boundary(&F, err))) goto out;
  for (int32_t k = 0; k < F.nbound; ++k)
    if (first_row(&F, k, &buf, err) < 0) {
      st = PM_ERR_NOMEM;
      goto out;
    }
  /* breadth first over the placed points, each trying its six lattice neighbours */
  for (int32_t k = F.nbound; k < F.n; ++k) {
    if (F.n - F.nbound > s->max_particles) break; /* the caps stop the run later */
    const fpt p = F.pt[k];
    double x[3], nrm[3];
    if (!frame(F.f, p.uv, x, nrm)) continue;
    double e2[3];
    pm_v3_cross(e2, nrm, p.dir);
    const double h = s->p.edge_per_sigma * p.sigma;
    for (int q = 0; q < 6; ++q) {
      const double th = q * M_PI / 3;
      double dx[3];
      for (int c = 0; c < 3; ++c) dx[c] = h * (cos(th) * p.dir[c] + sin(th) * e2[c]);
      if (try_point(&F, &p, dx, &buf, err) < 0) {
        st = PM_ERR_NOMEM;
        goto out;
      }
    }
  }
  const int32_t m = F.n - F.nbound;
  if (m > 0) {
    *out_uv = malloc(sizeof(double) * 2 * (size_t)m);
    *out_sigma = malloc(sizeof(double) * (size_t)m);
    if (!*out_uv || !*out_sigma) {
      free(*out_uv), free(*out_sigma);
      *out_uv = *out_sigma = NULL;
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto out;
    }
    for (int32_t k = 0; k < m; ++k) {
      memcpy(&(*out_uv)[2 * k], F.pt[F.nbound + k].uv, 2 * sizeof(double));
      (*out_sigma)[k] = F.pt[F.nbound + k].sigma;
    }
    *count = m;
  }
out:
  if (st == PM_ERR_NOMEM && err && !err->msg[0]) pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_idbuf_free(&buf);
  pm_grid_destroy(F.grid);
  free(F.pt);
  return st;
}
