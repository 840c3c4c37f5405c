/* The mesh validity checker: accepts closed shells and a tetrahedralized cube (with and without
 * a model), rejects each kind of defect it is meant to find. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"

/* ---- hand-built models (plain structs; geom.c is not needed to describe a complex) ---------- */

static pm_model *model_new(int nv, int nc, int nf, int nvol) {
  pm_model *md = calloc(1, sizeof *md);
  int32_t n[4] = {nv, nc, nf, nvol};
  for (int d = 0; d < 4; ++d) {
    md->count[d] = n[d];
    md->cells[d] = calloc((size_t)(n[d] ? n[d] : 1), sizeof(pm_cell));
    for (int32_t i = 0; i < n[d]; ++i) {
      md->cells[d][i].dim = d;
      md->cells[d][i].index = i;
      md->cells[d][i].tag = i + 1;
    }
    if (n[d]) md->dim = d;
  }
  return md;
}

static void cell_bound(pm_model *md, int d, int32_t i, int n, const int32_t *cells,
                       const int8_t *senses) {
  pm_cell *c = &md->cells[d][i];
  c->nbound = n;
  c->bound = calloc((size_t)n, sizeof(pm_use));
  for (int k = 0; k < n; ++k) {
    c->bound[k].cell = cells[k];
    c->bound[k].sense = senses ? senses[k] : 1;
  }
}

static void model_free(pm_model *md) {
  for (int d = 0; d < 4; ++d) {
    for (int32_t i = 0; i < md->count[d]; ++i) {
      free(md->cells[d][i].bound);
      free(md->cells[d][i].embed);
    }
    free(md->cells[d]);
  }
  free(md);
}

/* ---- the octahedron ------------------------------------------------------------------------ */

static const int oct_tri[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                  {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

static pm_mesh *octahedron(int skip) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  double p[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < 6; ++i) pm_mesh_add_node(m, p[i], 2, 0, NULL, NULL, &e);
  for (int t = 0; t < 8; ++t)
    if (t != skip) pm_mesh_add_tri(m, oct_tri[t][0], oct_tri[t][1], oct_tri[t][2], 0, &e);
  return m;
}

/* One closed face (no boundary curves) bounding one volume, like a sphere. */
static pm_model *sphere_model(void) {
  pm_model *md = model_new(0, 0, 1, 1);
  int32_t f = 0;
  int8_t s = 1;
  cell_bound(md, 3, 0, 1, &f, &s);
  return md;
}

static void check(const pm_mesh *m, const pm_model *md, pm_check_report *r) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(m, md, r, &e), e);
}

static void octahedron_valid(void **state) {
  (void)state;
  pm_mesh *m = octahedron(-1);
  pm_check_report r;
  check(m, NULL, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.nproblem, 0);
  assert_int_equal(r.nshell, 1);
  assert_int_equal(r.shell[0].volume, -1);
  assert_int_equal(r.shell[0].nodes, 6);
  assert_int_equal(r.shell[0].edges, 12);
  assert_int_equal(r.shell[0].triangles, 8);
  assert_int_equal(r.shell[0].euler, 2);
  assert_int_equal(r.shell[0].components, 1);
  assert_true(r.shell[0].closed);
  assert_int_equal(r.shell[0].genus, 0);
  PM_ASSERT_NEAR(r.shell[0].enclosed, 4.0 / 3.0, 1e-14);
  pm_check_report_clear(&r);

  pm_model *md = sphere_model();
  check(m, md, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.nshell, 1);
  assert_int_equal(r.shell[0].volume, 0);
  assert_int_equal(r.shell[0].euler, 2);
  assert_int_equal(r.shell[0].genus, 0);
  PM_ASSERT_NEAR(r.shell[0].enclosed, 4.0 / 3.0, 1e-14);
  pm_check_report_clear(&r);

  /* Triangles point out of the face's (first) volume whichever way its natural normal points
   * (geom.h, pm_face_mesh_sign): sense -1 changes nothing. */
  md->cells[3][0].bound[0].sense = -1;
  check(m, md, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  pm_check_report_clear(&r);
  /* Every triangle turned over: consistent, closed, but inward. */
  for (int32_t t = 0; t < m->ntri; ++t) {
    int32_t x = m->tri[3 * t + 1];
    m->tri[3 * t + 1] = m->tri[3 * t + 2];
    m->tri[3 * t + 2] = x;
  }
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_SHELL_INWARD], 1);
  assert_int_equal(r.count[PM_CHECK_SHELL_ORIENTATION], 0);
  assert_non_null(strstr(r.problem[0], "oriented inwards"));
  assert_true(r.shell[0].enclosed < 0);
  pm_check_report_clear(&r);
  model_free(md);
  pm_mesh_destroy(m);
}

static void octahedron_defects(void **state) {
  (void)state;
  pm_model *md = sphere_model();
  pm_check_report r;

  /* A flipped triangle: its three edges disagree with their neighbours. */
  pm_mesh *m = octahedron(-1);
  int32_t t = m->tri[3 * 2 + 1];
  m->tri[3 * 2 + 1] = m->tri[3 * 2 + 2];
  m->tri[3 * 2 + 2] = t;
  check(m, NULL, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_ORIENTATION], 3);
  assert_non_null(strstr(r.problem[0], "inconsistently oriented"));
  pm_check_report_clear(&r);
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_ORIENTATION], 3);
  assert_int_equal(r.count[PM_CHECK_SHELL_ORIENTATION], 3);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A duplicate triangle (also over-uses three shell edges). */
  m = octahedron(-1);
  pm_error e = {0};
  pm_mesh_add_tri(m, 2, 4, 0, 0, &e); /* = triangle 0 rotated */
  check(m, NULL, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_DUP_ELEMENT], 1);
  pm_check_report_clear(&r);
  check(m, md, &r);
  assert_int_equal(r.count[PM_CHECK_DUP_ELEMENT], 1);
  assert_int_equal(r.count[PM_CHECK_SHELL_OPEN], 3);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A hole: without a model an open surface is allowed (but reported open); with the model the
   * shell is open and the face patch has a boundary no curve explains. */
  m = octahedron(3);
  check(m, NULL, &r);
  assert_true(r.valid);
  assert_false(r.shell[0].closed);
  assert_int_equal(r.shell[0].open_edges, 3);
  assert_int_equal(r.shell[0].euler, 1); /* a disk */
  assert_int_equal(r.shell[0].genus, -1);
  pm_check_report_clear(&r);
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_SHELL_OPEN], 3);
  assert_int_equal(r.count[PM_CHECK_PATCH_BOUNDARY], 3);
  assert_false(r.shell[0].closed);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A zero-area triangle: node 5 moved onto the segment between nodes 0 and 2... the triangles
   * at node 5 become (2, 0, 5): flat. */
  m = octahedron(-1);
  m->xyz[3 * 5 + 0] = 0.5;
  m->xyz[3 * 5 + 1] = 0.5;
  m->xyz[3 * 5 + 2] = 0.0;
  check(m, NULL, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_ZERO_AREA], 1);
  assert_non_null(strstr(r.problem[0], "zero-area triangles: 1 (first: triangle 4"));
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* Duplicate nodes and bad indices. */
  m = octahedron(-1);
  double p[3] = {1 + 1e-13, 0, 0};
  pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e);
  pm_mesh_add_tri(m, 0, 1, 99, 0, &e);
  pm_mesh_add_tri(m, 0, 0, 1, 0, &e);
  check(m, NULL, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_DUP_NODE], 1);
  assert_int_equal(r.count[PM_CHECK_INDEX], 2);
  pm_check_report_clear(&r);
  /* With the model: a tag naming no face, a node classified on a missing cell. */
  m->tri[3 * 8 + 2] = 2;
  m->tri[3 * 9 + 1] = 3;
  m->tri_cell[9] = 5;
  m->node_dim[6] = 1;
  m->node_cell[6] = 0;
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_CELL_TAG], 2);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  model_free(md);
}

/* A torus grid: euler 0, genus 1. */
static void torus_genus(void **state) {
  (void)state;
  enum { NU = 8, NV = 5 };
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int j = 0; j < NV; ++j)
    for (int i = 0; i < NU; ++i) {
      double u = 2 * M_PI * i / NU, v = 2 * M_PI * j / NV;
      double p[3] = {(2 + cos(v)) * cos(u), (2 + cos(v)) * sin(u), sin(v)};
      pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e);
    }
  for (int j = 0; j < NV; ++j)
    for (int i = 0; i < NU; ++i) {
      int32_t a = i + NU * j, b = (i + 1) % NU + NU * j, c = (i + 1) % NU + NU * ((j + 1) % NV),
              d = i + NU * ((j + 1) % NV);
      pm_mesh_add_tri(m, a, b, c, 0, &e);
      pm_mesh_add_tri(m, a, c, d, 0, &e);
    }
  pm_check_report r;
  check(m, NULL, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.shell[0].euler, 0);
  assert_int_equal(r.shell[0].genus, 1);
  assert_true(r.shell[0].enclosed > 0);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
}

/* ---- the tetrahedralized cube, with its full B-rep ------------------------------------------ */

static const int cube_quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
static int cube_edges[12][2];

static int cube_edge(int a, int b) {
  int lo = a < b ? a : b, hi = a < b ? b : a;
  for (int k = 0; k < 12; ++k)
    if (cube_edges[k][0] == lo && cube_edges[k][1] == hi) return k;
  return -1;
}

/* Vertex i = corner (i&1, i>>1&1, i>>2&1); curve k runs from cube_edges[k][0] to [1]; face f is
 * the quad cube_quads[f], oriented outward (its natural normal points out: sense +1). */
static pm_model *cube_model(void) {
  int n = 0;
  for (int f = 0; f < 6; ++f)
    for (int k = 0; k < 4; ++k) {
      int a = cube_quads[f][k], b = cube_quads[f][(k + 1) % 4];
      int lo = a < b ? a : b, hi = a < b ? b : a, seen = 0;
      for (int j = 0; j < n; ++j) seen |= cube_edges[j][0] == lo && cube_edges[j][1] == hi;
      if (!seen) {
        cube_edges[n][0] = lo;
        cube_edges[n][1] = hi;
        ++n;
      }
    }
  assert_int_equal(n, 12);
  pm_model *md = model_new(8, 12, 6, 1);
  for (int k = 0; k < 12; ++k) {
    int32_t v[2] = {cube_edges[k][0], cube_edges[k][1]};
    int8_t s[2] = {-1, 1};
    cell_bound(md, 1, k, 2, v, s);
  }
  for (int f = 0; f < 6; ++f) {
    int32_t c[4];
    int8_t s[4];
    for (int k = 0; k < 4; ++k) {
      int a = cube_quads[f][k], b = cube_quads[f][(k + 1) % 4];
      c[k] = cube_edge(a, b);
      s[k] = (int8_t)(a < b ? 1 : -1);
    }
    cell_bound(md, 2, f, 4, c, s);
  }
  int32_t faces[6] = {0, 1, 2, 3, 4, 5};
  int8_t senses[6] = {1, 1, 1, 1, 1, 1};
  cell_bound(md, 3, 0, 6, faces, senses);
  return md;
}

static pm_mesh *cube_mesh(void) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int i = 0; i < 8; ++i) {
    double p[3] = {i & 1, (i >> 1) & 1, (i >> 2) & 1};
    pm_mesh_add_node(m, p, 0, i, NULL, NULL, &e);
  }
  double ctr[3] = {0.5, 0.5, 0.5};
  pm_mesh_add_node(m, ctr, 3, 0, NULL, NULL, &e);
  for (int k = 0; k < 12; ++k) pm_mesh_add_seg(m, cube_edges[k][0], cube_edges[k][1], k, &e);
  for (int f = 0; f < 6; ++f) {
    const int *q = cube_quads[f];
    pm_mesh_add_tri(m, q[0], q[1], q[2], f, &e);
    pm_mesh_add_tri(m, q[0], q[2], q[3], f, &e);
    pm_mesh_add_tet(m, q[0], q[2], q[1], 8, 0, &e);
    pm_mesh_add_tet(m, q[0], q[3], q[2], 8, 0, &e);
  }
  return m;
}

static void cube_valid(void **state) {
  (void)state;
  pm_model *md = cube_model();
  pm_mesh *m = cube_mesh();
  pm_check_report r;
  check(m, md, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.nshell, 1);
  assert_int_equal(r.shell[0].nodes, 8);
  assert_int_equal(r.shell[0].edges, 18);
  assert_int_equal(r.shell[0].triangles, 12);
  assert_int_equal(r.shell[0].euler, 2);
  assert_int_equal(r.shell[0].genus, 0);
  PM_ASSERT_NEAR(r.shell[0].enclosed, 1.0, 1e-14);
  pm_check_report_clear(&r);
  check(m, NULL, &r); /* the generic checks agree */
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.shell[0].euler, 2);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  model_free(md);
}

static void cube_defects(void **state) {
  (void)state;
  pm_model *md = cube_model();
  pm_check_report r;
  pm_error e = {0};

  /* An inverted tet. */
  pm_mesh *m = cube_mesh();
  int32_t t = m->tet[4 * 5 + 0];
  m->tet[4 * 5 + 0] = m->tet[4 * 5 + 1];
  m->tet[4 * 5 + 1] = t;
  check(m, NULL, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_INVERTED], 1);
  pm_check_report_clear(&r);
  check(m, md, &r);
  assert_int_equal(r.count[PM_CHECK_INVERTED], 1);
  assert_true(r.count[PM_CHECK_TET_FACE] > 0 || r.count[PM_CHECK_TET_BOUNDARY] > 0);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A zero-volume tet: the centre moved onto face 0 (z = 0) makes its two tets flat. */
  m = cube_mesh();
  m->xyz[3 * 8 + 2] = 0.0;
  check(m, NULL, &r);
  assert_int_equal(r.count[PM_CHECK_ZERO_VOLUME], 2);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A missing tet: its shell triangle is no tet face any more, and its three inner faces become
   * tet boundary faces that are no shell triangles. */
  m = cube_mesh();
  m->ntet--;
  check(m, md, &r);
  assert_false(r.valid);
  assert_true(r.count[PM_CHECK_TET_BOUNDARY] >= 1);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A missing segment: the two faces along that curve lose their patch boundary and the curve
   * has no segments. */
  m = cube_mesh();
  m->seg[0] = m->seg[2 * 11];
  m->seg[1] = m->seg[2 * 11 + 1];
  m->seg_cell[0] = 11;
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_MISSING], 1);
  assert_int_equal(r.count[PM_CHECK_PATCH_BOUNDARY], 2);
  assert_int_equal(r.count[PM_CHECK_DUP_ELEMENT], 1);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A segment tagged with the wrong curve: not an edge of the faces that curve bounds. */
  m = cube_mesh();
  m->seg_cell[0] = 11;
  m->seg_cell[11] = 0;
  check(m, md, &r);
  assert_false(r.valid);
  assert_true(r.count[PM_CHECK_SEG_CONFORM] >= 2);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A node classified on a vertex that is not in its elements' closure: the centre on vertex 0
   * (the tets of volume 0 contain vertex 0 in their closure; a triangle of face 1 does not). */
  m = cube_mesh();
  m->node_dim[4] = 0;
  m->node_cell[4] = 0; /* corner 4 claims to be vertex 0 */
  check(m, md, &r);
  assert_false(r.valid);
  assert_true(r.count[PM_CHECK_CLASSIFICATION] >= 1);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A triangle of face 0 tagged face 1: face 0's patch and the shells disagree. */
  m = cube_mesh();
  m->tri_cell[0] = 1;
  check(m, md, &r);
  assert_false(r.valid);
  assert_true(r.count[PM_CHECK_PATCH_BOUNDARY] > 0);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* A face with no triangles at all. */
  m = cube_mesh();
  m->ntri -= 2; /* face 5 */
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_MISSING], 1);
  assert_true(r.count[PM_CHECK_SHELL_OPEN] > 0);
  assert_true(r.count[PM_CHECK_SEG_CONFORM] > 0);
  pm_check_report_clear(&r);
  (void)e;
  pm_mesh_destroy(m);
  model_free(md);
}

/* A box with an internal face that cuts it in half, meshed conformally on both sides: the
 * face is embedded in the volume, so its triangles lie between two tets. */
static void embedded_face(void **state) {
  (void)state;
  pm_model *md = cube_model();
  pm_mesh *m = cube_mesh();
  pm_error e = {0};
  /* Model: one more face (index 6) embedded in the volume, bounded by no curve. */
  pm_model *md2 = model_new(8, 12, 7, 1);
  for (int d = 0; d < 4; ++d)
    for (int32_t i = 0; i < md->count[d]; ++i) {
      pm_cell *src = &md->cells[d][i], *dst = &md2->cells[d][i];
      dst->nbound = src->nbound;
      dst->bound = calloc((size_t)(src->nbound ? src->nbound : 1), sizeof(pm_use));
      for (int k = 0; k < src->nbound; ++k) dst->bound[k] = src->bound[k];
    }
  md2->cells[3][0].nembed = 1;
  md2->cells[3][0].embed = calloc(1, sizeof(pm_cellref));
  md2->cells[3][0].embed[0] = (pm_cellref){2, 6};
  /* Triangle (0, 3, 8): an internal face of the tets (0, 3, 2, 8) and (0, 1, 3, 8)? Those are
   * tets (q0, q2, q1, 8) = (0, 3, 2, 8) and (q0, q3, q2, 8) = (0, 1, 3, 8) of face 0: they share
   * the face (0, 3, 8). */
  pm_mesh_add_tri(m, 0, 3, 8, 6, &e);
  pm_check_report r;
  check(m, md2, &r);
  /* The face's patch boundary has no curve (it is a lone triangle): only that is reported; the
   * tet side of the check is satisfied (two tets of the volume at the triangle). */
  assert_int_equal(r.count[PM_CHECK_TET_BOUNDARY], 0);
  assert_int_equal(r.count[PM_CHECK_PATCH_BOUNDARY], 3);
  pm_check_report_clear(&r);
  /* A triangle of the embedded face that is no tet face. */
  m->tri[3 * 12 + 2] = 4;
  check(m, md2, &r);
  assert_int_equal(r.count[PM_CHECK_TET_BOUNDARY], 1);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  model_free(md);
  model_free(md2);
}

/* ---- two volumes sharing a face ------------------------------------------------------------ */

/* Two tets glued along the face (0, 1, 2): apex 3 above (volume 0), apex 4 below (volume 1).
 * Face k is one triangle whose natural normal is its listed order; faces 1..3 bound volume 0,
 * faces 4..6 volume 1, face 0 both (its natural normal points up: out of volume 1, into
 * volume 0). Its triangles point out of its first volume, volume 0: downwards. */
static const int two_faces[7][3] = {{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3},
                                    {0, 4, 1}, {1, 4, 2}, {2, 4, 0}};

static void two_volumes(void **state) {
  (void)state;
  int edges[9][2], ne = 0;
  for (int f = 0; f < 7; ++f)
    for (int k = 0; k < 3; ++k) {
      int a = two_faces[f][k], b = two_faces[f][(k + 1) % 3];
      int lo = a < b ? a : b, hi = a < b ? b : a, seen = 0;
      for (int j = 0; j < ne; ++j) seen |= edges[j][0] == lo && edges[j][1] == hi;
      if (!seen) {
        edges[ne][0] = lo;
        edges[ne][1] = hi;
        ++ne;
      }
    }
  assert_int_equal(ne, 9);
  pm_model *md = model_new(5, 9, 7, 2);
  for (int k = 0; k < 9; ++k) {
    int32_t v[2] = {edges[k][0], edges[k][1]};
    int8_t sn[2] = {-1, 1};
    cell_bound(md, 1, k, 2, v, sn);
  }
  for (int f = 0; f < 7; ++f) {
    int32_t c[3];
    for (int k = 0; k < 3; ++k) {
      int a = two_faces[f][k], b = two_faces[f][(k + 1) % 3];
      for (int j = 0; j < 9; ++j)
        if ((edges[j][0] == a && edges[j][1] == b) || (edges[j][0] == b && edges[j][1] == a))
          c[k] = j;
    }
    cell_bound(md, 2, f, 3, c, NULL);
  }
  int32_t up_faces[4] = {0, 1, 2, 3}, down_faces[4] = {0, 4, 5, 6};
  int8_t up_sense[4] = {-1, 1, 1, 1}, down_sense[4] = {1, 1, 1, 1};
  cell_bound(md, 3, 0, 4, up_faces, up_sense);
  cell_bound(md, 3, 1, 4, down_faces, down_sense);

  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  double p[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 1}, {0.3, 0.3, -1}};
  for (int i = 0; i < 5; ++i) pm_mesh_add_node(m, p[i], 0, i, NULL, NULL, &e);
  for (int k = 0; k < 9; ++k) pm_mesh_add_seg(m, edges[k][0], edges[k][1], k, &e);
  pm_mesh_add_tri(m, 0, 2, 1, 0, &e); /* face 0, pointing down: out of volume 0 */
  for (int f = 1; f < 7; ++f) pm_mesh_add_tri(m, two_faces[f][0], two_faces[f][1], two_faces[f][2], f, &e);
  pm_mesh_add_tet(m, 0, 1, 2, 3, 0, &e);
  pm_mesh_add_tet(m, 0, 2, 1, 4, 1, &e);
  pm_check_report r;
  check(m, md, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.nshell, 2);
  for (int v = 0; v < 2; ++v) {
    assert_int_equal(r.shell[v].euler, 2);
    assert_true(r.shell[v].closed);
    PM_ASSERT_NEAR(r.shell[v].enclosed, 1.0 / 6.0, 1e-15);
  }
  pm_check_report_clear(&r);
  /* The shared triangle pointing up (out of volume 1 instead of its first volume): both shells
   * disagree along its three edges, and both tets see it the wrong way. */
  m->tri[1] = 1;
  m->tri[2] = 2;
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_SHELL_ORIENTATION], 6);
  assert_int_equal(r.count[PM_CHECK_TET_BOUNDARY], 2);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  model_free(md);
}

/* ---- a planar face with an evaluator: triangles against the natural normal --------------- */

static void plane_eval(const pm_cell *self, const double uv[2], int order, pm_face_point *out) {
  (void)self;
  (void)order;
  memset(out, 0, sizeof *out);
  out->p[0] = uv[0];
  out->p[1] = uv[1];
  out->su[0] = 1;
  out->sv[1] = 1;
}
static const pm_cell_class plane_class = {"plane", NULL, plane_eval, NULL, NULL, NULL, NULL};

/* The unit square: vertices 0..3 counter-clockwise from the origin, curve k from vertex k to
 * k + 1, one face S(u, v) = (u, v, 0). Mesh: an n x n grid of nodes (i, j) = i + n j, classified,
 * with parameters; triangles counter-clockwise (along +z = Su x Sv). */
static void square_n(int n, pm_model **mdp, pm_mesh **mp) {
  pm_model *md = model_new(4, 4, 1, 0);
  for (int k = 0; k < 4; ++k) {
    int32_t v[2] = {k, (k + 1) % 4};
    int8_t sn[2] = {-1, 1};
    cell_bound(md, 1, k, 2, v, sn);
  }
  int32_t cu[4] = {0, 1, 2, 3};
  cell_bound(md, 2, 0, 4, cu, NULL);
  md->cells[2][0].cls = &plane_class;
  md->diagonal = sqrt(2.0);
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  double h = 1.0 / (n - 1);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double p[3] = {h * i, h * j, 0}, par[2] = {h * i, h * j};
      int bi = i == 0 || i == n - 1, bj = j == 0 || j == n - 1;
      if (bi && bj) {
        int vtx = i == 0 ? (j == 0 ? 0 : 3) : (j == 0 ? 1 : 2);
        pm_mesh_add_node(m, p, 0, vtx, NULL, NULL, &e);
      } else if (bi || bj) {
        int curve = j == 0 ? 0 : i == n - 1 ? 1 : j == n - 1 ? 2 : 3;
        double t = curve == 0 || curve == 2 ? h * i : h * j;
        pm_mesh_add_node(m, p, 1, curve, &t, NULL, &e);
      } else {
        pm_mesh_add_node(m, p, 2, 0, par, NULL, &e);
      }
    }
  for (int i = 0; i + 1 < n; ++i) {
    pm_mesh_add_seg(m, i, i + 1, 0, &e);                                 /* bottom */
    pm_mesh_add_seg(m, n - 1 + n * i, n - 1 + n * (i + 1), 1, &e);       /* right */
    pm_mesh_add_seg(m, i + n * (n - 1), i + 1 + n * (n - 1), 2, &e);     /* top */
    pm_mesh_add_seg(m, n * i, n * (i + 1), 3, &e);                       /* left */
  }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      int32_t a = i + n * j, b = a + 1, c = a + n + 1, d = a + n;
      pm_mesh_add_tri(m, a, b, c, 0, &e);
      pm_mesh_add_tri(m, a, c, d, 0, &e);
    }
  *mdp = md;
  *mp = m;
}

static void square(pm_model **mdp, pm_mesh **mp) { square_n(3, mdp, mp); }

static void face_normal(void **state) {
  (void)state;
  pm_model *md;
  pm_mesh *m;
  square(&md, &m);
  pm_check_report r;
  check(m, md, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  assert_int_equal(r.nshell, 0);
  pm_check_report_clear(&r);
  /* Every triangle turned over: consistent among themselves, but against the face's normal. */
  for (int32_t t = 0; t < m->ntri; ++t) {
    int32_t x = m->tri[3 * t + 1];
    m->tri[3 * t + 1] = m->tri[3 * t + 2];
    m->tri[3 * t + 2] = x;
  }
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_ORIENTATION], 0);
  /* The face as a whole: six triangles are judged (at the centre node; (1, 2, 5) and (3, 7, 6)
   * touch no node of the face itself), all against. No single triangle is called folded: one
   * node is not enough to tell. */
  assert_int_equal(r.count[PM_CHECK_FACE_NORMAL], 1);
  assert_non_null(strstr(r.problem[0], "face 0: 100% of its triangles' area runs against the face's natural normal"));
  pm_check_report_clear(&r);
  /* Parameters that do not evaluate back to the node (a file without them): not judged. */
  m->node_par[2 * 4] = 0;
  m->node_par[2 * 4 + 1] = 0;
  check(m, md, &r);
  assert_int_equal(r.count[PM_CHECK_FACE_NORMAL], 0);
  pm_check_report_clear(&r);
  /* A missing boundary segment leaves an unexplained patch boundary and a bare curve piece. */
  m->node_par[2 * 4] = 0.5;
  m->node_par[2 * 4 + 1] = 0.5;
  for (int32_t t = 0; t < m->ntri; ++t) {
    int32_t x = m->tri[3 * t + 1];
    m->tri[3 * t + 1] = m->tri[3 * t + 2];
    m->tri[3 * t + 2] = x;
  }
  m->nseg--;
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_PATCH_BOUNDARY], 1);
  assert_int_equal(r.count[PM_CHECK_FACE_NORMAL], 0);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  model_free(md);

  /* A fold: on a 4 x 4 grid the interior node (1, 1) is dragged past (2, 2), with its
   * parameters; the triangles around it turn over while staying combinatorially consistent. */
  square_n(4, &md, &m);
  check(m, md, &r);
  if (!r.valid) fail_msg("%s", r.problem[0]);
  pm_check_report_clear(&r);
  m->xyz[3 * 5] = m->xyz[3 * 5 + 1] = 0.8;
  m->node_par[2 * 5] = m->node_par[2 * 5 + 1] = 0.8;
  check(m, md, &r);
  assert_false(r.valid);
  assert_int_equal(r.count[PM_CHECK_ORIENTATION], 0);
  assert_true(r.count[PM_CHECK_FACE_NORMAL] >= 1);
  assert_non_null(strstr(r.problem[0], "is folded over"));
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  model_free(md);
}

/* A face that bounds more volumes than any edge has triangles (a model read from a file may say
 * so): every volume's shell is counted, each with all of the face's edges. */
static void face_of_many_volumes(void **state) {
  (void)state;
  enum { NVOL = 12 };
  pm_model *md = model_new(0, 0, 1, NVOL);
  int32_t f = 0;
  for (int v = 0; v < NVOL; ++v) cell_bound(md, 3, v, 1, &f, NULL);
  pm_mesh *m = octahedron(-1);
  pm_check_report r;
  check(m, md, &r);
  assert_int_equal(r.nshell, NVOL);
  for (int v = 0; v < NVOL; ++v) {
    assert_int_equal(r.shell[v].volume, v);
    assert_int_equal(r.shell[v].edges, 12);
    assert_int_equal(r.shell[v].triangles, 8);
    assert_true(r.shell[v].closed);
  }
  pm_check_report_clear(&r);
  model_free(md);
  pm_mesh_destroy(m);
}

static void null_arguments(void **state) {
  (void)state;
  pm_check_report r;
  pm_error e = {0};
  assert_int_equal(pm_mesh_check(NULL, NULL, &r, &e), PM_ERR_ARG);
  pm_mesh *m = pm_mesh_create();
  PM_ASSERT_OK(pm_mesh_check(m, NULL, &r, &e), e); /* an empty mesh is valid */
  assert_true(r.valid);
  pm_check_report_clear(&r);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(octahedron_valid), cmocka_unit_test(octahedron_defects),
      cmocka_unit_test(torus_genus),      cmocka_unit_test(cube_valid),
      cmocka_unit_test(cube_defects),     cmocka_unit_test(embedded_face),
      cmocka_unit_test(two_volumes),      cmocka_unit_test(face_normal),
      cmocka_unit_test(null_arguments),   cmocka_unit_test(face_of_many_volumes),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
