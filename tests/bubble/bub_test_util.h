/* Helpers of the bubble tests: planar models and hand-made bubble configurations. */
#ifndef BUB_TEST_UTIL_H
#define BUB_TEST_UTIL_H

#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "bubble/bub_private.h"
#include "common/geom/geom_analytic.h"
#include "common/base/rng.h"
#include "common/base/vec3.h"

/* The square [x0, x0 + a] x [y0, y0 + a]: vertices 0..3 at its corners (counter-clockwise from
 * (x0, y0)), curve 0 the bottom edge from (x0, y0) to (x0 + a, y0), one face. */
static inline pm_model *bt_square(double x0, double y0, double a) {
  const pm_planar_piece pc[4] = {{PM_PIECE_LINE, {x0, y0}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {x0 + a, y0}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {x0 + a, y0 + a}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {x0, y0 + a}, {0, 0}, 0}};
  pm_planar_loop lp = {4, pc};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("square", 1, &lp, &m, &e), e);
  return m;
}

/* Parameters for hand-driven states: no population control unless asked. */
static inline bub_params bt_params(void) {
  bub_params p;
  bub_params_init(&p);
  p.population = 0;
  return p;
}

/* A state with no bubbles yet. */
static inline bub_state *bt_state(const pm_model *m, const pm_sizing *size, const bub_params *p,
                                  int threads) {
  bub_state *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_create(m, size, p, threads, 7, &s, &e), e);
  return s;
}

/* Add a face bubble of face 0 at (u, v) (planar: (x, y)). */
static inline int32_t bt_face_bubble(bub_state *s, double u, double v) {
  double par[2] = {u, v};
  int32_t id;
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_add(s, BUB_KFACE, 0, par, NULL, 0, &id, &e), e);
  return id;
}

/* A hexagonal patch of face bubbles at spacing h centred at (cx, cy): rows j = -R..R, each
 * point within radius R h of the centre. Returns the index of the centre bubble. */
static inline int32_t bt_hex_patch(bub_state *s, double cx, double cy, double h, int R) {
  int32_t centre = -1;
  for (int j = -R; j <= R; ++j)
    for (int i = -2 * R; i <= 2 * R; ++i) {
      double x = cx + (i + 0.5 * j) * h, y = cy + j * 0.86602540378443865 * h;
      if (hypot(x - cx, y - cy) > R * h + 1e-9) continue;
      int32_t id = bt_face_bubble(s, x, y);
      if (i == 0 && j == 0) centre = id;
    }
  return centre;
}

/* Run n steps; returns the last step's info. */
static inline bub_step_info bt_steps(bub_state *s, int n) {
  bub_step_info info;
  memset(&info, 0, sizeof info);
  pm_error e = {0};
  for (int k = 0; k < n; ++k) PM_ASSERT_OK(bub_dynamics_step(s, &info, &e), e);
  return info;
}

#endif /* BUB_TEST_UTIL_H */
