/* Shared helpers of the peer tests: open a case, run a method, check and measure the mesh. */
#ifndef PM_PEER_TEST_UTIL_H
#define PM_PEER_TEST_UTIL_H

#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/input/cases.h"
#include "common/geom/geom.h"
#include "common/input/input.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"
#include "common/sizing/sizing.h"
#include "peers/peers.h"

/* Run `method` with its default parameters plus "KEY=VALUE" settings (NULL-terminated, may be
 * NULL) on model md with size field sz (may be NULL). Returns the status; *mesh receives the
 * mesh on success. */
static inline pm_status peer_test_run(const pm_method *method, const pm_model *md,
                                      const pm_sizing *sz, int volume, const char *const *sets,
                                      pm_mesh **mesh, pm_error *e) {
  void *params = calloc(1, method->params_size ? method->params_size : 1);
  if (method->params_init) method->params_init(params);
  for (int k = 0; sets && sets[k]; ++k) {
    pm_status s = pm_params_set_pair(method->params, params, sets[k], e);
    if (s) {
      free(params);
      return s;
    }
  }
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = md;
  in.size = sz;
  in.seed = 1;
  in.threads = 2;
  in.volume = volume;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  pm_status s = method->run(&in, params, &out, e);
  free(params);
  *mesh = out.mesh;
  return s;
}

/* The checker's verdict with the model; fails the test with the first problem. */
static inline void peer_test_expect_valid(const pm_mesh *m, const pm_model *md) {
  pm_check_report r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(m, md, &r, &e), e);
  if (!r.valid) fail_msg("invalid mesh: %s", r.problem[0]);
  pm_check_report_clear(&r);
}

/* Open case `name` with its default size field. */
static inline void peer_test_case(const char *name, pm_model **md, pm_sizing **sz) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open(name, md, sz, &e), e);
}

/* The analytic node count of a planar domain of area A and perimeter P meshed by equilateral
 * triangles of edge d: A / (sqrt(3)/2 d^2) nodes inside plus the boundary's share, P / (2 d)
 * (Euler's formula for a triangulated polygon: V = T/2 + B/2 + 1, T = A / (sqrt(3)/4 d^2)). */
static inline double peer_test_expected_nodes(double area, double perimeter, double d) {
  return area / (sqrt(3.0) / 2.0 * d * d) + perimeter / (2.0 * d) + 1.0;
}

/* Squared distance of two points. */
static inline double pm_test_d2(const double a[3], const double b[3]) {
  return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

#endif /* PM_PEER_TEST_UTIL_H */
