/* geom_cad: loading every shared CAD model (counts against gmsh's own, curve ends, loops,
 * volume orientation), the error paths, and the built-in solid cases (counts, enclosed volumes
 * by the divergence theorem, curvatures). */
#include "test_geom_cad_util.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int is_cad_file(const char *name) {
  const char *dot = strrchr(name, '.');
  if (!dot) return 0;
  return !strcasecmp(dot, ".step") || !strcasecmp(dot, ".stp") || !strcasecmp(dot, ".iges") ||
         !strcasecmp(dot, ".igs") || !strcasecmp(dot, ".brep");
}

static int cmp_str(const void *a, const void *b) {
  return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Sorted names of the CAD files in PM_CAD_DIR; *n receives the count. */
static char **cad_files(int *n) {
  DIR *d = opendir(PM_CAD_DIR);
  assert_non_null(d);
  char **names = NULL;
  *n = 0;
  struct dirent *e;
  while ((e = readdir(d))) {
    if (!is_cad_file(e->d_name)) continue;
    names = realloc(names, sizeof(char *) * (size_t)(*n + 1));
    names[(*n)++] = strdup(e->d_name);
  }
  closedir(d);
  qsort(names, (size_t)*n, sizeof(char *), cmp_str);
  return names;
}

/* Structural checks every loaded model must pass. */
static void check_structure(const pm_model *m) {
  /* Loosely toleranced files: fusee.stp's curves end up to 1.9e-4 x diagonal from their
   * vertices (CATALOG.md reports pcurve mismatches of the same size). */
  const double tol = 5e-4 * m->diagonal;
  for (int32_t i = 0; i < m->count[PM_CURVE]; ++i) {
    const pm_cell *c = pm_model_cell(m, PM_CURVE, i);
    if (c->nbound == 0) continue;
    assert_int_equal(c->nbound, 2);
    assert_int_equal(c->bound[0].sense, -1);
    assert_int_equal(c->bound[1].sense, 1);
    pm_curve_point a, b;
    pm_curve_eval(c, c->lo[0], 0, &a);
    pm_curve_eval(c, c->hi[0], 0, &b);
    /* The start vertex is at C(lo), the end vertex at C(hi), within the file's tolerance. */
    double ds = pm_v3_dist(a.p, pm_model_cell(m, PM_VERTEX, c->bound[0].cell)->xyz);
    double de = pm_v3_dist(b.p, pm_model_cell(m, PM_VERTEX, c->bound[1].cell)->xyz);
    if (ds > tol || de > tol)
      fail_msg("%s: curve %d ends %.3g / %.3g from its vertices", m->name, c->tag, ds, de);
    /* The start vertex is the one nearer to C(lo). */
    if (c->bound[0].cell != c->bound[1].cell)
      assert_true(ds <= pm_v3_dist(a.p, pm_model_cell(m, PM_VERTEX, c->bound[1].cell)->xyz));
    if (c->periodic[0]) {
      assert_int_equal(c->bound[0].cell, c->bound[1].cell);
      PM_ASSERT_NEAR(c->period[0], c->hi[0] - c->lo[0], 1e-12 * c->period[0]);
    }
  }
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, i);
    assert_true(f->nloop >= 1);
    assert_int_equal(f->loop[0].outer, 1);
    for (int k = 0; k < 2; ++k)
      if (f->periodic[k]) {
        /* Every shared model's periodic faces are OCC elementary surfaces or revolutions. */
        PM_ASSERT_NEAR(f->period[k], 2 * M_PI, 1e-9);
        double uv[2] = {0.5 * (f->lo[0] + f->hi[0]), 0.5 * (f->lo[1] + f->hi[1])},
               uv2[2] = {uv[0], uv[1]};
        uv2[k] += f->period[k];
        pm_face_point p, q;
        pm_face_eval(f, uv, 0, &p);
        pm_face_eval(f, uv2, 0, &q);
        assert_true(pm_v3_dist(p.p, q.p) <= 1e-9 * m->diagonal);
      }
  }
  for (int32_t i = 0; i < m->count[PM_VOLUME]; ++i) {
    const pm_cell *v = pm_model_cell(m, PM_VOLUME, i);
    assert_true(v->nbound > 0);
    for (int32_t k = 0; k < v->nbound; ++k)
      assert_true(v->bound[k].sense == 1 || v->bound[k].sense == -1);
  }
  assert_int_equal(pm_cad_eval_failures(m), 0);
}

/* Test 1: every shared model loads; its counts equal gmsh's own (synthetic degenerate curves,
 * added where a sewn IGES file lost its pole edges, excepted and counted). */
static void every_model_loads_with_gmsh_counts(void **state) {
  (void)state;
  CAD_REQUIRE();
  int n;
  char **files = cad_files(&n);
  assert_true(n >= 20);
  double total = 0;
  for (int i = 0; i < n; ++i) {
    char path[1024];
    pm_test_cad(files[i], path, sizeof path);
    const char *dot = strrchr(files[i], '.');
    int iges = !strcasecmp(dot, ".iges") || !strcasecmp(dot, ".igs");
    int g[4];
    cad_gmsh_counts(path, iges, g);
    pm_model *m = NULL;
    pm_error e = {0};
    double t0 = now_s();
    pm_status s = pm_cad_load(path, &m, &e);
    double t1 = now_s();
    total += t1 - t0;
    if (s) fail_msg("%s does not load: %s", files[i], e.msg);
    /* Synthetic curves follow gmsh's, with higher tags. */
    int synth = 0;
    for (int32_t k = g[1]; k < m->count[PM_CURVE]; ++k) {
      const pm_cell *c = pm_model_cell(m, PM_CURVE, k);
      assert_true(c->degenerate);
      assert_int_equal(c->up != NULL && c->nup == 1, 1);
      ++synth;
    }
    print_message("  %-26s %7.3f s  V/E/F/R %d/%d/%d/%d  (+%d degenerate curves)\n", files[i],
                  t1 - t0, m->count[0], m->count[1] - synth, m->count[2], m->count[3], synth);
    assert_int_equal(m->count[PM_VERTEX], g[0]);
    assert_int_equal(m->count[PM_CURVE] - synth, g[1]);
    assert_int_equal(m->count[PM_FACE], g[2]);
    assert_int_equal(m->count[PM_VOLUME], g[3]);
    /* Only bearing.iges (sewn) lacks pole edges: 16, as many as its unsewn import has. */
    assert_int_equal(synth, strcmp(files[i], "bearing.iges") == 0 ? 16 : 0);
    /* Cells are in gmsh tag order. */
    for (int d = 0; d < 4; ++d)
      for (int32_t k = 1; k < m->count[d]; ++k)
        assert_true(pm_model_cell(m, d, k)->tag > pm_model_cell(m, d, k - 1)->tag);
    check_structure(m);
    pm_model_destroy(m);
    free(files[i]);
  }
  free(files);
  print_message("  total load time %.2f s\n", total);
}

/* The volumes' face senses: the divergence theorem gives gmsh's (OpenCASCADE's) volume, which
 * fails if any face's sense is wrong (a face's flux counts twice). Models with volumes. The
 * midpoint rule on trimmed faces converges slowly (solid56.step: 3% off at 64 x 64 samples per
 * face, 1.2% at 128, 0.2% at 512), hence the 2% bar. */
static void volume_orientation_matches_gmsh_mass(void **state) {
  (void)state;
  CAD_REQUIRE();
  const char *files[] = {"synth_box_hole.brep", "synth_sphere.brep",   "synth_torus.brep",
                         "synth_cone.brep",     "planar_step.brep",    "crack.brep",
                         "table.brep",          "screw.step",          "bottle.brep",
                         "box_sides.step",      "wrench.stp",          "t20_component8.step",
                         "solid56.step",        "bspline_sphere.brep", "featuretype.step"};
  for (size_t i = 0; i < sizeof files / sizeof files[0]; ++i) {
    pm_model *m = cad_load_file(files[i]);
    for (int32_t k = 0; k < m->count[PM_VOLUME]; ++k) {
      const pm_cell *v = pm_model_cell(m, PM_VOLUME, k);
      double mass = 0;
      pm_gmsh_scope sc;
      cad_gmsh_begin(m, &sc);
      int ierr = 0;
      gmshModelOccGetMass(3, v->tag, &mass, &ierr);
      cad_gmsh_end(&sc);
      assert_int_equal(ierr, 0);
      double vol = cad_divergence_volume(m, v, 128);
      print_message("  %-22s volume %d: divergence %.6g, OCC %.6g\n", files[i], v->tag, vol, mass);
      if (!(fabs(vol - mass) <= 0.02 * mass))
        fail_msg("%s volume %d: divergence-theorem volume %g, OCC mass %g", files[i], v->tag, vol,
                 mass);
    }
    pm_model_destroy(m);
  }
}

/* ---- errors ------------------------------------------------------------------------------ */

static char tmpdir[64];

static void write_file(const char *path, const void *data, size_t n) {
  FILE *f = fopen(path, "wb");
  assert_non_null(f);
  assert_int_equal(fwrite(data, 1, n, f), n);
  fclose(f);
}

static void copy_prefix(const char *from, const char *to, long nbytes) {
  FILE *f = fopen(from, "rb");
  assert_non_null(f);
  char *buf = malloc((size_t)nbytes);
  size_t n = fread(buf, 1, (size_t)nbytes, f);
  fclose(f);
  write_file(to, buf, n);
  free(buf);
}

/* The load fails with `code` and a one-line message naming the file. */
static void expect_failure(const char *path, pm_status code, const char *needle) {
  pm_model *m = (pm_model *)1;
  pm_error e = {0};
  pm_status s = pm_cad_load(path, &m, &e);
  print_message("  %s -> %s: %s\n", path, pm_status_name(s), e.msg);
  assert_int_equal(s, code);
  assert_int_equal(e.code, code);
  assert_null(m);
  assert_non_null(strstr(e.msg, path));
  assert_null(strchr(e.msg, '\n'));
  if (needle && !strstr(e.msg, needle)) fail_msg("message '%s' lacks '%s'", e.msg, needle);
}

static void load_errors(void **state) {
  (void)state;
  snprintf(tmpdir, sizeof tmpdir, "/tmp/pm_test_geom_cad_XXXXXX");
  assert_non_null(mkdtemp(tmpdir));
  char p[256];

  snprintf(p, sizeof p, "%s/missing.step", tmpdir);
  expect_failure(p, PM_ERR_IO, "No such file");
  snprintf(p, sizeof p, "%s/model.obj", tmpdir);
  write_file(p, "v 0 0 0\n", 8);
  expect_failure(p, PM_ERR_ARG, "extension");
  snprintf(p, sizeof p, "%s/noext", tmpdir);
  write_file(p, "x", 1);
  expect_failure(p, PM_ERR_ARG, "extension");
  snprintf(p, sizeof p, "%s/dir.step", tmpdir);
  assert_int_equal(mkdir(p, 0700), 0);
  expect_failure(p, PM_ERR_IO, "regular");
  snprintf(p, sizeof p, "%s/empty.stp", tmpdir);
  write_file(p, "", 0);
  expect_failure(p, PM_ERR_PARSE, "empty");
  snprintf(p, sizeof p, "%s/garbage.step", tmpdir);
  write_file(p, "garbage, not STEP\n", 18);
  expect_failure(p, PM_ERR_PARSE, "cannot parse");
  snprintf(p, sizeof p, "%s/garbage.brep", tmpdir);
  write_file(p, "garbage\n", 8);
  expect_failure(p, PM_ERR_PARSE, "cannot parse");
  snprintf(p, sizeof p, "%s/garbage.igs", tmpdir);
  write_file(p, "garbage\n", 8);
  expect_failure(p, PM_ERR_PARSE, "cannot parse");
  /* A STEP file with a valid header and no data: well-formed, nothing in it. */
  const char *nodata =
      "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('empty'),'2;1');\n"
      "FILE_NAME('e.step','2020-01-01T00:00:00',(''),(''),'','','');\n"
      "FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\nENDSEC;\nDATA;\nENDSEC;\n"
      "END-ISO-10303-21;\n";
  snprintf(p, sizeof p, "%s/nodata.step", tmpdir);
  write_file(p, nodata, strlen(nodata));
  expect_failure(p, PM_ERR_GEOM, "empty model");
  if (pm_test_have_cad()) {
    char src[1024];
    snprintf(p, sizeof p, "%s/truncated.step", tmpdir);
    copy_prefix(pm_test_cad("screw.step", src, sizeof src), p, 30000);
    expect_failure(p, PM_ERR_PARSE, "truncated");
    /* The extension is case-insensitive. */
    snprintf(p, sizeof p, "%s/SPHERE.BRep", tmpdir);
    copy_prefix(pm_test_cad("synth_sphere.brep", src, sizeof src), p, 1 << 20);
    pm_model *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_cad_load(p, &m, &e), e);
    assert_int_equal(m->count[PM_FACE], 1);
    assert_string_equal(m->name, p);
    pm_model_destroy(m);
  }
  /* The gmsh models of failed loads are gone: only the test's own models would remain. */
  pm_gmsh_lock();
  char **names = NULL;
  size_t nn = 0;
  int ierr = 0;
  gmshModelList(&names, &nn, &ierr);
  int left = 0;
  for (size_t i = 0; i < nn; ++i) {
    left += !strncmp(names[i], "pm_cad_", 7);
    gmshFree(names[i]);
  }
  if (names) gmshFree(names);
  pm_gmsh_unlock();
  assert_int_equal(left, 0);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf %s", tmpdir);
  assert_int_equal(system(cmd), 0);
}

/* ---- the built-in cases ------------------------------------------------------------------ */

static void case_table(void **state) {
  (void)state;
  int n, nsolid = 0;
  const pm_case_info *t = pm_cases(&n);
  for (int i = 0; i < n; ++i) {
    if (t[i].dim != 3) continue;
    ++nsolid;
    assert_true(atof(t[i].size) > 0);
    assert_non_null(t[i].description);
    assert_ptr_equal(pm_case_find(t[i].name), &t[i]);
  }
  assert_int_equal(nsolid, 5);
  pm_model *m = (pm_model *)1;
  pm_error e = {0};
  assert_int_equal(pm_case_open("cube", &m, NULL, &e), PM_ERR_ARG);
  assert_null(m);
  assert_non_null(strstr(e.msg, "boxhole"));
}

/* Counts, names, volumes and default sizes of the cases (diagonal / size within 15 .. 20). */
static void cases_counts_and_volumes(void **state) {
  (void)state;
  const struct {
    const char *name;
    int v, e, f, r;
    double volume;
  } want[] = {
      {"sphere", 2, 3, 1, 1, 4.0 / 3.0 * M_PI},
      {"torus", 1, 2, 1, 1, 2 * M_PI * M_PI * 1.0 * 0.35 * 0.35},
      {"cylinder", 2, 3, 3, 1, M_PI * 0.25 * 2},
      {"boxhole", 10, 15, 7, 1, 2 * 1 * 0.6 - M_PI * 0.25 * 0.25 * 0.6},
      {"nonmanifold", 10, 15, 7, 1, 1.0},
  };
  for (size_t i = 0; i < sizeof want / sizeof want[0]; ++i) {
    const pm_case_info *info = pm_case_find(want[i].name);
    assert_non_null(info);
    pm_model *m = cad_load_case(want[i].name);
    char label[64];
    snprintf(label, sizeof label, "case:%s", want[i].name);
    assert_string_equal(m->name, label);
    assert_int_equal(m->count[0], want[i].v);
    assert_int_equal(m->count[1], want[i].e);
    assert_int_equal(m->count[2], want[i].f);
    assert_int_equal(m->count[3], want[i].r);
    check_structure(m);
    double vol = cad_divergence_volume(m, pm_model_cell(m, PM_VOLUME, 0), 200);
    print_message("  case %-12s volume %.6f (exact %.6f), diagonal / size = %.1f\n", want[i].name,
                  vol, want[i].volume, m->diagonal / atof(info->size));
    PM_ASSERT_NEAR(vol, want[i].volume, 0.01 * want[i].volume);
    assert_true(m->diagonal / atof(info->size) >= 15 && m->diagonal / atof(info->size) <= 20);
    for (int32_t k = 0; k < m->count[PM_FACE]; ++k)
      assert_int_equal(pm_cad_cell_is_fast(pm_model_cell(m, PM_FACE, k)), 1);
    pm_model_destroy(m);
  }
}

/* The nonmanifold case: the triangle, the segment and the segment's vertices are embedded in
 * the volume, the triangle shares the cube edge x = y = 0 (a curve bounding three faces), the
 * segment dangles. */
static void nonmanifold_embedding(void **state) {
  (void)state;
  pm_model *m = cad_load_case("nonmanifold");
  const pm_cell *v = pm_model_cell(m, PM_VOLUME, 0);
  assert_int_equal(v->nbound, 6);
  int faces = 0, curves = 0, points = 0;
  const pm_cell *tri = NULL, *seg = NULL;
  for (int32_t k = 0; k < v->nembed; ++k) {
    const pm_cell *c = pm_model_cell(m, v->embed[k].dim, v->embed[k].index);
    assert_int_equal(c->nhost, 1);
    assert_int_equal(c->host[0].dim, PM_VOLUME);
    if (c->dim == PM_FACE) ++faces, tri = c;
    if (c->dim == PM_CURVE) ++curves, seg = c;
    if (c->dim == PM_VERTEX) ++points;
  }
  assert_int_equal(faces, 1);
  assert_int_equal(curves, 1);
  assert_int_equal(points, 2);
  assert_int_equal(tri->nup, 0);
  assert_int_equal(tri->nloop, 1);
  assert_int_equal(tri->loop[0].nuse, 3);
  assert_int_equal(seg->nup, 0);
  PM_ASSERT_NEAR(pm_v3_dist(pm_model_cell(m, 0, seg->bound[0].cell)->xyz,
                            pm_model_cell(m, 0, seg->bound[1].cell)->xyz),
                 sqrt(0.3 * 0.3 + 0.1 * 0.1), 1e-12);
  int shared3 = 0;
  for (int32_t k = 0; k < tri->nbound; ++k)
    shared3 += pm_model_cell(m, PM_CURVE, tri->bound[k].cell)->nup == 3;
  assert_int_equal(shared3, 1);
  /* The triangle's inside test: its centroid in, a point beyond an edge out. */
  double x[3] = {0.5 / 3, 0.5 / 3, 1.5 / 3}, uv[2], dist;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cell_project(tri, x, NULL, uv, NULL, &dist, &e), e);
  PM_ASSERT_NEAR(dist, 0, 1e-12);
  assert_true(pm_face_inside(tri, uv));
  pm_model_destroy(m);
}

/* synth_bspline_patch.brep keeps the patch's 25 control points as free points. Those on the
 * patch's corners or on its straight boundary edges are strays (no mesh node: one would
 * duplicate a vertex's or a curve node that lands on it); those off the patch are kept. */
static void construction_points_on_curves_are_stray(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  pm_model *m = cad_load_file("synth_bspline_patch.brep");
  int isolated = 0, stray = 0, stray_on_curve = 0, kept_on_curve = 0;
  for (int32_t v = 0; v < m->count[PM_VERTEX]; ++v) {
    const pm_cell *a = pm_model_cell(m, PM_VERTEX, v);
    if (a->nup || a->nhost) {
      assert_false(a->stray);
      continue;
    }
    ++isolated;
    stray += a->stray;
    double nearest = INFINITY;
    for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
      double t, d;
      pm_error e = {0};
      PM_ASSERT_OK(pm_cell_project(pm_model_cell(m, PM_CURVE, c), a->xyz, NULL, &t, NULL, &d, &e),
                   e);
      nearest = fmin(nearest, d);
    }
    if (nearest <= 1e-9) {
      stray_on_curve += a->stray;
      kept_on_curve += !a->stray;
    } else {
      assert_false(a->stray);
    }
  }
  assert_int_equal(isolated, 25);
  assert_true(stray_on_curve > 0);
  assert_int_equal(kept_on_curve, 0);
  assert_int_equal(stray, stray_on_curve);
  pm_model_destroy(m);
}

/* crack.brep: the crack face lies inside the volume (embedded, bounding nothing), its straight
 * edge is embedded in the cube face it touches, its elliptical front bounds only the crack. */
static void crack_embedding(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("crack.brep");
  const pm_cell *v = pm_model_cell(m, PM_VOLUME, 0);
  assert_int_equal(v->nbound, 6);
  const pm_cell *crack = cad_face_by_tag(m, PM_FACE, 7);
  assert_int_equal(crack->nup, 0);
  assert_int_equal(crack->nhost, 1);
  assert_int_equal(crack->host[0].dim, PM_VOLUME);
  const pm_cell *side = cad_face_by_tag(m, PM_FACE, 6), *edge = cad_face_by_tag(m, PM_CURVE, 13);
  assert_int_equal(side->nembed, 1);
  assert_int_equal(side->embed[0].dim, PM_CURVE);
  assert_int_equal(side->embed[0].index, edge->index);
  assert_int_equal(edge->nup, 1);
  assert_int_equal(edge->up[0], crack->index);
  const pm_cell *front = cad_face_by_tag(m, PM_CURVE, 14);
  assert_string_equal(front->cls->name, "ellipse");
  assert_int_equal(front->nup, 1);
  pm_model_destroy(m);
}

/* Sphere curvatures are -1 everywhere (Su x Sv points outward, the sphere bends away from it),
 * poles included (the limit); torus curvatures -1/r along the meridian and
 * -cos v / (R + r cos v) along the parallel. */
static void cases_curvatures(void **state) {
  (void)state;
  pm_model *m = cad_load_case("sphere");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  for (int a = 0; a <= 8; ++a)
    for (int b = 0; b <= 8; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * a / 8,
                      f->lo[1] + (f->hi[1] - f->lo[1]) * b / 8};
      double k1, k2, nrm[3];
      pm_face_curvatures(f, uv, &k1, &k2, nrm);
      PM_ASSERT_NEAR(k1, -1, 1e-6);
      PM_ASSERT_NEAR(k2, -1, 1e-6);
    }
  pm_model_destroy(m);
  m = cad_load_case("torus");
  f = pm_model_cell(m, PM_FACE, 0);
  const double R = 1, r = 0.35;
  for (int a = 0; a < 7; ++a)
    for (int b = 0; b < 7; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (a + 0.3) / 7,
                      f->lo[1] + (f->hi[1] - f->lo[1]) * (b + 0.3) / 7};
      double k1, k2, nrm[3];
      pm_face_curvatures(f, uv, &k1, &k2, nrm);
      PM_ASSERT_NEAR(k1, -1 / r, 1e-9);
      PM_ASSERT_NEAR(k2, -cos(uv[1]) / (R + r * cos(uv[1])), 1e-9);
      /* The natural normal points away from the tube's core circle. */
      pm_face_point p;
      pm_face_eval(f, uv, 0, &p);
      double rho = hypot(p.p[0], p.p[1]);
      double out[3] = {p.p[0] - p.p[0] / rho, p.p[1] - p.p[1] / rho, p.p[2]};
      assert_true(pm_v3_dot(out, nrm) > 0.999 * r);
    }
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(case_table),
      cmocka_unit_test(cases_counts_and_volumes),
      cmocka_unit_test(nonmanifold_embedding),
      cmocka_unit_test(cases_curvatures),
      cmocka_unit_test(crack_embedding),
      cmocka_unit_test(construction_points_on_curves_are_stray),
      cmocka_unit_test(load_errors),
      cmocka_unit_test(every_model_loads_with_gmsh_counts),
      cmocka_unit_test(volume_orientation_matches_gmsh_mass),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  return rc;
}
