/* A run of the bubble method: placement, relaxation rounds with population control, stopping,
 * trace and frames, connection (papers/003 section 3.1, papers/000 section 4.1, papers/004
 * section 2).
 *
 * Rounds. A population control (bub_population.c) follows at least control_steps relaxation
 * steps (000 section 4.2.6: 20), and only when the system is relatively calm (003 section 3.5:
 * "only when the maximum velocity of all bubbles is within a small value"): when no bubble
 * moved more than `calm` of its diameter in the last step -- or, by default, 99% of them
 * (disp_quantile: the largest of n displacements grows with n, and with it the steps a test on
 * it waits; a quantile does not). A system that does not calm down
 * within 4 x control_steps steps is controlled anyway (our choice: oscillations that never settle
 * below `calm` must not stop the population from adapting). The steps between two controls are
 * a round (004's "round of simulation").
 *
 * Stopping, whichever comes first (the run reports it in out->stop_reason):
 *   - the self-adaptive stop (004 section 2.4): the count of curve and face bubbles changed by at
 *     most stop_change of itself in stop_rounds consecutive controls; then population control
 *     ends and up to final_steps relaxation steps follow (until the displacement tolerance),
 *     the bubbles of curved faces damped with final_zeta in the surface phase (our choice;
 *     planes keep the schedule, bub_zeta_curved): the saw-tooth would hold its cap, 1.5, where the
 *     packing's long waves relax at a rate k / c, slowly; at 0.3 (synth_torus.brep, d = 0.0366,
 *     the 100 steps of the former default) the mean radius ratio reached 0.9900 against 0.9881,
 *     and 50 steps at 0.3 gave 0.9893 (`packmesh mesh synth_torus.brep --size 0.0366 --set
 *     final_zeta=Z --set final_steps=N --stats`);
 *   - the displacement tolerance (003 section 3.4: "the distance moved by the bubbles during one
 *     time-step in any d.o.f becomes less than a given small value"): no bubble (the
 *     disp_quantile of them) moved more than disp_tol of its diameter in a step, and the last
 *     control changed nothing (or population control is off);
 *   - max_steps;
 *   - the bubble cap max_bubbles: reached by insertions, it ends population control like the
 *     adaptive stop (the run reports it). The run's node budget (in->max_nodes, --max-nodes) is
 *     a hard limit instead: a placement above it, or insertions that reach it, are PM_ERR_LIMIT
 *     (DESIGN.md: "a node budget that would be exceeded" is an error). Before any placement, a
 *     field whose estimated node count exceeds 1.5 x the lower of the two is PM_ERR_LIMIT
 *     (node_budget.h): its placement alone would fill memory before reaching either check.
 *
 * Nodes for the connection: vertex bubbles (dim 0), curve bubbles (dim 1, t) and face bubbles
 * (dim 2, (u, v)); outside-layer bubbles exist only during a control and are never nodes.
 *
 * Volumes (in->volume). With tets = bubbles (the default; papers/003 sections 3.1-3.5: bubbles on
 * vertices, curves, faces and volumes in ascending order of dimension, centres connected by
 * constrained Delaunay tetrahedrization), once the lower dimensions have stopped by the rules above
 * they are frozen, connected into the surface mesh (pm_connect, no volume), and the volume phase
 * follows (bub_volume.c): volume bubbles placed by the octree of rhombohedra, relaxed and
 * controlled by the same rounds and stopping rules (max_steps counts per phase, the saw-tooth
 * restarts). The volume bubbles then become the nodes of the volumes (dim 3, the volume's index)
 * and TetGen tetrahedralizes the surface mesh with them and no Steiner point (pm_connect_volumes,
 * PM_VOLUME_GIVEN; it may add the few interior points boundary recovery needs, counted in
 * bubble.recovery_points). With tets = tetgen the surface mesh is filled with TetGen's quality
 * refinement instead (PM_VOLUME_REFINE), for comparison.
 *
 * Slivers (our addition; papers/003 does not discuss them): Delaunay tets of well-spaced points
 * include slivers, four nearly cospherical points spanning almost no volume, whatever the
 * spacing. With sliver_angle > 0, after the tetrahedralization every tet whose smallest dihedral
 * angle is below sliver_angle drops one volume bubble at its corners (the lowest-numbered: a
 * fixed choice), and the volumes are tetrahedralized again without them, up to 10 rounds (the
 * built-in non-manifold case needed 5). A sliver whose four corners lie on the surface has no
 * volume bubble to drop: it sits where two faces meet at an edge (two nodes on each face,
 * cospherical about a point of the edge, in the gap the wall rule keeps free of volume bubbles)
 * or under a face curved towards the volume (four nodes of one face). There a node is added
 * inside the sliver's circumsphere, so that the four corners no longer form a Delaunay tet: on
 * the line from its centroid through its circumcentre or across it (normal to two opposite
 * edges), on either side, 0.15 to 0.5 of its mean edge length L from the centroid, the
 * candidate inside the volume and farthest from the walls
 * (at least BUB_VMARGIN L from them, reached from the centroid without crossing one); none
 * such, nothing is added. An added node that is a corner of a later sliver is dropped again, and
 * its place is not offered again (else the first sliver comes back, gets the same node, and the
 * two take turns to the last round: a 1.86-degree sliver of the non-manifold case did). The
 * counts are bubble.sliver_dropped and bubble.sliver_added. The trace's `phase` column is 2 in the
 * surface phase and 3 in the volume phase, where `bubbles` counts volume bubbles and eps_t is
 * mean |degree - 12|; frames show volume bubbles as dimension 3.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/connect/connect.h"
#include "common/sizing/node_budget.h"
#include "common/measure/quality.h"
#include "common/base/vec3.h"

/* Re-tetrahedralizations of the sliver step at most (header). */
#define SLIVER_ROUNDS 10

/* The trace (header of trace.h). `bubbles` counts the bubbles the relaxation moves (curve and
 * face bubbles; volume bubbles in the volume phase); `nodes` counts the bubbles that become mesh
 * nodes (vertex, curve, face and volume bubbles alike), so that the last row's `nodes` is the
 * mesh's node count. `event` says what a row records: a relaxation step (BUB_EV_STEP), or an
 * event between steps that changes the population -- a population control (its insertions and
 * deletions), the border cleanup after the relaxation, the connection (`nodes` is then the
 * mesh's, with the nodes the connection step or the sliver step added) -- whose rows carry the
 * step they follow and leave the step's measures empty. */
static const char *const trace_cols[] = {"step",     "bubbles",  "kinetic",   "potential",
                                         "mean_disp", "max_disp", "insertions", "deletions",
                                         "eps_t",    "zeta",     "max_rel_disp", "round",
                                         "phase",    "q_rel_disp", "nodes",   "event"};
#define NCOL ((int)(sizeof trace_cols / sizeof trace_cols[0]))
enum { BUB_EV_STEP = 0, BUB_EV_CONTROL = 1, BUB_EV_CLEANUP = 2, BUB_EV_MESH = 3 };

/* The bubbles that become mesh nodes now (compacted: no dead bubble between steps). */
static int32_t node_bubbles(const bub_state *s) { return s->volume_phase ? s->nw : s->nf; }

/* An event row: the step it follows, the counts, and no step measures (empty in the CSV). */
static pm_status trace_event(const bub_state *s, const pm_run_input *in, int event,
                             int32_t inserted, int32_t removed, int32_t nodes, pm_error *err) {
  if (!pm_observe_wants_trace(in->observer)) return PM_OK;
  double row[NCOL];
  for (int k = 0; k < NCOL; ++k) row[k] = NAN;
  row[0] = (double)s->step;
  row[1] = (double)(s->volume_phase ? s->nw - s->nf : s->nf - s->nv);
  row[6] = inserted, row[7] = removed;
  row[11] = (double)s->round, row[12] = s->volume_phase ? 3 : 2;
  row[14] = nodes, row[15] = event;
  return pm_observe_trace_row(in->observer, row, err);
}

static pm_status snapshot(bub_state *s, const pm_run_observer *obs, pm_error *err) {
  if (!pm_observe_wants_frames(obs) || s->n == 0) return PM_OK;
  double *r = malloc(sizeof(double) * (size_t)s->n);
  int8_t *dim = malloc((size_t)s->n);
  if (!r || !dim) {
    free(r), free(dim);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t i = 0; i < s->n; ++i) r[i] = 0.5 * s->d[i], dim[i] = s->kind[i];
  /* Bubbles are drawn at their radius: neighbours at the stable distance touch. */
  const pm_run_frame f = {s->step, s->volume_phase ? 3 : 2, s->volume_phase ? "volume" : "surface",
                          s->n, s->x, r, 1.0, dim, s->cell, s->par, NULL};
  pm_status st = pm_observe_frame(obs, &f, err);
  free(r), free(dim);
  return st;
}

pm_status bub_connect_nodes(const bub_state *s, const pm_run_input *in, int surface_only,
                               pm_mesh **out, pm_error *err) {
  pm_mesh *mesh = pm_mesh_create();
  if (!mesh) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status st = pm_mesh_reserve(mesh, s->n, 0, 0, 0, err);
  for (int32_t i = 0; i < s->n && !st; ++i) {
    if (s->kind[i] > BUB_KFACE || (s->flags[i] & BUB_FDEAD)) continue;
    st = pm_mesh_add_node(mesh, &s->x[3 * i], s->kind[i], s->cell[i], &s->par[2 * i], NULL, err);
  }
  if (!st) {
    pm_connect_params cp;
    pm_connect_params_init(&cp);
    cp.metric_flips = s->p.metric_flips;
    cp.drop_crossed = s->p.drop_crossed;
    cp.smooth = s->p.smooth;
    cp.needle_moves = s->p.needle_moves;
    if (in->volume && !surface_only) {
      cp.volume = PM_VOLUME_REFINE;
      cp.max_nodes = in->max_nodes > 0 && in->max_nodes < INT32_MAX ? (int32_t)in->max_nodes : 0;
    }
    st = pm_connect(s->model, mesh, &cp, NULL, err);
    if (st) pm_error_prefix(err, "bubble: connecting %d nodes", (int)mesh->nnode);
  }
  if (st) {
    pm_mesh_destroy(mesh);
    return st;
  }
  *out = mesh;
  return PM_OK;
}

pm_status bub_relax(bub_state *s, const pm_run_input *in, int64_t cap, int budget,
                    char reason[128], pm_error *err) {
  const bub_params *p = &s->p;
  const int64_t step0 = s->step;
  int settled = 0, final_phase = 0, final_left = 0;
  s->final_phase = 0; /* (the volume phase relaxes again) */
  int32_t last_change = -1; /* bubbles changed by the last control (-1: none yet) */
  pm_status st = PM_OK;
  reason[0] = 0;
  while (!st) {
    if (s->step - step0 >= p->max_steps) {
      snprintf(reason, 128, "max steps (%d)", p->max_steps);
      break;
    }
    bub_step_info info;
    st = bub_dynamics_step(s, &info, err);
    if (st) break;
    if (pm_observe_wants_trace(in->observer)) {
      double row[NCOL] = {(double)s->step, (double)(s->volume_phase ? s->nw - s->nf : s->nf - s->nv),
                          info.kinetic, info.potential, info.mean_disp, info.max_disp, 0,
                          0, info.eps_t, bub_zeta_now(s), info.max_rel_disp,
                          (double)s->round, s->volume_phase ? 3 : 2, info.q_rel_disp,
                          node_bubbles(s), BUB_EV_STEP};
      st = pm_observe_trace_row(in->observer, row, err);
      if (st) break;
    }
    bub_control_info ci = {0};
    int controlled = 0;
    if (p->population && !final_phase && s->steps_in_round >= p->control_steps &&
        (info.q_rel_disp <= p->calm || s->steps_in_round >= 4 * p->control_steps)) {
      st = bub_population_control(s, cap, &ci, err);
      if (st) break;
      controlled = 1;
      s->round++;
      st = trace_event(s, in, BUB_EV_CONTROL, ci.inserted, ci.removed, node_bubbles(s), err);
      if (st) break;
      s->steps_in_round = 0;
      last_change = ci.inserted + ci.removed;
      int32_t delta = ci.after > ci.before ? ci.after - ci.before : ci.before - ci.after;
      if (ci.before > 0 && delta <= p->stop_change * ci.before)
        ++settled;
      else
        settled = 0;
      if (p->adaptive_stop && settled >= p->stop_rounds) {
        final_phase = s->final_phase = 1, final_left = p->final_steps;
        snprintf(reason, 128, "converged: bubble count changed by <= %g%% in %d consecutive rounds",
                 100 * p->stop_change, p->stop_rounds);
      } else if (s->nw >= cap && budget) {
        st = pm_error_setf(err, PM_ERR_LIMIT,
                           "bubble: the node budget of %lld would be exceeded (the size field asks "
                           "for more nodes)",
                           (long long)cap);
        break;
      } else if (s->nw >= cap) {
        final_phase = s->final_phase = 1, final_left = p->final_steps;
        snprintf(reason, 128, "bubble cap (%lld) reached", (long long)cap);
      }
    }
    if (s->step % p->frame_every == 0 && (st = snapshot(s, in->observer, err))) break;
    if (final_phase) {
      if (p->final_steps == 0 || --final_left <= 0 || (info.q_rel_disp <= p->disp_tol && !controlled))
        break;
    } else if (info.q_rel_disp <= p->disp_tol &&
               (!p->population || (controlled && last_change == 0))) {
      snprintf(reason, 128, "converged: no bubble moved more than %g of its diameter in a step",
               p->disp_tol);
      break;
    }
  }
  if (!st) { /* nodes exactly on their cells (the frames' model is within FRAME_ERR d) */
    double t0 = pm_seconds();
    bub_state_refresh(s);
    s->t.project += pm_seconds() - t0;
  }
  return st;
}

/* A node for a sliver whose corners all lie on the surface (header, "Slivers"): 1 and *x
 * when a candidate qualifies. A candidate within 0.01 L of one of the ndead points (added nodes
 * dropped again because they made a sliver of their own) is passed over: the same sliver would
 * get the same node back, and the two would take turns until the last round. */
static int sliver_node(const bub_state *s, int32_t volume, const double *P[4], const double *dead,
                       int32_t ndead, double x[3]) {
  double g[3] = {0, 0, 0}, L = 0;
  for (int q = 0; q < 4; ++q) pm_v3_axpy(g, g, 0.25, P[q]);
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) L += pm_v3_dist(P[i], P[j]) / 6;
  /* circumcentre - a = (|u|^2 (v x w) + |v|^2 (w x u) + |w|^2 (u x v)) / (2 u.(v x w)) */
  double u[3], v[3], w[3], vw[3], wu[3], uv[3], cc[3];
  pm_v3_sub(u, P[1], P[0]), pm_v3_sub(v, P[2], P[0]), pm_v3_sub(w, P[3], P[0]);
  pm_v3_cross(vw, v, w), pm_v3_cross(wu, w, u), pm_v3_cross(uv, u, v);
  double den = 2 * pm_v3_dot(u, vw);
  if (!(fabs(den) > 0) || !(L > 0)) return 0;
  for (int k = 0; k < 3; ++k)
    cc[k] = P[0][k] + (pm_v3_dot(u, u) * vw[k] + pm_v3_dot(v, v) * wu[k] + pm_v3_dot(w, w) * uv[k]) / den;
  double R = pm_v3_dist(cc, P[0]);
  if (!isfinite(R)) return 0;
  /* Two directions: towards the circumcentre, and across the sliver (the cross product of the
   * pair of opposite edges with the largest one): when the centroid is near the circumcentre
   * (four corners near a great circle) only the second is defined. */
  double dirs[2][3];
  int ndir = 0;
  pm_v3_sub(dirs[ndir], cc, g);
  if (pm_v3_normalize(dirs[ndir]) > 1e-9 * L) ++ndir;
  static const int opp[3][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}};
  double big = 0;
  for (int k = 0; k < 3; ++k) {
    double e1[3], e2[3], n[3];
    pm_v3_sub(e1, P[opp[k][1]], P[opp[k][0]]), pm_v3_sub(e2, P[opp[k][3]], P[opp[k][2]]);
    pm_v3_cross(n, e1, e2);
    double nn = pm_v3_norm(n);
    if (nn > big) big = nn, pm_v3_scale(dirs[ndir], n, 1 / nn);
  }
  if (big > 0) ++ndir;
  static const double steps[4] = {0.5, 0.35, 0.25, 0.15};
  double best = -1;
  for (int m = 0; m < 8 * ndir; ++m) { /* direction m / 8, side, step */
    double c[3];
    pm_v3_axpy(c, g, (m % 2 ? 1 : -1) * steps[(m / 2) % 4] * L, dirs[m / 8]);
    if (!(pm_v3_dist(c, cc) < 0.95 * R)) continue;
    int near_dead = 0;
    for (int32_t k = 0; k < ndead && !near_dead; ++k) near_dead = pm_v3_dist(c, &dead[3 * k]) < 0.01 * L;
    if (near_dead) continue;
    if (!bub_volume_place_ok(s, volume, g, c, L)) continue;
    double dw = pm_volume_shell_distance(s->shell[volume], c, L);
    if (dw > best) best = dw, pm_v3_copy(x, c);
  }
  return best >= 0;
}

/* The volume phase and the tets from the volume bubbles (the header's "Volumes"): *mesh receives
 * the hybrid mesh. */
static pm_status volume_phase(bub_state *s, const pm_run_input *in, int64_t cap, int budget,
                              char reason[128], pm_mesh **mesh, int32_t *recovery,
                              int32_t *slivers, int32_t *added, double *t_relaxed, pm_error *err) {
  pm_mesh *surf = NULL;
  pm_status st = bub_connect_nodes(s, in, 1, &surf, err);
  if (!st) st = bub_volume_begin(s, surf, err);
  if (!st) st = bub_place_volumes(s, err);
  if (!st && s->nw > cap)
    st = pm_error_setf(err, PM_ERR_LIMIT, "bubble: the volume placement has %d bubbles, above the %s of %lld",
                       (int)s->nw, budget ? "node budget" : "cap max_bubbles", (long long)cap);
  char vreason[128] = "";
  if (!st && s->nw > s->nf) st = bub_relax(s, in, cap, budget, vreason, err);
  if (!st && vreason[0]) snprintf(reason, 128, "%.120s", vreason);
  *t_relaxed = pm_seconds();
  /* Tets from the surface and the volume bubbles; then the sliver step (header): volume bubbles
   * at a corner of a tet flatter than sliver_angle are dropped and the volumes tetrahedralized
   * again, at most SLIVER_ROUNDS times. */
  const int32_t base = surf ? surf->nnode : 0;
  const int32_t nvb = s->nw - s->nf;
  uint8_t *drop = st ? NULL : calloc((size_t)nvb + 1, 1);
  if (!st && !drop) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  /* Nodes added at the centroids of all-surface slivers (header), at most one per sliver a round;
   * a dropped one is marked dead. */
  double *ex = NULL, *gone = NULL; /* gone: the positions of the dropped ones */
  int32_t *ex_cell = NULL;
  uint8_t *ex_dead = NULL;
  int32_t nex = 0, capex = 0, ngone = 0;
  for (int round = 0; !st; ++round) {
    surf->nnode = base, surf->ntet = 0; /* no tet refers to a volume node any more */
    for (int32_t k = 0; k < nvb && !st; ++k)
      if (!drop[k]) st = pm_mesh_add_node(surf, &s->x[3 * (s->nf + k)], PM_VOLUME, s->cell[s->nf + k], NULL, NULL, err);
    const int32_t ex_base = surf->nnode;
    int32_t *ex_of = nex ? malloc(sizeof(int32_t) * (size_t)nex) : NULL; /* mesh node -> extra */
    if (nex && !ex_of) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    int32_t nlive = 0;
    for (int32_t k = 0; k < nex && !st; ++k)
      if (!ex_dead[k]) {
        ex_of[nlive++] = k;
        st = pm_mesh_add_node(surf, &ex[3 * k], PM_VOLUME, ex_cell[k], NULL, NULL, err);
      }
    if (st) {
      free(ex_of);
      break;
    }
    pm_connect_params cp;
    pm_connect_params_init(&cp);
    cp.volume = PM_VOLUME_GIVEN;
    cp.max_nodes = in->max_nodes > 0 && in->max_nodes < INT32_MAX ? (int32_t)in->max_nodes : 0;
    pm_connect_report rep;
    memset(&rep, 0, sizeof rep);
    st = pm_connect_volumes(s->model, surf, &cp, &rep, err);
    if (st) {
      free(ex_of);
      pm_error_prefix(err, "bubble: tets from %d volume bubbles", (int)nvb);
      break;
    }
    *recovery = rep.steiner;
    if (!(s->p.sliver_angle > 0) || round >= SLIVER_ROUNDS) {
      free(ex_of);
      break;
    }
    /* Mesh node -> volume bubble: the kept ones in order from base. */
    int32_t *which = malloc(sizeof(int32_t) * ((size_t)nvb + 1));
    if (!which) {
      free(ex_of);
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      break;
    }
    int32_t nk = 0;
    for (int32_t k = 0; k < nvb; ++k)
      if (!drop[k]) which[nk++] = k;
    int32_t dropped = 0, changed = 0; /* bubbles dropped; added nodes added or dropped */
    for (int32_t t = 0; t < surf->ntet; ++t) {
      const int32_t *v = &surf->tet[4 * t];
      pm_tet_measure tm;
      pm_tet_measure_eval(&surf->xyz[3 * v[0]], &surf->xyz[3 * v[1]], &surf->xyz[3 * v[2]],
                          &surf->xyz[3 * v[3]], &tm);
      if (tm.min_dihedral >= s->p.sliver_angle) continue;
      int32_t pick = -1; /* the lowest-numbered volume bubble at a corner */
      for (int q = 0; q < 4; ++q)
        if (v[q] >= base && v[q] < base + nk && (pick < 0 || which[v[q] - base] < pick)) pick = which[v[q] - base];
      if (pick >= 0) {
        if (!drop[pick]) drop[pick] = 1, ++dropped;
        continue;
      }
      int surface_only = 1; /* no added node at a corner either */
      for (int q = 0; q < 4; ++q)
        if (v[q] >= ex_base) {
          surface_only = 0;
          const int32_t k = ex_of[v[q] - ex_base];
          if (!ex_dead[k]) {
            double *g = realloc(gone, sizeof(double) * 3 * ((size_t)ngone + 1));
            if (!g) {
              st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
              break;
            }
            gone = g, pm_v3_copy(&gone[3 * ngone++], &ex[3 * k]);
            ex_dead[k] = 1, ++changed;
          }
          break;
        }
      if (st) break;
      if (!surface_only) continue;
      if (nex == capex) {
        int32_t c = capex ? 2 * capex : 16;
        double *g = realloc(ex, sizeof(double) * 3 * (size_t)c);
        if (g) ex = g;
        int32_t *gc = realloc(ex_cell, sizeof(int32_t) * (size_t)c);
        if (gc) ex_cell = gc;
        uint8_t *gd = realloc(ex_dead, (size_t)c);
        if (gd) ex_dead = gd;
        if (!g || !gc || !gd) {
          st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
          break;
        }
        capex = c;
      }
      const double *P[4] = {&surf->xyz[3 * v[0]], &surf->xyz[3 * v[1]], &surf->xyz[3 * v[2]],
                            &surf->xyz[3 * v[3]]};
      if (!sliver_node(s, surf->tet_cell[t], P, gone, ngone, &ex[3 * nex])) continue;
      ex_cell[nex] = surf->tet_cell[t];
      ex_dead[nex++] = 0;
      ++changed;
    }
    free(which);
    free(ex_of);
    *slivers += dropped;
    if (st || (!dropped && !changed)) break;
  }
  for (int32_t k = 0; k < nex; ++k) *added += !ex_dead[k];
  free(ex), free(ex_cell), free(ex_dead), free(gone);
  if (!st) { /* the dropped bubbles leave the state too (frames, counts) */
    for (int32_t k = 0; k < nvb; ++k)
      if (drop[k]) s->flags[s->nf + k] |= BUB_FDEAD;
    if (*slivers) st = bub_state_compact(s, err);
  }
  free(drop);
  if (st) {
    pm_mesh_destroy(surf);
    return st;
  }
  *mesh = surf;
  return PM_OK;
}

pm_status bub_run(const pm_run_input *in, const void *params, pm_run_output *out, pm_error *err) {
  bub_params defaults;
  const bub_params *p = params;
  if (!p) {
    bub_params_init(&defaults);
    p = &defaults;
  }
  out->mesh = NULL;
  out->iterations = 0;
  snprintf(out->stop_reason, sizeof out->stop_reason, "failed");
  if (!in || !in->model) return pm_error_setf(err, PM_ERR_ARG, "bubble: no model");
  pm_status st = bub_params_check(p, err);
  if (st) return st;
  const pm_model *m = in->model;
  if (m->count[PM_CURVE] == 0 && m->count[PM_FACE] == 0)
    return pm_error_setf(err, PM_ERR_GEOM, "bubble: model %s has no curves or faces to mesh", m->name);

  double t0 = pm_seconds();
  const pm_sizing *size = in->size;
  pm_sizing *own_size = NULL;
  void *rule = NULL;
  if (!size) {
    st = bub_size_rule_create(m, p, &own_size, &rule, err);
    if (st) return st;
    size = own_size;
  }
  int64_t cap = (int64_t)fmin(p->max_bubbles, 2e9);
  int budget = 0; /* the cap is the run's node budget, not the method's own */
  if (in->max_nodes > 0 && in->max_nodes <= cap) cap = in->max_nodes, budget = 1;
  bub_params q = *p;
  q.max_bubbles = (double)cap;
  /* The field is measured against the cap before the first bubble is placed: placing towards a
   * field far beyond it would fill memory before the placement's own count check stopped it. */
  st = pm_node_budget_check(m, size, cap, budget ? "node cap" : "cap max_bubbles", "bubble", err);
  if (st) {
    pm_sizing_destroy(own_size);
    bub_size_rule_free(rule);
    return st;
  }

  bub_state *s = NULL;
  st = bub_state_create(m, size, &q, in->threads, in->seed, &s, err);
  if (!st) st = bub_place(s, err);
  if (st == PM_ERR_LIMIT && budget && err) { /* name the budget the caller set */
    char msg[sizeof err->msg];
    snprintf(msg, sizeof msg, "%s", strncmp(err->msg, "bubble: ", 8) == 0 ? err->msg + 8 : err->msg);
    st = pm_error_setf(err, PM_ERR_LIMIT, "bubble: the node budget of %lld would be exceeded (%.400s)",
                       (long long)cap, msg);
  }
  if (!st && s->n > cap)
    st = pm_error_setf(err, PM_ERR_LIMIT, "bubble: the initial placement has %d bubbles, above the %s of %lld",
                       (int)s->n, budget ? "node budget" : "cap max_bubbles", (long long)cap);
  double t_place = pm_seconds();
  int32_t initial = s ? s->nf : 0;
  if (!st) st = pm_observe_trace_columns(in->observer, NCOL, trace_cols, err);
  if (!st) st = snapshot(s, in->observer, err);

  char reason[128] = "";
  if (!st) st = bub_relax(s, in, cap, budget, reason, err);
  double t_relax = pm_seconds();
  int32_t border_dropped = 0;
  if (!st) st = bub_border_cleanup(s, &border_dropped, err);
  if (!st && border_dropped)
    st = trace_event(s, in, BUB_EV_CLEANUP, 0, border_dropped, node_bubbles(s), err);
  int volumes = !st && in->volume && p->tets == BUB_TETS_BUBBLES && m->count[PM_VOLUME] > 0;
  pm_mesh *mesh = NULL;
  int32_t recovery = 0, sliver_dropped = 0, sliver_added = 0;
  int64_t surface_steps = s ? s->step : 0;
  int32_t volume_final = 0;
  double t_vrelax = t_relax;
  if (volumes) {
    st = volume_phase(s, in, cap, budget, reason, &mesh, &recovery, &sliver_dropped, &sliver_added,
                      &t_vrelax, err);
  } else if (!st) {
    st = bub_connect_nodes(s, in, 0, &mesh, err);
  }
  if (s && volumes) volume_final = (int32_t)(s->nw - s->nf);
  double t_end = pm_seconds();
  if (!st) st = trace_event(s, in, BUB_EV_MESH, 0, 0, mesh->nnode, err);
  if (!st && s->step % p->frame_every != 0) st = snapshot(s, in->observer, err);
  if (!st) {
    out->mesh = mesh;
    mesh = NULL;
    out->iterations = s->step;
    snprintf(out->stop_reason, sizeof out->stop_reason, "%s", reason);
    if (in->observer) {
      const pm_run_observer *S = in->observer;
      pm_error e = {0};
      pm_observe_time(S, "place", t_place - t0, &e);
      pm_observe_time(S, "relax", t_relax - t_place, &e);
      if (volumes) pm_observe_time(S, "volume", t_vrelax - t_relax, &e);
      pm_observe_time(S, "connect", t_end - t_vrelax, &e);
      /* The relaxation by stage (bub_private.h, bub_times; "other": the trace, frames, the
       * stopping rules, and the threads' waits at the end of each parallel stage). */
      const struct bub_times *bt = &s->t;
      double staged = bt->neighbors + bt->force + bt->integrate + bt->project + bt->overlap + bt->population;
      pm_observe_time(S, "bubble.neighbors", bt->neighbors, &e);
      pm_observe_time(S, "bubble.force", bt->force, &e);
      pm_observe_time(S, "bubble.integrate", bt->integrate, &e);
      pm_observe_time(S, "bubble.project", bt->project, &e);
      pm_observe_time(S, "bubble.overlap", bt->overlap, &e);
      pm_observe_time(S, "bubble.population", bt->population, &e);
      pm_observe_time(S, "bubble.other", fmax(0, (t_vrelax - t_place) - staged), &e);
      pm_observe_number(S, "bubble.initial", initial, &e);
      pm_observe_number(S, "bubble.final", s->nf, &e);
      pm_observe_number(S, "bubble.steps", (double)s->step, &e);
      pm_observe_number(S, "bubble.rounds", (double)s->round, &e);
      pm_observe_number(S, "bubble.insertions", (double)s->insertions, &e);
      pm_observe_number(S, "bubble.deletions", (double)s->deletions, &e);
      pm_observe_number(S, "bubble.failed_insertions", (double)s->failed_insertions, &e);
      pm_observe_number(S, "bubble.list_builds", (double)s->list_builds, &e);
      pm_observe_number(S, "bubble.outer_builds", (double)s->outer_builds, &e);
      pm_observe_number(S, "bubble.partial_builds", (double)s->partial_builds, &e);
      pm_observe_number(S, "bubble.partial_outer", (double)s->partial_outer, &e);
      pm_observe_number(S, "bubble.evaluations", (double)s->evals, &e);
      pm_observe_number(S, "bubble.bubble_steps", (double)s->bubble_steps, &e);
      pm_observe_number(S, "bubble.border_dropped", border_dropped, &e);
      pm_observe_number(S, "bubble.time_step", bub_time_step(p), &e);
      if (volumes) {
        pm_observe_number(S, "bubble.volume_bubbles", volume_final, &e);
        pm_observe_number(S, "bubble.volume_steps", (double)(s->step - surface_steps), &e);
        pm_observe_number(S, "bubble.recovery_points", recovery, &e);
        pm_observe_number(S, "bubble.sliver_dropped", sliver_dropped, &e);
        pm_observe_number(S, "bubble.sliver_added", sliver_added, &e);
      }
      pm_observe_text(S, "bubble.stop", reason, &e);
      pm_observe_text(S, "bubble.size", pm_sizing_describe(size), &e);
    }
  }
  pm_mesh_destroy(mesh);
  bub_state_destroy(s);
  pm_sizing_destroy(own_size);
  bub_size_rule_free(rule);
  return st;
}

static void params_init(void *p) { bub_params_init(p); }

const pm_method bub_method = {
    .name = "bubble",
    .description = "Shimada's bubble mesh: packed bubbles by damped dynamics with population "
                   "control (papers/003, 000, 004), connected by constrained Delaunay",
    .params = &bub_params_table,
    .params_size = sizeof(bub_params),
    .params_init = params_init,
    .run = bub_run,
    .planar_only = 0,
    .needs_size = 0,
    .default_size = bub_default_size,
};
