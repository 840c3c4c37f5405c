/* Helpers shared by the geom_cad tests: loading, direct gmsh access under a scope, and the
 * divergence-theorem volume of a cell complex's volume. */
#ifndef PM_TEST_GEOM_CAD_UTIL_H
#define PM_TEST_GEOM_CAD_UTIL_H

#include "test_support.h"

#include <gmshc.h>

#include <stdlib.h>
#include <string.h>

#include "common/geom/geom.h"
#include "common/geom/geom_cad.h"
#include "common/input/cases.h"
#include "common/backends/gmsh_session.h"
#include "common/base/vec3.h"

/* Skip the calling test when the shared CAD folder is missing. */
#define CAD_REQUIRE()                                                               \
  do {                                                                              \
    if (!pm_test_have_cad()) {                                                      \
      print_message("skipped: no CAD models in %s (set PM_CAD_DIR)\n", PM_CAD_DIR); \
      skip();                                                                       \
    }                                                                               \
  } while (0)

static inline pm_model *cad_load_file(const char *file) {
  char path[1024];
  pm_test_cad(file, path, sizeof path);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  assert_non_null(m);
  return m;
}

static inline pm_model *cad_load_case(const char *name) {
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open(name, &m, NULL, &e), e);
  return m;
}

/* A check inside a pm_gmsh_lock()ed region: on failure the lock is released first (a failing
 * assertion leaves the test by longjmp, and a lock left held would block every later gmsh user,
 * the threads of later tests included). */
#define CAD_LOCKED_CHECK(cond)                                 \
  do {                                                         \
    if (!(cond)) {                                             \
      pm_gmsh_unlock();                                        \
      fail_msg("%s:%d: %s failed", __FILE__, __LINE__, #cond); \
    }                                                          \
  } while (0)

/* Make m's gmsh model current (gmsh locked) for direct gmsh calls; cad_gmsh_end restores. */
/* No assertion may fail between the two (a failing assertion leaves the test by longjmp, and the
 * gmsh lock held would block every later gmsh user). */
static inline void cad_gmsh_begin(const pm_model *m, pm_gmsh_scope *scope) {
  pm_error e = {0};
  pm_gmsh_lock();
  pm_status s = pm_gmsh_scope_enter(scope, pm_cad_gmsh_model(m), 0, &e);
  if (s) {
    pm_gmsh_unlock();
    fail_msg("selecting gmsh model %s: %s", pm_cad_gmsh_model(m), e.msg);
  }
}

static inline void cad_gmsh_end(pm_gmsh_scope *scope) {
  pm_gmsh_scope_leave(scope, 0);
  pm_gmsh_unlock();
}

/* The face with gmsh tag `tag`. */
static inline const pm_cell *cad_face_by_tag(const pm_model *m, int dim, int tag) {
  for (int32_t i = 0; i < m->count[dim]; ++i)
    if (m->cells[dim][i].tag == tag) return &m->cells[dim][i];
  fail_msg("no cell of dimension %d with tag %d", dim, tag);
  return NULL;
}

/* Volume enclosed by volume cell v from the divergence theorem,
 *   V = 1/3 sum_F sense_F  int_F (S - c) . (Su x Sv) du dv,
 * midpoint rule on an n x n grid of each face's parameter box, trimmed by pm_face_inside
 * (c: the model's box centre, to reduce cancellation). */
static inline double cad_divergence_volume(const pm_model *m, const pm_cell *v, int n) {
  double c[3] = {0.5 * (m->box[0] + m->box[3]), 0.5 * (m->box[1] + m->box[4]),
                 0.5 * (m->box[2] + m->box[5])};
  double total = 0;
  double *uv = malloc(sizeof(double) * 2 * (size_t)n * (size_t)n);
  pm_face_point *fp = malloc(sizeof(pm_face_point) * (size_t)n * (size_t)n);
  assert_non_null(uv);
  assert_non_null(fp);
  for (int32_t k = 0; k < v->nbound; ++k) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, v->bound[k].cell);
    double du = (f->hi[0] - f->lo[0]) / n, dv = (f->hi[1] - f->lo[1]) / n;
    int32_t np = 0;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        double q[2] = {f->lo[0] + (a + 0.5) * du, f->lo[1] + (b + 0.5) * dv};
        if (!pm_face_inside(f, q)) continue;
        uv[2 * np] = q[0], uv[2 * np + 1] = q[1], ++np;
      }
    pm_face_eval_many(f, np, uv, 1, fp);
    double flux = 0;
    for (int32_t i = 0; i < np; ++i) {
      double x[3], r[3];
      pm_v3_cross(x, fp[i].su, fp[i].sv);
      pm_v3_sub(r, fp[i].p, c);
      flux += pm_v3_dot(r, x);
    }
    total += v->bound[k].sense * flux * du * dv / 3.0;
  }
  free(uv);
  free(fp);
  return total;
}

/* Entity counts of `path` imported independently into a scratch gmsh model, with the option
 * pm_cad_load uses (IGES sewn). */
static inline void cad_gmsh_counts(const char *path, int iges, int counts[4]) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_gmsh_begin(&e), e);
  pm_gmsh_lock();
  pm_gmsh_scope scope;
  if (pm_gmsh_scope_enter(&scope, "test_geom_cad_counts", 1, &e)) {
    pm_gmsh_unlock();
    fail_msg("creating a gmsh model: %s", e.msg);
  }
  int ierr = 0;
  double sew = 0;
  gmshOptionGetNumber("Geometry.OCCSewFaces", &sew, &ierr);
  gmshOptionSetNumber("Geometry.OCCSewFaces", iges ? 1 : 0, &ierr);
  int token = pm_gmsh_mute_stdout();
  int *dt = NULL;
  size_t n = 0;
  gmshModelOccImportShapes(path, &dt, &n, 0, "", &ierr);
  if (dt) gmshFree(dt);
  gmshModelOccSynchronize(&ierr);
  pm_gmsh_unmute_stdout(token);
  gmshOptionSetNumber("Geometry.OCCSewFaces", sew, &ierr);
  for (int d = 0; d < 4; ++d) {
    dt = NULL;
    gmshModelGetEntities(&dt, &n, d, &ierr);
    counts[d] = (int)(n / 2);
    if (dt) gmshFree(dt);
  }
  pm_gmsh_scope_leave(&scope, 1);
  pm_gmsh_unlock();
}

#endif /* PM_TEST_GEOM_CAD_UTIL_H */
