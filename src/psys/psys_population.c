/* Splitting and deleting (papers/001 eq. 3-6): the particle count follows the energy density.
 *
 * Each movable particle draws eps uniform in [0, 1) from its own stream (seed, serial,
 * iteration) and forms E* = E_i (1 + a eps) (eq. 3); with E_ideal = sigma_i 6 E(beta) (eq. 6) it
 * splits when E* < 0.35 a E_ideal (eq. 4) and is deleted when E* > 1.75 E_ideal / a (eq. 5).
 * a is the annealing weight of psys_phases.c: 1 gives the paper's rules; as the phase converges a
 * falls towards 0, the bias fades and the thresholds move apart until splits and deletes stop
 * (section 3: "this bias can be adjusted to stop splits and deletes all together, ensuring
 * termination"; the schedule is ours).
 *
 * E_ideal on curves (ours). Eq. 6 counts the six particles of a hexagonal one-ring; a curve
 * particle of an ideal chain has two neighbours, so with the paper's 6 the curves are split down
 * to a spacing about 0.55 sigma while the faces settle near 0.66 sigma, and the boundary rows of
 * triangles are squeezed (R / l_min 0.72 against 0.61 inside, measured on a planar square). We
 * use E_ideal = sigma ring_curve E(beta) on curves, ring_curve = 0.7: a curve then settles at the
 * faces' spacing, and the first row of face particles near the height of an equilateral
 * triangle. On case:qi1 with --size 0.05: median segment 0.0506 against 0.0501 for the edges
 * between face nodes, first row at a median height of 0.875 spacings (equilateral: 0.866), and
 * a median R / l_min of 0.595 for the triangles with a corner on a curve (gmsh's
 * Frontal-Delaunay: 0.595); with 1.5, 0.0464, 0.912 and 0.633. With the inferred field the
 * median over all triangles falls by 0.010 to 0.012 on synth_box_hole.step, cube_fillet.stp,
 * screw.step and synth_torus.brep, and by 0.001 on t20_component8.step (`packmesh quality` on
 * the meshes of `packmesh mesh MODEL --method psys --set ring_curve=0.7`, against 1.5). Below
 * 0.7 the curves get longer than the faces' spacing (0.6: 0.0514 on qi1) and the boundary rows
 * worse again.
 *
 * Order (ours; the paper is silent): particles are visited in index order, one thread. A particle
 * whose neighbourhood changed in this pass (a neighbour split or was deleted) waits for the next
 * iteration: its energy no longer describes its surroundings, and acting on it would delete both
 * particles of a crowded pair or split both sides of a hole.
 *
 * Empty cells (ours). A curve or face whose particles all went (before the last-particle rule
 * below could hold one, when its sigma was larger) gets one particle again, at the middle of a
 * curve or at a random point of a face, once it extends over more than two ideal spacings of its
 * end vertices: only particles split, so an empty cell would stay empty however fine the field
 * around it becomes.
 *
 * Gaps along curves (ours). A curve starts from one particle at its middle (section 4.1), and
 * eq. 4 grows it outward one particle per front every few iterations: a long curve, or one whose
 * sigma shrinks towards a sharp vertex (Lipschitz), needed more iterations than a phase allows,
 * and was left with empty ends (the bottle's thread helices: 11 long, with a sigma of 1.5; the
 * faces along them folded over). In phases 1-2, two consecutive particles of a curve (its end
 * vertices included, in parameter order) more than 1.2 sigma apart -- the larger sigma of the
 * two; they do not interact at all beyond 1 -- get a particle at the middle of their parameter
 * interval, so a gap halves every iteration. The paper remarks (section 5) that its naive seeding
 * makes particles "generated during the early stages" and that bootstrapping would help; this is
 * the least of that.
 *
 * The last particle of a cell (ours). Particles of different cells repel each other in world
 * space, and before the gap size is known (phase 1) the particle of a long curve can sit within
 * a far smaller distance than its sigma of another curve's particle (the two outlines of a thin
 * plate); the pair's energy then deletes one of them, and a curve left without particles can
 * never get one back (only particles split). So the last particle of a curve or face is not
 * deleted while the cell extends over more than two ideal spacings, 2 beta sigma_i (arc length
 * of a curve, box diagonal of a face); the gap size of phase 2 then lowers its sigma and it
 * splits like the others.
 *
 * Grace (ours). A split or a delete changes the energies around it at once, while the moves
 * that even the spacing out again spread over a few iterations: a child that halves a gap of a
 * curve leaves its neighbours crowded until the chain has relaxed, and deleting them then
 * undoes the split (on long curves half the splits were undone so). So the particles around a
 * split or a delete, and the child, are not deleted for the next delete_grace (3) iterations.
 *
 * Face particles on the boundary (ours). A face particle within 0.15 sigma of its face's
 * boundary polyline (a seed or a child placed there, or one that slid between two curve
 * particles before its step rule held it) is deleted whatever its energy: in line with the
 * boundary nodes it would make a needle triangle.
 *
 * Where a split puts the child (ours): at the ideal lattice distance beta sigma_i from the parent,
 * along the parent's force projected on its cell (the force points away from the
 * neighbours, towards the empty side); when that force vanishes (a lone particle), along a random
 * tangent direction from the particle's stream. The child is placed through pm_cell_displace, so
 * it never leaves the cell; if the cell stops it (an end of a curve, a trim boundary), the other
 * direction is tried, and the split is dropped when neither gives room.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"
#include "psys/psys_private.h"

enum { RND_EPS = 1, RND_DIR = 2 };

/* The unit direction (3D, tangent to the cell) along which particle i splits. */
static void split_direction(const psys_sys *s, int32_t i, double dir[3]) {
  const double *f = &s->force[3 * i], *d = &s->deriv[6 * i];
  double t[3];
  if (s->dim[i] == PM_CURVE) {
    double g = pm_v3_dot(d, d), ft = g > 0 ? pm_v3_dot(f, d) / g : 0;
    pm_v3_scale(t, d, ft);
  } else {
    double nrm[3];
    pm_v3_cross(nrm, d, d + 3);
    pm_v3_normalize(nrm);
    pm_v3_axpy(t, f, -pm_v3_dot(f, nrm), nrm);
  }
  if (pm_v3_normalize(t) > 1e-9 * (pm_v3_norm(f) + 1e-300) && pm_v3_norm(f) > 1e-12) {
    pm_v3_copy(dir, t);
    return;
  }
  double r = psys_random(s, i, RND_DIR);
  if (s->dim[i] == PM_CURVE) {
    pm_v3_copy(dir, d);
    pm_v3_normalize(dir);
    if (r < 0.5) pm_v3_scale(dir, dir, -1.0);
    return;
  }
  double e1[3], e2[3], nrm[3];
  pm_v3_copy(e1, d);
  if (pm_v3_normalize(e1) == 0) pm_v3_copy(e1, d + 3), pm_v3_normalize(e1);
  pm_v3_cross(nrm, d, d + 3);
  pm_v3_normalize(nrm);
  pm_v3_cross(e2, nrm, e1);
  double th = 2 * M_PI * r;
  for (int k = 0; k < 3; ++k) dir[k] = cos(th) * e1[k] + sin(th) * e2[k];
}

/* The state of one population pass: the particles deleted so far, and the children added so far
 * (not in the neighbour lists yet: they live in a grid of their own until the pass ends). */
typedef struct pass {
  const uint8_t *dead;  /* [n0 + children] */
  int32_t n0;           /* particles before the pass (all in the neighbour lists) */
  pm_grid *kids;        /* the children of this pass, id = index, radius sigma */
  pm_idbuf buf;         /* scratch */
  int32_t *ids;         /* scratch: candidates */
  int32_t cap;
} pass;

/* The particles within max(sigma, sigma_j) of x for a point x near particle i (within beta
 * sigma_i, psys_nbr.c): i, its listed neighbours and the children of this pass, alive, sorted. */
static pm_status around(psys_sys *s, pass *P, int32_t i, const double x[3], double sigma,
                        int32_t *m, pm_error *err) {
  const psys_list *l = psys_nb(s, i);
  pm_status st = pm_grid_query_mutual(P->kids, x, sigma, &P->buf, err);
  if (st) return st;
  const int32_t need = l->n + 1 + P->buf.n;
  if (need > P->cap) {
    int32_t *ids = realloc(P->ids, sizeof(int32_t) * (size_t)need);
    if (!ids) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    P->ids = ids, P->cap = need;
  }
  int32_t n = 0;
  int self = 0;
  for (int32_t q = 0; q <= l->n; ++q) {
    const int32_t j = q < l->n ? l->ids[q] : INT32_MAX;
    if (!self && i < j) { /* i in its place among its neighbours */
      self = 1;
      if (!P->dead[i]) P->ids[n++] = i;
    }
    if (q == l->n || P->dead[j]) continue;
    const double sj = sigma > s->sigma[j] ? sigma : s->sigma[j];
    if (psys_d2(x, &s->xyz[3 * j]) < sj * sj) P->ids[n++] = j;
  }
  for (int32_t q = 0; q < P->buf.n; ++q)
    if (!P->dead[P->buf.ids[q]]) P->ids[n++] = P->buf.ids[q]; /* all above n0: still sorted */
  *m = n;
  return PM_OK;
}

/* Split particle i; *child = -1 when there was no room. */
static pm_status split(psys_sys *s, pass *P, int32_t i, int32_t *child, pm_error *err) {
  *child = -1;
  const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
  double dir[3], e1[3], e2[3], nrm[3];
  split_direction(s, i, dir);
  /* candidate directions: the split direction and its turns by 60 degrees in the tangent plane
   * (faces), or the two senses of the tangent (curves) */
  int ndir = 2;
  pm_v3_copy(e1, dir);
  if (s->dim[i] == PM_FACE) {
    const double *d = &s->deriv[6 * i];
    pm_v3_cross(nrm, d, d + 3);
    if (pm_v3_normalize(nrm) > 0) {
      pm_v3_cross(e2, nrm, e1);
      ndir = 6;
    }
  }
  const int32_t ki = psys_key(s, s->dim[i], s->cell[i]);
  const double sigma = s->sigma[i], dists[2] = {PSYS_BETA * sigma, 0.6 * PSYS_BETA * sigma};
  double best_e = INFINITY, best_par[2] = {0, 0};
  for (int k = 0; k < ndir; ++k) {
    double dk[3];
    if (ndir == 2) {
      pm_v3_scale(dk, e1, k ? -1.0 : 1.0);
    } else {
      double th = k * M_PI / 3;
      for (int q = 0; q < 3; ++q) dk[q] = cos(th) * e1[q] + sin(th) * e2[q];
    }
    for (int h = 0; h < 2; ++h) {
      double dx[3], np[2] = {s->par[2 * i], s->par[2 * i + 1]}, x[3];
      pm_v3_scale(dx, dk, dists[h]);
      pm_cell_displace(c, &s->par[2 * i], dx, np);
      pm_cell_point(c, np, x);
      /* a child much closer than intended sits against the cell's boundary: no room there */
      if (pm_v3_dist(x, &s->xyz[3 * i]) < 0.5 * dists[h]) continue;
      /* the energy a particle of radius sigma on i's cell would have at x */
      int32_t m;
      pm_status st = around(s, P, i, x, sigma, &m, err);
      if (st) return st;
      const double e = psys_energy_at(s, -1, ki, sigma, x, P->ids, m, NULL, NULL);
      if (e < best_e) best_e = e, best_par[0] = np[0], best_par[1] = np[1];
    }
  }
  if (best_e == INFINITY) return PM_OK;
  pm_status st = psys_add_child(s, i, best_par, child, err);
  if (!st) st = pm_grid_insert(P->kids, *child, &s->xyz[3 * *child], s->sigma[*child], err);
  return st;
}

/* Flag every particle within sigma_i of particle i's point (mutual relation) in mark[], and give
 * it the grace period. */
static pm_status mark_around(psys_sys *s, pass *P, int32_t i, uint8_t *mark, pm_error *err) {
  int32_t m;
  pm_status st = around(s, P, i, &s->xyz[3 * i], s->sigma[i], &m, err);
  if (st) return st;
  for (int32_t q = 0; q < m; ++q) {
    mark[P->ids[q]] = 1;
    s->grace[P->ids[q]] = s->iter + 1 + s->p.delete_grace;
  }
  return PM_OK;
}

/* Empty cells (see the file comment): a movable curve or face without particles whose extent
 * exceeds two ideal spacings of its end vertices (2 beta sigma, sigma the smallest of theirs)
 * gets one again, at the middle of a curve, at a random point of a face (curves in phases 1-2,
 * faces in phase 3, when they move). */
static pm_status refill(psys_sys *s, int32_t *added, pm_error *err) {
  const pm_model *m = s->model;
  const int32_t nv = m->count[PM_VERTEX], nc = m->count[PM_CURVE], nf = m->count[PM_FACE];
  const int curves_move = s->phase < 3, faces_move = s->phase == 3;
  int32_t *now = calloc((size_t)nc + (size_t)nf + 1, sizeof(int32_t)); /* particles per cell */
  double *vsig = malloc(sizeof(double) * ((size_t)nv + 1)); /* sigma of each vertex's particle */
  pm_status st = PM_OK;
  if (!now || !vsig) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  for (int32_t v = 0; v < nv; ++v) vsig[v] = -1;
  for (int32_t i = 0; i < s->n; ++i) {
    if (s->dim[i] == PM_VERTEX) vsig[s->cell[i]] = s->sigma[i];
    else now[(s->dim[i] == PM_FACE ? nc : 0) + s->cell[i]]++;
  }
  for (int32_t k = 0; k < nc + nf; ++k) {
    const int is_face = k >= nc;
    if (now[k] || (is_face ? !faces_move : !curves_move)) continue;
    if (is_face && s->face_on && !s->face_on[k - nc]) continue;
    const int32_t cell = is_face ? k - nc : k;
    const pm_cell *c = pm_model_cell(m, is_face ? PM_FACE : PM_CURVE, cell);
    if (!is_face && c->degenerate) continue;
    /* the smallest sigma of the cell's vertices */
    const int32_t key = psys_key(s, is_face ? PM_FACE : PM_CURVE, cell);
    double sg = INFINITY;
    for (int32_t q = s->vert_off[key]; q < s->vert_off[key + 1]; ++q)
      if (vsig[s->vert[q]] > 0) sg = fmin(sg, vsig[s->vert[q]]);
    if (!(sg < INFINITY) || !(s->extent[k] > 2 * PSYS_BETA * sg)) continue;
    int32_t before = s->n;
    if (is_face) {
      st = psys_seed_face(s, cell, 1, err);
    } else {
      double t = 0.5 * (c->lo[0] + c->hi[0]);
      st = psys_add(s, PM_CURVE, cell, &t, sg, NULL, err);
    }
    if (st) goto out;
    for (int32_t i = before; i < s->n; ++i) s->grace[i] = s->iter + 1 + s->p.delete_grace;
    *added += s->n - before;
  }
out:
  free(now), free(vsig);
  return st;
}

/* Gaps along curves (see the file comment): in phases 1-2, two consecutive particles of a curve
 * (its end vertices included, in parameter order) farther apart than GAP_FILL times the larger of
 * their sigma get a particle at the middle of their parameter interval.
 *
 * A gap with no curve between its ends is left (ours). Where a curve's end misses its vertex (a
 * CAD gap: on robust/step__SampleCrankshaft4A.stp curves 337 and 13 meet 0.057 from their
 * vertex, where sigma is 0.015), the particle clipped at the curve's end and the vertex are far
 * apart in space but not in the parameter; a child at the middle lands on or next to the clipped
 * particle, a coincident pair has no gradient (psys_energy_at skips r = 0), and every pass put
 * one more there: after phase 2, 160 pairs of particles of one curve within 1e-3 sigma over the
 * model, and the end particles of curves 337 and 13 at 8 to 23 E_ideal, 0.5 sigma apart. So a
 * gap is filled only when its length along the curve, the parameter interval times the larger
 * speed |C'| of its curve particles, exceeds GAP_ARC of its sigma: half of GAP_FILL, since the
 * speed at the particles may misjudge the interval (at 0.1 the end of curve 337, 0.005 of curve
 * from its last particle, was still filled; at 0.6 its particles end at 1.2-1.3 E_ideal). */
#define GAP_FILL 1.2 /* a gap is filled when consecutive particles are this many sigma apart */
#define GAP_ARC 0.6  /* ... and the curve between them is longer than this many sigma */

static double curve_speed(const psys_sys *s, int32_t i) {
  return s->dim[i] == PM_CURVE ? pm_v3_norm(&s->deriv[6 * i]) : 0;
}

static pm_status fill_curve_gaps(psys_sys *s, int32_t *added, pm_error *err) {
  if (s->phase >= 3) return PM_OK;
  const pm_model *m = s->model;
  int32_t *off = NULL, *chain = NULL, *vpart = NULL;
  pm_status st = psys_curve_chains(s, &off, &chain, &vpart, err);
  if (st) return st;
  for (int32_t c = 0; c < m->count[PM_CURVE] && !st; ++c) {
    const pm_cell *cu = pm_model_cell(m, PM_CURVE, c);
    const int32_t a = off[c], b = off[c + 1];
    int32_t own = 0;
    for (int32_t k = a; k < b; ++k) own += s->dim[chain[k]] == PM_CURVE;
    if (own == 0 || cu->degenerate) continue; /* an empty curve is refill's */
    for (int32_t k = a; k + 1 < b && !st; ++k) {
      const int32_t p = chain[k], q = chain[k + 1];
      const double sg = fmax(s->sigma[p], s->sigma[q]);
      if (!(pm_v3_dist(&s->xyz[3 * p], &s->xyz[3 * q]) > GAP_FILL * sg)) continue;
      /* a vertex's parameter is its end of the curve: the chain's first or last place */
      const double tp = s->dim[p] == PM_CURVE ? s->par[2 * p] : cu->lo[0];
      const double tq = s->dim[q] == PM_CURVE ? s->par[2 * q] : cu->hi[0];
      const double speed = fmax(curve_speed(s, p), curve_speed(s, q));
      if (!(fabs(tq - tp) * speed > GAP_ARC * sg)) continue;
      double t = 0.5 * (tp + tq);
      int32_t child = -1;
      if ((st = psys_add_child(s, s->dim[p] == PM_CURVE ? p : q, &t, &child, err))) break;
      s->grace[child] = s->iter + 1 + s->p.delete_grace;
      ++*added;
    }
  }
  free(off), free(chain), free(vpart);
  return st;
}

/* E_ideal of eq. 6 for particle i; on a curve the one-ring of the ideal lattice has ring_curve
 * particles (see the file comment). */
static double ideal_energy_of(const psys_sys *s, int32_t i) {
  double eid = psys_ideal_energy(s->sigma[i]);
  return s->dim[i] == PM_CURVE ? eid * s->p.ring_curve / 6.0 : eid;
}

int32_t psys_hungry_count(const psys_sys *s) {
  int32_t n = 0;
  for (int32_t i = 0; i < s->n; ++i)
    n += !s->fixed[i] && (s->dim[i] == PM_FACE || s->p.hungry_curves) &&
         s->energy[i] < 0.5 * s->p.split_ratio * ideal_energy_of(s, i);
  return n;
}

pm_status psys_population_pass(psys_sys *s, double a, int32_t *splits, int32_t *deletes,
                               pm_error *err) {
  *splits = *deletes = 0;
  if (!(a > 0)) return PM_OK;
  pm_status st = psys_nbr_update(s, err);
  if (st) return st;
  const int32_t n0 = s->n;
  /* marks cover the children too: at most one per particle */
  uint8_t *mark = calloc(2 * (size_t)n0 + 1, 1);
  uint8_t *dead = calloc(2 * (size_t)n0 + 1, 1);
  pass P;
  memset(&P, 0, sizeof P);
  P.dead = dead, P.n0 = n0;
  const int32_t nc = s->model->count[PM_CURVE], ncell = nc + s->model->count[PM_FACE];
  int32_t *count = calloc((size_t)ncell + 1, sizeof(int32_t)); /* particles per curve, face */
  if (!mark || !dead || !count) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  if ((st = pm_grid_create(s->size ? 1e-6 * s->model->diagonal : 1e-2 * s->sigma_min, &P.kids,
                           err)))
    goto out;
  for (int32_t i = 0; i < n0; ++i)
    if (s->dim[i] > PM_VERTEX) count[(s->dim[i] == PM_FACE ? nc : 0) + s->cell[i]]++;
  for (int32_t i = 0; i < n0; ++i) {
    if (s->fixed[i] || mark[i]) continue;
    const double eid = ideal_energy_of(s, i); /* eq. 6 */
    const double es = s->energy[i] * (1 + a * psys_random(s, i, RND_EPS)); /* eq. 3 */
    /* a face particle on its face's boundary polyline (see the file comment) */
    const int on_boundary =
        s->dim[i] == PM_FACE && s->bdist[i] < PSYS_BOUNDARY_CLEARANCE * s->sigma[i];
    if (on_boundary) {
      const int32_t kc = nc + s->cell[i];
      count[kc]--;
      if ((st = mark_around(s, &P, i, mark, err))) goto out;
      dead[i] = 1;
      (*deletes)++;
    } else if (es < s->p.split_ratio * a * eid) { /* eq. 4 */
      int32_t child;
      if ((st = split(s, &P, i, &child, err))) goto out;
      if (child < 0) continue;
      if ((st = mark_around(s, &P, i, mark, err))) goto out;
      mark[child] = 1;
      s->grace[child] = s->iter + 1 + s->p.delete_grace;
      (*splits)++;
    } else if (es > s->p.delete_ratio / a * eid && s->iter >= s->grace[i]) { /* eq. 5 */
      const int32_t kc = (s->dim[i] == PM_FACE ? nc : 0) + s->cell[i];
      if (count[kc] == 1 && s->extent[kc] > 2 * PSYS_BETA * s->sigma[i]) continue;
      count[kc]--;
      if ((st = mark_around(s, &P, i, mark, err))) goto out;
      dead[i] = 1;
      (*deletes)++;
    }
  }
  if (*deletes && (st = psys_compact(s, dead, err))) goto out;
  {
    int32_t added = 0;
    if ((st = refill(s, &added, err))) goto out;
    if ((st = fill_curve_gaps(s, &added, err))) goto out;
    *splits += added;
  }
  s->splits_total += *splits;
  s->deletes_total += *deletes;
out:
  pm_grid_destroy(P.kids);
  pm_idbuf_free(&P.buf);
  free(P.ids);
  free(mark), free(dead), free(count);
  return st;
}
