/* Initial placement of face bubbles by growing a hexagonal lattice from the face's border (our
 * addition; place = lattice).
 *
 * Why. The papers place face bubbles by the rhombic quadtree (bub_place.c), whose leaf corners
 * form hexagonal lattices at spacings between d and 2 d (halvings of the root), aligned with the
 * parameter axes; population control then inserts the missing bubbles, up to half of them, around
 * open bubbles. The relaxed packing is polycrystalline: the inserted bubbles nucleate grains of
 * different orientation, and where grains meet the packing keeps lines of lattice defects (a node
 * with 5 neighbours beside one with 7), whose triangles are the worst of the mesh (qi1 at d = 0.1:
 * 671 of 1836 triangles around defects against gmsh-frontal's 237, packmesh quality's
 * tri.by_site). A front-based mesher lays rows parallel to the boundary and has one grain almost
 * everywhere. This placement does the same with bubbles: a start close to the final packing,
 * with the final count, so that the relaxation has little to do (fewer steps) and keeps one grain
 * (better triangles).
 *
 * Curves first, in the same spirit: the relaxed chain of a curve's bubbles between its fixed end
 * bubbles is evenly spaced in units of the stable distance (bub_population.c, "curve chains"), so
 * the curve gets round(integral of ds / d) segments, its bubbles at equal steps of that integral
 * (instead of the binary subdivision, whose spacings lie anywhere between d / 2 and d).
 *
 * Then, per face:
 *   - seeds: for every border chord (A, B) (bub_for_each_chord) the apex of the equilateral
 *     triangle on it, inside the face, with the lattice direction along the chord: the row that
 *     would continue the boundary's own spacing. The chords of the face's longest boundary curve
 *     (most chords) come first, from its middle chord outwards;
 *   - growth: from the first seed that is not crowded (below), breadth first: each bubble tries
 *     the six lattice directions at 0, 60, ..., 300 degrees from its row direction, in its tangent
 *     plane, at the distance l0 = (d(parent) + d(place)) / 2 (the stable distance, 003 eq. 10),
 *     moved there by the shared displacement rule (geom.h; a step that would leave the face is not
 *     a place); the row direction is carried to the new bubble by projecting it onto the new
 *     tangent plane. Once a grain can grow no further, the next seed that is not crowded starts
 *     another (a part of the face the first could not reach: behind a narrow neck, another
 *     component);
 *   - a place is crowded, and not used, when it is closer than 0.7 l0 to a bubble of the face or
 *     of its closure (our choice: the nearest neighbours of a lattice site are at l0, those of a
 *     site offset by the misfit between two rows at least about 0.7 l0 further than the
 *     quadtree's 0.25 / 0.5, since the lattice has the right density and needs no removal);
 *   - lattice sites are numbered (grain, i, j) in the grain's axial coordinates, so that a site
 *     reached from several bubbles is tried once;
 *   - two parents (curved faces, lattice_apex = 1): a step of l0 from one parent along its row
 *     direction keeps that one edge at the stable distance, and on a curved face the lattice's
 *     other edges drift from it: where rows diverge (the outer side of a torus, going outwards)
 *     the sites end up to 1.2 l0 apart, too close for a place between them (crowded below) and
 *     too far for the packing (synth_torus.brep at d = 0.0366: 8752 bubbles placed against
 *     10160 after population control, whole bands of the torus at 56-78% of the ideal density).
 *     So when one of the two sites next to both the parent and the new site (directions k - 1
 *     and k + 1) holds a bubble already, the new bubble goes to the point of the parent's
 *     tangent plane at l0 from both, on the side of direction k (an advancing front's equilateral
 *     triangle): 9322 placed, every band at 80-100%. Planes keep the one-parent step (exact
 *     there).
 * The result on a uniform field is one grain aligned with the longest boundary curve, with its
 * misfit along the other curves, where relaxation and population control adjust it, as a
 * frontal mesher's rows meet in a seam.
 *
 * Fit (lattice_fit, planes). A curve gets a whole number of segments, so its chords are the stable
 * distance times a factor near 1 (4 / 0.098 = 40.8: 41 chords of 0.0976 on qi1's long side at
 * d = 0.098). A grain stepping at the stable distance drifts off its seed curve's bubbles by that
 * factor's excess per step (0.45%, a fifth of a spacing along the side), and the rows along the
 * border no longer continue the curve's spacing: the held interior (below) shrinks and the bands
 * carry the strain. So each grain on a plane steps at its seed chord's length over the chord's
 * stable distance (fit, when within LATTICE_FIT_MAX = 1.2% of 1) times the stable distance.
 * Further off, a lattice that far from the field's spacing loses more in the bands than the rows
 * gain: with 5%, occ__box.brep's median R / l_min went 0.5803 -> 0.5863, planar_step.brep 0.5818
 * -> 0.5887 (`packmesh mesh FILE --method bubble --threads 1 --stats`); with 1.2% they stay, and
 * brep__cylinder.brep goes 0.6011 -> 0.5987. On qi1 at sizes 0.098, 0.099,
 * 0.1, 0.101, 0.102 the median R / l_min went 0.5793 0.5809 0.5776 0.5819 0.5798 -> 0.5775
 * 0.5783 0.5776 0.5789 0.5795, the mean radius ratio 0.9962 0.9942 0.9934 0.9950 0.9918 -> 0.9964
 * 0.9949 0.9934 0.9951 0.9923 (`packmesh mesh case:qi1 --method bubble --size D --stats`).
 *
 * Holding (hold_rings R > 0, planes only). Relaxing every bubble spreads that misfit as a strain
 * over every row: qi1 (2 x 4, d = 0.1) fits 23.09 rows across, and its relaxed rows are all 0.4%
 * off, most triangles at R / l_min 0.578-0.579 (median 0.5799) where a front's are 0.5774 but for
 * its one seam (gmsh-frontal, the same node count: 0.5775). So a bubble whose sites within R
 * rings all hold bubbles of its grain with its own diameter is held where it was placed
 * (BUB_FHOLD: the dynamics gives it no acceleration, and the stopping tests' quantile is over the
 * other bubbles): the relaxation then works on the bands along borders, grain boundaries and size
 * changes, against rows that stay straight. A site next to the border whose place a curve's
 * bubble occupies (the lattice continuing the boundary's spacing, as along the seed's curve) is
 * marked with that bubble, so those rows count as full. R = 4 by measurement (bench_bubble
 * compare, qi1 against gmsh-frontal at the same count, rr_mean / median: R = 0 0.9949 / 0.5799,
 * 3 0.9943 / 0.5774, 4 0.9947 / 0.5774, 5 0.9948 / 0.5786, 6 0.9949 / 0.5798; gmsh-frontal
 * 0.9943-0.9947 / 0.5775-0.5777 at 984-986 nodes): a narrower band leaves the seam's triangles
 * worse, a wider one spreads the strain again. Curved faces (the lattice is not at rest there)
 * and graded fields (sizes differ within R rings) hold nothing.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/keyindex.h"
#include "common/base/vec3.h"

/* A place closer than this x l0 to a bubble it feels is crowded (header). */
#define CROWDED 0.7

/* The largest |fit - 1| a grain takes (header, "Fit"). */
#define LATTICE_FIT_MAX 0.012

/* The id of a lattice site found unusable (outside, crowded). */
#define UNUSABLE INT32_MAX

/* Axial offsets of the six lattice directions k x 60 degrees. */
static const int DI[6] = {1, 0, -1, -1, 0, 1}, DJ[6] = {0, 1, 1, 0, -1, -1};

typedef struct grow_item {
  int32_t id;      /* the bubble */
  int32_t grain;   /* its grain */
  int32_t i, j;    /* its axial coordinates in its grain */
  double e1[3];    /* its row direction (unit, tangent) */
} grow_item;

typedef struct grow_ctx {
  bub_state *s;
  const pm_cell *f;
  int32_t face;
  int64_t cap;
  grow_item *q;      /* breadth-first queue */
  int64_t qn, qcap;
  pm_keyindex sites; /* (grain, i, j) -> bubble id, or UNUSABLE */
  int32_t grain;
  int apex;          /* two parents where there are (curved faces with lattice_apex) */
  double fit;        /* the grain's step over the stable distance (lattice_fit) */
  pm_error *err;
} grow_ctx;

static uint64_t site_key(int32_t grain, int32_t i, int32_t j) {
  return ((uint64_t)(uint32_t)grain << 44) | ((uint64_t)((uint32_t)i & 0x3fffff) << 22) |
         (uint64_t)((uint32_t)j & 0x3fffff);
}

/* The unit normal at bubble o (0 when its tangent plane is singular). */
static int normal_at(const bub_state *s, int32_t o, double n[3]) {
  pm_v3_cross(n, &s->der[6 * o], &s->der[6 * o + 3]);
  return pm_v3_normalize(n) > 0;
}

typedef struct crowd {
  const bub_state *s;
  const double *x;
  double d;
  int32_t face;
  int crowded;
  int want_at; /* look for `at` too (else stop at the first bubble that crowds the place) */
  int32_t at;  /* a bubble of the face or its closure at the place itself (within 1e-9 d), or -1 */
} crowd;

static int crowd_visit(int32_t id, double d2, void *user) {
  crowd *c = user;
  const bub_state *s = c->s;
  if (s->flags[id] & BUB_FDEAD) return 0;
  if (!(s->kind[id] == BUB_KFACE && s->cell[id] == c->face) && !bub_related_cell(s, BUB_KFACE, c->face, id))
    return 0;
  double l = CROWDED * 0.5 * (c->d + s->d[id]);
  if (d2 < l * l) c->crowded = 1;
  if (c->want_at && d2 <= 1e-18 * c->d * c->d && fabs(s->d[id] - c->d) <= 1e-9 * c->d) c->at = id;
  return c->crowded && (!c->want_at || c->at >= 0);
}

/* 1 when a place is crowded; *at: a bubble of the same diameter standing on the place itself
 * (a curve's bubble where the lattice continues the boundary's spacing), or -1. */
static int crowded(const bub_state *s, int32_t face, const double x[3], double d, int32_t *at) {
  crowd c = {s, x, d, face, 0, at != NULL, -1};
  /* Grid radius >= d_j: the overlap query with radius 0.35 d returns every bubble within
   * 0.35 (d + d_j) (and more). */
  pm_grid_visit(s->grid, x, 0.5 * CROWDED * d, PM_GRID_OVERLAP, crowd_visit, &c);
  if (at) *at = c.at;
  return c.crowded;
}

/* The place at object-space offset dx from face point (par, der) on the face: 0 when the step
 * would leave it. */
static int step_from(const pm_cell *f, const double par[2], const double der[6], const double dx[3],
                     double out[2]) {
  double dpar[3] = {0, 0, 0};
  pm_cell_param_delta(f, par, der, dx, dpar);
  out[1] = 0;
  return pm_cell_move(f, par, dpar, out) == PM_MOVE_FREE;
}

static pm_status push(grow_ctx *g, int32_t id, int32_t i, int32_t j, const double e1[3]) {
  if (g->qn == g->qcap) {
    int64_t nc = g->qcap ? 2 * g->qcap : 1024;
    grow_item *nq = realloc(g->q, sizeof(grow_item) * (size_t)nc);
    if (!nq) return pm_error_setf(g->err, PM_ERR_NOMEM, "out of memory");
    g->q = nq, g->qcap = nc;
  }
  grow_item *it = &g->q[g->qn++];
  it->id = id, it->grain = g->grain, it->i = i, it->j = j;
  pm_v3_copy(it->e1, e1);
  return PM_OK;
}

static pm_status mark(grow_ctx *g, uint64_t key, int32_t id) {
  if (!pm_keyindex_reserve(&g->sites, g->sites.n + 1))
    return pm_error_setf(g->err, PM_ERR_NOMEM, "out of memory");
  pm_keyindex_put(&g->sites, key, id);
  return PM_OK;
}

/* A new bubble at par (not crowded), the grid and the queue. */
static pm_status add(grow_ctx *g, const double par[2], int32_t i, int32_t j, const double e1[3]) {
  bub_state *s = g->s;
  if (s->n >= g->cap)
    return pm_error_setf(g->err, PM_ERR_LIMIT, "bubble placement exceeds the cap of %lld bubbles (face %d)",
                         (long long)g->cap, g->f->tag);
  int32_t id;
  pm_status st = bub_state_add(s, BUB_KFACE, g->face, par, NULL, 0, &id, g->err);
  if (!st) st = pm_grid_insert(s->grid, id, &s->x[3 * id], s->grid_factor * s->d[id], g->err);
  if (!st) st = mark(g, site_key(g->grain, i, j), id);
  /* The row direction in the new tangent plane. */
  double n[3], e[3];
  pm_v3_copy(e, e1);
  if (!st && normal_at(s, id, n)) {
    pm_v3_axpy(e, e, -pm_v3_dot(e, n), n);
    if (!(pm_v3_normalize(e) > 0)) pm_v3_copy(e, e1);
  }
  if (!st) st = push(g, id, i, j, e);
  return st;
}

/* The object-space offset from bubble o (unit normal n) to a lattice place of diameter dc in
 * direction dir: dir x l0(o, place); with a second parent p (>= 0), the point of o's tangent plane
 * at l0 from both o and p on dir's side of the line o p (header, "two parents"), when there is
 * one. */
static void place_offset(const bub_state *s, int32_t o, int32_t p, const double n[3], const double dir[3],
                         double dc, double fit, double dx[3]) {
  const double lo = fit * 0.5 * (s->d[o] + dc);
  pm_v3_scale(dx, dir, lo);
  if (p < 0) return;
  const double lp = fit * 0.5 * (s->d[p] + dc);
  double b[3], w[3];
  pm_v3_sub(b, &s->x[3 * p], &s->x[3 * o]);
  pm_v3_axpy(b, b, -pm_v3_dot(b, n), n);
  const double B = pm_v3_normalize(b);
  if (!(B > 0)) return;
  const double a = (lo * lo - lp * lp + B * B) / (2 * B), h2 = lo * lo - a * a;
  if (!(h2 > 0.25 * lo * lo)) return; /* the parents too far apart, or too close: no triangle */
  pm_v3_cross(w, n, b);
  const double h = pm_v3_dot(w, dir) < 0 ? -sqrt(h2) : sqrt(h2);
  for (int q = 0; q < 3; ++q) dx[q] = a * b[q] + h * w[q];
}

/* The six lattice directions of item it: a bubble at each free place. With sites, a place is tried
 * only when its site (it's grain, axial coordinates) has not been tried before, and is marked. */
static pm_status try_six(grow_ctx *g, const grow_item *it, int sites) {
  bub_state *s = g->s;
  pm_status st = PM_OK;
  const int32_t o = it->id;
  double n[3], e2[3];
  if (!normal_at(s, o, n)) return PM_OK;
  pm_v3_cross(e2, n, it->e1);
  for (int k = 0; k < 6 && !st; ++k) {
    const int32_t i = it->i + DI[k], j = it->j + DJ[k];
    const uint64_t key = site_key(g->grain, i, j);
    if (sites && (pm_keyindex_get(&g->sites, key) != -1 || g->sites.n >= INT32_MAX / 2)) continue;
    const double ang = k * (M_PI / 3), c = cos(ang), sn = sin(ang);
    double dir[3], dx[3], par[2], x[3], dc;
    for (int q = 0; q < 3; ++q) dir[q] = c * it->e1[q] + sn * e2[q];
    /* The second parent (header, "two parents"): a placed bubble at a site next to both. */
    int32_t p2 = -1;
    if (sites && g->apex)
      for (int side = 1; side <= 5 && p2 < 0; side += 4) {
        const int32_t id = pm_keyindex_get(&g->sites, site_key(g->grain, it->i + DI[(k + side) % 6],
                                                               it->j + DJ[(k + side) % 6]));
        if (id >= 0 && id != UNUSABLE) p2 = id;
      }
    /* The stable distance to the place: d there from a first step of d(parent). */
    place_offset(s, o, p2, n, dir, s->d[o], g->fit, dx);
    int ok = step_from(g->f, &s->par[2 * o], &s->der[6 * o], dx, par);
    if (ok) {
      pm_cell_point(g->f, par, x);
      dc = pm_sizing_eval(s->size, x);
      ok = dc > 0 && isfinite(dc);
      if (ok && fabs(dc - s->d[o]) > 1e-3 * s->d[o]) {
        place_offset(s, o, p2, n, dir, dc, g->fit, dx);
        ok = step_from(g->f, &s->par[2 * o], &s->der[6 * o], dx, par);
        if (ok) {
          pm_cell_point(g->f, par, x);
          dc = pm_sizing_eval(s->size, x);
          ok = dc > 0 && isfinite(dc);
        }
      }
    }
    /* On a plane with holding, a bubble standing on the site (a curve's, where the lattice
     * continues the boundary's spacing) holds it for hold_interior. Planes have no second
     * parents, so growth does not read it. */
    const int holding = sites && s->affine[g->face] && !g->apex && s->p.hold_rings > 0;
    int32_t at = -1;
    if (ok) ok = pm_face_inside(g->f, par) && !crowded(s, g->face, x, dc, holding ? &at : NULL);
    if (ok) {
      st = add(g, par, i, j, it->e1);
    } else if (sites) {
      if (holding && at < 0) { /* the site on the border: the step to it was refused */
        double xp[3];
        pm_v3_add(xp, &s->x[3 * o], dx);
        crowded(s, g->face, xp, s->d[o], &at);
      }
      st = mark(g, key, at >= 0 ? at : UNUSABLE);
    }
  }
  return st;
}

/* Held bubbles (hold_rings R > 0, planes; header, "Holding"): a bubble of the face's queue whose
 * lattice sites within R rings (axial distance max(|a|, |b|, |a + b|) <= R) all hold bubbles of
 * its grain with its own diameter (to 1e-9) is marked BUB_FHOLD. Found in time linear in the
 * bubbles, whatever R: a placed site with a neighbour site empty, or holding a bubble of another
 * diameter, is an edge of the region; a bubble is held when no edge lies within R - 1 steps of
 * it, the steps counted breadth first from every edge through placed sites (the nearest edge is
 * reached through placed sites only, so that count is the axial distance). The sites are the
 * queue's and those of the border bubbles marked on sites next to them. */
typedef struct hold_site {
  int32_t grain, i, j, id, dist;
} hold_site;

static int32_t site_id(const grow_ctx *g, int32_t grain, int32_t i, int32_t j) {
  const int32_t id = pm_keyindex_get(&g->sites, site_key(grain, i, j));
  return id >= 0 && id != UNUSABLE ? id : -1;
}

static pm_status hold_interior(grow_ctx *g, int R) {
  bub_state *s = g->s;
  const int64_t cap = 7 * g->qn + 1;
  if (cap > INT32_MAX / 2) return PM_OK; /* beyond the site index's range: nothing held */
  hold_site *v = malloc(sizeof(hold_site) * (size_t)cap);
  int32_t *order = malloc(sizeof(int32_t) * (size_t)cap);
  pm_keyindex at = {0}; /* site key -> index in v */
  if (!v || !order || !pm_keyindex_reserve(&at, (int32_t)cap)) {
    free(v), free(order), pm_keyindex_free(&at);
    return pm_error_setf(g->err, PM_ERR_NOMEM, "out of memory");
  }
  int32_t n = 0;
  for (int64_t k = 0; k < g->qn; ++k)
    for (int q = -1; q < 6; ++q) {
      const grow_item *it = &g->q[k];
      const int32_t i = it->i + (q < 0 ? 0 : DI[q]), j = it->j + (q < 0 ? 0 : DJ[q]);
      const int32_t id = q < 0 ? it->id : site_id(g, it->grain, i, j);
      const uint64_t key = site_key(it->grain, i, j);
      if (id < 0 || pm_keyindex_get(&at, key) >= 0) continue;
      pm_keyindex_put(&at, key, n);
      v[n++] = (hold_site){it->grain, i, j, id, -1};
    }
  int32_t head = 0, tail = 0;
  for (int32_t k = 0; k < n; ++k) {
    const double d = s->d[v[k].id];
    for (int q = 0; q < 6 && v[k].dist < 0; ++q) {
      const int32_t id = site_id(g, v[k].grain, v[k].i + DI[q], v[k].j + DJ[q]);
      if (id < 0 || fabs(s->d[id] - d) > 1e-9 * d) v[k].dist = 0, order[tail++] = k;
    }
  }
  while (head < tail) {
    const hold_site *c = &v[order[head++]];
    for (int q = 0; q < 6; ++q) {
      const int32_t k = pm_keyindex_get(&at, site_key(c->grain, c->i + DI[q], c->j + DJ[q]));
      if (k >= 0 && v[k].dist < 0) v[k].dist = c->dist + 1, order[tail++] = k;
    }
  }
  /* (a site no edge reaches lies in a region with no edge at all: held) */
  for (int64_t k = 0; k < g->qn; ++k) {
    const int32_t x = pm_keyindex_get(&at, site_key(g->q[k].grain, g->q[k].i, g->q[k].j));
    if (v[x].dist < 0 || v[x].dist >= R) s->flags[g->q[k].id] |= BUB_FHOLD;
  }
  free(v), free(order), pm_keyindex_free(&at);
  return PM_OK;
}

/* Grow the current grain breadth first from the queue's items from head on (and from every item
 * added meanwhile). */
static pm_status grow(grow_ctx *g, int64_t head) {
  pm_status st = PM_OK;
  for (; head < g->qn && !st; ++head) {
    const grow_item it = g->q[head];
    st = try_six(g, &it, 1);
  }
  return st;
}

typedef struct chord_list {
  bub_chord *c;
  int32_t n, cap;
} chord_list;

static pm_status collect(bub_state *s, const bub_chord *c, void *user, pm_error *err) {
  (void)s;
  chord_list *l = user;
  if (l->n == l->cap) {
    int32_t nc = l->cap ? 2 * l->cap : 256;
    bub_chord *np = realloc(l->c, sizeof(bub_chord) * (size_t)nc);
    if (!np) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    l->c = np, l->cap = nc;
  }
  l->c[l->n++] = *c;
  return PM_OK;
}

/* Seed order of a face's chords [lo, hi): the longest curve's (most chords) first, from its
 * middle chord outwards, then the others in loop order. */
typedef struct seed_key {
  int32_t rank, dist, idx;
} seed_key;

static int cmp_seed(const void *a, const void *b) {
  const seed_key *x = a, *y = b;
  if (x->rank != y->rank) return x->rank - y->rank;
  if (x->dist != y->dist) return x->dist - y->dist;
  return x->idx - y->idx;
}

/* The seed of chord c: the apex of the equilateral triangle on it, inside the face (its height
 * from the chord's length, which the curve's placement made the stable distance). */
static int seed_of(const bub_state *s, const pm_cell *f, const bub_chord *c, double par[2]) {
  pm_face_point fp;
  pm_face_eval(f, c->uv, 1, &fp);
  double der[6] = {fp.su[0], fp.su[1], fp.su[2], fp.sv[0], fp.sv[1], fp.sv[2]};
  /* From the chord's midpoint on the face (its pcurves' midpoint, on the border). */
  double mid[3], dx[3], x0[3];
  pm_v3_add(mid, &s->x[3 * c->A], &s->x[3 * c->B]);
  pm_v3_scale(mid, mid, 0.5);
  pm_v3_axpy(x0, mid, -0.86602540378443865 * c->len, c->w);
  pm_v3_sub(dx, x0, fp.p);
  return step_from(f, c->uv, der, dx, par) && pm_face_inside(f, par);
}

/* ---- curves ------------------------------------------------------------------------------- */

/* The integral of |C'| / d along curve c from lo to t at n + 1 equally spaced parameters (the
 * trapezoidal rule), into I[0..n]; 0 when the size field fails somewhere. */
static int curve_table(const bub_state *s, const pm_cell *c, int64_t n, double *I) {
  double prev = 0, t0 = c->lo[0], h = (c->hi[0] - c->lo[0]) / (double)n;
  I[0] = 0;
  for (int64_t k = 0; k <= n; ++k) {
    pm_curve_point cp;
    pm_curve_eval(c, t0 + h * (double)k, 1, &cp);
    double d = pm_sizing_eval(s->size, cp.p);
    if (!(d > 0) || !isfinite(d)) return 0;
    double g = pm_v3_norm(cp.d1) / d;
    if (k > 0) I[k] = I[k - 1] + 0.5 * h * (prev + g);
    prev = g;
  }
  return 1;
}

pm_status bub_place_curve_lattice(const bub_state *s, int32_t curve, int64_t cap, double **t,
                                  int32_t *nt, pm_error *err) {
  *t = NULL, *nt = 0;
  const pm_cell *c = pm_model_cell(s->model, PM_CURVE, curve);
  if (c->degenerate || !(c->hi[0] > c->lo[0])) return PM_OK;
  /* A coarse table for the count, then one fine enough to place it (8 samples per bubble). */
  double coarse[65];
  if (!curve_table(s, c, 64, coarse))
    return pm_error_setf(err, PM_ERR_ARG, "the size field is not finite and > 0 on curve %d", c->tag);
  double total = coarse[64];
  if (!(total < (double)cap + 2))
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "bubble placement exceeds the cap of %lld bubbles (curve %d asks for %.3g)",
                         (long long)cap, c->tag, total);
  int64_t nseg = (int64_t)floor(total + 0.5);
  if (nseg < 1) nseg = 1;
  const int64_t fine = 8 * nseg + 64;
  double *I = malloc(sizeof(double) * ((size_t)fine + 1));
  if (!I) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  if (!curve_table(s, c, fine, I)) {
    free(I);
    return pm_error_setf(err, PM_ERR_ARG, "the size field is not finite and > 0 on curve %d", c->tag);
  }
  /* The equilibrium of a chain between fixed ends: equal steps of the integral (bub_population.c,
   * "curve chains"), bubbles at I = k I(hi) / nseg. The fine integral can exceed the coarse one
   * (table.brep: a curve's count grew by one), so the count and the cap are taken again. */
  total = I[fine];
  if (!(total < (double)cap + 2)) {
    free(I);
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "bubble placement exceeds the cap of %lld bubbles (curve %d asks for %.3g)",
                         (long long)cap, c->tag, total);
  }
  nseg = (int64_t)floor(total + 0.5);
  if (nseg < 1) nseg = 1;
  double *out = malloc(sizeof(double) * ((size_t)nseg + 1));
  if (!out) {
    free(I);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  const double h = (c->hi[0] - c->lo[0]) / (double)fine;
  int64_t at = 0;
  int32_t n = 0;
  for (int64_t k = 1; k < nseg; ++k) {
    double want = total * (double)k / (double)nseg;
    while (at + 1 < fine && I[at + 1] < want) ++at;
    double span = I[at + 1] - I[at], f = span > 0 ? (want - I[at]) / span : 0;
    out[n++] = c->lo[0] + h * ((double)at + f);
  }
  free(I);
  *t = out, *nt = n;
  return PM_OK;
}

/* ---- faces -------------------------------------------------------------------------------- */

pm_status bub_place_lattice(bub_state *s, int64_t cap, pm_error *err) {
  const pm_model *m = s->model;
  chord_list cl = {0};
  pm_status st = bub_for_each_chord(s, collect, &cl, err);
  int32_t *cstart = calloc((size_t)m->count[PM_FACE] + 2, sizeof(int32_t));
  seed_key *keys = malloc(sizeof(seed_key) * ((size_t)cl.n + 1));
  int32_t *ncurve = calloc((size_t)m->count[PM_CURVE] + 1, sizeof(int32_t));
  if (!st && (!cstart || !keys || !ncurve)) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t k = 0; k < cl.n && !st; ++k) cstart[cl.c[k].face + 1]++;
  for (int32_t f = 0; f < m->count[PM_FACE] && !st; ++f) cstart[f + 1] += cstart[f];
  grow_ctx g = {0};
  g.fit = 1;
  g.s = s, g.cap = cap, g.err = err;
  for (int32_t f = 0; f < m->count[PM_FACE] && !st; ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    if (fc->nloop == 0) continue;
    g.f = fc, g.face = f, g.grain = 0, g.qn = 0;
    g.apex = s->p.lattice_apex && !s->affine[f];
    pm_keyindex_free(&g.sites);
    const int32_t lo = cstart[f], hi = cstart[f + 1];
    /* Seed order: chords per curve, the curve's middle chord. */
    for (int32_t k = lo; k < hi; ++k) ncurve[cl.c[k].curve] = 0;
    for (int32_t k = lo; k < hi; ++k) ncurve[cl.c[k].curve]++;
    int32_t best = -1;
    for (int32_t k = lo; k < hi; ++k)
      if (best < 0 || ncurve[cl.c[k].curve] > ncurve[cl.c[best].curve]) best = k;
    int32_t pos = 0, mid_at = 0;
    for (int32_t k = lo; k < hi; ++k) /* the middle chord of the best curve */
      if (best >= 0 && cl.c[k].curve == cl.c[best].curve && pos++ == ncurve[cl.c[best].curve] / 2) mid_at = k;
    int32_t nk = 0;
    for (int32_t k = lo; k < hi; ++k) {
      int same = best >= 0 && cl.c[k].curve == cl.c[best].curve;
      keys[nk++] = (seed_key){same ? 0 : 1, same ? abs(k - mid_at) : 0, k};
    }
    qsort(keys, (size_t)nk, sizeof(seed_key), cmp_seed);
    for (int32_t q = 0; q < nk && !st; ++q) {
      const bub_chord *c = &cl.c[keys[q].idx];
      double par[2], x[3];
      if (!seed_of(s, fc, c, par)) continue;
      pm_cell_point(fc, par, x);
      double d = pm_sizing_eval(s->size, x);
      if (!(d > 0) || !isfinite(d) || crowded(s, f, x, d, NULL)) continue;
      int64_t head = g.qn;
      g.fit = 1; /* (header, "Fit") */
      if (s->p.lattice_fit && s->affine[f]) {
        const double r = c->len / (0.5 * (s->d[c->A] + s->d[c->B]));
        if (fabs(r - 1) < LATTICE_FIT_MAX) g.fit = r;
      }
      st = add(&g, par, 0, 0, c->e);
      if (!st) st = grow(&g, head);
      g.grain++;
    }
    /* No border chord (a closed surface of seams only): one seed at the box centre. */
    if (!st && nk == 0) {
      double par[2] = {0.5 * (fc->lo[0] + fc->hi[0]), 0.5 * (fc->lo[1] + fc->hi[1])}, x[3];
      pm_cell_point(fc, par, x);
      double d = pm_sizing_eval(s->size, x);
      if (pm_face_inside(fc, par) && d > 0 && isfinite(d) && !crowded(s, f, x, d, NULL)) {
        pm_face_point fp;
        pm_face_eval(fc, par, 1, &fp);
        double e1[3];
        pm_v3_copy(e1, fp.su);
        if (!(pm_v3_normalize(e1) > 0)) pm_v3_copy(e1, fp.sv), pm_v3_normalize(e1);
        st = add(&g, par, 0, 0, e1);
        if (!st) st = grow(&g, 0);
      }
    }
    if (!st && s->affine[f] && s->p.hold_rings > 0) st = hold_interior(&g, s->p.hold_rings);
    /* Curved faces: where the face bent the lattice so that a site was found crowded while a
     * place next to it is free, every bubble of the face tries its six directions again,
     * whatever the sites' numbers say (a grain of its own each, so no site is looked up), then
     * every bubble so added, up to 4 passes. (A bubble tried once need not be tried again:
     * bubbles added since only crowd its places more. Planes keep their grains: a gap between
     * two is a grain boundary population control fills as well.) */
    for (int64_t from = 0, to = g.qn, pass = 0; pass < 4 && from < to && !st && !s->affine[f]; ++pass) {
      for (int64_t k = from; k < to && !st; ++k) {
        grow_item it = g.q[k];
        it.i = it.j = 0;
        ++g.grain;
        st = try_six(&g, &it, 0);
      }
      from = to, to = g.qn;
    }
  }
  free(g.q);
  pm_keyindex_free(&g.sites);
  free(cl.c), free(cstart), free(keys), free(ncurve);
  return st;
}
