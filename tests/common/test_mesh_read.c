/* The mesh readers (mesh_read*.c): gmsh's element table, the binary and variant forms of each
 * format, and files built to break a reader -- counts far beyond the file's size, node
 * references to nothing, negative tags, non-finite and huge coordinates, truncation at every
 * byte and random byte changes -- each refused with one line naming the file and the fault, and
 * never a crash (this test runs under ASan + UBSan too). */
#include "test_support.h"

#include <gmshc.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/gmsh_session.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh_read_private.h"
#include "common/base/rng.h"

static char dir[256];

/* ---- building files ------------------------------------------------------------------------- */

typedef struct buf {
  char *s;
  size_t n, cap;
} buf;

static void put(buf *b, const void *d, size_t n) {
  if (b->n + n + 1 > b->cap) {
    b->cap = 2 * (b->n + n + 1);
    b->s = realloc(b->s, b->cap);
  }
  memcpy(b->s + b->n, d, n);
  b->n += n;
  b->s[b->n] = '\0';
}
static void puts_(buf *b, const char *t) { put(b, t, strlen(t)); }
/* A value in little- (be = 0) or big-endian order. */
static void put_val(buf *b, const void *v, size_t n, int be) {
  unsigned char t[8];
  memcpy(t, v, n);
  int host_big = pm_rd_host_big();
  if (be != host_big)
    for (size_t i = 0; i < n / 2; ++i) {
      unsigned char c = t[i];
      t[i] = t[n - 1 - i], t[n - 1 - i] = c;
    }
  put(b, t, n);
}
static void put_i32(buf *b, int32_t v, int be) { put_val(b, &v, 4, be); }
static void put_u64(buf *b, uint64_t v, int be) { put_val(b, &v, 8, be); }
static void put_f64(buf *b, double v, int be) { put_val(b, &v, 8, be); }
static void put_f32(buf *b, float v, int be) { put_val(b, &v, 4, be); }

/* Read `len` bytes as format fmt under the name `name`. */
static pm_status read_mem(const char *name, const void *data, size_t len, pm_mesh **m, pm_error *e) {
  pm_mesh_format fmt;
  pm_status s = pm_mesh_format_of(name, &fmt, e);
  if (s) return s;
  return pm_mesh_read_buffer(name, fmt, data, len, m, e);
}

/* Expect a refusal with `code` and a one-line message holding `needle` and the file's name. */
static void expect_refused(const char *name, const char *text, size_t len, pm_status code,
                           const char *needle) {
  pm_mesh *m = (pm_mesh *)0x1;
  pm_error e = {0};
  pm_status s = read_mem(name, text, len, &m, &e);
  if (s != code || !strstr(e.msg, needle) || !strstr(e.msg, name) || strchr(e.msg, '\n'))
    fail_msg("%s: status %d (want %d), message '%s' (want '%s')", name, (int)s, (int)code, e.msg,
             needle);
  assert_null(m);
}

static void refused(const char *name, const char *text, const char *needle) {
  expect_refused(name, text, strlen(text), PM_ERR_PARSE, needle);
}

/* ---- .obj ------------------------------------------------------------------------------------ */

/* Other tools' OBJ: corners written a/t/n, negative indices, a polyline, texture and normal
 * records, groups other than cell_N (untagged); and the refusals, each naming the fault. */
static void obj_variants(void **state) {
  (void)state;
  const char *text = "# a square in two triangles\nmtllib x.mtl\no square\n"
                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\nvt 0 0\nvn 0 0 1\n"
                     "g cell_4\nf 1/1/1 2/1/1 3/1/1\ng walls\nf -4 -2 -1\n"
                     "g cell_7\nl 1 2 3\ns off\n";
  pm_mesh *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(read_mem("a.obj", text, strlen(text), &m, &e), e);
  assert_int_equal(m->nnode, 4);
  assert_int_equal(m->ntri, 2);
  assert_int_equal(m->nseg, 2);
  assert_int_equal(m->tri[3], 0);
  assert_int_equal(m->tri[4], 2);
  assert_int_equal(m->tri[5], 3);
  assert_int_equal(m->tri_cell[0], 4);
  assert_int_equal(m->tri_cell[1], -1);
  assert_int_equal(m->seg_cell[0], 7);
  assert_int_equal(m->seg[2], 1);
  assert_int_equal(m->seg[3], 2);
  assert_int_equal(m->node_dim[0], -1);
  assert_true(m->xyz[3 * 3 + 1] == 1.0);
  pm_mesh_destroy(m);
  refused("b.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", "3");
  refused("c.obj", "v 0 0\n", "vertex 1: 3 coordinates");
  refused("d.obj", "v 0 0 nan\n", "non-finite");
  refused("e.obj", "v 0 0 1e308\n", "beyond");
  refused("f.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 x\n", "'x' is not a vertex index");
  refused("g.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 -4\n", "goes back beyond the 3 vertices");
  refused("h.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "face on line 3 has 2 vertices");
  refused("i.obj", "v 0 0 0\nl 1\n", "a line needs 2 at least");
  refused("j.obj", "v 0 0 0\ncurv 1 2\n", "unknown record 'curv'");
  refused("k.obj", "# nothing\n", "no vertices");
  refused("l.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 0\n", "'0' is not a vertex index");
  expect_refused("m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", 42, PM_ERR_ARG,
                 "not polygons");
}

/* ---- gmsh's table ----------------------------------------------------------------------------- */

static void element_types_match_gmsh(void **state) {
  (void)state;
  int checked = 0;
  for (int type = 1; type <= 150; ++type) {
    /* gmsh 4.8.4 frees the face closures of prisms with the wrong operator (ASan:
     * alloc-dealloc-mismatch in ClosureGen::getFaceClosurePrism): prisms, which packmesh refuses
     * by name only, are not asked for. */
    const rd_elem_type *own = pm_rd_elem_type(type);
    if (own && !strcmp(own->family, "Prism")) {
      ++checked;
      continue;
    }
    char *name = NULL;
    int dim = 0, order = 0, nnode = 0, nprim = 0, ierr = 0;
    double *lc = NULL;
    size_t nlc = 0;
    pm_gmsh_lock();
    gmshModelMeshGetElementProperties(type, &name, &dim, &order, &nnode, &lc, &nlc, &nprim, &ierr);
    pm_gmsh_unlock();
    if (lc) gmshFree(lc);
    const rd_elem_type *t = pm_rd_elem_type(type);
    if (ierr || !name || strcmp(name, "Unknown") == 0) {
      if (name) gmshFree(name);
      if (t) fail_msg("type %d: in packmesh's table, not in gmsh's", type);
      continue;
    }
    if (!t) fail_msg("type %d (%s): in gmsh's table, not in packmesh's", type, name);
    assert_int_equal(t->nnode, nnode);
    assert_int_equal(strncmp(name, t->family, strlen(t->family)), 0);
    /* Read kinds: simplices with their corners first (nprim of them) and points. */
    if (t->kind > 0) {
      assert_int_equal(t->kind, dim);
      assert_int_equal(nprim, dim + 1);
      assert_true(nnode >= nprim);
    }
    gmshFree(name);
    ++checked;
  }
  assert_int_equal(checked, 135); /* gmsh 4.8.4 names 135 types from 1 to 150 */
}

/* ---- variants of each format -------------------------------------------------------------- */

/* A unit square of two triangles with a boundary segment, in tags 1..4. */
static void check_square(const pm_mesh *m, int nseg) {
  assert_int_equal(m->nnode, 4);
  assert_int_equal(m->ntri, 2);
  assert_int_equal(m->nseg, nseg);
  assert_true(m->xyz[3 * 2 + 0] == 1 && m->xyz[3 * 2 + 1] == 1);
}

static void msh_binary_and_swapped(void **state) {
  (void)state;
  for (int be = 0; be < 2; ++be) {
    buf b = {0};
    puts_(&b, "$MeshFormat\n4.1 1 8\n");
    put_i32(&b, 1, be);
    puts_(&b, "\n$EndMeshFormat\n$Nodes\n");
    put_u64(&b, 1, be), put_u64(&b, 4, be), put_u64(&b, 1, be), put_u64(&b, 4, be);
    put_i32(&b, 2, be), put_i32(&b, 3, be), put_i32(&b, 0, be), put_u64(&b, 4, be);
    for (int i = 1; i <= 4; ++i) put_u64(&b, (uint64_t)i, be);
    const double xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; ++i) put_f64(&b, xy[i][0], be), put_f64(&b, xy[i][1], be), put_f64(&b, 0, be);
    puts_(&b, "\n$EndNodes\n$Elements\n");
    put_u64(&b, 1, be), put_u64(&b, 2, be), put_u64(&b, 1, be), put_u64(&b, 2, be);
    put_i32(&b, 2, be), put_i32(&b, 3, be), put_i32(&b, 2, be), put_u64(&b, 2, be);
    const uint64_t el[2][4] = {{1, 1, 2, 3}, {2, 1, 3, 4}};
    for (int i = 0; i < 2; ++i)
      for (int k = 0; k < 4; ++k) put_u64(&b, el[i][k], be);
    puts_(&b, "\n$EndElements\n");
    pm_mesh *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(read_mem("bin.msh", b.s, b.n, &m, &e), e);
    check_square(m, 0);
    assert_int_equal(m->tri_cell[0], 2);
    assert_int_equal(m->node_dim[0], 2);
    assert_int_equal(m->node_cell[3], 2);
    pm_mesh_destroy(m);
    /* The same cut one byte short, and with the block claiming 2e9 elements. */
    expect_refused("bin.msh", b.s, b.n - 14, PM_ERR_PARSE, "$EndElements");
    free(b.s);
  }
}

/* gmsh writes the sample as MSH 4.1 binary and MSH 2.2 text and binary: all read the same. */
static void msh_written_by_gmsh(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int i = 0; i < 5; ++i) {
    double x[3] = {i % 2, i / 2, 0.25 * i};
    PM_ASSERT_OK(pm_mesh_add_node(m, x, 2, 3, NULL, NULL, &e), e);
  }
  PM_ASSERT_OK(pm_mesh_add_tri(m, 0, 1, 2, 3, &e), e);
  PM_ASSERT_OK(pm_mesh_add_tri(m, 1, 3, 2, 3, &e), e);
  PM_ASSERT_OK(pm_mesh_add_seg(m, 2, 4, 0, &e), e);
  PM_ASSERT_OK(pm_mesh_add_tet(m, 0, 1, 2, 4, 1, &e), e);
  char p41[512], pb41[512], p22[512], pb22[512];
  snprintf(p41, sizeof p41, "%s/w41.msh", dir);
  snprintf(pb41, sizeof pb41, "%s/wb41.msh", dir);
  snprintf(p22, sizeof p22, "%s/w22.msh", dir);
  snprintf(pb22, sizeof pb22, "%s/wb22.msh", dir);
  PM_ASSERT_OK(pm_mesh_write(m, p41, &e), e);
  int ierr = 0;
  pm_gmsh_lock();
  gmshModelAdd("rewrite", &ierr);
  gmshMerge(p41, &ierr);
  gmshOptionSetNumber("Mesh.Binary", 1, &ierr);
  gmshWrite(pb41, &ierr);
  gmshOptionSetNumber("Mesh.MshFileVersion", 2.2, &ierr);
  gmshWrite(pb22, &ierr);
  gmshOptionSetNumber("Mesh.Binary", 0, &ierr);
  gmshWrite(p22, &ierr);
  gmshOptionSetNumber("Mesh.MshFileVersion", 4.1, &ierr);
  gmshModelRemove(&ierr);
  pm_gmsh_unlock();
  assert_int_equal(ierr, 0);
  pm_mesh *a = NULL, *b = NULL, *c = NULL, *d = NULL;
  PM_ASSERT_OK(pm_mesh_read(p41, &a, &e), e);
  PM_ASSERT_OK(pm_mesh_read(pb41, &b, &e), e);
  PM_ASSERT_OK(pm_mesh_read(p22, &c, &e), e);
  PM_ASSERT_OK(pm_mesh_read(pb22, &d, &e), e);
  const pm_mesh *all[4] = {a, b, c, d};
  for (int k = 0; k < 4; ++k) {
    const pm_mesh *r = all[k];
    assert_int_equal(r->nnode, 5);
    assert_int_equal(r->nseg, 1);
    assert_int_equal(r->ntri, 2);
    assert_int_equal(r->ntet, 1);
    assert_memory_equal(r->xyz, m->xyz, 15 * sizeof(double));
    assert_memory_equal(r->tri, m->tri, 6 * sizeof(int32_t));
    assert_memory_equal(r->tet, m->tet, 4 * sizeof(int32_t));
    assert_int_equal(r->seg_cell[0], 0);
    assert_int_equal(r->tri_cell[1], 3);
    assert_int_equal(r->tet_cell[0], 1);
  }
  /* MSH 4.1 keeps the classification; MSH 2 has it from the lowest-dimensional element using a
   * node: node 4 from the segment (curve 0), node 0 from a triangle (face 3). */
  assert_int_equal(a->node_dim[4], 2);
  assert_memory_equal(a->node_dim, b->node_dim, 5);
  for (int k = 2; k < 4; ++k) {
    assert_int_equal(all[k]->node_dim[4], 1);
    assert_int_equal(all[k]->node_cell[4], 0);
    assert_int_equal(all[k]->node_dim[0], 2);
    assert_int_equal(all[k]->node_cell[0], 3);
  }
  pm_mesh_destroy(a);
  pm_mesh_destroy(b);
  pm_mesh_destroy(c);
  pm_mesh_destroy(d);
  pm_mesh_destroy(m);
}

/* The unit square in two triangles as a BINARY legacy VTK grid (big-endian floats and ints),
 * up to and including its CELL_TYPES. */
static void square_binary_vtk(buf *b) {
  puts_(b, "# vtk DataFile Version 3.0\nbin\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n");
  const float xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int i = 0; i < 4; ++i) put_f32(b, xy[i][0], 1), put_f32(b, xy[i][1], 1), put_f32(b, 0, 1);
  puts_(b, "\nCELLS 2 8\n");
  const int32_t cells[8] = {3, 0, 1, 2, 3, 0, 2, 3};
  for (int i = 0; i < 8; ++i) put_i32(b, cells[i], 1);
  puts_(b, "\nCELL_TYPES 2\n");
  put_i32(b, 5, 1), put_i32(b, 5, 1);
}

static const char square_vtk[] =
    "# vtk DataFile Version 3.0\nsquare\nASCII\nDATASET UNSTRUCTURED_GRID\n"
    "POINTS 4 double\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
    "CELLS 3 11\n3 0 1 2\n3 0 2 3\n2 0 1\nCELL_TYPES 3\n5\n5\n3\n"
    "CELL_DATA 3\nSCALARS x int 1\nLOOKUP_TABLE default\n1 2 3\n";

static void vtk_variants(void **state) {
  (void)state;
  pm_mesh *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(read_mem("a.vtk", square_vtk, strlen(square_vtk), &m, &e), e);
  check_square(m, 1);
  assert_int_equal(m->tri_cell[0], -1);
  pm_mesh_destroy(m);
  /* VTK 5's OFFSETS / CONNECTIVITY, and a quadratic triangle reduced to its corners. */
  const char *v5 =
      "# vtk DataFile Version 5.1\nv5\nASCII\nDATASET UNSTRUCTURED_GRID\n"
      "POINTS 6 float\n0 0 0 1 0 0 1 1 0 0.5 0 0 1 0.5 0 0.5 0.5 0\n"
      "CELLS 2 6\nOFFSETS vtktypeint64\n0 6\nCONNECTIVITY vtktypeint64\n0 1 2 3 4 5\n"
      "CELL_TYPES 1\n22\n";
  PM_ASSERT_OK(read_mem("b.vtk", v5, strlen(v5), &m, &e), e);
  assert_int_equal(m->nnode, 3);
  assert_int_equal(m->ntri, 1);
  pm_mesh_destroy(m);
  /* POLYDATA: a poly-line of three points is two segments. */
  const char *poly = "# vtk DataFile Version 3.0\np\nASCII\nDATASET POLYDATA\n"
                     "POINTS 4 double\n0 0 0 1 0 0 1 1 0 0 1 0\n"
                     "POLYGONS 2 8\n3 0 1 2\n3 0 2 3\nLINES 1 4\n3 0 1 2\n";
  PM_ASSERT_OK(read_mem("c.vtk", poly, strlen(poly), &m, &e), e);
  check_square(m, 2);
  pm_mesh_destroy(m);
  /* BINARY: big-endian floats and ints. */
  buf b = {0};
  square_binary_vtk(&b);
  puts_(&b, "\n");
  PM_ASSERT_OK(read_mem("d.vtk", b.s, b.n, &m, &e), e);
  check_square(m, 0);
  pm_mesh_destroy(m);
  free(b.s);
  const char *quad = "# vtk DataFile Version 3.0\nq\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 "
                     "double\n0 0 0 1 0 0 1 1 0 0 1 0\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n9\n";
  expect_refused("q.vtk", quad, strlen(quad), PM_ERR_ARG, "VTK_QUAD");
}

/* The data sections: packmesh's arrays (cell, node_dim, node_cell, node_par) are read in ASCII
 * and binary, other SCALARS passed over, the rest of the file after another data keyword left;
 * wrong counts and values are refused by name. */
#define SQUARE_GRID                                                                           \
  "# vtk DataFile Version 3.0\nsquare\nASCII\nDATASET UNSTRUCTURED_GRID\n"                   \
  "POINTS 4 double\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"                                           \
  "CELLS 3 11\n3 0 1 2\n3 0 2 3\n2 0 1\nCELL_TYPES 3\n5\n5\n3\n"

static void vtk_data_arrays(void **state) {
  (void)state;
  pm_mesh *m = NULL;
  pm_error e = {0};
  const char *tagged =
      SQUARE_GRID "POINT_DATA 4\nSCALARS node_dim int 1\nLOOKUP_TABLE default\n0 0 2 -1\n"
                  "SCALARS weight float\nLOOKUP_TABLE default\n1 2 3 4\n"
                  "SCALARS node_cell int 1\nLOOKUP_TABLE default\n3 5 0 -1\n"
                  "SCALARS node_par double 2\nLOOKUP_TABLE default\n0 0 0 0 0.25 0.5 9 9\n"
                  "CELL_DATA 3\nSCALARS cell int\nLOOKUP_TABLE default\n0 0 7\n"
                  "VECTORS v double\nthis is not read\n";
  PM_ASSERT_OK(read_mem("t.vtk", tagged, strlen(tagged), &m, &e), e);
  assert_int_equal(m->nnode, 4);
  const int8_t dims[4] = {0, 0, 2, -1};
  const int32_t cells[4] = {3, 5, 0, -1};
  for (int v = 0; v < 4; ++v) {
    assert_int_equal(m->node_dim[v], dims[v]);
    assert_int_equal(m->node_cell[v], cells[v]);
  }
  PM_ASSERT_NEAR(m->node_par[4], 0.25, 0);
  PM_ASSERT_NEAR(m->node_par[5], 0.5, 0);
  PM_ASSERT_NEAR(m->node_par[6], 0, 0); /* an unclassified node has no parameters */
  assert_int_equal(m->tri_cell[0], 0);
  assert_int_equal(m->tri_cell[1], 0);
  assert_int_equal(m->seg_cell[0], 7);
  pm_mesh_destroy(m);

  /* BINARY: a 4-byte cell array and an 8-byte one passed over. */
  buf b = {0};
  square_binary_vtk(&b);
  puts_(&b, "\nCELL_DATA 2\nSCALARS q double 1\nLOOKUP_TABLE default\n");
  put_f64(&b, 0.5, 1), put_f64(&b, 0.75, 1);
  puts_(&b, "\nSCALARS cell int 1\nLOOKUP_TABLE default\n");
  put_i32(&b, 4, 1), put_i32(&b, 6, 1);
  puts_(&b, "\n");
  PM_ASSERT_OK(read_mem("d.vtk", b.s, b.n, &m, &e), e);
  assert_int_equal(m->ntri, 2);
  assert_int_equal(m->tri_cell[0], 4);
  assert_int_equal(m->tri_cell[1], 6);
  assert_int_equal(m->node_dim[0], -1);
  pm_mesh_destroy(m);
  free(b.s);

  refused("count.vtk", SQUARE_GRID "CELL_DATA 4\nSCALARS cell int 1\nLOOKUP_TABLE default\n1 2 3 4\n",
          "CELL_DATA 4 for 3 cells");
  refused("before.vtk",
          "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 double\n"
          "0 0 0 1 0 0 0 1 0\nCELL_DATA 1\nSCALARS cell int 1\nLOOKUP_TABLE default\n0\n",
          "CELL_DATA before CELLS");
  refused("dim.vtk",
          SQUARE_GRID "POINT_DATA 4\nSCALARS node_dim int 1\nLOOKUP_TABLE default\n0 4 0 0\n"
                      "SCALARS node_cell int 1\nLOOKUP_TABLE default\n0 0 0 0\n",
          "point 1: node_dim 4");
  refused("neg.vtk", SQUARE_GRID "CELL_DATA 3\nSCALARS cell int 1\nLOOKUP_TABLE default\n0 -2 0\n",
          "cell 1 has cell index -2");
  refused("half.vtk", SQUARE_GRID "CELL_DATA 3\nSCALARS cell double 1\nLOOKUP_TABLE default\n0 0.5 0\n",
          "cell 1 has cell index 0.5");
  refused("type.vtk", SQUARE_GRID "CELL_DATA 3\nSCALARS cell bit 1\nLOOKUP_TABLE default\n0 1 0\n",
          "SCALARS of type 'bit'");
  refused("comp.vtk", SQUARE_GRID "CELL_DATA 3\nSCALARS cell int 9\nLOOKUP_TABLE default\n0\n",
          "9 components");
  refused("short.vtk", SQUARE_GRID "CELL_DATA 3\nSCALARS cell int 1\nLOOKUP_TABLE default\n0 1\n",
          "data value");
  refused("twice.vtk",
          SQUARE_GRID "CELL_DATA 3\nSCALARS cell int 1\nLOOKUP_TABLE default\n0 1 0\n"
                      "SCALARS cell int 1\nLOOKUP_TABLE default\n0 1 0\n",
          "a second array");
}

static void stl_variants(void **state) {
  (void)state;
  pm_mesh *m = NULL;
  pm_error e = {0};
  /* Binary, with a header that begins with "solid" as some writers do; -0 and 0 one point. */
  buf b = {0};
  char head[80];
  memset(head, ' ', sizeof head);
  memcpy(head, "solid binary", 12);
  put(&b, head, 80);
  put_i32(&b, 2, 0);
  const float t[2][3][3] = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}, {{-0.0f, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 3; ++k) put_f32(&b, k == 2 ? 1 : 0, 0);
    for (int v = 0; v < 3; ++v)
      for (int k = 0; k < 3; ++k) put_f32(&b, t[i][v][k], 0);
    put(&b, "\0\0", 2);
  }
  PM_ASSERT_OK(read_mem("a.stl", b.s, b.n, &m, &e), e);
  check_square(m, 0);
  assert_true(m->tri[3] == 0 && m->tri[4] == 2);
  pm_mesh_destroy(m);
  free(b.s);
  /* ASCII, two solids: cells 0 and 1. */
  const char *two =
      "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n"
      "endloop\nendfacet\nendsolid a\nsolid b\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n"
      "   vertex 1 1 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid b\n";
  PM_ASSERT_OK(read_mem("b.stl", two, strlen(two), &m, &e), e);
  check_square(m, 0);
  assert_int_equal(m->tri_cell[0], 0);
  assert_int_equal(m->tri_cell[1], 1);
  pm_mesh_destroy(m);
  refused("c.stl", "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n", "vertex");
  refused("d.stl", "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 nan\n"
          "endloop\nendfacet\nendsolid\n", "non-finite");
  refused("e.stl", "solid a\n", "facet or endsolid");
  refused("f.stl", "hello", "solid");
}

static void medit_variants(void **state) {
  (void)state;
  pm_mesh *m = NULL;
  pm_error e = {0};
  const char *ok =
      "# a comment\nMeshVersionFormatted 2\nDimension\n2\nVertices\n4\n0 0 1\n1 0 1\n1 1 1\n0 1 "
      "1\nCorners\n1\n1\nTriangles\n2\n1 2 3 5\n1 3 4 5 # comment\nEdges\n1\n1 2 0\nEnd\n";
  PM_ASSERT_OK(read_mem("a.mesh", ok, strlen(ok), &m, &e), e);
  check_square(m, 1);
  assert_int_equal(m->tri_cell[0], 4);
  assert_int_equal(m->seg_cell[0], -1);
  pm_mesh_destroy(m);
  const char *quad = "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n1 1 0 0\n"
                     "0 1 0 0\nQuadrilaterals\n1\n1 2 3 4 0\nEnd\n";
  expect_refused("b.mesh", quad, strlen(quad), PM_ERR_ARG, "Quadrilaterals");
  refused("c.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n1 1 0 0\n"
          "Triangles\n1\n1 2 9 0\nEnd\n", "uses vertex 9; the file has 3 vertices");
  refused("d.mesh", "MeshVersionFormatted 2\nDimension 3\nBogus\n", "unknown keyword 'Bogus'");
}

static void vtu_variants(void **state) {
  (void)state;
  pm_mesh *m = NULL;
  pm_error e = {0};
  const char *pv =
      "<?xml version=\"1.0\"?>\n<!-- from elsewhere -->\n<VTKFile type=\"UnstructuredGrid\">"
      "<UnstructuredGrid><Piece NumberOfPoints=\"4\" NumberOfCells=\"2\">"
      "<PointData><DataArray type=\"Float32\" Name=\"other\" format=\"ascii\">1 2 3 4</DataArray></PointData>"
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">"
      "0 0 0 1 0 0 1 1 0 0 1 0</DataArray></Points>"
      "<Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2 0 2 3</DataArray>"
      "<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">3 6</DataArray>"
      "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">5 5</DataArray></Cells>"
      "</Piece></UnstructuredGrid></VTKFile>\n";
  PM_ASSERT_OK(read_mem("a.vtu", pv, strlen(pv), &m, &e), e);
  check_square(m, 0);
  assert_int_equal(m->node_dim[0], -1);
  pm_mesh_destroy(m);
  char *bin = strdup(pv);
  char *f = strstr(bin, "format=\"ascii\">0 1 2");
  memcpy(f, "format=\"binary\"", 15);
  expect_refused("b.vtu", bin, strlen(bin), PM_ERR_ARG, "stored as 'binary'");
  free(bin);
  char *cut = strdup(pv);
  cut[strstr(cut, "</Cells>") - cut] = '\0';
  refused("c.vtu", cut, "truncated");
  free(cut);
}

/* ---- hostile files ------------------------------------------------------------------------ */

static const char msh41_head[] = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
static const char square_nodes41[] =
    "$Nodes\n1 4 1 4\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n$EndNodes\n";

static void hostile_files(void **state) {
  (void)state;
  char t[2048];
  /* A $Elements block claiming 2e9 elements (gmsh: "double free or corruption"). */
  snprintf(t, sizeof t, "%s%s$Elements\n1 2 1 2\n2 1 2 2000000000\n1 1 2 3\n2 1 3 4\n$EndElements\n",
           msh41_head, square_nodes41);
  refused("e2e9.msh", t, "claims 2000000000 elements");
  snprintf(t, sizeof t, "%s%s$Elements\n1 2000000000 1 2000000000\n2 1 2 2000000000\n1 1 2 3\n$EndElements\n",
           msh41_head, square_nodes41);
  refused("e2e9b.msh", t, "declares 2000000000");
  /* An element node -5 (gmsh: an uninitialised node tag, different on every run). */
  snprintf(t, sizeof t, "%s%s$Elements\n1 2 1 2\n2 1 2 2\n1 1 -5 3\n2 1 3 4\n$EndElements\n",
           msh41_head, square_nodes41);
  refused("neg.msh", t, "node 2 of element 1 is -5");
  snprintf(t, sizeof t, "%s%s$Elements\n1 2 1 2\n2 1 2 2\n1 1 2 3\n2 1 3 99\n$EndElements\n",
           msh41_head, square_nodes41);
  refused("missing.msh", t, "element 2 uses node 99, which the file does not define");
  /* A VTK cell naming a point the file does not have (gmsh: SIGSEGV). */
  refused("oob.vtk",
          "# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 double\n"
          "0 0 0\n1 0 0\n0 1 0\nCELLS 1 4\n3 0 1 77\nCELL_TYPES 1\n5\n",
          "cell 0 uses point 77; the file has 3 points");
  refused("pts.vtk",
          "# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2000000000 double\n0 0 0\n",
          "POINTS: the file declares 2000000000");
  refused("cells.vtk",
          "# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 double\n"
          "0 0 0\n1 0 0\n0 1 0\nCELLS 1 4\n3000000000 0 1 2\nCELL_TYPES 1\n5\n",
          "claims 3000000000 points");
  /* A binary .msh claiming 2e9 nodes (gmsh under ASan: out of memory). */
  buf b = {0};
  puts_(&b, "$MeshFormat\n4.1 1 8\n");
  put_i32(&b, 1, 0);
  puts_(&b, "\n$EndMeshFormat\n$Nodes\n");
  put_u64(&b, 1, 0), put_u64(&b, 2000000000, 0), put_u64(&b, 1, 0), put_u64(&b, 2000000000, 0);
  put_i32(&b, 2, 0), put_i32(&b, 1, 0), put_i32(&b, 0, 0), put_u64(&b, 2000000000, 0);
  put_u64(&b, 1, 0), put_f64(&b, 0, 0), put_f64(&b, 0, 0), put_f64(&b, 0, 0);
  puts_(&b, "\n$EndNodes\n");
  expect_refused("nodes2e9.msh", b.s, b.n, PM_ERR_PARSE, "declares 2000000000");
  free(b.s);
  /* Coordinates: NaN, infinite, 1e308 (beyond what the measures can square). */
  snprintf(t, sizeof t, "%s$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\nnan 0 0\n0 1 0\n$EndNodes\n", msh41_head);
  refused("nan.msh", t, "node 2 has a non-finite coordinate");
  snprintf(t, sizeof t, "%s$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1e308 0 0\n0 1 0\n$EndNodes\n", msh41_head);
  refused("huge.msh", t, "node 2 has coordinate x = 1e+308, beyond");
  snprintf(t, sizeof t, "%s$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1e999 0 0\n0 1 0\n$EndNodes\n", msh41_head);
  refused("inf.msh", t, "non-finite");
  /* Tags and counts. */
  snprintf(t, sizeof t, "%s$Nodes\n1 2 1 2\n2 1 0 2\n1\n1\n0 0 0\n1 0 0\n$EndNodes\n$Elements\n1 1 1 1\n1 1 1 1\n1 1 2\n$EndElements\n", msh41_head);
  refused("dup.msh", t, "node tag 1 appears twice");
  snprintf(t, sizeof t, "%s$Nodes\n1 1 1 1\n2 1 0 1\n5\n0 0 0\n$EndNodes\n", msh41_head);
  refused("range.msh", t, "outside the section's declared range 1..1");
  snprintf(t, sizeof t, "%s$Nodes\n1 1 1 1\n7 1 0 1\n1\n0 0 0\n$EndNodes\n", msh41_head);
  refused("dim.msh", t, "entity dimension 7");
  snprintf(t, sizeof t, "%s$Nodes\n1 1 1 1\n2 -3 0 1\n1\n0 0 0\n$EndNodes\n", msh41_head);
  refused("etag.msh", t, "entity tag -3");
  snprintf(t, sizeof t, "%s%s$Elements\n1 1 1 1\n2 1 999 1\n1 1 2 3\n$EndElements\n", msh41_head, square_nodes41);
  refused("type.msh", t, "element type 999 is not one gmsh defines");
  snprintf(t, sizeof t, "%s%s$Elements\n1 1 1 1\n1 1 2 1\n1 1 2 3\n$EndElements\n", msh41_head, square_nodes41);
  refused("tdim.msh", t, "Triangle elements (dimension 2) on an entity of dimension 1");
  snprintf(t, sizeof t, "%s%s$Elements\n1 2 1 2\n2 1 2 1\n1 1 2 3\n$EndElements\n", msh41_head, square_nodes41);
  refused("count.msh", t, "$Elements declares 2 elements, its blocks hold 1");
  snprintf(t, sizeof t, "%s%s$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n", msh41_head, square_nodes41);
  refused("noend.msh", t, "$EndElements");
  snprintf(t, sizeof t, "%s%s$Periodic\n1 2 3\n", msh41_head, square_nodes41);
  refused("skip.msh", t, "section $Periodic has no $EndPeriodic");
  refused("v1.msh", "$NOD\n1\n1 0 0 0\n$ENDNOD\n", "does not begin with $MeshFormat");
  refused("v3.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", "MSH version 3 is not read");
  snprintf(t, sizeof t, "%s%s", msh41_head, square_nodes41);
  refused("noel.msh", t, "no $Elements section");
  /* MSH 2: a tag count far beyond the file, a negative node. */
  refused("tags.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$Elements\n"
          "1\n1 15 2000000000 1 1\n$EndElements\n", "tags of an element");
  refused("neg2.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$Elements\n"
          "1\n1 1 2 0 1 1 -1\n$EndElements\n", "node 2 of element 1 is -1");
  /* Other formats. */
  refused("bad.stl", "solid x\nfacet normal 0 0 1\n outer loop\n  vertex 0 0\n", "coordinate of triangle 1");
  refused("big.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n99999999999\n0 0 0 0\n", "Vertices: the file declares 99999999999");
  refused("big.vtu", "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"4000000000\" "
          "NumberOfCells=\"1\">", "NumberOfPoints: the file declares 4000000000");
  refused("empty.vtk", "# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\n", "no POINTS");
  expect_refused("zero.msh", "", 0, PM_ERR_PARSE, "empty");
}

/* ---- truncation and random changes ---------------------------------------------------------- */

/* Reading must end in success or a one-line refusal naming the file, never a crash. */
static void read_anything(const char *name, const char *data, size_t len) {
  pm_mesh *m = NULL;
  pm_error e = {0};
  pm_status s = read_mem(name, data, len, &m, &e);
  if (s == PM_OK) {
    assert_non_null(m);
    assert_true(m->nseg + m->ntri + m->ntet > 0);
    for (int64_t i = 0; i < 3 * (int64_t)m->ntri; ++i) assert_true(m->tri[i] >= 0 && m->tri[i] < m->nnode);
    pm_mesh_destroy(m);
    return;
  }
  assert_null(m);
  if (s != PM_ERR_PARSE && s != PM_ERR_ARG && s != PM_ERR_LIMIT)
    fail_msg("%s (%zu bytes): status %d, '%s'", name, len, (int)s, e.msg);
  assert_non_null(strstr(e.msg, name));
  assert_null(strchr(e.msg, '\n'));
}

static void truncated_and_mutated(void **state) {
  (void)state;
  char msh[1024];
  snprintf(msh, sizeof msh, "%s%s$Elements\n2 3 1 3\n1 1 1 1\n1 1 2\n2 1 2 2\n2 1 2 3\n3 1 3 4\n$EndElements\n",
           msh41_head, square_nodes41);
  const char *stl =
      "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n"
      "endloop\nendfacet\nendsolid a\n";
  const char *medit = "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n1 1 0 0\n"
                      "Triangles\n1\n1 2 3 1\nEnd\n";
  const char *vtu =
      "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"3\" NumberOfCells=\"1\">"
      "<Points><DataArray format=\"ascii\">0 0 0 1 0 0 1 1 0</DataArray></Points><Cells>"
      "<DataArray Name=\"connectivity\" format=\"ascii\">0 1 2</DataArray><DataArray Name=\"offsets\" "
      "format=\"ascii\">3</DataArray><DataArray Name=\"types\" format=\"ascii\">5</DataArray></Cells>"
      "</Piece></UnstructuredGrid></VTKFile>";
  struct {
    const char *name, *text;
  } files[] = {{"t.msh", msh}, {"t.vtk", square_vtk}, {"t.stl", stl}, {"t.mesh", medit}, {"t.vtu", vtu}};
  pm_rng rng;
  pm_rng_init(&rng, 22, 0);
  int reads = 0;
  for (size_t f = 0; f < sizeof files / sizeof files[0]; ++f) {
    size_t len = strlen(files[f].text);
    for (size_t cut = 0; cut <= len; ++cut, ++reads) read_anything(files[f].name, files[f].text, cut);
    char *copy = malloc(len + 1);
    for (int k = 0; k < 3000; ++k, ++reads) {
      memcpy(copy, files[f].text, len + 1);
      int changes = 1 + (int)pm_rng_below(&rng, 4);
      for (int c = 0; c < changes; ++c) {
        size_t at = (size_t)pm_rng_below(&rng, len);
        static const char pool[] = "0123456789-+.e $\n<>\"/9";
        copy[at] = pm_rng_below(&rng, 4) == 0 ? (char)pm_rng_below(&rng, 256)
                                               : pool[pm_rng_below(&rng, sizeof pool - 1)];
      }
      read_anything(files[f].name, copy, len);
    }
    free(copy);
  }
  assert_true(reads > 15000);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_mesh_read_XXXXXX");
  if (!mkdtemp(dir)) return 1;
  pm_error e = {0};
  if (pm_gmsh_begin(&e)) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(element_types_match_gmsh), cmocka_unit_test(msh_binary_and_swapped),
      cmocka_unit_test(msh_written_by_gmsh),      cmocka_unit_test(vtk_variants), cmocka_unit_test(vtk_data_arrays),
      cmocka_unit_test(stl_variants),             cmocka_unit_test(medit_variants),
      cmocka_unit_test(vtu_variants),             cmocka_unit_test(obj_variants),
      cmocka_unit_test(hostile_files),
      cmocka_unit_test(truncated_and_mutated),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  char cmd[300];
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
