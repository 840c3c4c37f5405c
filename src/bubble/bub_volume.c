/* The volume phase of the bubble method (papers/003 sections 3.1-3.5: bubbles are packed on
 * vertices, curves, faces and volumes in ascending order of dimension).
 *
 * Order. Vertex, curve and face bubbles are relaxed and controlled first (bub_run.c); they do not
 * feel volume bubbles (000 section 4.2.2 carried up one dimension, bub_state.c), so once settled
 * they are frozen and the surface mesh is connected from them -- the very surface TetGen receives
 * in the end. That mesh is the volume's walls (volume_inside.h): a point is inside a volume when
 * it is inside that closed triangle mesh, tested exactly. Then volume bubbles are placed, relaxed
 * and controlled with the faces' dynamics and population control.
 *
 * Placement: an octree of rhombohedra. 000 section 4.1.1 lays a face's quadtree out in 60-degree
 * rhombi, so that the corners of the leaves form a hexagonal (close-packed) lattice where the
 * leaves have one size. Carried to 3D: the cell is the rhombohedron spanned by three unit vectors
 * at 60 degrees to each other,
 *     a1 = (1, 0, 0),  a2 = (1/2, sqrt3/2, 0),  a3 = (1/2, sqrt3/6, sqrt(2/3)),
 * the primitive cell of the face-centred cubic lattice: its corners and those of its eight
 * half-size sub-cells (split at the edge midpoints, as the rhombi are) are FCC lattice points, a
 * close packing in which every point has 12 neighbours at the lattice distance, all along cell
 * edges or the short face diagonals. A cell is split in eight while for some edge (Pi, Pj)
 * w2 |PiPj| > ri + rj (003 section 3.2 and 000 eq. 4.1 with 004's weight w2, as on faces; the
 * face diagonals are not checked, as there). Cells are BOUNDARY when some wall triangle comes
 * within the cell's circumscribed ball (its centroid closer to the walls than its farthest
 * corner), else IN or OUT by the inside test of the centroid; OUT cells are dropped, sub-cells of
 * an IN cell are IN. The bubbles are the leaf corners, those of BOUNDARY leaves tested one by one.
 * Lattice points are named by integer coordinates on the finest level (20 levels below the root),
 * so a corner shared by several cells is one bubble.
 *
 * Choices where the papers are silent (the face rules of bub_place.c carried up):
 *   - a corner closer to the walls than half its diameter, or closer than half the stable
 *     distance to a vertex, curve or face bubble of the volume's closure, is not used (it would
 *     start squeezed against the wall, where the face bubbles' saturated force has no useful
 *     direction); nor one closer than a quarter of the stable distance to another volume bubble;
 *   - a corner where the size field is not positive takes the mean diameter of the volume's face
 *     bubbles.
 *
 * The rule for a step that would leave the volume (bub_volume_move), one rule for every step:
 * the step from x0 to x0 + dx is taken when its segment meets no wall (bounding or embedded face
 * triangle, exact test) and its end is at least BUB_VMARGIN = 1/4 of the bubble's diameter from
 * the walls; otherwise the step is halved, up to four times, and the first half that passes is
 * taken; if none does, the bubble stays. A bubble whose step was cut stops (velocity zero in
 * bub_dynamics.c): the faces' "clip to the boundary and stop" of geom.h. A volume bubble
 * therefore never leaves its volume (it starts inside and never crosses a wall) and never comes
 * nearer than a quarter diameter to a wall (where its tets would be flat); in a relaxed packing
 * the face bubbles keep it about 0.8 d away (the distance between close-packed layers), so the
 * rule only acts on the transient after placement and insertion. Cost: each bubble keeps a lower
 * bound on its distance to the walls; a step shorter than that bound minus the margin needs no
 * query, so bubbles away from the walls cost O(1) per step, the others a BVH query.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/keyindex.h"
#include "common/base/vec3.h"

/* ---- the phase and the rule ------------------------------------------------------------------ */

pm_status bub_volume_begin(bub_state *s, const pm_mesh *surface, pm_error *err) {
  const pm_model *m = s->model;
  int32_t nvol = m->count[PM_VOLUME];
  if (!s->shell) {
    s->shell = calloc((size_t)nvol + 1, sizeof(pm_volume_shell *));
    if (!s->shell) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t v = 0; v < nvol; ++v) {
    pm_volume_shell_destroy(s->shell[v]);
    s->shell[v] = NULL;
    pm_status st = pm_volume_shell_create(m, surface, v, &s->shell[v], err);
    if (st) return pm_error_prefix(err, "bubble: the walls of volume %d", m->cells[PM_VOLUME][v].tag);
  }
  s->volume_phase = 1;
  s->round0 = s->round;
  s->steps_in_round = 0;
  s->odd_active = 0;
  s->lists_valid = 0;
  for (int32_t i = 0; i < s->n; ++i) {
    pm_v3_zero(&s->v[3 * i]);
    s->flags[i] &= (uint8_t)~BUB_FODD;
  }
  return PM_OK;
}

int bub_volume_move(bub_state *s, int32_t i, const double x0[3], const double dx[3], double x1[3]) {
  const pm_volume_shell *sh = s->shell[s->cell[i]];
  const double L = pm_v3_norm(dx), d = s->d[i], margin = BUB_VMARGIN * d;
  if (s->wall[i] - L >= margin) { /* far from every wall: nothing to test */
    pm_v3_add(x1, x0, dx);
    s->wall[i] -= L;
    return PM_MOVE_FREE;
  }
  const double reach = margin + 2 * d; /* distances beyond this are not needed exactly */
  double f = 1;
  for (int k = 0; k < 5; ++k, f *= 0.5) {
    double xt[3];
    pm_v3_axpy(xt, x0, f, dx);
    double dist = pm_volume_shell_distance(sh, xt, reach);
    if (dist < margin) continue;
    if (!(s->wall[i] > f * L) && pm_volume_shell_segment_meets(sh, x0, xt)) continue;
    pm_v3_copy(x1, xt);
    s->wall[i] = isfinite(dist) ? dist : reach;
    return k == 0 ? PM_MOVE_FREE : PM_MOVE_CLIPPED;
  }
  pm_v3_copy(x1, x0);
  return PM_MOVE_CLIPPED;
}

int bub_volume_place_ok(const bub_state *s, int32_t volume, const double x0[3], const double x[3],
                        double d) {
  const pm_volume_shell *sh = s->shell[volume];
  if (pm_volume_shell_distance(sh, x, BUB_VMARGIN * d) < BUB_VMARGIN * d) return 0;
  return !pm_volume_shell_segment_meets(sh, x0, x);
}

/* ---- the octree of rhombohedra ---------------------------------------------------------------- */

#define OT_LEVELS 20 /* depth cap below the root; coordinates up to 2^20 fit 21 bits */

static const double A[3][3] = {/* columns a1, a2, a3 */
                               {1.0, 0.5, 0.5},
                               {0.0, 0.86602540378443865, 0.28867513459481287},
                               {0.0, 0.0, 0.81649658092772603}};

typedef struct opoint {
  uint64_t key;
  double x[3], d;
  uint8_t used; /* 1: corner of an IN leaf; 2: corner of a BOUNDARY leaf only */
} opoint;

typedef struct oct_ctx {
  bub_state *s;
  int32_t vol;
  const pm_volume_shell *sh;
  double origin[3]; /* lattice coordinates of the root's corner */
  double h;         /* lattice step on the finest level */
  double dref;
  opoint *pts;
  int32_t npts, cap_pts;
  pm_keyindex index;  /* lattice key -> point */
  int64_t budget;
  pm_status st;
  pm_error *err;
} oct_ctx;

static void lattice_xyz(const oct_ctx *o, double i, double j, double k, double x[3]) {
  double l[3] = {o->origin[0] + i * o->h, o->origin[1] + j * o->h, o->origin[2] + k * o->h};
  for (int r = 0; r < 3; ++r) x[r] = A[r][0] * l[0] + A[r][1] * l[1] + A[r][2] * l[2];
}

static int32_t lattice_point(oct_ctx *o, int64_t i, int64_t j, int64_t k) {
  if (o->st) return -1;
  uint64_t key = (uint64_t)i | ((uint64_t)j << 21) | ((uint64_t)k << 42);
  if (!pm_keyindex_reserve(&o->index, o->npts + 1)) {
    o->st = pm_error_setf(o->err, PM_ERR_NOMEM, "out of memory");
    return -1;
  }
  int32_t found = pm_keyindex_get(&o->index, key);
  if (found >= 0) return found;
  if (o->npts >= o->budget) {
    o->st = pm_error_setf(o->err, PM_ERR_LIMIT,
                          "bubble placement in volume %d: the octree exceeds %lld lattice points",
                          o->s->model->cells[PM_VOLUME][o->vol].tag, (long long)o->budget);
    return -1;
  }
  if (o->npts == o->cap_pts) {
    int32_t nc = o->cap_pts ? 2 * o->cap_pts : 1024;
    opoint *np = realloc(o->pts, sizeof(opoint) * (size_t)nc);
    if (!np) {
      o->st = pm_error_setf(o->err, PM_ERR_NOMEM, "out of memory");
      return -1;
    }
    o->pts = np, o->cap_pts = nc;
  }
  int32_t id = o->npts++;
  opoint *q = &o->pts[id];
  q->key = key;
  lattice_xyz(o, (double)i, (double)j, (double)k, q->x);
  double d = pm_sizing_eval(o->s->size, q->x);
  q->d = (d > 0 && isfinite(d)) ? d : o->dref;
  q->used = 0;
  pm_keyindex_put(&o->index, key, id);
  return id;
}

enum { OCT_IN = 1, OCT_BOUNDARY = 2 };

/* The 12 edges of a cell by corner index (bit 0: +a1, bit 1: +a2, bit 2: +a3). */
static const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                 {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

/* Classify the cell with corner (i, j, k) and side 2^lev steps: OCT_IN, OCT_BOUNDARY or 0 (OUT). */
static int classify(oct_ctx *o, int64_t i, int64_t j, int64_t k, int lev) {
  double sz = (double)((int64_t)1 << lev), c[3], R = 0;
  lattice_xyz(o, (double)i + 0.5 * sz, (double)j + 0.5 * sz, (double)k + 0.5 * sz, c);
  for (int q = 0; q < 8; ++q) {
    double x[3];
    lattice_xyz(o, (double)i + (q & 1) * sz, (double)j + ((q >> 1) & 1) * sz, (double)k + ((q >> 2) & 1) * sz, x);
    R = fmax(R, pm_v3_dist(c, x));
  }
  if (isfinite(pm_volume_shell_distance(o->sh, c, R * (1 + 1e-9)))) return OCT_BOUNDARY;
  return pm_volume_shell_inside(o->sh, c) == 1 ? OCT_IN : 0;
}

static void oct_cell(oct_ctx *o, int64_t i, int64_t j, int64_t k, int lev, int state) {
  if (o->st) return;
  int64_t sz = (int64_t)1 << lev;
  int32_t c[8];
  for (int q = 0; q < 8; ++q)
    c[q] = lattice_point(o, i + (q & 1) * sz, j + ((q >> 1) & 1) * sz, k + ((q >> 2) & 1) * sz);
  if (o->st) return;
  int split = 0;
  for (int e = 0; e < 12 && !split; ++e) {
    const opoint *a = &o->pts[c[edges[e][0]]], *b = &o->pts[c[edges[e][1]]];
    if (o->s->p.w2 * pm_v3_dist(a->x, b->x) > 0.5 * (a->d + b->d)) split = 1;
  }
  if (!split || lev == 0) {
    for (int q = 0; q < 8; ++q) {
      uint8_t *u = &o->pts[c[q]].used;
      if (state == OCT_IN) *u = OCT_IN;
      else if (*u != OCT_IN) *u = OCT_BOUNDARY;
    }
    return;
  }
  int64_t half = sz >> 1;
  for (int q = 0; q < 8 && !o->st; ++q) {
    int64_t si = i + (q & 1) * half, sj = j + ((q >> 1) & 1) * half, sk = k + ((q >> 2) & 1) * half;
    int sub = state == OCT_IN ? OCT_IN : classify(o, si, sj, sk, lev - 1);
    if (sub) oct_cell(o, si, sj, sk, lev - 1, sub);
  }
}

static int cmp_key(const void *a, const void *b) {
  uint64_t x = ((const opoint *)a)->key, y = ((const opoint *)b)->key;
  return (x > y) - (x < y);
}

static pm_status place_volume(bub_state *s, int32_t vol, int64_t cap, pm_error *err) {
  const pm_model *m = s->model;
  const pm_cell *vc = pm_model_cell(m, PM_VOLUME, vol);
  oct_ctx o;
  memset(&o, 0, sizeof o);
  o.s = s, o.vol = vol, o.sh = s->shell[vol], o.err = err;
  o.budget = 16 * (cap - s->n) + 4096;
  /* The root: the lattice-coordinate box of the volume's box (B = A^-1 applied to its corners). */
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int q = 0; q < 8; ++q) {
    double x[3] = {vc->box[(q & 1) ? 3 : 0], vc->box[((q >> 1) & 1) ? 4 : 1], vc->box[((q >> 2) & 1) ? 5 : 2]};
    double l[3];
    l[2] = x[2] / A[2][2];
    l[1] = (x[1] - A[1][2] * l[2]) / A[1][1];
    l[0] = x[0] - A[0][1] * l[1] - A[0][2] * l[2];
    for (int r = 0; r < 3; ++r) lo[r] = fmin(lo[r], l[r]), hi[r] = fmax(hi[r], l[r]);
  }
  double S = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
  if (!(S > 0) || !isfinite(S)) return PM_OK;
  double pad = 1e-3 * S;
  for (int r = 0; r < 3; ++r) o.origin[r] = lo[r] - pad;
  S += 2 * pad;
  o.h = S / (double)((int64_t)1 << OT_LEVELS);
  /* The reference diameter: the mean over the volume's face, curve and vertex bubbles. */
  double sum = 0;
  int32_t cnt = 0;
  for (int32_t i = 0; i < s->nf; ++i)
    if (bub_related_cell(s, BUB_KVOLUME, vol, i)) sum += s->d[i], ++cnt;
  o.dref = cnt ? sum / cnt : m->diagonal / 30;

  int root = classify(&o, 0, 0, 0, OT_LEVELS);
  if (root) oct_cell(&o, 0, 0, 0, OT_LEVELS, root);
  pm_status st = o.st;
  if (!st) qsort(o.pts, (size_t)o.npts, sizeof(opoint), cmp_key);
  pm_idbuf buf = PM_IDBUF_INIT;
  for (int32_t q = 0; q < o.npts && !st; ++q) {
    const opoint *pt = &o.pts[q];
    if (!pt->used) continue;
    double d;
    double v = pm_sizing_eval(s->size, pt->x);
    if (!(v > 0) || !isfinite(v)) {
      if (pt->used == OCT_BOUNDARY) continue; /* a point outside the field's domain */
      st = bub_size_at(s, pt->x, &d, err);
      break;
    }
    d = v;
    double wall = pm_volume_shell_distance(o.sh, pt->x, 2.5 * d);
    if (wall < 0.5 * d) continue;
    if (pt->used == OCT_BOUNDARY && pm_volume_shell_inside(o.sh, pt->x) != 1) continue;
    int skip = 0;
    st = bub_place_crowded(s, BUB_KVOLUME, vol, pt->x, d, &buf, &skip, err);
    if (st || skip) continue;
    if (s->n >= cap) {
      st = pm_error_setf(err, PM_ERR_LIMIT,
                         "bubble placement exceeds the cap of %lld bubbles (volume %d)",
                         (long long)cap, vc->tag);
      break;
    }
    int32_t id;
    st = bub_state_add(s, BUB_KVOLUME, vol, NULL, pt->x, 0, &id, err);
    if (!st) {
      s->wall[id] = isfinite(wall) ? wall : 2.5 * d;
      st = pm_grid_insert(s->grid, id, &s->x[3 * id], s->grid_factor * s->d[id], err);
    }
  }
  pm_idbuf_free(&buf);
  free(o.pts), pm_keyindex_free(&o.index);
  return st;
}

pm_status bub_place_volumes(bub_state *s, pm_error *err) {
  if (!s->volume_phase || !s->shell)
    return pm_error_setf(err, PM_ERR_INTERNAL, "bubble: volume placement before the volume phase");
  int64_t cap = (int64_t)fmin(s->p.max_bubbles, 2e9);
  pm_status st = bub_state_grid_rebuild(s, err);
  for (int32_t v = 0; v < s->model->count[PM_VOLUME] && !st; ++v) st = place_volume(s, v, cap, err);
  if (st) return st;
  return bub_state_order(s, err);
}
