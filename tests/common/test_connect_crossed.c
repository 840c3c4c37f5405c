/* pm_connect where a face's pcurve disagreed with its 3D curve: fusee.stp's face 85 is bounded by
 * curve 418, whose pcurve's image S(pcurve(t)) lies 0.03-0.08 off C(t), more than the spacing of
 * the nodes there, and by curve 415, whose pcurve agrees to 1e-7. A face node put just inside the
 * pcurve's trace in (u, v) (as a mesher that keeps its face nodes inside the trim does) was, along
 * curve 418, closer to the boundary than the trace's own error: the bubble mesh folded a triangle
 * there, and step 1b of the connection (connect.c) dropped such nodes. Loading now takes curve
 * 418's (u, v) on this face by projecting the curve onto the surface (geom_cad_eval.c), so its
 * trace is the curve's: the nodes just inside both traces are ordinary face nodes, step 1b finds
 * nothing to drop, and no triangle folds. (Step 1b's own case, a face leaning back over a coarse
 * arc's chord, is test_cad_heal's quarter frustum.) The curve nodes come from gmsh's 1D mesh
 * (fast, unlike meshing the whole model). */
#include "test_support.h"

#include <gmshc.h>
#include <stdlib.h>
#include <string.h>

#include "common/connect/connect.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/base/vec3.h"

static const char *model_path = PM_CAD_DIR "/fusee.stp";

static int32_t cell_of_tag(const pm_model *m, int dim, int tag) {
  for (int32_t i = 0; i < m->count[dim]; ++i)
    if (m->cells[dim][i].tag == tag) return i;
  return -1;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* gmsh's vertex and curve nodes at mesh size `size`. */
static pm_mesh *curve_nodes(const pm_model *m, double size) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  pm_gmsh_scope scope;
  pm_gmsh_lock();
  PM_ASSERT_OK(pm_gmsh_scope_enter(&scope, pm_cad_gmsh_model(m), 0, &e), e);
  int ierr = 0;
  gmshOptionSetNumber("Mesh.MeshSizeMax", size, &ierr);
  gmshOptionSetNumber("Mesh.MeshSizeMin", size / 20, &ierr);
  gmshModelMeshGenerate(1, &ierr);
  assert_int_equal(ierr, 0);
  for (int dim = 0; dim <= 1; ++dim)
    for (int32_t i = 0; i < m->count[dim]; ++i) {
      const pm_cell *c = &m->cells[dim][i];
      size_t *tags = NULL, nt = 0, nc = 0, np = 0;
      double *coord = NULL, *par = NULL;
      gmshModelMeshGetNodes(&tags, &nt, &coord, &nc, &par, &np, dim, c->tag, 0, 1, &ierr);
      if (ierr) continue;
      for (size_t k = 0; k < nt; ++k) {
        double t[2] = {dim == 1 && np >= nt ? par[k * (np / nt)] : 0, 0};
        PM_ASSERT_OK(pm_mesh_add_node(mesh, &coord[3 * k], dim, i, t, NULL, &e), e);
      }
      gmshFree(tags), gmshFree(coord), gmshFree(par);
    }
  gmshModelMeshClear(NULL, 0, &ierr);
  pm_gmsh_scope_leave(&scope, 0);
  pm_gmsh_unlock();
  return mesh;
}

/* Triangles of face f whose normal runs against the face's mesh orientation at one of its
 * nodes classified on f. */
static int32_t folded(const pm_model *m, const pm_mesh *mesh, int32_t f) {
  const pm_cell *fc = &m->cells[PM_FACE][f];
  int sign = pm_face_mesh_sign(m, f);
  int32_t n = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    if (mesh->tri_cell[t] != f) continue;
    const int32_t *v = &mesh->tri[3 * t];
    double ab[3], ac[3], nrm[3];
    pm_v3_sub(ab, &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[0]]);
    pm_v3_sub(ac, &mesh->xyz[3 * v[2]], &mesh->xyz[3 * v[0]]);
    pm_v3_cross(nrm, ab, ac);
    int bad = 0;
    for (int k = 0; k < 3; ++k) {
      if (mesh->node_dim[v[k]] != PM_FACE || mesh->node_cell[v[k]] != f) continue;
      pm_face_point fp;
      pm_face_eval(fc, &mesh->node_par[2 * v[k]], 1, &fp);
      double s[3];
      pm_v3_cross(s, fp.su, fp.sv);
      bad |= sign * pm_v3_dot(s, nrm) < 0;
    }
    n += bad;
  }
  return n;
}

/* The use of curve index c in face fc's loops. */
static const pm_use *use_of(const pm_cell *fc, int32_t c) {
  for (int32_t l = 0; l < fc->nloop; ++l)
    for (int32_t k = 0; k < fc->loop[l].nuse; ++k)
      if (fc->loop[l].use[k].cell == c) return &fc->loop[l].use[k];
  return NULL;
}

/* Face nodes on the (u, v) trace of curve `tag` in face f: at each segment's middle, a hundredth
 * of the segment's (u, v) length inside the face. Returns how many. */
static int32_t trace_nodes(const pm_model *m, pm_mesh *mesh, int32_t f, int tag) {
  const pm_cell *fc = &m->cells[PM_FACE][f];
  int32_t c = cell_of_tag(m, PM_CURVE, tag);
  assert_true(c >= 0);
  const pm_use *use = use_of(fc, c);
  assert_non_null(use);
  const pm_cell *cv = &m->cells[PM_CURVE][c];
  double *t = malloc(sizeof(double) * ((size_t)mesh->nnode + 2));
  int32_t nt = 0;
  t[nt++] = cv->lo[0], t[nt++] = cv->hi[0];
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == PM_CURVE && mesh->node_cell[i] == c) t[nt++] = mesh->node_par[2 * i];
  qsort(t, (size_t)nt, sizeof(double), cmp_double);
  pm_error e = {0};
  int32_t placed = 0;
  for (int32_t k = 0; k + 1 < nt; ++k) {
    double a[2], b[2], q[2];
    pm_face_curve_uv(fc, use, t[k], a);
    pm_face_curve_uv(fc, use, t[k + 1], b);
    pm_face_curve_uv(fc, use, 0.5 * (t[k] + t[k + 1]), q);
    double d[2] = {b[0] - a[0], b[1] - a[1]};
    for (int side = -1; side <= 1; side += 2) {
      double uv[2] = {q[0] - side * 0.01 * d[1], q[1] + side * 0.01 * d[0]}, x[3];
      if (!pm_face_inside(fc, uv)) continue;
      pm_cell_point(fc, uv, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_FACE, f, uv, NULL, &e), e);
      ++placed;
      break;
    }
  }
  free(t);
  return placed;
}

static int32_t face_nodes(const pm_mesh *mesh, int32_t f) {
  int32_t n = 0;
  for (int32_t i = 0; i < mesh->nnode; ++i) n += mesh->node_dim[i] == PM_FACE && mesh->node_cell[i] == f;
  return n;
}

/* Both traces follow their curves (curve 418's was 0.03-0.08 off in 3D, 415's 1.4e-7): every node
 * along them is kept, with step 1b or without, and no triangle folds. */
static void trace_nodes_kept(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(model_path, &m, &e), e);
  int32_t f = cell_of_tag(m, PM_FACE, 85);
  assert_true(f >= 0);
  pm_mesh *mesh = curve_nodes(m, 0.1);
  int32_t off = trace_nodes(m, mesh, f, 418), on = trace_nodes(m, mesh, f, 415);
  assert_true(off >= 10 && on >= 5);
  /* curve 418's trace is the curve's, to the curve's own distance from the surface (0.0011) */
  {
    const pm_cell *fc = &m->cells[PM_FACE][f], *cv = &m->cells[PM_CURVE][cell_of_tag(m, PM_CURVE, 418)];
    const pm_use *use = use_of(fc, cv->index);
    assert_non_null(use);
    double worst = 0;
    for (int k = 0; k <= 40; ++k) {
      const double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / 40;
      double uv[2], x[3], y[3];
      pm_face_curve_uv(fc, use, t, uv);
      pm_cell_point(fc, uv, x);
      pm_cell_point(cv, &t, y);
      worst = fmax(worst, pm_v3_dist(x, y));
    }
    print_message("face 85: curve 418's trace within %.3g of the curve\n", worst);
    assert_true(worst < 2e-3);
  }
  /* The same nodes without step 1b, then with it. */
  pm_mesh *kept = pm_mesh_copy(mesh);
  assert_non_null(kept);
  pm_connect_params p;
  pm_connect_params_init(&p);
  p.drop_crossed = 0;
  pm_connect_report rep;
  PM_ASSERT_OK(pm_connect(m, kept, &p, &rep, &e), e);
  assert_int_equal(rep.crossed_nodes, 0);
  assert_int_equal(face_nodes(kept, f), off + on);
  p.drop_crossed = 1;
  PM_ASSERT_OK(pm_connect(m, mesh, &p, &rep, &e), e);
  int32_t nf = folded(m, mesh, f);
  print_message("face 85: %d nodes on curve 418's trace, %d on curve 415's; %d dropped as crossed, "
                "%d face nodes left, %d folded triangles\n",
                (int)off, (int)on, (int)rep.crossed_nodes, (int)face_nodes(mesh, f), (int)nf);
  assert_int_equal(rep.crossed_nodes, 0);
  assert_int_equal(face_nodes(mesh, f), off + on);
  assert_int_equal(nf, 0);
  assert_int_equal(folded(m, kept, f), 0);
  pm_mesh_destroy(kept);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

int main(void) {
  if (access(model_path, R_OK) != 0) {
    printf("skipped: %s is not there\n", model_path);
    return 0;
  }
  const struct CMUnitTest tests[] = {cmocka_unit_test(trace_nodes_kept)};
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  return rc;
}
