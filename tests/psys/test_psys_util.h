/* Helpers shared by the psys tests: a square planar model, hexagonal patches of particles. */
#ifndef TEST_PSYS_UTIL_H
#define TEST_PSYS_UTIL_H

#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/geom/geom_analytic.h"
#include "common/base/rng.h"
#include "common/base/vec3.h"
#include "common/input/input.h"
#include "psys/psys_private.h"

/* The square [0, side]^2 in the plane z = 0 (one face, (u, v) = (x, y)). */
static inline pm_model *psys_test_square(double side) {
  const pm_planar_piece sq[4] = {
      {PM_PIECE_LINE, {0, 0}, {0, 0}, 0},
      {PM_PIECE_LINE, {side, 0}, {0, 0}, 0},
      {PM_PIECE_LINE, {side, side}, {0, 0}, 0},
      {PM_PIECE_LINE, {0, side}, {0, 0}, 0},
  };
  pm_planar_loop loop = {4, sq};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("square", 1, &loop, &m, &e), e);
  return m;
}

/* A model of the shared CAD folder (file relative to it), or NULL when the folder is not there
 * (the caller skips). */
static inline pm_model *psys_test_open_cad(const char *file) {
  if (!pm_test_have_cad()) return NULL;
  char path[1024];
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open(pm_test_cad(file, path, sizeof path), &m, NULL, &e), e);
  return m;
}

/* A system on m with the defaults (size NULL: the inferred field), seed 1, `threads`. */
static inline psys_sys *psys_test_system(const pm_model *m, const psys_params *p, int threads) {
  psys_params def;
  if (!p) psys_params_init(&def), p = &def;
  psys_sys *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(psys_sys_create(m, p, NULL, 1, threads, 10000000, &s, &e), e);
  return s;
}

/* Face particles of radius sigma on a hexagonal lattice of spacing a, rows along x, filling the
 * box [x0, x1] x [y0, y1] of face 0. Returns how many were added. */
static inline int32_t psys_test_hex(psys_sys *s, double a, double sigma, double x0, double y0,
                                    double x1, double y1) {
  pm_error e = {0};
  int32_t n = 0;
  const double h = a * sqrt(3.0) / 2;
  for (int row = 0; y0 + row * h <= y1 + 1e-12; ++row)
    for (int col = 0;; ++col) {
      double uv[2] = {x0 + col * a + (row % 2 ? 0.5 * a : 0), y0 + row * h};
      if (uv[0] > x1 + 1e-12) break;
      PM_ASSERT_OK(psys_add(s, PM_FACE, 0, uv, sigma, NULL, &e), e);
      ++n;
    }
  return n;
}

/* Energies (and forces) of every particle at its place, without moving any; returns their sum. */
static inline double psys_test_energies(psys_sys *s) {
  uint8_t *keep = malloc((size_t)s->n + 1);
  memcpy(keep, s->fixed, (size_t)s->n);
  memset(s->fixed, 1, (size_t)s->n);
  psys_move_info mi;
  pm_error e = {0};
  PM_ASSERT_OK(psys_move_pass(s, &mi, &e), e);
  memcpy(s->fixed, keep, (size_t)s->n);
  free(keep);
  return mi.energy;
}

#endif /* TEST_PSYS_UTIL_H */
