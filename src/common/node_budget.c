/* The node count a size field asks for (see node_budget.h). */
#include "common/node_budget.h"

#include <math.h>
#include <stdlib.h>

#include "common/vec3.h"

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
      double h = fmax(pm_v3_norm(fp.su) * e.du, pm_v3_norm(fp.sv) * e.dv);
      if (d < h && e.depth < EST_DEPTH && n + 4 <= cap) {
        /* The field varies on a scale finer than the cell: split it (a stack of depth-first
         * splits holds at most 3 siblings per level above the top grid). */
        double hu = 0.5 * e.du, hv = 0.5 * e.dv;
        stack[n++] = (est_cell){e.u, e.v, hu, hv, e.depth + 1};
        stack[n++] = (est_cell){e.u + hu, e.v, hu, hv, e.depth + 1};
        stack[n++] = (est_cell){e.u, e.v + hv, hu, hv, e.depth + 1};
        stack[n++] = (est_cell){e.u + hu, e.v + hv, hu, hv, e.depth + 1};
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
