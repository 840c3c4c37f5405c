/* packmesh quality, end to end: a mesh made by gmsh's own mesher from a shared CAD model is
 * measured by the command, and its --json figures are compared with a computation done here
 * from gmsh's raw nodes and triangles, with formulas independent of quality.c (Qi's side-length
 * form of the radius ratio, Heron's area, the law of cosines, a plain sort for percentiles, a
 * sorted edge list for node degrees). Then the error paths: one line on stderr, a non-zero exit,
 * nothing on stdout. */
#include "test_support.h"

#include "cli_run.h"
#include "cli_stats.h"

#include <cjson/cJSON.h>
#include <gmshc.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "common/backends/gmsh_session.h"

static char dir[256];

/* The mesh gmsh made, as the test sees it. */
typedef struct raw {
  size_t nnode, ntri;
  size_t *tag;    /* node tags */
  double *xyz;
  int *dim;       /* dimension of each node's entity */
  size_t *tri;    /* node tags, 3 per triangle */
} raw;

static raw R;
static char msh[512];

static int setup(void **state) {
  (void)state;
  snprintf(dir, sizeof dir, "/tmp/pm_test_cli_quality_XXXXXX");
  if (!mkdtemp(dir)) return -1;
  return 0;
}

static int teardown(void **state) {
  (void)state;
  char cmd[600];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return -1;
  free(R.tag);
  free(R.xyz);
  free(R.dim);
  free(R.tri);
  pm_gmsh_shutdown();
  return 0;
}

/* Mesh synth_torus.brep with gmsh (2D) and write it; keep the raw data. */
static int make_mesh(void) {
  if (!pm_test_have_cad()) return 0;
  if (R.ntri) return 1;
  char cad[512];
  pm_test_cad("synth_torus.brep", cad, sizeof cad);
  pm_error e = {0};
  if (pm_gmsh_begin(&e)) fail_msg("%s", e.msg);
  int ierr = 0;
  pm_gmsh_lock();
  gmshModelAdd("e2e", &ierr);
  int *dt = NULL;
  size_t ndt = 0;
  int tok = pm_gmsh_mute_stdout();
  gmshModelOccImportShapes(cad, &dt, &ndt, 0, "", &ierr);
  pm_gmsh_unmute_stdout(tok);
  assert_int_equal(ierr, 0);
  gmshFree(dt);
  gmshModelOccSynchronize(&ierr);
  gmshOptionSetNumber("Mesh.MeshSizeMax", 0.12, &ierr);
  gmshModelMeshGenerate(2, &ierr);
  assert_int_equal(ierr, 0);
  snprintf(msh, sizeof msh, "%s/torus.msh", dir);
  gmshWrite(msh, &ierr);
  assert_int_equal(ierr, 0);
  /* Nodes entity by entity, to know each node's dimension. */
  gmshModelGetEntities(&dt, &ndt, -1, &ierr);
  size_t cap = 0;
  for (size_t i = 0; i < ndt; i += 2) {
    size_t *nt = NULL, nn = 0, nc = 0, np = 0;
    double *c = NULL, *p = NULL;
    gmshModelMeshGetNodes(&nt, &nn, &c, &nc, &p, &np, dt[i], dt[i + 1], 0, 0, &ierr);
    if (R.nnode + nn > cap) {
      cap = 2 * (R.nnode + nn);
      R.tag = realloc(R.tag, cap * sizeof *R.tag);
      R.xyz = realloc(R.xyz, 3 * cap * sizeof *R.xyz);
      R.dim = realloc(R.dim, cap * sizeof *R.dim);
    }
    for (size_t k = 0; k < nn; ++k) {
      R.tag[R.nnode] = nt[k];
      memcpy(R.xyz + 3 * R.nnode, c + 3 * k, 3 * sizeof(double));
      R.dim[R.nnode] = dt[i];
      ++R.nnode;
    }
    gmshFree(nt);
    gmshFree(c);
    if (p) gmshFree(p);
  }
  gmshFree(dt);
  size_t *et = NULL, net = 0, *en = NULL, nen = 0;
  gmshModelMeshGetElementsByType(2, &et, &net, &en, &nen, -1, 0, 1, &ierr);
  R.ntri = net;
  R.tri = malloc(nen * sizeof *R.tri);
  memcpy(R.tri, en, nen * sizeof *R.tri);
  gmshFree(et);
  gmshFree(en);
  gmshModelRemove(&ierr);
  pm_gmsh_unlock();
  assert_true(R.ntri > 500);
  return 1;
}

static size_t node_index(size_t tag) {
  for (size_t i = 0; i < R.nnode; ++i)
    if (R.tag[i] == tag) return i;
  fail_msg("node tag %zu missing", tag);
  return 0;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static int cmp_edge(const void *a, const void *b) {
  const size_t *x = a, *y = b;
  if (x[0] != y[0]) return (x[0] > y[0]) - (x[0] < y[0]);
  return (x[1] > y[1]) - (x[1] < y[1]);
}

static double quantile(const double *x, size_t n, double p) {
  double h = (double)(n - 1) * p;
  size_t i = (size_t)h;
  return i + 1 < n ? x[i] + (h - (double)i) * (x[i + 1] - x[i]) : x[n - 1];
}

static void compare_summary(const cJSON *obj, double *v, size_t n, const char *what) {
  qsort(v, n, sizeof *v, cmp_double);
  double sum = 0;
  for (size_t i = 0; i < n; ++i) sum += v[i];
  const char *key[6] = {"min", "p25", "median", "p75", "max", "mean"};
  double want[6] = {v[0], quantile(v, n, 0.25), quantile(v, n, 0.5), quantile(v, n, 0.75),
                    v[n - 1], sum / (double)n};
  for (int k = 0; k < 6; ++k) {
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(obj, key[k]);
    if (!cJSON_IsNumber(x)) fail_msg("%s.%s missing", what, key[k]);
    if (!(fabs(x->valuedouble - want[k]) <= 1e-9))
      fail_msg("%s.%s = %.15g, independent value %.15g", what, key[k], x->valuedouble, want[k]);
  }
}

/* Run the command line; capture stdout and stderr; return the exit code. */
static int run(const char *args, char **out, char **err) { return pm_test_cli(dir, args, out, err); }

static void json_matches_independent_computation(void **state) {
  (void)state;
  if (!make_mesh()) skip();
  char args[600], *out, *err;
  snprintf(args, sizeof args, "quality '%s' --json", msh);
  int code = run(args, &out, &err);
  if (code != 0) fail_msg("exit %d: %s", code, err);
  assert_string_equal(err, "");
  cJSON *root = cJSON_Parse(out);
  assert_non_null(root);
  assert_string_equal(cJSON_GetObjectItem(root, "method")->valuestring, "external");
  assert_string_equal(cJSON_GetObjectItem(root, "input")->valuestring, msh);
  assert_true(cJSON_GetObjectItem(root, "nodes")->valuedouble == (double)R.nnode);
  assert_true(cJSON_GetObjectItem(root, "triangles")->valuedouble == (double)R.ntri);
  assert_true(cJSON_GetObjectItem(root, "tets")->valuedouble == 0);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItem(root, "valid")));
  const cJSON *tri = cJSON_GetObjectItem(root, "tri");
  assert_non_null(tri);

  size_t n = R.ntri;
  double *q = malloc(n * sizeof *q), *ar = malloc(n * sizeof *ar), *amin = malloc(n * sizeof *amin),
         *amax = malloc(n * sizeof *amax);
  double eps_g = 0;
  size_t (*edges)[2] = malloc(3 * n * sizeof *edges);
  for (size_t t = 0; t < n; ++t) {
    size_t id[3];
    for (int k = 0; k < 3; ++k) id[k] = node_index(R.tri[3 * t + k]);
    double l[3]; /* l[k] opposite vertex k */
    for (int k = 0; k < 3; ++k) {
      const double *p = R.xyz + 3 * id[(k + 1) % 3], *r = R.xyz + 3 * id[(k + 2) % 3];
      l[k] = sqrt((p[0] - r[0]) * (p[0] - r[0]) + (p[1] - r[1]) * (p[1] - r[1]) +
                  (p[2] - r[2]) * (p[2] - r[2]));
    }
    double a = l[0], b = l[1], c = l[2];
    /* papers/004: q = (b + c - a)(c + a - b)(a + b - c) / (abc) */
    q[t] = (b + c - a) * (c + a - b) * (a + b - c) / (a * b * c);
    double area4 = sqrt((a + b + c) * (b + c - a) * (c + a - b) * (a + b - c)); /* Heron: 4A */
    double R_ = a * b * c / area4;
    ar[t] = R_ / fmin(a, fmin(b, c));
    double ang[3];
    for (int k = 0; k < 3; ++k) {
      double x = l[k], y = l[(k + 1) % 3], z = l[(k + 2) % 3];
      ang[k] = acos((y * y + z * z - x * x) / (2 * y * z)) * 180 / M_PI;
    }
    amin[t] = fmin(ang[0], fmin(ang[1], ang[2]));
    amax[t] = fmax(ang[0], fmax(ang[1], ang[2]));
    eps_g += 0.5 - q[t] / 2; /* papers/003 eq. 9, r/R = q/2 */
    for (int k = 0; k < 3; ++k) {
      size_t u = id[k], v = id[(k + 1) % 3];
      edges[3 * t + k][0] = u < v ? u : v;
      edges[3 * t + k][1] = u < v ? v : u;
    }
  }
  compare_summary(cJSON_GetObjectItem(tri, "radius_ratio"), q, n, "tri.radius_ratio");
  compare_summary(cJSON_GetObjectItem(tri, "aspect_ratio"), ar, n, "tri.aspect_ratio");
  compare_summary(cJSON_GetObjectItem(tri, "min_angle_deg"), amin, n, "tri.min_angle_deg");
  compare_summary(cJSON_GetObjectItem(tri, "max_angle_deg"), amax, n, "tri.max_angle_deg");
  PM_ASSERT_NEAR(cJSON_GetObjectItem(tri, "eps_g")->valuedouble, eps_g / (double)n, 1e-9);

  /* eps_t (papers/003 eq. 8): degrees from the unique edges, over the nodes gmsh put on the
   * torus face (dim 2); the seam nodes lie on curves. */
  qsort(edges, 3 * n, sizeof *edges, cmp_edge);
  int *deg = calloc(R.nnode, sizeof *deg);
  for (size_t i = 0; i < 3 * n; ++i) {
    if (i > 0 && edges[i][0] == edges[i - 1][0] && edges[i][1] == edges[i - 1][1]) continue;
    deg[edges[i][0]]++;
    deg[edges[i][1]]++;
  }
  double sum = 0;
  size_t ni = 0;
  for (size_t v = 0; v < R.nnode; ++v)
    if (R.dim[v] == 2 && deg[v] > 0) {
      sum += fabs(deg[v] - 6.0);
      ++ni;
    }
  assert_true(ni > 100);
  assert_true(cJSON_GetObjectItem(tri, "eps_t_nodes")->valuedouble == (double)ni);
  PM_ASSERT_NEAR(cJSON_GetObjectItem(tri, "eps_t")->valuedouble, sum / (double)ni, 1e-12);

  /* Size conformity with --size EXPR: edge length / d(midpoint) over the unique edges, d an
   * expression evaluated here by hand. */
  {
    char *o2, *e2;
    snprintf(args, sizeof args, "quality '%s' --json --size '0.1+0.05*x*x+0.02*abs(z)'", msh);
    int c2 = run(args, &o2, &e2);
    if (c2 != 0) fail_msg("exit %d: %s", c2, e2);
    cJSON *r2 = cJSON_Parse(o2);
    const cJSON *sr = cJSON_GetObjectItem(cJSON_GetObjectItem(r2, "tri"), "size_ratio");
    assert_non_null(sr);
    double sum1 = 0, sum2 = 0;
    size_t ne = 0;
    for (size_t i = 0; i < 3 * n; ++i) {
      if (i > 0 && edges[i][0] == edges[i - 1][0] && edges[i][1] == edges[i - 1][1]) continue;
      const double *a = R.xyz + 3 * edges[i][0], *b = R.xyz + 3 * edges[i][1];
      double mx = 0.5 * (a[0] + b[0]), mz = 0.5 * (a[2] + b[2]);
      double d = 0.1 + 0.05 * mx * mx + 0.02 * fabs(mz);
      double l = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                      (a[2] - b[2]) * (a[2] - b[2]));
      sum1 += l / d;
      ++ne;
    }
    double mean = sum1 / (double)ne;
    for (size_t i = 0; i < 3 * n; ++i) {
      if (i > 0 && edges[i][0] == edges[i - 1][0] && edges[i][1] == edges[i - 1][1]) continue;
      const double *a = R.xyz + 3 * edges[i][0], *b = R.xyz + 3 * edges[i][1];
      double mx = 0.5 * (a[0] + b[0]), mz = 0.5 * (a[2] + b[2]);
      double d = 0.1 + 0.05 * mx * mx + 0.02 * fabs(mz);
      double l = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                      (a[2] - b[2]) * (a[2] - b[2]));
      sum2 += (l / d - mean) * (l / d - mean);
    }
    PM_ASSERT_NEAR(cJSON_GetObjectItem(sr, "mean")->valuedouble, mean, 1e-9);
    PM_ASSERT_NEAR(cJSON_GetObjectItem(sr, "std")->valuedouble, sqrt(sum2 / (double)ne), 1e-9);
    assert_string_equal(cJSON_GetObjectItem(r2, "size")->valuestring, "0.1+0.05*x*x+0.02*abs(z)");
    cJSON_Delete(r2);
    free(o2);
    free(e2);
  }

  /* The torus surface: closed, V - E + F = 0, genus 1. */
  const cJSON *sh = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "shells"), 0);
  assert_true(cJSON_GetObjectItem(sh, "euler")->valuedouble == 0);
  assert_true(cJSON_GetObjectItem(sh, "genus")->valuedouble == 1);

  /* --csv: one row per triangle, the same radius ratios. */
  free(out);
  free(err);
  snprintf(args, sizeof args, "quality '%s' --csv", msh);
  assert_int_equal(run(args, &out, &err), 0);
  assert_int_equal(pm_test_count_lines(out), (int)n + 1);
  assert_int_equal(strncmp(out, "kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg\n", 70), 0);
  double *qc = malloc(n * sizeof *qc);
  size_t k = 0;
  for (char *line = strchr(out, '\n') + 1; *line && k < n; line = strchr(line, '\n') + 1) {
    char kind[8];
    long idx, cell;
    assert_int_equal(sscanf(line, "%7[^,],%ld,%ld,%lf", kind, &idx, &cell, &qc[k]), 4);
    assert_string_equal(kind, "tri");
    assert_int_equal(idx, (long)k);
    assert_int_equal(cell, 0); /* the torus face, gmsh tag 1 */
    ++k;
  }
  assert_int_equal(k, n);
  qsort(qc, n, sizeof *qc, cmp_double);
  for (size_t i = 0; i < n; ++i) PM_ASSERT_NEAR(qc[i], q[i], 1e-12); /* q sorted above */

  /* The readable table. */
  free(out);
  free(err);
  snprintf(args, sizeof args, "quality '%s'", msh);
  assert_int_equal(run(args, &out, &err), 0);
  assert_non_null(strstr(out, "radius ratio"));
  assert_non_null(strstr(out, "genus 1"));
  free(out);
  free(err);
  free(qc);
  free(deg);
  free(edges);
  free(q);
  free(ar);
  free(amin);
  free(amax);
  cJSON_Delete(root);
}

/* Distance from p to the torus of synth_torus.brep (R = 1, r = 0.3 about the z axis). */
static double torus_distance(const double p[3]) {
  double rho = sqrt(p[0] * p[0] + p[1] * p[1]) - 1.0;
  return fabs(sqrt(rho * rho + p[2] * p[2]) - 0.3);
}

/* --geometry: the model checks pass on gmsh's mesh of the same CAD file, and the two-sided
 * distance is at least the distance of the worst triangle centroid to the exact torus. */
static void geometry_checks_and_distance(void **state) {
  (void)state;
  if (!make_mesh()) skip();
  char cad[512], args[1200], *out, *err;
  pm_test_cad("synth_torus.brep", cad, sizeof cad);
  snprintf(args, sizeof args, "quality '%s' --geometry '%s' --json --size 0.1", msh, cad);
  int code = run(args, &out, &err);
  if (code != 0) fail_msg("exit %d: %s", code, err);
  assert_string_equal(err, "");
  cJSON *root = cJSON_Parse(out);
  assert_non_null(root);
  if (!cJSON_IsTrue(cJSON_GetObjectItem(root, "valid")))
    fail_msg("not valid: %s", cJSON_GetArrayItem(cJSON_GetObjectItem(root, "problems"), 0)->valuestring);
  const cJSON *sh = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "shells"), 0);
  assert_true(cJSON_GetObjectItem(sh, "volume")->valuedouble == 0);
  assert_true(cJSON_GetObjectItem(sh, "genus")->valuedouble == 1);
  const cJSON *d = cJSON_GetObjectItem(root, "distance");
  assert_non_null(d);
  double dmean = cJSON_GetObjectItem(d, "mean")->valuedouble;
  double dmax = cJSON_GetObjectItem(d, "max")->valuedouble;
  PM_ASSERT_NEAR(cJSON_GetObjectItem(d, "bbox_diagonal")->valuedouble, sqrt(2 * 2.6 * 2.6 + 0.6 * 0.6), 1e-6);
  double worst = 0;
  for (size_t t = 0; t < R.ntri; ++t) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      size_t id = node_index(R.tri[3 * t + k]);
      for (int j = 0; j < 3; ++j) c[j] += R.xyz[3 * id + j] / 3;
    }
    worst = fmax(worst, torus_distance(c));
  }
  assert_true(worst > 0);
  if (!(dmax >= 0.999 * worst)) fail_msg("distance.max %.9g below a centroid's %.9g", dmax, worst);
  assert_true(dmean > 0 && dmean < dmax);
  assert_true(dmax < 0.05 * 3.7256);
  assert_true(cJSON_IsNumber(cJSON_GetObjectItem(d, "rel_max")));
  assert_string_equal(cJSON_GetObjectItem(root, "geometry")->valuestring, cad);
  cJSON_Delete(root);
  free(out);
  free(err);
  /* Against another model: a verdict, not an error. */
  pm_test_cad("planar_step.brep", cad, sizeof cad);
  snprintf(args, sizeof args, "quality '%s' --geometry '%s' --json", msh, cad);
  assert_int_equal(run(args, &out, &err), 0);
  root = cJSON_Parse(out);
  assert_true(cJSON_IsFalse(cJSON_GetObjectItem(root, "valid")));
  cJSON_Delete(root);
  free(out);
  free(err);
}

/* The number at a dotted key of a stats object (NAN when missing). */
static double stat_at(const cJSON *root, const char *dotted) {
  char key[128];
  snprintf(key, sizeof key, "%s", dotted);
  const cJSON *o = root;
  for (char *part = strtok(key, "."); part && o; part = strtok(NULL, "."))
    o = cJSON_GetObjectItem(o, part);
  return cJSON_IsNumber(o) ? o->valuedouble : cJSON_IsBool(o) ? cJSON_IsTrue(o) : NAN;
}

static cJSON *quality_json(const char *args) {
  char *out, *err;
  int code = run(args, &out, &err);
  if (code != 0) fail_msg("'%s': exit %d: %s", args, code, err);
  cJSON *root = cJSON_Parse(out);
  assert_non_null(root);
  free(out);
  free(err);
  return root;
}

/* --geometry classifies the nodes of files without entity tags: the same mesh as .mesh (tags on
 * elements only) and .stl (triangles only) gives the figures of its .msh, where without a model
 * every node of a closed shell counts as interior. A .vtk carries its tags and needs none. */
static void untagged_formats_classified(void **state) {
  (void)state;
  static const char *const keys[] = {
      "tri.eps_t", "tri.eps_t_nodes", "tri.by_site.boundary.count", "tri.by_site.regular.count",
      "tri.by_site.irregular.count", "valid", "nodes", "tet.eps_t", "tet.eps_t_nodes"};
  const char *ext[4] = {"msh", "mesh", "stl", "vtk"};
  const int nkey[4] = {9, 9, 5, 9}; /* an .stl has no segments (invalid) and no tets */
  char args[3200], path[4][600];
  for (int f = 0; f < 4; ++f) {
    snprintf(path[f], sizeof path[f], "%s/boxhole.%s", dir, ext[f]);
    snprintf(args, sizeof args, "mesh case:boxhole --method gmsh-frontal --volume -o '%s'",
             path[f]);
    char *out, *err;
    if (run(args, &out, &err) != 0) fail_msg("%s: %s", args, err);
    free(out);
    free(err);
  }
  snprintf(args, sizeof args, "quality '%s' --geometry case:boxhole --json", path[0]);
  cJSON *tagged = quality_json(args);
  assert_true(stat_at(tagged, "valid") == 1);
  assert_true(isnan(stat_at(tagged, "classified.nodes")));
  for (int f = 1; f < 4; ++f) {
    snprintf(args, sizeof args, "quality '%s' --geometry case:boxhole --json", path[f]);
    cJSON *root = quality_json(args);
    for (int k = 0; k < nkey[f]; ++k)
      if (!(stat_at(root, keys[k]) == stat_at(tagged, keys[k])))
        fail_msg(".%s %s: %.12g, .msh %.12g", ext[f], keys[k], stat_at(root, keys[k]),
                 stat_at(tagged, keys[k]));
    if (f == 3) {
      assert_true(isnan(stat_at(root, "classified.nodes")));
    } else {
      assert_true(stat_at(root, "classified.nodes") == stat_at(root, "nodes"));
      assert_true(stat_at(root, "classified.unmatched") == 0);
    }
    cJSON_Delete(root);
  }
  /* Without the model, the .mesh's curve and vertex nodes count as interior. */
  snprintf(args, sizeof args, "quality '%s' --json", path[1]);
  cJSON *bare = quality_json(args);
  assert_true(stat_at(bare, "tri.eps_t_nodes") > stat_at(tagged, "tri.eps_t_nodes"));
  cJSON_Delete(bare);
  cJSON_Delete(tagged);
}

/* The distance of a mesh read back from its .msh (written without parameters) is the one
 * `mesh --stats` measured on the mesh as the mesher held it: on the OpenCASCADE sphere, node
 * parameters read as zeros once made it 1.41 instead of 0.0028. */
static void distance_of_file_matches_stats(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  char cad[512], args[2400], path[600], stats[600];
  pm_test_cad("synth_sphere.brep", cad, sizeof cad);
  snprintf(path, sizeof path, "%s/sphere.msh", dir);
  snprintf(stats, sizeof stats, "%s/sphere.json", dir);
  snprintf(args, sizeof args, "mesh '%s' --threads 1 -o '%s' --stats '%s'", cad, path, stats);
  char *out, *err;
  if (run(args, &out, &err) != 0) fail_msg("%s: %s", args, err);
  free(out);
  free(err);
  cJSON *meshed = pm_test_read_json(stats);
  snprintf(args, sizeof args, "quality '%s' --geometry '%s' --json", path, cad);
  cJSON *read = quality_json(args);
  for (int k = 0; k < 2; ++k) {
    const char *key = k ? "distance.max" : "distance.mean";
    const double a = stat_at(meshed, key), b = stat_at(read, key);
    if (!(a > 0 && a < 0.01 && fabs(a - b) <= 1e-6 * a))
      fail_msg("%s: mesh --stats %.12g, quality %.12g", key, a, b);
  }
  cJSON_Delete(read);
  cJSON_Delete(meshed);
}

static void write_file(const char *name, const char *text, char *path) {
  snprintf(path, 512, "%s/%s", dir, name);
  FILE *f = fopen(path, "w");
  fputs(text, f);
  fclose(f);
}

/* Each bad input: the expected exit code, exactly one line on stderr naming the problem, and
 * nothing on stdout. */
static void expect_error(const char *args, int code, const char *needle) {
  char *out, *err;
  int c = run(args, &out, &err);
  if (c != code) fail_msg("'%s': exit %d, expected %d (stderr: %s)", args, c, code, err);
  if (pm_test_count_lines(err) != 1)
    fail_msg("'%s': stderr has %d lines: %s", args, pm_test_count_lines(err), err);
  assert_int_equal(strncmp(err, "packmesh: ", 10), 0);
  if (!strstr(err, needle)) fail_msg("'%s': stderr '%s' does not name '%s'", args, err, needle);
  assert_string_equal(out, "");
  free(out);
  free(err);
}

static void errors(void **state) {
  (void)state;
  char p[512], args[1200];
  snprintf(args, sizeof args, "quality '%s/missing.msh'", dir);
  expect_error(args, 1, "missing.msh");
  write_file("corrupt.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n", p);
  snprintf(args, sizeof args, "quality '%s' --json", p);
  expect_error(args, 1, "corrupt.msh");
  write_file("noise.stl", "solid x\nfacet normal 0 0 1\n outer loop\n  vertex 0 0\n", p);
  snprintf(args, sizeof args, "quality '%s'", p);
  expect_error(args, 1, "noise.stl");
  write_file("x.vtu", "<VTKFile/>\n", p);
  snprintf(args, sizeof args, "quality '%s'", p);
  expect_error(args, 1, ".vtu");
  snprintf(args, sizeof args, "quality '%s'", dir);
  expect_error(args, 1, "extension");
  write_file("plain.txt", "1 2 3\n", p);
  snprintf(args, sizeof args, "quality '%s'", p);
  expect_error(args, 1, "'.txt'");
  /* Bad sizes: usage errors, reported before the mesh is read (so even for a missing mesh). */
  snprintf(args, sizeof args, "quality '%s/missing.msh' --size -0.1", dir);
  expect_error(args, 2, "size '-0.1'");
  expect_error("quality x.msh --size nan", 2, "nan");
  expect_error("quality x.msh --size inf", 2, "inf");
  expect_error("quality x.msh --size '0.1*(x'", 2, "Missing parenthesis");
  expect_error("quality x.msh --size 'foo+1'", 2, "foo");
  expect_error("quality x.msh --size '0*x'", 2, "0*x");
  expect_error("quality x.msh --size", 2, "--size needs a value");
  expect_error("quality x.msh --size 1 --size 2", 2, "twice");
  snprintf(args, sizeof args, "quality '%s/missing.msh' --geometry '%s/nope.step'", dir, dir);
  expect_error(args, 1, "nope.step");
  expect_error("quality x.msh --geometry case:nope", 1, "nope");
  expect_error("quality x.msh --geometry", 2, "--geometry needs a value");
  expect_error("quality some.msh --bogus", 2, "--bogus");
  expect_error("quality", 2, "no mesh file");
  expect_error("quality a.msh b.msh", 2, "b.msh");
  expect_error("quality a.msh --json --csv", 2, "--csv");
  expect_error("frobnicate", 2, "frobnicate");
  expect_error("--frobnicate", 2, "--frobnicate");
  expect_error("", 2, "no command");
}

static void help_and_version(void **state) {
  (void)state;
  char *out, *err;
  assert_int_equal(run("--version", &out, &err), 0);
  assert_int_equal(strncmp(out, "packmesh ", 9), 0);
  free(out);
  free(err);
  assert_int_equal(run("--help", &out, &err), 0);
  assert_non_null(strstr(out, "quality"));
  free(out);
  free(err);
  assert_int_equal(run("quality --help", &out, &err), 0);
  assert_non_null(strstr(out, "usage: packmesh quality"));
  assert_string_equal(err, "");
  free(out);
  free(err);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(json_matches_independent_computation),
      cmocka_unit_test(geometry_checks_and_distance),
      cmocka_unit_test(untagged_formats_classified),
      cmocka_unit_test(distance_of_file_matches_stats),
      cmocka_unit_test(errors),
      cmocka_unit_test(help_and_version),
  };
  return cmocka_run_group_tests(tests, setup, teardown);
}
