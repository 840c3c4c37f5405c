/* pm_connect on the shared CAD models with nodes from elsewhere: gmsh meshes the model (its own
 * node placement), its nodes are reparametrized onto our cells (curve t, face (u, v), as gmsh
 * reports them for the entity each node is classified on), and pm_connect must turn them into a
 * mesh that pm_mesh_check accepts: segments conforming to the faces' triangles, closed and
 * consistently oriented shells, no zero-area or duplicate triangles. Solids also get tets in both
 * TetGen modes, with the volume tags kept.
 *
 * Usage: test_connect_cad FILE [SIZE_FRACTION [JITTER_SEED]] (a seed given means the run must
 * meet TetGen's untagged inner tets and retag them -- a regression case)   (one shared model per ctest entry, so that a
 * crash of gmsh's mesher on one model stays that model's failure). */
#include "test_support.h"

#include <gmshc.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/connect/connect.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/mesh/mesh_check.h"
#include "common/base/rng.h"

static const char *model_path;
static double size_fraction = 1.0 / 15;
static uint64_t jitter_seed = 12345;
static int expect_retag; /* the run must have retagged tets TetGen left without a region */

static int32_t cell_of_tag(const pm_model *m, int dim, int tag) {
  for (int32_t i = 0; i < m->count[dim]; ++i)
    if (m->cells[dim][i].tag == tag) return i;
  return -1;
}

/* gmsh meshes congruent faces (the top and bottom of a plate) identically, so its nodes come in
 * exactly mirrored pairs; four of them then form a rectangle through the plate, a tie of the
 * Delaunay criterion that TetGen resolves with a flat tet no flip can remove (their neighbours are
 * coplanar too). Nodes of a real method are not mirrored to the last bit: a seeded jitter of 1% of
 * the spacing within the cell breaks the tie (faces: in (u, v), kept inside the trim; volumes: in
 * space). */
static void jitter(const pm_cell *c, uint64_t id, double h, double *par, double x[3]) {
  pm_rng r;
  pm_rng_init(&r, jitter_seed, id);
  if (c->dim == PM_VOLUME) {
    for (int k = 0; k < 3; ++k) x[k] += 0.01 * h * pm_rng_range(&r, -1, 1);
    return;
  }
  pm_face_point fp;
  pm_face_eval(c, par, 1, &fp);
  double su = sqrt(fp.su[0] * fp.su[0] + fp.su[1] * fp.su[1] + fp.su[2] * fp.su[2]);
  double sv = sqrt(fp.sv[0] * fp.sv[0] + fp.sv[1] * fp.sv[1] + fp.sv[2] * fp.sv[2]);
  if (!(su > 0 && sv > 0)) return;
  double uv[2] = {par[0] + 0.01 * h * pm_rng_range(&r, -1, 1) / su,
                  par[1] + 0.01 * h * pm_rng_range(&r, -1, 1) / sv};
  if (!pm_face_inside(c, uv)) return;
  par[0] = uv[0], par[1] = uv[1];
  pm_cell_point(c, uv, x);
}

/* gmsh's nodes of dimension <= maxdim, classified on our cells. */
static pm_mesh *gmsh_nodes(const pm_model *m, int maxdim, double size) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  pm_gmsh_scope scope;
  pm_gmsh_lock();
  PM_ASSERT_OK(pm_gmsh_scope_enter(&scope, pm_cad_gmsh_model(m), 0, &e), e);
  int ierr = 0;
  gmshOptionSetNumber("Mesh.MeshSizeMax", size, &ierr);
  gmshOptionSetNumber("Mesh.MeshSizeMin", size / 20, &ierr);
  /* Curved features need a few nodes per turn: with fewer, two faces of a small hole can share
   * all their boundary nodes, a node set no connection can mesh conformally. */
  gmshOptionSetNumber("Mesh.MeshSizeFromCurvature", 8, &ierr);
  gmshModelMeshGenerate(maxdim, &ierr);
  if (ierr) fail_msg("gmsh could not mesh %s", model_path);
  for (int dim = 0; dim <= maxdim; ++dim)
    for (int32_t i = 0; i < m->count[dim]; ++i) {
      const pm_cell *c = &m->cells[dim][i];
      size_t *tags = NULL, nt = 0, nc = 0, np = 0;
      double *coord = NULL, *par = NULL;
      gmshModelMeshGetNodes(&tags, &nt, &coord, &nc, &par, &np, dim, c->tag, 0, 1, &ierr);
      if (ierr) continue; /* a cell gmsh does not know (a synthetic pole curve) */
      int npar = nt ? (int)(np / nt) : 0;
      for (size_t k = 0; k < nt; ++k) {
        double uv[2] = {0, 0}, x[3] = {coord[3 * k], coord[3 * k + 1], coord[3 * k + 2]};
        if (dim == 1 && npar >= 1) uv[0] = par[npar * k];
        if (dim == 2 && npar >= 2) uv[0] = par[npar * k], uv[1] = par[npar * k + 1];
        int32_t cell = cell_of_tag(m, dim, c->tag);
        if (dim >= 2) jitter(&m->cells[dim][cell], (uint64_t)tags[k], size, uv, x);
        PM_ASSERT_OK(pm_mesh_add_node(mesh, x, dim, cell, uv, NULL, &e), e);
      }
      gmshFree(tags), gmshFree(coord), gmshFree(par);
    }
  gmshModelMeshClear(NULL, 0, &ierr);
  pm_gmsh_scope_leave(&scope, 0);
  pm_gmsh_unlock();
  return mesh;
}

static void report_check(const pm_mesh *mesh, const pm_model *m, pm_check_report *r) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, r, &e), e);
  if (!r->valid)
    for (int i = 0; i < r->nproblem; ++i) print_error("%s: %s\n", model_path, r->problem[i]);
  assert_true(r->valid);
}

static void connect_gmsh_nodes(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  double t0 = pm_seconds();
  PM_ASSERT_OK(pm_cad_load(model_path, &m, &e), e);
  double size = m->diagonal * size_fraction;
  pm_mesh *mesh = gmsh_nodes(m, 2, size);
  int32_t n0 = mesh->nnode;
  pm_connect_report rep;
  PM_ASSERT_OK(pm_connect(m, mesh, NULL, &rep, &e), e);
  pm_check_report r = {0};
  report_check(mesh, m, &r);
  /* Every volume's shell is closed; its Euler characteristic is even (2 - 2 genus per
   * component) -- the checker verified the orientation. */
  for (int32_t k = 0; k < r.nshell; ++k) {
    assert_true(r.shell[k].closed);
    assert_true(r.shell[k].euler % 2 == 0);
    assert_true(r.shell[k].enclosed > 0);
  }
  print_message("%s: %d nodes (%d from gmsh), %d segments, %d triangles; flips %d, mean R/l_min on "
                "curved faces %.4f -> %.4f over %d triangles (%d -> %d degenerate); %d dropped, %d pole triangles; %.2f s\n",
                model_path, (int)mesh->nnode, (int)n0, (int)mesh->nseg, (int)mesh->ntri, rep.flips,
                rep.aspect_before, rep.aspect_after, rep.curved_triangles, rep.degenerate_before, rep.degenerate_after, rep.dropped_nodes,
                rep.pole_triangles, pm_seconds() - t0);
  /* Stray points of the file on another vertex are the only nodes pm_connect may drop. */
  assert_true(rep.dropped_nodes <= m->count[PM_VERTEX]);
  pm_check_report_clear(&r);
  pm_mesh_destroy(mesh);

  /* Solids: tets in both modes, tags kept. Refinement first; its interior points are then the
   * given nodes of the no-Steiner mode (gmsh's own 3D mesher asserts on some of these models, so
   * it is not asked for interior nodes). */
  int32_t retagged = 0;
  if (m->count[PM_VOLUME] > 0) {
    pm_mesh *refined = NULL;
    for (int mode = PM_VOLUME_REFINE; mode >= PM_VOLUME_GIVEN; --mode) {
      pm_mesh *vm = gmsh_nodes(m, 2, size);
      if (mode == PM_VOLUME_GIVEN)
        for (int32_t i = 0; i < refined->nnode; ++i)
          if (refined->node_dim[i] == PM_VOLUME)
            PM_ASSERT_OK(pm_mesh_add_node(vm, &refined->xyz[3 * i], PM_VOLUME, refined->node_cell[i],
                                          NULL, NULL, &e), e);
      pm_connect_params p;
      pm_connect_params_init(&p);
      p.volume = mode;
      int32_t given = vm->nnode;
      PM_ASSERT_OK(pm_connect(m, vm, &p, &rep, &e), e);
      report_check(vm, m, &r);
      int32_t *seen = calloc((size_t)m->count[PM_VOLUME], sizeof(int32_t));
      for (int32_t t = 0; t < vm->ntet; ++t) seen[vm->tet_cell[t]]++;
      for (int32_t v = 0; v < m->count[PM_VOLUME]; ++v) assert_true(seen[v] > 0);
      /* Given nodes: no point added but the few TetGen needs to recover the boundary. */
      if (mode == PM_VOLUME_GIVEN) assert_int_equal(vm->nnode, given + rep.steiner);
      retagged += rep.retagged_tets;
      print_message("%s: %s: %d tets over %d volumes from %d nodes, %d added by TetGen; %d flat "
                    "tets removed by flips, %d by diagonal swaps; %d retagged\n",
                    model_path, mode == PM_VOLUME_GIVEN ? "given nodes" : "TetGen refinement",
                    (int)vm->ntet, (int)m->count[PM_VOLUME], (int)given, rep.steiner,
                    rep.flat_tet_flips, rep.flat_tets_repaired, rep.retagged_tets);
      free(seen);
      pm_check_report_clear(&r);
      if (mode == PM_VOLUME_REFINE)
        refined = vm;
      else
        pm_mesh_destroy(vm);
    }
    pm_mesh_destroy(refined);
  }
  if (expect_retag) assert_true(retagged > 0);
  pm_model_destroy(m);
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s FILE [SIZE_FRACTION]\n", argv[0]);
    return 2;
  }
  model_path = argv[1];
  if (argc > 2) size_fraction = atof(argv[2]);
  if (argc > 3) jitter_seed = (uint64_t)atoll(argv[3]), expect_retag = 1;
  if (access(model_path, R_OK) != 0) {
    printf("skipped: %s is not there\n", model_path);
    return 0;
  }
  const struct CMUnitTest tests[] = {cmocka_unit_test(connect_gmsh_nodes)};
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  return rc;
}
