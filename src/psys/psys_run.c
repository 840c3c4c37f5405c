/* The psys method (pm_method "psys") and the sizing inference for other methods: the phases of
 * psys_phases.c, then the shared connection step (papers/001 section 4.3-4.4). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/connect/connect.h"
#include "common/sizing/node_budget.h"
#include "psys/psys_private.h"

static void init_params(void *p) { psys_params_init(p); }

static void connect_params(const psys_params *p, int volume, int64_t max_nodes,
                           pm_connect_params *cp) {
  pm_connect_params_init(cp);
  cp->affine = p->affine;                                  /* eq. 16 */
  cp->metric_flips = p->metric_flips;
  cp->drop_crossed = p->drop_crossed;
  cp->flips = p->flips ? PM_FLIP_DIAMETRIC : PM_FLIP_NONE; /* section 4.3 */
  cp->smooth = p->smooth;
  cp->needle_moves = p->needle_moves;
  cp->volume = volume ? PM_VOLUME_REFINE : PM_VOLUME_NONE; /* section 4.4: TetGen refinement */
  cp->radius_edge = p->tet_radius_edge;
  cp->max_nodes = max_nodes > 0 && max_nodes < INT32_MAX ? (int32_t)max_nodes : 0;
}

static pm_status add_stats(const pm_run_observer *st, const psys_sys *s, const psys_phase_report rep[3],
                           pm_error *err) {
  if (!st) return PM_OK;
  static const char *const names[3] = {"phase1", "phase2", "phase3"};
  pm_status r = PM_OK;
  for (int k = 0; k < 3 && !r; ++k) r = pm_observe_time(st, names[k], rep[k].seconds, err);
  char key[64];
  for (int k = 0; k < 3 && !r; ++k) {
    snprintf(key, sizeof key, "psys.iterations.%s", names[k]);
    r = pm_observe_number(st, key, (double)rep[k].iterations, err);
  }
  if (!r) r = pm_observe_number(st, "psys.particles", s->n, err);
  if (!r) r = pm_observe_number(st, "psys.sigma_min", s->sigma_min, err);
  if (!r) r = pm_observe_number(st, "psys.sigma_max", s->sigma_max, err);
  if (!r) r = pm_observe_number(st, "psys.splits", s->splits_total, err);
  if (!r) r = pm_observe_number(st, "psys.deletes", s->deletes_total, err);
  /* the neighbour structure's work: lists made again one by one, updates that made all */
  if (!r) r = pm_observe_number(st, "psys.lists.neighbour_renewed", (double)s->nbr.nb.renewed, err);
  if (!r) r = pm_observe_number(st, "psys.lists.neighbour_rebuilds", (double)s->nbr.nb.rebuilds, err);
  if (!r) r = pm_observe_number(st, "psys.lists.gap_renewed", (double)s->nbr.gp.renewed, err);
  if (!r) r = pm_observe_number(st, "psys.lists.gap_rebuilds", (double)s->nbr.gp.rebuilds, err);
  if (!r) r = pm_observe_number(st, "psys.lists.recolours", (double)s->recolours, err);
  if (!r) r = pm_observe_number(st, "psys.lists.colour_mends", (double)s->colour_mends, err);
  /* time per step, under time_s: psys.STEP over all phases, psys.phaseK.STEP per phase */
  for (int k = 0; k < PSYS_T_COUNT && !r; ++k) {
    double sum = 0;
    for (int ph = 0; ph < 3; ++ph) sum += s->tstep[ph][k];
    snprintf(key, sizeof key, "psys.%s", psys_step_names[k]);
    r = pm_observe_time(st, key, sum, err);
    for (int ph = 0; ph < 3 && !r; ++ph) {
      snprintf(key, sizeof key, "psys.%s.%s", names[ph], psys_step_names[k]);
      r = pm_observe_time(st, key, s->tstep[ph][k], err);
    }
  }
  return r;
}

/* The particles' sigma as an edge-length field sampled on the connected mesh's nodes and
 * triangles (tets left out: the field is the surface's): each node takes the sigma of the nearest
 * particle, which is itself for every particle; the connection may add nodes (vertices without a
 * particle, closed curves with fewer than two, tet nodes) and drops none of ours. The particles'
 * points and sigma are copies (xyz[3 n], sigma[n]), taken before the system was freed. */
static pm_status field_of(const pm_model *model, double edge_per_sigma, int32_t n,
                          const double *xyz, const double *sigma, const pm_mesh *mesh,
                          pm_sizing **out, pm_error *err) {
  double *val = malloc(sizeof(double) * ((size_t)mesh->nnode + 1));
  if (!val) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_grid *g = NULL;
  pm_status st = pm_grid_create(1e-6 * model->diagonal, &g, err);
  for (int32_t i = 0; i < n && !st; ++i) st = pm_grid_insert(g, i, &xyz[3 * i], 0, err);
  for (int32_t k = 0; k < mesh->nnode && !st; ++k) {
    int32_t j = pm_grid_nearest(g, &mesh->xyz[3 * k], NULL);
    if (j < 0)
      st = pm_error_setf(err, PM_ERR_INTERNAL, "psys: no particle left for the sampled field");
    else
      val[k] = sigma[j] * edge_per_sigma; /* sigma -> edge length (the calibration) */
  }
  if (!st) {
    pm_mesh surface = *mesh; /* a view without the tets: pm_sizing_sampled copies what it uses */
    surface.ntet = 0;
    st = pm_sizing_sampled(&surface, val, out, err);
  }
  pm_grid_destroy(g);
  free(val);
  return st;
}

pm_status psys_run_with_field(const pm_run_input *in, const psys_params *p, pm_run_output *out,
                              pm_sizing **field, pm_error *err) {
  out->mesh = NULL;
  out->iterations = 0;
  out->stop_reason[0] = '\0';
  if (field) *field = NULL;
  if (!in || !in->model) return pm_error_setf(err, PM_ERR_ARG, "psys: no model");
  psys_sys *s = NULL;
  pm_mesh *mesh = NULL;
  double *fxyz = NULL, *fsig = NULL; /* the field's copies of the particles */
  int64_t cap = in->max_nodes > 0 ? in->max_nodes : PM_DEFAULT_MAX_NODES;
  /* The caps before the first particle: psys_check_caps measures the field, given or inferred,
   * against the node cap and the memory cap and names the size that fits; a given field is also
   * measured by the rule every method shares (node_budget.h). */
  pm_status st = psys_sys_create(in->model, p, in->size, in->seed, in->threads, cap, &s, err);
  if (!st) st = psys_check_caps(s, err);
  if (!st && in->size)
    st = pm_node_budget_check(in->model, in->size, cap, "node cap", "psys", err);
  if (st) {
    psys_sys_destroy(s);
    return st;
  }
  psys_observer obs = {in->observer};
  psys_phase_report rep[3];
  if ((st = psys_optimize(s, &obs, rep, err))) goto fail;
  for (int k = 0; k < 3; ++k) out->iterations += rep[k].iterations;
  if ((st = psys_to_mesh(s, &mesh, err))) goto fail;
  int all = rep[0].converged && rep[1].converged && rep[2].converged;
  snprintf(out->stop_reason, sizeof out->stop_reason,
           "%s: phases 1-3 ran %lld, %lld, %lld iterations%s", all ? "converged" : "max_iter",
           (long long)rep[0].iterations, (long long)rep[1].iterations,
           (long long)rep[2].iterations, all ? "" : " (a phase reached max_iter)");
  if ((st = add_stats(in->observer, s, rep, err))) goto fail;
  /* The particles are final: the system (its arrays, the neighbour and gap lists and their
   * grids) is freed before the connection, whose own peak (CDT, flips, the tets) then does not
   * come on top of it -- nor the tet step's child process, which shares the parent's resident
   * pages. The field keeps copies of the points and sigma. */
  const int32_t n = s->n;
  const double eps = s->p.edge_per_sigma;
  if (field) {
    fxyz = malloc(sizeof(double) * 3 * ((size_t)n + 1));
    fsig = malloc(sizeof(double) * ((size_t)n + 1));
    if (!fxyz || !fsig) {
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto fail;
    }
    memcpy(fxyz, s->xyz, sizeof(double) * 3 * (size_t)n);
    memcpy(fsig, s->sigma, sizeof(double) * (size_t)n);
  }
  psys_sys_destroy(s);
  s = NULL;
  pm_connect_params cp;
  connect_params(p, in->volume, in->max_nodes, &cp);
  double t0 = pm_seconds();
  pm_connect_report crep;
  if ((st = pm_connect(in->model, mesh, &cp, &crep, err))) goto fail;
  if ((st = pm_observe_time(in->observer, "connect", pm_seconds() - t0, err)))
    goto fail;
  if ((st = psys_trace_mesh(&obs, out->iterations, n, mesh->nnode, err))) goto fail;
  if (field && (st = field_of(in->model, eps, n, fxyz, fsig, mesh, field, err))) goto fail;
  free(fxyz), free(fsig);
  out->mesh = mesh;
  return PM_OK;
fail:
  free(fxyz), free(fsig);
  pm_mesh_destroy(mesh);
  psys_sys_destroy(s);
  return st;
}

static pm_status run(const pm_run_input *in, const void *params, pm_run_output *out,
                     pm_error *err) {
  return psys_run_with_field(in, params, out, NULL, err);
}

/* The default field as a pm_sizing a caller can scale (--target-nodes): the inferred one. */
static pm_status default_size(const pm_model *model, const void *params, uint64_t seed,
                              int threads, pm_sizing **out, pm_error *err) {
  return psys_infer_size(model, params, seed, threads, out, err);
}

const pm_method psys_method = {
    "psys",
    "Bronson, Levine & Whitaker's particle system with its inferred sizing field (papers/001)",
    &psys_param_table,
    sizeof(psys_params),
    init_params,
    run,
    0,
    0,
    default_size,
};

/* ---- the inferred field for other methods -------------------------------------------------- */

pm_status psys_infer_size(const pm_model *m, const psys_params *p, uint64_t seed, int threads,
                          pm_sizing **out, pm_error *err) {
  *out = NULL;
  psys_params def;
  if (!p) psys_params_init(&def), p = &def;
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.seed = seed, in.threads = threads, in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output ro;
  memset(&ro, 0, sizeof ro);
  pm_status st = psys_run_with_field(&in, p, &ro, out, err);
  pm_mesh_destroy(ro.mesh);
  if (st) pm_error_prefix(err, "psys sizing inference");
  return st;
}
