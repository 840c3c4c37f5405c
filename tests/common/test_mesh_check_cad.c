/* The checker against real CAD models: gmsh's own mesher meshes shared CAD files (surfaces and
 * tets), the mesh is written with its node parameters and read back through mesh_io, and
 * pm_mesh_check, given the model loaded by geom_cad, must accept it with the right Euler
 * characteristics; then defects are planted. This ties together three conventions that must
 * agree: geom_cad's cell numbering and face senses, mesh_io's entity tags, and the triangle
 * orientation of geom.h's pm_face_mesh_sign (which gmsh follows: outward on solids). */
#include "test_support.h"

#include <gmshc.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/geom.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/mesh/mesh_io.h"

static char dir[256];

static int setup(void **state) {
  (void)state;
  snprintf(dir, sizeof dir, "/tmp/pm_test_mesh_check_cad_XXXXXX");
  return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state) {
  (void)state;
  char cmd[400];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  int rc = system(cmd);
  pm_gmsh_shutdown();
  return rc == 0 ? 0 : -1;
}

/* Load `file` as a model and mesh it with gmsh (dimension dim, size factor), in a separate gmsh
 * model; return the mesh as packmesh reads it. */
static void load_and_mesh(const char *file, int dim, double factor, pm_model **md, pm_mesh **m) {
  char cad[512], msh[512];
  pm_test_cad(file, cad, sizeof cad);
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(cad, md, &e), e);
  int ierr = 0;
  pm_gmsh_lock();
  pm_gmsh_scope scope;
  PM_ASSERT_OK(pm_gmsh_scope_enter(&scope, "test-mesher", 1, &e), e);
  int *dt = NULL;
  size_t ndt = 0;
  int tok = pm_gmsh_mute_stdout();
  gmshModelOccImportShapes(cad, &dt, &ndt, 0, "", &ierr);
  pm_gmsh_unmute_stdout(tok);
  assert_int_equal(ierr, 0);
  gmshFree(dt);
  gmshModelOccSynchronize(&ierr);
  gmshOptionSetNumber("Mesh.MeshSizeFactor", factor, &ierr);
  gmshModelMeshGenerate(dim, &ierr);
  assert_int_equal(ierr, 0);
  snprintf(msh, sizeof msh, "%s/%s.msh", dir, file);
  double saved = 0;
  gmshOptionGetNumber("Mesh.SaveParametric", &saved, &ierr);
  gmshOptionSetNumber("Mesh.SaveParametric", 1, &ierr);
  gmshWrite(msh, &ierr);
  gmshOptionSetNumber("Mesh.SaveParametric", saved, &ierr);
  assert_int_equal(ierr, 0);
  pm_gmsh_scope_leave(&scope, 1);
  pm_gmsh_unlock();
  PM_ASSERT_OK(pm_mesh_read(msh, m, &e), e);
}

static void expect_valid(const pm_mesh *m, const pm_model *md, int euler, int genus) {
  pm_check_report r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(m, md, &r, &e), e);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.nshell, md->count[3]);
  assert_int_equal(r.shell[0].euler, euler);
  assert_int_equal(r.shell[0].genus, genus);
  assert_true(r.shell[0].closed);
  assert_true(r.shell[0].enclosed > 0);
  pm_check_report_clear(&r);
}

static void solids_accepted(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  static const struct {
    const char *file;
    int dim, euler, genus;
  } cases[] = {
      {"planar_step.brep", 3, 2, 0},    /* 11 planes, a concave pocket; with tets */
      {"synth_box_hole.brep", 3, 0, 1}, /* a through-hole: genus 1; with tets */
      {"synth_torus.brep", 2, 0, 1},    /* doubly periodic, two seams, one vertex */
      {"synth_sphere.brep", 2, 2, 0},   /* a seam and two poles */
      {"crack.brep", 2, 2, 0},          /* an embedded crack face */
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
    pm_model *md = NULL;
    pm_mesh *m = NULL;
    load_and_mesh(cases[i].file, cases[i].dim, 1.0, &md, &m);
    if (cases[i].dim == 3) assert_true(m->ntet > 100);
    expect_valid(m, md, cases[i].euler, cases[i].genus);
    pm_mesh_destroy(m);
    pm_model_destroy(md);
  }
}

static void defects_found(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  pm_model *md = NULL;
  pm_mesh *m = NULL;
  load_and_mesh("synth_box_hole.brep", 2, 1.0, &md, &m);
  expect_valid(m, md, 0, 1);
  pm_check_report r;
  pm_error e = {0};
  /* One face's triangles turned over: its border with every neighbour disagrees, and, its
   * nodes carrying their parameters, the face itself disagrees with its orientation. */
  int32_t f = m->tri_cell[0], nf = 0;
  for (int32_t t = 0; t < m->ntri; ++t)
    if (m->tri_cell[t] == f) {
      int32_t x = m->tri[3 * t + 1];
      m->tri[3 * t + 1] = m->tri[3 * t + 2];
      m->tri[3 * t + 2] = x;
      ++nf;
    }
  PM_ASSERT_OK(pm_mesh_check(m, md, &r, &e), e);
  assert_false(r.valid);
  assert_true(r.count[PM_CHECK_SHELL_ORIENTATION] > 0);
  assert_true(r.count[PM_CHECK_FACE_NORMAL] >= 1);
  assert_true(nf > 10);
  assert_int_equal(r.count[PM_CHECK_ORIENTATION], 0);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  pm_model_destroy(md);
  /* A triangle removed: a hole in the shell. */
  load_and_mesh("synth_box_hole.brep", 2, 1.0, &md, &m);
  m->tri[3 * 10] = m->tri[3 * (m->ntri - 1)];
  m->tri[3 * 10 + 1] = m->tri[3 * (m->ntri - 1) + 1];
  m->tri[3 * 10 + 2] = m->tri[3 * (m->ntri - 1) + 2];
  m->tri_cell[10] = m->tri_cell[m->ntri - 1];
  m->ntri--;
  PM_ASSERT_OK(pm_mesh_check(m, md, &r, &e), e);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_SHELL_OPEN], 3);
  assert_false(r.shell[0].closed);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  pm_model_destroy(md);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(solids_accepted),
      cmocka_unit_test(defects_found),
  };
  return cmocka_run_group_tests(tests, setup, teardown);
}
