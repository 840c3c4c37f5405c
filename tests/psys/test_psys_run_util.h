/* Running psys through its pm_method in tests: open an input, run with overrides, check the
 * mesh, summarize its triangles' R / l_min. */
#ifndef TEST_PSYS_RUN_UTIL_H
#define TEST_PSYS_RUN_UTIL_H

#include "test_psys_util.h"

#include "common/report/run_report.h"
#include "common/input/input.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"

static inline pm_model *psys_test_open(const char *spec) {
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open(spec, &m, NULL, &e), e);
  return m;
}

/* Run psys on m with size (may be NULL) and the given overrides ("KEY=VALUE", NULL-ended). */
static inline pm_mesh *psys_test_run(const pm_model *m, const pm_sizing *size, uint64_t seed, int threads,
                                         int volume, const char *const *sets, pm_stats *stats, pm_trace *trace,
                                         pm_frames *frames) {
  psys_params p;
  psys_params_init(&p);
  pm_error e = {0};
  for (int k = 0; sets && sets[k]; ++k) PM_ASSERT_OK(pm_params_set_pair(&psys_param_table, &p, sets[k], &e), e);
  PM_ASSERT_OK(pm_params_check(&psys_param_table, &p, &e), e);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.size = size, in.seed = seed, in.threads = threads, in.volume = volume;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_report report = {stats, trace, frames};
  pm_run_observer observer;
  pm_run_report_observer(&report, &observer);
  in.observer = &observer;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  PM_ASSERT_OK(psys_method.run(&in, &p, &out, &e), e);
  assert_non_null(out.mesh);
  assert_true(out.iterations > 0);
  assert_true(strlen(out.stop_reason) > 0);
  return out.mesh;
}

static inline void psys_test_assert_valid(const pm_mesh *mesh, const pm_model *m) {
  pm_check_report r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &r, &e), e);
  if (!r.valid) fail_msg("mesh check: %s", r.nproblem ? r.problem[0] : "invalid");
  pm_check_report_clear(&r);
}

static inline pm_summary psys_test_aspect(const pm_mesh *mesh, const pm_sizing *size, double *size_ratio) {
  pm_quality q;
  pm_error e = {0};
  PM_ASSERT_OK(pm_quality_compute(mesh, size, &q, &e), e);
  pm_summary s = q.tri.s_aspect_ratio;
  if (size_ratio) *size_ratio = q.tri.size_ratio.mean;
  pm_quality_clear(&q);
  return s;
}

#endif /* TEST_PSYS_RUN_UTIL_H */
