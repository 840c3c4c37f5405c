/* Mesh files: every writer is checked by reading the file back with pm_mesh_read (packmesh's own
 * readers, mesh_read*.c) and, for .msh, with gmsh directly; .vtu and .obj are also parsed back
 * here by small independent parsers and compared exactly. Also: atomic output, error cases,
 * higher-order and non-simplex input written by gmsh, and that a model current in gmsh stays
 * current. Hostile files are test_mesh_read's. */
#include "test_support.h"

#include <dirent.h>
#include <errno.h>
#include <gmshc.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/backends/gmsh_session.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_io.h"
#include "common/measure/quality.h"

static char dir[256];

static int setup(void **state) {
  (void)state;
  snprintf(dir, sizeof dir, "/tmp/pm_test_mesh_io_XXXXXX");
  if (!mkdtemp(dir)) return -1;
  pm_error e = {0};
  return pm_gmsh_begin(&e) == PM_OK ? 0 : -1;
}

static int teardown(void **state) {
  (void)state;
  DIR *d = opendir(dir);
  if (d) {
    struct dirent *de;
    char p[512];
    while ((de = readdir(d))) {
      if (de->d_name[0] == '.' && (!de->d_name[1] || de->d_name[1] == '.')) continue;
      snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
      struct stat st;
      if (stat(p, &st) == 0 && S_ISDIR(st.st_mode))
        rmdir(p);
      else
        unlink(p);
    }
    closedir(d);
  }
  rmdir(dir);
  pm_gmsh_shutdown();
  return 0;
}

static const char *path_in(const char *name, char *buf) {
  snprintf(buf, 512, "%s/%s", dir, name);
  return buf;
}

/* Number of entries in the test folder whose name contains `part`. */
static int count_files(const char *part) {
  DIR *d = opendir(dir);
  int n = 0;
  struct dirent *de;
  while ((de = readdir(d)))
    if (strstr(de->d_name, part)) ++n;
  closedir(d);
  return n;
}

/* The cube of test_mesh_check with awkward coordinates (every digit matters), classification
 * on vertices, curves (with t), faces (with u, v) and the volume, one unclassified node, and one
 * untagged triangle. */
static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

static pm_mesh *sample_mesh(void) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  const double s = M_PI / 3, o[3] = {-1.0 / 7, 2.0 / 3, 1e5 / 9};
  for (int i = 0; i < 8; ++i) {
    double p[3] = {o[0] + s * (i & 1), o[1] + s * ((i >> 1) & 1), o[2] + s * ((i >> 2) & 1)};
    pm_mesh_add_node(m, p, 0, i, NULL, NULL, &e);
  }
  double c[3] = {o[0] + s / 2, o[1] + s / 2, o[2] + s / 2};
  pm_mesh_add_node(m, c, 3, 0, NULL, NULL, &e); /* 8: in the volume */
  double q[3] = {o[0] + s / 2, o[1], o[2]}, tpar = 0.123456789012345678;
  pm_mesh_add_node(m, q, 1, 4, &tpar, NULL, &e); /* 9: on curve 4 (edge 0-1) */
  double f[3] = {o[0] + s / 3, o[1] + s / 5, o[2]}, uv[2] = {1.0 / 3, -2.0 / 7};
  pm_mesh_add_node(m, f, 2, 0, uv, NULL, &e); /* 10: on face 0 (z = o[2]) */
  double u[3] = {o[0] + s / 4, o[1] + s / 2, o[2] + s / 3};
  pm_mesh_add_node(m, u, -1, -1, NULL, NULL, &e); /* 11: unclassified, inside */
  pm_mesh_add_seg(m, 0, 9, 4, &e);
  pm_mesh_add_seg(m, 9, 1, 4, &e);
  pm_mesh_add_seg(m, 1, 3, 5, &e);
  for (int k = 0; k < 6; ++k) {
    const int *r = quads[k];
    pm_mesh_add_tri(m, r[0], r[1], r[2], k, &e);
    pm_mesh_add_tri(m, r[0], r[2], r[3], k, &e);
  }
  pm_mesh_add_tri(m, 0, 10, 3, -1, &e); /* untagged */
  pm_mesh_add_tet(m, 0, 3, 2, 8, 0, &e);
  pm_mesh_add_tet(m, 0, 1, 3, 8, 0, &e);
  pm_mesh_add_tet(m, 4, 5, 7, 11, -1, &e); /* untagged */
  return m;
}

static void assert_close_rel(double a, double b, double rel) {
  double tol = rel * fmax(1.0, fmax(fabs(a), fabs(b)));
  if (!(fabs(a - b) <= tol)) fail_msg("%.17g != %.17g (relative tolerance %g)", a, b, rel);
}

/* ---- .msh: everything round-trips, order included ------------------------------------------ */

/* r is m read back: the same nodes (within rel), classification, elements and cells; the
 * parameters too when with_par (else r's are 0). */
static void same_mesh_par(const pm_mesh *m, const pm_mesh *r, double rel, int with_par) {
  assert_int_equal(r->nnode, m->nnode);
  assert_int_equal(r->nseg, m->nseg);
  assert_int_equal(r->ntri, m->ntri);
  assert_int_equal(r->ntet, m->ntet);
  for (int32_t v = 0; v < m->nnode; ++v) {
    for (int k = 0; k < 3; ++k) assert_close_rel(r->xyz[3 * v + k], m->xyz[3 * v + k], rel);
    assert_int_equal(r->node_dim[v], m->node_dim[v]);
    assert_int_equal(r->node_cell[v], m->node_cell[v]);
    for (int k = 0; k < 2; ++k)
      assert_close_rel(r->node_par[2 * v + k], with_par ? m->node_par[2 * v + k] : 0, rel);
  }
  assert_memory_equal(r->seg, m->seg, 2 * sizeof(int32_t) * (size_t)m->nseg);
  assert_memory_equal(r->tri, m->tri, 3 * sizeof(int32_t) * (size_t)m->ntri);
  assert_memory_equal(r->tet, m->tet, 4 * sizeof(int32_t) * (size_t)m->ntet);
  assert_memory_equal(r->seg_cell, m->seg_cell, sizeof(int32_t) * (size_t)m->nseg);
  assert_memory_equal(r->tri_cell, m->tri_cell, sizeof(int32_t) * (size_t)m->ntri);
  assert_memory_equal(r->tet_cell, m->tet_cell, sizeof(int32_t) * (size_t)m->ntet);
}

static void same_mesh(const pm_mesh *m, const pm_mesh *r, double rel) { same_mesh_par(m, r, rel, 1); }

/* The "parametric" flag of the first $Entities-ordered node block on a curve or face: the
 * third number of a block header "dim tag parametric n" with dim 1 or 2. */
static int first_block_parametric(const char *path) {
  FILE *f = fopen(path, "r");
  assert_non_null(f);
  char line[256];
  int in_nodes = 0, header_next = 0, flag = -1;
  while (flag < 0 && fgets(line, sizeof line, f)) {
    if (strncmp(line, "$Nodes", 6) == 0) {
      in_nodes = 1;
      if (!fgets(line, sizeof line, f)) break; /* numEntityBlocks numNodes min max */
      header_next = 1;
      continue;
    }
    if (!in_nodes || !header_next) continue;
    int dim, tag, par;
    long n;
    if (sscanf(line, "%d %d %d %ld", &dim, &tag, &par, &n) != 4) break;
    if (dim == 1 || dim == 2) {
      flag = par;
      break;
    }
    /* skip the block: n tags, then n coordinate lines (no parameters on dim 0 / 3) */
    for (long k = 0; k < 2 * n && fgets(line, sizeof line, f); ++k) {
    }
  }
  fclose(f);
  return flag;
}

static char *slurp(const char *path);

static void msh_round_trip(void **state) {
  (void)state;
  pm_mesh *m = sample_mesh();
  pm_error e = {0};
  char p[512];
  /* By default no parameters (meshio 7 refuses parametric nodes): classification and elements
   * round-trip, the parameters read back as 0. */
  PM_ASSERT_OK(pm_mesh_write(m, path_in("plain.msh", p), &e), e);
  assert_int_equal(first_block_parametric(p), 0);
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  same_mesh_par(m, r, 1e-15, 0);
  pm_mesh_destroy(r);
  r = NULL;
  /* On request the parameters too. */
  pm_mesh_write_opts wo = {0};
  wo.msh_parametric = 1;
  PM_ASSERT_OK(pm_mesh_write_with(m, path_in("a.msh", p), &wo, &e), e);
  assert_int_equal(first_block_parametric(p), 1);
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  same_mesh(m, r, 1e-15);
  assert_true(r->node_par[2 * 9] != 0 && r->node_par[2 * 10 + 1] != 0);
  assert_int_equal(count_files("pmtmp"), 0);

  /* The file is MSH 4.1 with one entity per cell: read it with gmsh directly too. */
  int ierr = 0;
  pm_gmsh_lock();
  int *views0 = NULL;
  size_t nviews0 = 0;
  gmshViewGetTags(&views0, &nviews0, &ierr);
  gmshFree(views0);
  gmshModelAdd("direct", &ierr);
  gmshMerge(p, &ierr);
  /* The per-element quality blocks ($ElementData) become three views. */
  int *views = NULL;
  size_t nviews = 0;
  gmshViewGetTags(&views, &nviews, &ierr);
  assert_int_equal(nviews, nviews0 + 3);
  for (size_t k = nviews0; k < nviews; ++k) gmshViewRemove(views[k], &ierr);
  gmshFree(views);
  int *dt = NULL;
  size_t ndt = 0;
  gmshModelGetEntities(&dt, &ndt, 2, &ierr);
  /* faces 0..5 -> tags 1..6, plus the catch-all */
  assert_int_equal(ndt / 2, 7);
  assert_int_equal(dt[1], 1);
  assert_int_equal(dt[2 * 6 + 1], PM_MSH_UNTAGGED);
  gmshFree(dt);
  gmshModelRemove(&ierr);
  pm_gmsh_unlock();
  FILE *f = fopen(p, "r");
  char line[64];
  assert_non_null(fgets(line, sizeof line, f));
  assert_non_null(fgets(line, sizeof line, f));
  fclose(f);
  assert_int_equal(strncmp(line, "4.1 0 8", 7), 0);
  /* Each $ElementData block gives every element (by tag) its value: the quality module's, -1 on
   * segments. */
  pm_quality q = {0};
  PM_ASSERT_OK(pm_quality_compute(m, NULL, &q, &e), e);
  char *text = slurp(p);
  const char *names[3] = {"radius_ratio", "aspect_ratio", "min_angle_deg"};
  const double *tri[3] = {q.tri.radius_ratio, q.tri.aspect_ratio, q.tri.min_angle};
  const double *tet[3] = {q.tet.radius_ratio, q.tet.aspect_ratio, q.tet.min_angle};
  int32_t nelem = m->nseg + m->ntri + m->ntet;
  for (int a = 0; a < 3; ++a) {
    char head[128];
    snprintf(head, sizeof head, "$ElementData\n1\n\"%s\"\n1\n0\n3\n0\n1\n%d\n", names[a], (int)nelem);
    const char *at = strstr(text, head);
    if (!at) fail_msg("no $ElementData block for %s", names[a]);
    at += strlen(head);
    int seen = 0;
    for (int32_t k = 0; k < nelem; ++k) {
      char *next;
      long tag = strtol(at, &next, 10);
      double v = strtod(next, &next);
      at = next;
      assert_true(tag >= 1 && tag <= nelem);
      double want = tag <= m->nseg ? -1
                    : tag <= m->nseg + m->ntri ? tri[a][tag - 1 - m->nseg]
                                              : tet[a][tag - 1 - m->nseg - m->ntri];
      if (v != want) fail_msg("%s of element %ld: %.17g, want %.17g", names[a], tag, v, want);
      ++seen;
    }
    assert_int_equal(seen, nelem);
    while (*at == '\n') ++at;
    assert_int_equal(strncmp(at, "$EndElementData", 15), 0);
  }
  free(text);
  pm_quality_clear(&q);
  pm_mesh_destroy(r);
  pm_mesh_destroy(m);
}

/* ---- .vtk, .mesh, .stl: written by gmsh ------------------------------------------------------- */

/* Canonical triangle: its three vertex coordinates sorted lexicographically. */
typedef struct ctri {
  double v[9];
  int32_t cell;
} ctri;

static int cmp_pt(const double *a, const double *b) {
  for (int k = 0; k < 3; ++k)
    if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}

static int cmp_ctri(const void *pa, const void *pb) {
  const ctri *a = pa, *b = pb;
  for (int k = 0; k < 3; ++k) {
    int c = cmp_pt(a->v + 3 * k, b->v + 3 * k);
    if (c) return c;
  }
  return 0;
}

static ctri *canon(const pm_mesh *m, int per, int32_t *n) {
  const int32_t *conn = per == 3 ? m->tri : m->tet;
  int32_t cnt = per == 3 ? m->ntri : m->ntet;
  ctri *c = calloc((size_t)cnt + 1, sizeof *c);
  for (int32_t t = 0; t < cnt; ++t) {
    double pts[4][3];
    for (int k = 0; k < per; ++k) memcpy(pts[k], m->xyz + 3 * conn[per * t + k], sizeof pts[k]);
    for (int i = 1; i < per; ++i)
      for (int j = i; j > 0 && cmp_pt(pts[j], pts[j - 1]) < 0; --j) {
        double tmp[3];
        memcpy(tmp, pts[j], sizeof tmp);
        memcpy(pts[j], pts[j - 1], sizeof tmp);
        memcpy(pts[j - 1], tmp, sizeof tmp);
      }
    for (int k = 0; k < 3 && k < per; ++k) memcpy(c[t].v + 3 * k, pts[k], sizeof pts[k]);
    c[t].cell = per == 3 ? m->tri_cell[t] : m->tet_cell[t];
  }
  qsort(c, (size_t)cnt, sizeof *c, cmp_ctri);
  *n = cnt;
  return c;
}

/* Same triangles (as sets of coordinates, within rel), and cells when check_cells. */
static void same_triangles(const pm_mesh *a, const pm_mesh *b, double rel, int check_cells) {
  int32_t na, nb;
  ctri *ca = canon(a, 3, &na), *cb = canon(b, 3, &nb);
  assert_int_equal(na, nb);
  for (int32_t t = 0; t < na; ++t) {
    for (int k = 0; k < 9; ++k) assert_close_rel(ca[t].v[k], cb[t].v[k], rel);
    if (check_cells) assert_int_equal(ca[t].cell, cb[t].cell);
  }
  free(ca);
  free(cb);
}

static void vtk_medit_stl_round_trips(void **state) {
  (void)state;
  pm_mesh *m = sample_mesh();
  pm_error e = {0};
  char p[512];
  pm_mesh *r = NULL;

  /* .vtk (written here, %.17g): the same mesh to the bit, cells and classification included,
   * and the per-element quality as cell data. */
  PM_ASSERT_OK(pm_mesh_write(m, path_in("b.vtk", p), &e), e);
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  assert_int_equal(r->nnode, m->nnode);
  assert_int_equal(r->nseg, m->nseg);
  assert_int_equal(r->ntri, m->ntri);
  assert_int_equal(r->ntet, m->ntet);
  assert_memory_equal(r->xyz, m->xyz, 3 * sizeof(double) * (size_t)m->nnode);
  assert_memory_equal(r->node_dim, m->node_dim, (size_t)m->nnode);
  for (int32_t v = 0; v < m->nnode; ++v)
    if (m->node_dim[v] >= 0) {
      assert_int_equal(r->node_cell[v], m->node_cell[v]);
      assert_memory_equal(r->node_par + 2 * v, m->node_par + 2 * v, 2 * sizeof(double));
    }
  assert_memory_equal(r->seg, m->seg, 2 * sizeof(int32_t) * (size_t)m->nseg);
  assert_memory_equal(r->tri, m->tri, 3 * sizeof(int32_t) * (size_t)m->ntri);
  assert_memory_equal(r->tet, m->tet, 4 * sizeof(int32_t) * (size_t)m->ntet);
  assert_memory_equal(r->seg_cell, m->seg_cell, sizeof(int32_t) * (size_t)m->nseg);
  assert_memory_equal(r->tri_cell, m->tri_cell, sizeof(int32_t) * (size_t)m->ntri);
  assert_memory_equal(r->tet_cell, m->tet_cell, sizeof(int32_t) * (size_t)m->ntet);
  char *text = slurp(p);
  char line[96];
  snprintf(line, sizeof line, "CELL_DATA %d\nSCALARS cell int 1\n", m->nseg + m->ntri + m->ntet);
  assert_non_null(strstr(text, line));
  assert_non_null(strstr(text, "SCALARS aspect_ratio double 1\nLOOKUP_TABLE default\n-1\n"));
  free(text);
  pm_mesh_destroy(r);

  /* .mesh (Medit): 14 significant digits; element references are the cells. */
  PM_ASSERT_OK(pm_mesh_write(m, path_in("c.mesh", p), &e), e);
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  assert_int_equal(r->nnode, m->nnode);
  assert_int_equal(r->nseg, m->nseg);
  assert_int_equal(r->ntri, m->ntri);
  assert_int_equal(r->ntet, m->ntet);
  for (int32_t v = 0; v < m->nnode; ++v)
    for (int k = 0; k < 3; ++k) assert_close_rel(r->xyz[3 * v + k], m->xyz[3 * v + k], 1e-13);
  same_triangles(m, r, 1e-13, 1);
  int32_t na, nb;
  ctri *ta = canon(m, 4, &na), *tb = canon(r, 4, &nb);
  for (int32_t t = 0; t < na; ++t) assert_int_equal(ta[t].cell, tb[t].cell);
  free(ta);
  free(tb);
  pm_mesh_destroy(r);

  /* .stl: triangles only, one solid per face; gmsh merges the shared vertices on reading.
   * Cells come back as solid indices: with faces 0..5 written in order and the untagged
   * triangle in its own solid, they match for the tagged triangles. */
  PM_ASSERT_OK(pm_mesh_write(m, path_in("d.stl", p), &e), e);
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  assert_int_equal(r->ntri, m->ntri);
  assert_int_equal(r->nseg + r->ntet, 0);
  assert_int_equal(r->nnode, 9); /* the 8 corners and node 10, used by triangles */
  same_triangles(m, r, 1e-15, 0);
  int32_t nt;
  ctri *cr = canon(r, 3, &nt);
  int per_cell[8] = {0};
  for (int32_t t = 0; t < nt; ++t)
    if (cr[t].cell >= 0 && cr[t].cell < 8) per_cell[cr[t].cell]++;
  free(cr);
  for (int k = 0; k < 6; ++k) assert_int_equal(per_cell[k], 2);
  assert_int_equal(per_cell[6], 1);
  pm_mesh_destroy(r);
  assert_int_equal(count_files("pmtmp"), 0);
  pm_mesh_destroy(m);
}

/* ---- .vtu and .obj: parsed back here ------------------------------------------------------- */

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc((size_t)n + 1);
  assert_int_equal(fread(b, 1, (size_t)n, f), (size_t)n);
  b[n] = 0;
  fclose(f);
  return b;
}

/* The numbers of the DataArray named `name` (or the first one after `after`). */
static double *vtu_array(const char *xml, const char *name, int *n) {
  char key[128];
  snprintf(key, sizeof key, "Name=\"%s\"", name);
  const char *a = strstr(xml, key);
  if (!a) {
    /* The Points array has no name: the first DataArray inside <Points>. */
    a = strstr(xml, "<Points>");
    assert_non_null(a);
    a = strstr(a, "<DataArray");
  }
  a = strchr(a, '>') + 1;
  const char *end = strstr(a, "</DataArray>");
  int cap = 16, k = 0;
  double *v = malloc((size_t)cap * sizeof *v);
  char *q;
  while (a < end) {
    double x = strtod(a, &q);
    if (q == a) break;
    if (k == cap) v = realloc(v, (size_t)(cap *= 2) * sizeof *v);
    v[k++] = x;
    a = q;
  }
  *n = k;
  return v;
}

static void vtu_round_trip(void **state) {
  (void)state;
  pm_mesh *m = sample_mesh();
  pm_error e = {0};
  char p[512];
  PM_ASSERT_OK(pm_mesh_write(m, path_in("e.vtu", p), &e), e);
  char *x = slurp(p);
  char head[128];
  snprintf(head, sizeof head, "NumberOfPoints=\"%d\" NumberOfCells=\"%d\"", m->nnode,
           m->nseg + m->ntri + m->ntet);
  assert_non_null(strstr(x, head));
  int n;
  double *pts = vtu_array(x, "(points)", &n);
  assert_int_equal(n, 3 * m->nnode);
  for (int i = 0; i < n; ++i) assert_true(pts[i] == m->xyz[i]); /* %.17g: exact */
  double *conn = vtu_array(x, "connectivity", &n);
  assert_int_equal(n, 2 * m->nseg + 3 * m->ntri + 4 * m->ntet);
  int k = 0;
  for (int i = 0; i < 2 * m->nseg; ++i) assert_true(conn[k++] == m->seg[i]);
  for (int i = 0; i < 3 * m->ntri; ++i) assert_true(conn[k++] == m->tri[i]);
  for (int i = 0; i < 4 * m->ntet; ++i) assert_true(conn[k++] == m->tet[i]);
  double *types = vtu_array(x, "types", &n);
  assert_int_equal(n, m->nseg + m->ntri + m->ntet);
  assert_true(types[0] == 3 && types[m->nseg] == 5 && types[n - 1] == 10);
  double *offs = vtu_array(x, "offsets", &n);
  assert_true(offs[n - 1] == 2 * m->nseg + 3 * m->ntri + 4 * m->ntet);
  double *cell = vtu_array(x, "cell", &n);
  assert_true(cell[0] == 4 && cell[m->nseg + m->ntri - 1] == -1 && cell[n - 1] == -1);
  double *nd = vtu_array(x, "node_dim", &n), *nc = vtu_array(x, "node_cell", &n);
  double *np = vtu_array(x, "node_par", &n);
  assert_int_equal(n, 2 * m->nnode);
  for (int v = 0; v < m->nnode; ++v) {
    assert_true(nd[v] == m->node_dim[v]);
    assert_true(nc[v] == m->node_cell[v]);
    assert_true(np[2 * v] == m->node_par[2 * v] && np[2 * v + 1] == m->node_par[2 * v + 1]);
  }
  /* Per-element quality as cell data, bit for bit the quality module's (-1 on segments). */
  pm_quality q = {0};
  PM_ASSERT_OK(pm_quality_compute(m, NULL, &q, &e), e);
  const char *names[3] = {"radius_ratio", "aspect_ratio", "min_angle_deg"};
  const double *tri[3] = {q.tri.radius_ratio, q.tri.aspect_ratio, q.tri.min_angle};
  const double *tet[3] = {q.tet.radius_ratio, q.tet.aspect_ratio, q.tet.min_angle};
  for (int a = 0; a < 3; ++a) {
    double *v = vtu_array(x, names[a], &n);
    assert_int_equal(n, m->nseg + m->ntri + m->ntet);
    for (int i = 0; i < m->nseg; ++i) assert_true(v[i] == -1);
    for (int i = 0; i < m->ntri; ++i) assert_true(v[m->nseg + i] == tri[a][i]);
    for (int i = 0; i < m->ntet; ++i) assert_true(v[m->nseg + m->ntri + i] == tet[a][i]);
    assert_true(v[m->nseg] > 0);
    free(v);
  }
  pm_quality_clear(&q);
  free(pts);
  free(conn);
  free(types);
  free(offs);
  free(cell);
  free(nd);
  free(nc);
  free(np);
  free(x);
  /* And packmesh reads it back whole: %.17g, so bit for bit, classification included. */
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  same_mesh(m, r, 0);
  pm_mesh_destroy(r);
  pm_mesh_destroy(m);
}

static void obj_round_trip(void **state) {
  (void)state;
  pm_mesh *m = sample_mesh();
  pm_error e = {0};
  char p[512];
  PM_ASSERT_OK(pm_mesh_write(m, path_in("f.obj", p), &e), e);
  FILE *f = fopen(p, "r");
  char line[512], group[64] = "";
  int nv = 0, nl = 0, nf = 0;
  while (fgets(line, sizeof line, f)) {
    if (line[0] == 'v' && line[1] == ' ') {
      double x, y, z;
      assert_int_equal(sscanf(line + 2, "%lf %lf %lf", &x, &y, &z), 3);
      assert_true(x == m->xyz[3 * nv] && y == m->xyz[3 * nv + 1] && z == m->xyz[3 * nv + 2]);
      ++nv;
    } else if (line[0] == 'g') {
      sscanf(line + 2, "%63s", group);
    } else if (line[0] == 'l') {
      int a, b;
      assert_int_equal(sscanf(line + 2, "%d %d", &a, &b), 2);
      assert_true(a - 1 == m->seg[2 * nl] && b - 1 == m->seg[2 * nl + 1]);
      char want[64];
      snprintf(want, sizeof want, "cell_%d", m->seg_cell[nl]);
      assert_string_equal(group, want);
      ++nl;
    } else if (line[0] == 'f') {
      int a, b, c;
      assert_int_equal(sscanf(line + 2, "%d %d %d", &a, &b, &c), 3);
      assert_true(a - 1 == m->tri[3 * nf] && b - 1 == m->tri[3 * nf + 1] &&
                  c - 1 == m->tri[3 * nf + 2]);
      char want[64];
      if (m->tri_cell[nf] >= 0)
        snprintf(want, sizeof want, "cell_%d", m->tri_cell[nf]);
      else
        snprintf(want, sizeof want, "untagged");
      assert_string_equal(group, want);
      ++nf;
    }
  }
  fclose(f);
  assert_int_equal(nv, m->nnode);
  assert_int_equal(nl, m->nseg);
  assert_int_equal(nf, m->ntri);
  /* packmesh reads it back: the same vertices (bit for bit), segments, triangles and their cells
   * (the tets have no OBJ form). */
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  assert_int_equal(r->nnode, m->nnode);
  assert_int_equal(r->nseg, m->nseg);
  assert_int_equal(r->ntri, m->ntri);
  assert_int_equal(r->ntet, 0);
  assert_memory_equal(r->xyz, m->xyz, 3 * sizeof(double) * (size_t)m->nnode);
  assert_memory_equal(r->seg, m->seg, 2 * sizeof(int32_t) * (size_t)m->nseg);
  assert_memory_equal(r->tri, m->tri, 3 * sizeof(int32_t) * (size_t)m->ntri);
  assert_memory_equal(r->seg_cell, m->seg_cell, sizeof(int32_t) * (size_t)m->nseg);
  assert_memory_equal(r->tri_cell, m->tri_cell, sizeof(int32_t) * (size_t)m->ntri);
  pm_mesh_destroy(r);
  pm_mesh_destroy(m);
}

/* ---- errors and atomicity ------------------------------------------------------------------ */

static void write_errors(void **state) {
  (void)state;
  pm_mesh *m = sample_mesh();
  pm_error e = {0};
  char p[512];
  assert_int_equal(pm_mesh_write(m, path_in("g.xyz", p), &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "'.xyz'"));
  assert_int_equal(pm_mesh_write(m, path_in("noext", p), &e), PM_ERR_ARG);
  assert_int_equal(pm_mesh_write(m, "/nonexistent-dir/x.msh", &e), PM_ERR_IO);
  assert_non_null(strstr(e.msg, "/nonexistent-dir/x.msh"));
  assert_int_equal(pm_mesh_write(m, "/nonexistent-dir/x.vtu", &e), PM_ERR_IO);
  /* The destination is a directory: written under a temporary name, the rename fails, the
   * temporary file is removed. */
  path_in("h.msh", p);
  assert_int_equal(mkdir(p, 0700), 0);
  assert_int_equal(pm_mesh_write(m, p, &e), PM_ERR_IO);
  path_in("h.obj", p);
  assert_int_equal(mkdir(p, 0700), 0);
  assert_int_equal(pm_mesh_write(m, p, &e), PM_ERR_IO);
  assert_int_equal(count_files("pmtmp"), 0);
  /* Bad indices: refused before anything is written. */
  m->tri[0] = 1000;
  assert_int_equal(pm_mesh_write(m, path_in("i.msh", p), &e), PM_ERR_ARG);
  assert_int_equal(count_files("i.msh"), 0);
  pm_mesh_destroy(m);
  /* STL needs triangles. */
  m = pm_mesh_create();
  double x[3] = {0, 0, 0};
  pm_mesh_add_node(m, x, -1, -1, NULL, NULL, &e);
  assert_int_equal(pm_mesh_write(m, path_in("j.stl", p), &e), PM_ERR_ARG);
  assert_int_equal(count_files("j.stl"), 0);
  assert_int_equal(count_files("pmtmp"), 0);
  pm_mesh_destroy(m);
}

static void write_text(const char *path, const char *text) {
  FILE *f = fopen(path, "w");
  fputs(text, f);
  fclose(f);
}

static void read_errors(void **state) {
  (void)state;
  pm_error e = {0};
  pm_mesh *r = (pm_mesh *)0x1;
  char p[512];
  assert_int_equal(pm_mesh_read(path_in("missing.msh", p), &r, &e), PM_ERR_IO);
  assert_null(r);
  assert_non_null(strstr(e.msg, "missing.msh"));
  write_text(path_in("garbage.msh", p), "hello world\n");
  assert_int_equal(pm_mesh_read(p, &r, &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "garbage.msh"));
  write_text(path_in("empty.msh", p), "");
  assert_int_equal(pm_mesh_read(p, &r, &e), PM_ERR_PARSE);
  write_text(path_in("trunc.msh", p), "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n");
  assert_int_equal(pm_mesh_read(p, &r, &e), PM_ERR_PARSE);
  write_text(path_in("bad.stl", p), "solid x\nfacet normal 0 0 1\n outer loop\n  vertex 0 0\n");
  assert_int_equal(pm_mesh_read(p, &r, &e), PM_ERR_PARSE);
  assert_int_equal(pm_mesh_read(path_in("x.vtu", p), &r, &e), PM_ERR_IO); /* read, but missing */
  assert_int_equal(pm_mesh_read(path_in("x.obj", p), &r, &e), PM_ERR_IO);  /* read, but missing */
  assert_non_null(strstr(e.msg, ".obj"));
  assert_int_equal(pm_mesh_read(path_in("x.step", p), &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "'.step'"));
  assert_int_equal(pm_mesh_read(dir, &r, &e), PM_ERR_ARG); /* no extension */
  path_in("adir.msh", p);
  mkdir(p, 0700);
  assert_int_equal(pm_mesh_read(p, &r, &e), PM_ERR_IO);
  assert_null(r);
}

/* A mesh gmsh writes itself: quadrangles are refused by name, quadratic triangles reduced. */
static void foreign_elements(void **state) {
  (void)state;
  char p[512];
  int ierr = 0;
  pm_gmsh_lock();
  gmshModelAdd("foreign", &ierr);
  gmshModelAddDiscreteEntity(2, 1, NULL, 0, &ierr);
  size_t nt[6] = {1, 2, 3, 4, 5, 6};
  double xyz[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0.5, 0, 0, 0.5, 0.5, 0, 0, 0.5, 0};
  gmshModelMeshAddNodes(2, 1, nt, 6, xyz, 18, NULL, 0, &ierr);
  size_t et[1] = {1}, en[6] = {1, 2, 3, 4, 5, 6};
  gmshModelMeshAddElementsByType(1, 9, et, 1, en, 6, &ierr); /* 6-node triangle */
  assert_int_equal(ierr, 0);
  gmshWrite(path_in("ho.msh", p), &ierr);
  gmshModelRemove(&ierr);
  gmshModelAdd("foreign-quad", &ierr);
  gmshModelAddDiscreteEntity(2, 1, NULL, 0, &ierr);
  double q[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  gmshModelMeshAddNodes(2, 1, nt, 4, q, 12, NULL, 0, &ierr);
  size_t qn[4] = {1, 2, 3, 4};
  gmshModelMeshAddElementsByType(1, 3, et, 1, qn, 4, &ierr); /* quadrangle */
  char qp[512];
  gmshWrite(path_in("quad.msh", qp), &ierr);
  gmshModelRemove(&ierr);
  pm_gmsh_unlock();

  pm_error e = {0};
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  assert_int_equal(r->ntri, 1);
  assert_int_equal(r->nnode, 3); /* the mid-edge nodes are dropped */
  assert_true(r->xyz[3] == 1 && r->xyz[7] == 1);
  assert_true(r->tri[0] == 0 && r->tri[1] == 1 && r->tri[2] == 2);
  pm_mesh_destroy(r);
  assert_int_equal(pm_mesh_read(qp, &r, &e), PM_ERR_ARG);
  if (!strstr(e.msg, "Quadrilateral")) fail_msg("%s", e.msg);
  assert_null(r);
}

/* Files gmsh writes in other ways: MSH 2.2, and sparse node tags (read through a sorted map). */
static void msh2_and_sparse_tags(void **state) {
  (void)state;
  char p2[512], ps[512];
  int ierr = 0;
  pm_gmsh_lock();
  gmshModelAdd("msh2", &ierr);
  gmshModelAddDiscreteEntity(2, 7, NULL, 0, &ierr);
  size_t nt[4] = {5, 900000, 17, 123456789};
  double xyz[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.25};
  gmshModelMeshAddNodes(2, 7, nt, 4, xyz, 12, NULL, 0, &ierr);
  size_t et[2] = {3, 1}, en[6] = {5, 900000, 17, 900000, 123456789, 17};
  gmshModelMeshAddElementsByType(7, 2, et, 2, en, 6, &ierr);
  assert_int_equal(ierr, 0);
  gmshWrite(path_in("sparse.msh", ps), &ierr);
  double saved = 0;
  gmshOptionGetNumber("Mesh.MshFileVersion", &saved, &ierr);
  gmshOptionSetNumber("Mesh.MshFileVersion", 2.2, &ierr);
  gmshWrite(path_in("v22.msh", p2), &ierr);
  gmshOptionSetNumber("Mesh.MshFileVersion", saved, &ierr);
  gmshModelRemove(&ierr);
  pm_gmsh_unlock();
  FILE *f = fopen(p2, "r");
  char line[64];
  assert_non_null(fgets(line, sizeof line, f));
  assert_non_null(fgets(line, sizeof line, f));
  fclose(f);
  assert_int_equal(strncmp(line, "2.2", 3), 0);

  pm_error e = {0};
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(ps, &r, &e), e);
  assert_int_equal(r->nnode, 4);
  assert_int_equal(r->ntri, 2);
  /* nodes by increasing tag: 5, 17, 900000, 123456789 */
  assert_true(r->xyz[0] == 0 && r->xyz[1] == 0);
  assert_true(r->xyz[3 * 1 + 1] == 1);
  assert_true(r->xyz[3 * 2 + 0] == 1 && r->xyz[3 * 2 + 1] == 0);
  assert_true(r->xyz[3 * 3 + 2] == 0.25);
  /* elements by increasing tag: 1 = (900000, 123456789, 17), 3 = (5, 900000, 17) */
  assert_true(r->tri[0] == 2 && r->tri[1] == 3 && r->tri[2] == 1);
  assert_true(r->tri[3] == 0 && r->tri[4] == 2 && r->tri[5] == 1);
  assert_int_equal(r->tri_cell[0], 6);
  assert_int_equal(r->tri_cell[1], 6);
  assert_int_equal(r->node_dim[0], 2);
  pm_mesh_destroy(r);
  /* MSH 2.2: gmsh numbers nodes and elements in the order it writes them (5, 900000, 17,
   * 123456789; element 3 first); the elementary tag still gives the cell. */
  PM_ASSERT_OK(pm_mesh_read(p2, &r, &e), e);
  assert_int_equal(r->nnode, 4);
  assert_int_equal(r->ntri, 2);
  assert_true(r->xyz[3 * 1] == 1 && r->xyz[3 * 2 + 1] == 1 && r->xyz[3 * 3 + 2] == 0.25);
  assert_true(r->tri[0] == 0 && r->tri[1] == 1 && r->tri[2] == 2);
  assert_true(r->tri[3] == 1 && r->tri[4] == 3 && r->tri[5] == 2);
  assert_int_equal(r->tri_cell[1], 6);
  pm_mesh_destroy(r);
}

/* Reading and writing leave the current gmsh model current and add no model. */
/* A volume mesh is mostly tets: writing one entity's block of tets needs five tags per tet (the
 * element's and its four nodes'); a buffer sized for four overran on such meshes. */
static void tet_dominated_msh(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  const int n = 6; /* n^3 cubes of 6 tets, one volume, no triangles */
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        double x[3] = {i, j, k};
        PM_ASSERT_OK(pm_mesh_add_node(m, x, 3, 0, NULL, NULL, &e), e);
      }
#define ID(i, j, k) ((int32_t)((k) * (n + 1) * (n + 1) + (j) * (n + 1) + (i)))
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        int32_t c[8] = {ID(i, j, k), ID(i + 1, j, k), ID(i + 1, j + 1, k), ID(i, j + 1, k),
                        ID(i, j, k + 1), ID(i + 1, j, k + 1), ID(i + 1, j + 1, k + 1), ID(i, j + 1, k + 1)};
        /* The six tets around the diagonal c0-c6. */
        static const int t[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                    {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
        for (int q = 0; q < 6; ++q)
          PM_ASSERT_OK(pm_mesh_add_tet(m, c[t[q][0]], c[t[q][1]], c[t[q][2]], c[t[q][3]], 0, &e), e);
      }
#undef ID
  char path[600];
  snprintf(path, sizeof path, "%s/tets.msh", dir);
  PM_ASSERT_OK(pm_mesh_write(m, path, &e), e);
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(path, &r, &e), e);
  assert_int_equal(r->nnode, m->nnode);
  assert_int_equal(r->ntet, 6 * n * n * n);
  assert_memory_equal(r->tet, m->tet, sizeof(int32_t) * 4 * (size_t)m->ntet);
  pm_mesh_destroy(r);
  pm_mesh_destroy(m);
}

static void keeps_current_model(void **state) {
  (void)state;
  int ierr = 0;
  pm_gmsh_lock();
  gmshModelAdd("cad-like", &ierr);
  char **names = NULL;
  size_t n0 = 0;
  gmshModelList(&names, &n0, &ierr);
  for (size_t i = 0; i < n0; ++i) gmshFree(names[i]);
  gmshFree(names);
  pm_gmsh_unlock();
  pm_mesh *m = sample_mesh();
  pm_error e = {0};
  char p[512];
  PM_ASSERT_OK(pm_mesh_write(m, path_in("k.msh", p), &e), e);
  pm_mesh *r = NULL;
  PM_ASSERT_OK(pm_mesh_read(p, &r, &e), e);
  pm_mesh_destroy(r);
  assert_int_equal(pm_mesh_read(path_in("garbage.msh", p), &r, &e), PM_ERR_PARSE);
  pm_gmsh_lock();
  char *cur = NULL;
  gmshModelGetCurrent(&cur, &ierr);
  assert_string_equal(cur, "cad-like");
  gmshFree(cur);
  size_t n1 = 0;
  gmshModelList(&names, &n1, &ierr);
  for (size_t i = 0; i < n1; ++i) gmshFree(names[i]);
  gmshFree(names);
  assert_int_equal(n1, n0);
  gmshModelRemove(&ierr);
  pm_gmsh_unlock();
  pm_mesh_destroy(m);
  pm_mesh_destroy(r);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(msh_round_trip),   cmocka_unit_test(vtk_medit_stl_round_trips),
      cmocka_unit_test(vtu_round_trip),   cmocka_unit_test(obj_round_trip),
      cmocka_unit_test(write_errors),     cmocka_unit_test(read_errors),
      cmocka_unit_test(foreign_elements), cmocka_unit_test(msh2_and_sparse_tags),
      cmocka_unit_test(keeps_current_model), cmocka_unit_test(tet_dominated_msh),
  };
  return cmocka_run_group_tests(tests, setup, teardown);
}
