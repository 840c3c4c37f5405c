/* The planar rectangle [0, 1] x [0, h] (face 0; curves 0..3 counter-clockwise from the bottom
 * side, vertex k at the start of curve k), shared by the tests of one planar face. */
#ifndef PM_TEST_RECT_MODEL_H
#define PM_TEST_RECT_MODEL_H

#include "test_support.h"

#include "common/geom/geom_analytic.h"

static inline pm_model *pm_test_rect_model(const char *name, double h) {
  const pm_planar_piece p[4] = {{PM_PIECE_LINE, {0, 0}, {0, 0}, 0},
                                {PM_PIECE_LINE, {1, 0}, {0, 0}, 0},
                                {PM_PIECE_LINE, {1, h}, {0, 0}, 0},
                                {PM_PIECE_LINE, {0, h}, {0, 0}, 0}};
  pm_planar_loop loop = {4, p};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model(name, 1, &loop, &m, &e), e);
  return m;
}

#endif /* PM_TEST_RECT_MODEL_H */
