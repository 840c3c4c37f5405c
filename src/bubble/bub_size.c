/* The default size rule of the bubble method, for a model given without a size field:
 *
 *   d(x) = min( D / size_div,  min over features k of ( h_k + g dist(x, k) ) )
 *
 * D is the model's bounding-box diagonal, size_div = 30 and g = size_grade = 0.3 by default; the
 * features (short and curved curves, narrow faces and sharp wedges, curved faces) and the exact
 * evaluation are the shared layer's (sizing_features.h): g-Lipschitz, so neighbouring bubbles
 * differ in size by at most a factor 1 + g, which the packing follows without distortion.
 *
 * bub_run uses this exact field. bub_default_size, which hands the field to a caller (to scale it:
 * --target-nodes, matched node counts), returns the same rule sampled on a triangulation of the
 * model: the bubbles of the initial
 * placement under the exact rule, connected by pm_connect, with the exact values at the nodes,
 * interpolated linearly on the triangles (sizing.h, pm_sizing_sampled); when the connection
 * fails, the nodes alone (inverse distance weighting).
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/connect/connect.h"
#include "common/sizing/sizing_features.h"
#include "common/base/vec3.h"

pm_status bub_size_rule_create(const pm_model *m, const bub_params *p, pm_sizing **field,
                               void **rule, pm_error *err) {
  *field = NULL, *rule = NULL;
  const double d0 = (m->diagonal > 0 ? m->diagonal : 1) / p->size_div;
  pm_feature_size *fs = NULL;
  pm_status st = pm_feature_size_create(m, d0, p->size_grade, PM_FEATURE_ALL, &fs, err);
  if (st) return st;
  st = pm_sizing_features(NULL, fs, field, err);
  if (st) pm_feature_size_destroy(fs);
  return st;
}

/* The field owns its features: nothing else to release (kept for bub_run's pairing). */
void bub_size_rule_free(void *rule) { (void)rule; }

pm_status bub_default_size(const pm_model *model, const void *params, uint64_t seed, int threads,
                           pm_sizing **out, pm_error *err) {
  *out = NULL;
  bub_params p;
  if (params)
    p = *(const bub_params *)params;
  else
    bub_params_init(&p);
  pm_sizing *exact = NULL;
  void *rule = NULL;
  pm_status st = bub_size_rule_create(model, &p, &exact, &rule, err);
  if (st) return st;
  /* Samples: the initial placement under the exact rule (no subdivision weights: w1 = w2 = 1,
   * so the samples are at least as dense as the field asks). */
  p.w1 = 1, p.w2 = 1;
  bub_state *s = NULL;
  pm_mesh *mesh = NULL;
  double *val = NULL;
  st = bub_state_create(model, exact, &p, threads, seed, &s, err);
  if (!st) st = bub_place(s, err);
  if (!st && !(mesh = pm_mesh_create())) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < (s ? s->n : 0) && !st; ++i)
    st = pm_mesh_add_node(mesh, &s->x[3 * i], s->kind[i], s->cell[i], &s->par[2 * i], NULL, err);
  if (!st) {
    pm_connect_params cp;
    pm_connect_params_init(&cp);
    cp.flips = PM_FLIP_NONE;
    pm_error ce = {0};
    if (pm_connect(model, mesh, &cp, NULL, &ce) != PM_OK) {
      /* Nodes alone: the sampled field falls back to inverse-distance weighting. */
      mesh->ntri = mesh->nseg = mesh->ntet = 0;
    }
    val = malloc(sizeof(double) * ((size_t)mesh->nnode + 1));
    if (!val) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t i = 0; i < mesh->nnode && !st; ++i) val[i] = pm_sizing_eval(exact, &mesh->xyz[3 * i]);
  }
  if (!st && mesh->nnode == 0) {
    /* Nothing to sample (a model without curves or faces): the uniform size. */
    st = pm_sizing_constant((model->diagonal > 0 ? model->diagonal : 1) / p.size_div, out, err);
  } else if (!st) {
    st = pm_sizing_sampled(mesh, val, out, err);
  }
  free(val);
  pm_mesh_destroy(mesh);
  bub_state_destroy(s);
  pm_sizing_destroy(exact);
  bub_size_rule_free(rule);
  return st;
}
