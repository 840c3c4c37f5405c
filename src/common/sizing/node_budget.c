/* The node count a size field asks for (see node_budget.h). */
#include "common/sizing/node_budget.h"

#include <math.h>
#include <stdlib.h>

#include "common/base/vec3.h"
#include "common/mesh/volume_inside.h"

/* One cell of a face's parameter box in the adaptive estimate. */
typedef struct est_cell {
  double u, v, du, dv; /* lower corner and extent */
  int depth;
} est_cell;

#define EST_TOP 16      /* top grid: EST_TOP x EST_TOP cells per face */
#define EST_DEPTH 14    /* subdivisions below the top grid at most */
#define BUDGET_REPORT 1e5 /* pm_node_budget_check integrates to this count at least */

pm_status pm_node_estimate_surface(const pm_model *m, const pm_sizing *s, double stop,
                                   double *estimate, pm_error *err) {
  /* Area per node of the equilateral lattice of edge d: two triangles of area sqrt(3)/4 d^2. */
  const double per_node = sqrt(3.0) / 2.0;
  double total = 0;
  size_t cap = 4 * EST_TOP * EST_TOP + 4 * EST_DEPTH + 16;
  est_cell *stack = malloc(sizeof *stack * cap);
  if (!stack) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status st = PM_OK;
  for (int32_t f = 0; f < m->count[PM_FACE] && !st && total <= stop; ++f) {
    const pm_cell *c = &m->cells[PM_FACE][f];
    double du = (c->hi[0] - c->lo[0]) / EST_TOP, dv = (c->hi[1] - c->lo[1]) / EST_TOP;
    if (!(du > 0) || !(dv > 0)) continue;
    size_t n = 0;
    for (int i = 0; i < EST_TOP; ++i)
      for (int j = 0; j < EST_TOP; ++j)
        stack[n++] = (est_cell){c->lo[0] + i * du, c->lo[1] + j * dv, du, dv, 0};
    while (n > 0 && total <= stop) {
      est_cell e = stack[--n];
      double uv[2] = {e.u + 0.5 * e.du, e.v + 0.5 * e.dv};
      if (!pm_face_inside(c, uv)) continue;
      pm_face_point fp;
      pm_face_eval(c, uv, 1, &fp);
      double d = pm_sizing_eval(s, fp.p);
      if (!(d > 0) || !isfinite(d)) {
        st = pm_error_setf(err, PM_ERR_ARG,
                           "the size field is %g at (%g, %g, %g) on face %d, not > 0", d,
                           fp.p[0], fp.p[1], fp.p[2], c->tag);
        break;
      }
      const int split_u = pm_v3_norm(fp.su) * e.du > d, split_v = pm_v3_norm(fp.sv) * e.dv > d;
      if ((split_u || split_v) && e.depth < EST_DEPTH && n + 4 <= cap) {
        /* The field varies on a scale finer than the cell: split it along the sides longer than
         * d only (a stack of depth-first splits holds at most 3 siblings per level above the
         * top grid). Splitting both sides of a sliver face's cells (slender_face.brep: 10 long,
         * 4e-4 wide) would make 4^k cells where 2^k cover its length, and the estimate took
         * minutes. */
        const double hu = split_u ? 0.5 * e.du : e.du, hv = split_v ? 0.5 * e.dv : e.dv;
        stack[n++] = (est_cell){e.u, e.v, hu, hv, e.depth + 1};
        if (split_u) stack[n++] = (est_cell){e.u + hu, e.v, hu, hv, e.depth + 1};
        if (split_v) stack[n++] = (est_cell){e.u, e.v + hv, hu, hv, e.depth + 1};
        if (split_u && split_v) stack[n++] = (est_cell){e.u + hu, e.v + hv, hu, hv, e.depth + 1};
        continue;
      }
      double nrm[3];
      pm_v3_cross(nrm, fp.su, fp.sv);
      double dA = pm_v3_norm(nrm) * e.du * e.dv;
      if (isfinite(dA)) total += dA / (per_node * d * d);
    }
  }
  free(stack);
  *estimate = total;
  return st;
}

pm_status pm_node_budget_check(const pm_model *m, const pm_sizing *s, int64_t cap,
                               const char *cap_name, const char *method, pm_error *err) {
  /* The integration goes on past the limit up to BUDGET_REPORT nodes (a few tenths of a second
   * of sampling at most), so that a message about a small cap gives the count the field needs,
   * not only the point where the sum passed the limit. */
  double limit = cap > 0 ? 1.5 * (double)cap : INFINITY, stop = fmax(limit, BUDGET_REPORT);
  double est = 0;
  pm_status st = pm_node_estimate_surface(m, s, stop, &est, err);
  if (st) return pm_error_prefix(err, "%s", method);
  if (est > limit)
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "%s: the size field would need %s %.3g surface nodes, over the %s %lld",
                         method, est > stop ? "more than" : "about", est, cap_name,
                         (long long)cap);
  return PM_OK;
}

/* One cell of a volume's box in the adaptive estimate; `inside` 1 when the whole cell is known
 * to lie inside (no shell triangle within its half-diagonal of the centre), so that its children
 * need no inside test. */
typedef struct vest_cell {
  double x[3], h[3]; /* lower corner and extent */
  int depth, inside;
} vest_cell;

#define VEST_TOP 8    /* top grid: VEST_TOP^3 cells per volume */
#define VEST_DEPTH 10 /* subdivisions below the top grid at most */

pm_status pm_node_estimate_volume(const pm_model *m, const pm_mesh *surface, const pm_sizing *s,
                                  double stop, double *estimate, pm_error *err) {
  /* Volume per node of the face-centred cubic lattice of edge d (cube edge sqrt(2) d, four
   * nodes per cube): d^3 / sqrt(2). */
  const double per_node = 1.0 / sqrt(2.0);
  double total = 0;
  size_t cap = 8 * VEST_TOP * VEST_TOP * VEST_TOP + 8 * VEST_DEPTH + 16;
  vest_cell *stack = malloc(sizeof *stack * cap);
  if (!stack) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status st = PM_OK;
  for (int32_t v = 0; v < m->count[PM_VOLUME] && !st && total <= stop; ++v) {
    const pm_cell *c = &m->cells[PM_VOLUME][v];
    double h0[3];
    int flat = 0;
    for (int k = 0; k < 3; ++k) {
      h0[k] = (c->box[3 + k] - c->box[k]) / VEST_TOP;
      flat |= !(h0[k] > 0) || !isfinite(h0[k]);
    }
    if (flat) continue;
    pm_volume_shell *sh = NULL;
    /* A volume without boundary triangles has nothing to measure here: the mesher reports it. */
    if (pm_volume_shell_create(m, surface, v, &sh, NULL) != PM_OK) continue;
    size_t n = 0;
    for (int i = 0; i < VEST_TOP; ++i)
      for (int j = 0; j < VEST_TOP; ++j)
        for (int k = 0; k < VEST_TOP; ++k)
          stack[n++] = (vest_cell){{c->box[0] + i * h0[0], c->box[1] + j * h0[1],
                                    c->box[2] + k * h0[2]},
                                   {h0[0], h0[1], h0[2]},
                                   0,
                                   0};
    while (n > 0 && total <= stop) {
      vest_cell e = stack[--n];
      double x[3] = {e.x[0] + 0.5 * e.h[0], e.x[1] + 0.5 * e.h[1], e.x[2] + 0.5 * e.h[2]};
      double h = fmax(e.h[0], fmax(e.h[1], e.h[2]));
      int in = 1, near = 0;
      if (!e.inside) {
        /* A cell clear of the shell is wholly inside or wholly outside, as its centre is; a cell
         * the shell passes through is split as the field asks wherever its centre is, and only
         * the leaves count by their centre (no part of the volume is lost with a coarse cell
         * whose centre lies outside). */
        near = !isinf(pm_volume_shell_distance(sh, x, 0.5 * pm_v3_norm(e.h)));
        in = pm_volume_shell_inside(sh, x) == 1;
        if (!near && !in) continue;
        e.inside = !near;
      }
      double d = pm_sizing_eval(s, x);
      if (!in) {
        /* Outside, near the shell: the field need not be defined here. */
        if (d > 0 && isfinite(d) && d < h && e.depth < VEST_DEPTH && n + 8 <= cap) {
          double q[3] = {0.5 * e.h[0], 0.5 * e.h[1], 0.5 * e.h[2]};
          for (int o = 0; o < 8; ++o)
            stack[n++] = (vest_cell){{e.x[0] + (o & 1) * q[0], e.x[1] + ((o >> 1) & 1) * q[1],
                                      e.x[2] + ((o >> 2) & 1) * q[2]},
                                     {q[0], q[1], q[2]},
                                     e.depth + 1,
                                     0};
        }
        continue;
      }
      if (!(d > 0) || !isfinite(d)) {
        st = pm_error_setf(err, PM_ERR_ARG,
                           "the size field is %g at (%g, %g, %g) in volume %d, not > 0", d, x[0],
                           x[1], x[2], c->tag);
        break;
      }
      if (d < h && e.depth < VEST_DEPTH && n + 8 <= cap) {
        /* The field varies on a scale finer than the cell: split it in eight (a stack of
         * depth-first splits holds at most 7 siblings per level above the top grid). */
        double q[3] = {0.5 * e.h[0], 0.5 * e.h[1], 0.5 * e.h[2]};
        for (int o = 0; o < 8; ++o)
          stack[n++] = (vest_cell){{e.x[0] + (o & 1) * q[0], e.x[1] + ((o >> 1) & 1) * q[1],
                                    e.x[2] + ((o >> 2) & 1) * q[2]},
                                   {q[0], q[1], q[2]},
                                   e.depth + 1,
                                   e.inside};
        continue;
      }
      double dV = e.h[0] * e.h[1] * e.h[2];
      if (isfinite(dV)) total += dV / (per_node * d * d * d);
    }
    pm_volume_shell_destroy(sh);
  }
  free(stack);
  *estimate = total;
  return st;
}

pm_status pm_node_budget_check_volume(const pm_model *m, const pm_mesh *surface,
                                      const pm_sizing *s, int64_t cap, const char *cap_name,
                                      const char *method, pm_error *err) {
  double limit = cap > 0 ? 1.5 * (double)cap : INFINITY, stop = fmax(limit, BUDGET_REPORT);
  double have = surface ? (double)surface->nnode : 0, est = 0;
  pm_status st = pm_node_estimate_volume(m, surface, s, stop - have, &est, err);
  if (st) return pm_error_prefix(err, "%s", method);
  if (have + est > limit)
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "%s: the size field would need %s %.3g nodes with the volumes (%.0f on "
                         "the surface mesh), over the %s %lld",
                         method, have + est > stop ? "more than" : "about", have + est, have,
                         cap_name, (long long)cap);
  return PM_OK;
}
