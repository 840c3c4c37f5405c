/* Tetrahedralization through TetGen (tet_tetgen.h): unit cubes with exact volumes, the given
 * points kept without Steiner points, quality refinement with a volume bound, surface triangles
 * and segments kept as tet faces and edges, region tags across an internal face, TetGen's own
 * consistency check, Steiner points refused when the boundary needs them, self-intersecting and
 * bad input refused without a crash or a word on stdout. */
#include "test_support.h"

#include "common/backends/predicates.h"
#include "common/backends/tet_tetgen.h"

#include <stdlib.h>
#include <string.h>

/* ---- a surface builder on an integer lattice ------------------------------------------------ */

enum { MAXP = 4096, MAXT = 8192 };

typedef struct surf {
  double xyz[3 * MAXP];
  int32_t npts;
  int32_t tri[3 * MAXT];
  int32_t tag[MAXT];
  int32_t ntri;
  int n;          /* lattice cells per unit length */
  int32_t *id;    /* lattice point -> index, -1 when absent */
  int nx, ny, nz; /* lattice extent in cells */
} surf;

static void surf_init(surf *s, int n, int nx_units) {
  memset(s, 0, sizeof *s);
  s->n = n;
  s->nx = n * nx_units, s->ny = n, s->nz = n;
  size_t count = (size_t)(s->nx + 1) * (s->ny + 1) * (s->nz + 1);
  s->id = malloc(count * sizeof *s->id);
  for (size_t i = 0; i < count; ++i) s->id[i] = -1;
}

static void surf_free(surf *s) { free(s->id); }

/* Coordinates are lattice index / n, computed the same way everywhere so shared points agree. */
static int32_t lattice_point(surf *s, int i, int j, int k) {
  size_t key = ((size_t)i * (s->ny + 1) + j) * (s->nz + 1) + k;
  if (s->id[key] < 0) {
    s->xyz[3 * s->npts] = (double)i / s->n;
    s->xyz[3 * s->npts + 1] = (double)j / s->n;
    s->xyz[3 * s->npts + 2] = (double)k / s->n;
    s->id[key] = s->npts++;
  }
  return s->id[key];
}

static int32_t add_point(surf *s, double x, double y, double z) {
  s->xyz[3 * s->npts] = x, s->xyz[3 * s->npts + 1] = y, s->xyz[3 * s->npts + 2] = z;
  return s->npts++;
}

static void add_tri(surf *s, int32_t a, int32_t b, int32_t c, int32_t tag) {
  s->tri[3 * s->ntri] = a, s->tri[3 * s->ntri + 1] = b, s->tri[3 * s->ntri + 2] = c;
  s->tag[s->ntri++] = tag;
}

/* The square wall {axis = level} over lattice cells [u0, u0 + n) x [0, n) of the other two axes
 * (u along the next axis cyclically, v the one after), split into triangles whose normal points
 * along +axis when outward > 0, -axis otherwise. */
static void add_wall(surf *s, int axis, int level, int u0, int outward, int32_t tag) {
  for (int a = 0; a < s->n; ++a)
    for (int b = 0; b < s->n; ++b) {
      int32_t q[4];
      const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
      for (int c = 0; c < 4; ++c) {
        int ijk[3];
        ijk[axis] = level;
        ijk[(axis + 1) % 3] = u0 + a + du[c];
        ijk[(axis + 2) % 3] = b + dv[c];
        q[c] = lattice_point(s, ijk[0], ijk[1], ijk[2]);
      }
      /* (u, v, axis) is right-handed, so q0 q1 q2 turns counter-clockwise around +axis. */
      if (outward > 0) {
        add_tri(s, q[0], q[1], q[2], tag);
        add_tri(s, q[0], q[2], q[3], tag);
      } else {
        add_tri(s, q[0], q[2], q[1], tag);
        add_tri(s, q[0], q[3], q[2], tag);
      }
    }
}

/* The surface of the unit cube [c, c + 1] x [0, 1]^2 (c = cube number along x); `skip_left`
 * leaves out its x = c wall (shared with the previous cube). Walls x: tags 10c+0/1, y: 2/3,
 * z: 4/5. Only the x walls take the offset: the y and z walls of cube c span u along z / x, so
 * the x offset goes to whichever of u, v runs along x. */
static void add_cube(surf *s, int c, int skip_left) {
  int n = s->n, x0 = c * n;
  if (!skip_left) add_wall(s, 0, x0, 0, -1, 10 * c + 0);
  add_wall(s, 0, x0 + n, 0, +1, 10 * c + 1);
  /* y walls: u = z, v = x. */
  for (int side = 0; side < 2; ++side) {
    int level = side * n;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        int32_t q0 = lattice_point(s, x0 + b, level, a), q1 = lattice_point(s, x0 + b, level, a + 1);
        int32_t q2 = lattice_point(s, x0 + b + 1, level, a + 1), q3 = lattice_point(s, x0 + b + 1, level, a);
        /* (z, x, y) is right-handed: q0 q1 q2 turns around +y. */
        if (side) add_tri(s, q0, q1, q2, 10 * c + 3), add_tri(s, q0, q2, q3, 10 * c + 3);
        else add_tri(s, q0, q2, q1, 10 * c + 2), add_tri(s, q0, q3, q2, 10 * c + 2);
      }
  }
  /* z walls: u = x, v = y. */
  for (int side = 0; side < 2; ++side) {
    int level = side * n;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        int32_t q0 = lattice_point(s, x0 + a, b, level), q1 = lattice_point(s, x0 + a + 1, b, level);
        int32_t q2 = lattice_point(s, x0 + a + 1, b + 1, level), q3 = lattice_point(s, x0 + a, b + 1, level);
        if (side) add_tri(s, q0, q1, q2, 10 * c + 5), add_tri(s, q0, q2, q3, 10 * c + 5);
        else add_tri(s, q0, q2, q1, 10 * c + 4), add_tri(s, q0, q3, q2, 10 * c + 4);
      }
  }
}

static pm_tet_input input_of(const surf *s, pm_tet_mode mode) {
  pm_tet_input in;
  memset(&in, 0, sizeof in);
  in.npts = s->npts;
  in.xyz = s->xyz;
  in.nsurf = s->npts;
  in.ntri = s->ntri;
  in.tri = s->tri;
  in.tri_tag = s->tag;
  in.mode = mode;
  return in;
}

/* ---- checks on a result -------------------------------------------------------------------- */

static double tet_volume(const double *xyz, const int32_t *v) {
  const double *a = xyz + 3 * v[0], *b = xyz + 3 * v[1], *c = xyz + 3 * v[2], *d = xyz + 3 * v[3];
  double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  double z[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return ((u[1] * w[2] - u[2] * w[1]) * z[0] + (u[2] * w[0] - u[0] * w[2]) * z[1] +
          (u[0] * w[1] - u[1] * w[0]) * z[2]) / 6.0;
}

/* Orders for grouping equal keys (any total order will do). */
static int cmp3(const void *a, const void *b) { return memcmp(a, b, 3 * sizeof(int32_t)); }
static int cmp2(const void *a, const void *b) { return memcmp(a, b, 2 * sizeof(int32_t)); }
static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

static void sort3(int32_t *t) { qsort(t, 3, sizeof *t, cmp_i32); }

/* Faces of all tets, each a sorted triple, sorted; 4 * ntet of them. */
static int32_t *tet_faces(const pm_tet_result *r) {
  int32_t *f = malloc((size_t)r->ntet * 12 * sizeof *f);
  for (int32_t t = 0; t < r->ntet; ++t) {
    const int32_t *v = r->tet + 4 * t;
    for (int o = 0; o < 4; ++o) {
      int32_t *g = f + 12 * t + 3 * o;
      int m = 0;
      for (int j = 0; j < 4; ++j)
        if (j != o) g[m++] = v[j];
      sort3(g);
    }
  }
  qsort(f, (size_t)r->ntet * 4, 3 * sizeof *f, cmp3);
  return f;
}

/* How many tets have the face (a, b, c). */
static int face_count(const int32_t *faces, int32_t ntet, int32_t a, int32_t b, int32_t c) {
  int32_t key[3] = {a, b, c};
  sort3(key);
  const int32_t *hit = bsearch(key, faces, (size_t)ntet * 4, 3 * sizeof *faces, cmp3);
  if (!hit) return 0;
  const int32_t *lo = hit, *hi = hit;
  while (lo > faces && cmp3(lo - 3, key) == 0) lo -= 3;
  while (hi + 3 < faces + 12 * (size_t)ntet && cmp3(hi + 3, key) == 0) hi += 3;
  return (int)((hi - lo) / 3 + 1);
}

/* Everything a valid result of a closed, conforming input must satisfy: positive tets (exact),
 * the given volume, every input triangle a tet face -- once on the outer boundary, twice on an
 * internal face (`internal_tag` >= 0 marks those tags, -1 none) -- every other face shared by
 * exactly two tets, and Euler's relation V - E + F - T = 1 for a ball (components balls). */
static void check_mesh(const pm_tet_input *in, const pm_tet_result *r, double volume,
                       int32_t internal_tag, int balls) {
  assert_true(r->npts >= in->npts);
  for (int32_t i = 0; i < 3 * in->npts; ++i) assert_true(r->xyz[i] == in->xyz[i]);
  double sum = 0;
  for (int32_t t = 0; t < r->ntet; ++t) {
    const int32_t *v = r->tet + 4 * t;
    for (int j = 0; j < 4; ++j) assert_true(v[j] >= 0 && v[j] < r->npts);
    assert_int_equal(pm_orient3d(r->xyz + 3 * v[0], r->xyz + 3 * v[1], r->xyz + 3 * v[2],
                                 r->xyz + 3 * v[3]), 1);
    double vol = tet_volume(r->xyz, v);
    assert_true(vol > 0);
    sum += vol;
  }
  PM_ASSERT_NEAR(sum, volume, 1e-12);

  int32_t *faces = tet_faces(r);
  for (int32_t k = 0; k < in->ntri; ++k) {
    const int32_t *t = in->tri + 3 * k;
    int expect = (internal_tag >= 0 && in->tri_tag && in->tri_tag[k] == internal_tag) ? 2 : 1;
    assert_int_equal(face_count(faces, r->ntet, t[0], t[1], t[2]), expect);
  }
  /* Faces seen once are exactly the outer boundary triangles. */
  int32_t nface = 0, nonce = 0;
  for (int32_t i = 0; i < 4 * r->ntet;) {
    int32_t j = i + 1;
    while (j < 4 * r->ntet && memcmp(faces + 3 * j, faces + 3 * i, 3 * sizeof(int32_t)) == 0) ++j;
    assert_true(j - i <= 2);
    if (j - i == 1) ++nonce;
    ++nface;
    i = j;
  }
  int32_t nouter = 0;
  for (int32_t k = 0; k < in->ntri; ++k)
    if (!(internal_tag >= 0 && in->tri_tag && in->tri_tag[k] == internal_tag)) ++nouter;
  assert_int_equal(nonce, nouter);

  /* Euler's relation: V - E + F - T = number of balls. */
  int32_t *e = malloc((size_t)r->ntet * 12 * sizeof *e);
  int32_t ne = 0;
  for (int32_t t = 0; t < r->ntet; ++t)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        int32_t x = r->tet[4 * t + a], y = r->tet[4 * t + b];
        e[2 * ne] = x < y ? x : y, e[2 * ne + 1] = x < y ? y : x;
        ++ne;
      }
  qsort(e, (size_t)ne, 2 * sizeof *e, cmp2);
  int32_t nedge = 0;
  for (int32_t i = 0; i < ne; ++i)
    if (i == 0 || cmp2(e + 2 * i, e + 2 * (i - 1)) != 0) ++nedge;
  char *used = calloc((size_t)r->npts, 1);
  int32_t nvert = 0;
  for (int32_t i = 0; i < 4 * r->ntet; ++i)
    if (!used[r->tet[i]]) used[r->tet[i]] = 1, ++nvert;
  assert_int_equal(nvert, r->npts); /* every point, given or added, is a vertex */
  assert_int_equal(nvert - nedge + nface - r->ntet, balls);
  free(used);
  free(e);
  free(faces);
}

/* ---- stdout watch: nothing may be printed by the library ------------------------------------ */

typedef struct watch {
  int saved;
  FILE *tmp;
} watch;

static watch watch_begin(void) {
  watch w;
  fflush(stdout);
  w.tmp = tmpfile();
  assert_non_null(w.tmp);
  w.saved = dup(1);
  assert_true(w.saved >= 0);
  assert_true(dup2(fileno(w.tmp), 1) >= 0);
  return w;
}

/* Restores stdout and returns how many bytes were written meanwhile. */
static long watch_end(watch w) {
  fflush(stdout);
  dup2(w.saved, 1);
  close(w.saved);
  fseek(w.tmp, 0, SEEK_END);
  long n = ftell(w.tmp);
  fclose(w.tmp);
  return n;
}

/* ---- tests ------------------------------------------------------------------------------------ */

/* The unit cube (12 triangles) and one interior point: exactly the 9 points come back, no Steiner
 * point, volume 1, every surface triangle a tet face; TetGen's -C check finds no problem. */
static void cube_given_points(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 1, 1);
  add_cube(s, 0, 0);
  assert_int_equal(s->npts, 8);
  assert_int_equal(s->ntri, 12);
  add_point(s, 0.4, 0.45, 0.55);
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  in.nsurf = 8;
  pm_tet_result r;
  pm_error e = {0};
  watch w = watch_begin();
  pm_status st = pm_tet_tetrahedralize(&in, &r, &e);
  long printed = watch_end(w);
  PM_ASSERT_OK(st, e);
  assert_int_equal(printed, 0);
  assert_int_equal(r.npts, 9);
  assert_int_equal(r.nsteiner, 0);
  check_mesh(&in, &r, 1.0, -1, 1);
  for (int32_t t = 0; t < r.ntet; ++t) assert_int_equal(r.tet_tag[t], -1); /* no region seed */
  pm_tet_result_free(&r);
  assert_null(r.tet);
  assert_int_equal(r.ntet, 0);

  int32_t problems = -1;
  w = watch_begin();
  st = pm_tet_check_with_tetgen(&in, &problems, &e);
  printed = watch_end(w);
  PM_ASSERT_OK(st, e);
  assert_int_equal(printed, 0);
  assert_int_equal(problems, 0);
  surf_free(s);
  free(s);
}

/* A finer cube surface with 27 interior lattice points: all of them become vertices and none is
 * added. */
static void cube_given_points_grid(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 4, 1);
  add_cube(s, 0, 0);
  int32_t nsurf = s->npts;
  assert_int_equal(nsurf, 98); /* 5^3 - 3^3 */
  for (int i = 1; i < 4; ++i)
    for (int j = 1; j < 4; ++j)
      for (int k = 1; k < 4; ++k) add_point(s, i / 4.0, j / 4.0, k / 4.0);
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  in.nsurf = nsurf;
  pm_tet_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  assert_int_equal(r.npts, 125);
  assert_int_equal(r.nsteiner, 0);
  check_mesh(&in, &r, 1.0, -1, 1);
  pm_tet_result_free(&r);
  surf_free(s);
  free(s);
}

/* Quality refinement with a volume bound: Steiner points inside only, every tet <= 0.01, the
 * surface triangles kept. */
static void cube_refine(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 5, 1);
  add_cube(s, 0, 0);
  pm_tet_input in = input_of(s, PM_TET_REFINE);
  in.radius_edge = 2.0;
  in.max_volume = 0.01;
  pm_tet_result r;
  pm_error e = {0};
  watch w = watch_begin();
  pm_status st = pm_tet_tetrahedralize(&in, &r, &e);
  long printed = watch_end(w);
  PM_ASSERT_OK(st, e);
  assert_int_equal(printed, 0);
  assert_true(r.nsteiner > 0);
  assert_int_equal(r.npts, s->npts + r.nsteiner);
  double vmax = 0;
  for (int32_t t = 0; t < r.ntet; ++t) {
    double v = tet_volume(r.xyz, r.tet + 4 * t);
    if (v > vmax) vmax = v;
  }
  assert_true(vmax <= 0.01);
  /* Steiner points are strictly inside: -Y puts none on the boundary. */
  for (int32_t i = s->npts; i < r.npts; ++i)
    for (int k = 0; k < 3; ++k) assert_true(r.xyz[3 * i + k] > 0 && r.xyz[3 * i + k] < 1);
  check_mesh(&in, &r, 1.0, -1, 1);
  int32_t got = r.npts;
  pm_tet_result_free(&r);

  /* The same with a cap on the point count: exactly enough passes, one less fails. */
  in.max_points = got;
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  assert_int_equal(r.npts, got);
  pm_tet_result_free(&r);
  in.max_points = got - 1;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "max_points"));
  assert_null(r.tet);
  in.max_points = s->npts - 1;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_LIMIT);
  surf_free(s);
  free(s);
}

/* Two unit cubes sharing the face x = 1 (tag 1, an internal face), a seed in each: every tet
 * carries its cube's tag, and the shared triangles are faces of a tet on each side. */
static void two_cubes_regions(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 2, 2);
  add_cube(s, 0, 0);
  add_cube(s, 1, 1);
  int32_t nsurf = s->npts;
  add_point(s, 0.45, 0.55, 0.5);
  add_point(s, 1.55, 0.45, 0.5);
  double seeds[8] = {0.3, 0.3, 0.3, 7, 1.7, 0.6, 0.6, 9};
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  in.nsurf = nsurf;
  in.nregion = 2;
  in.region = seeds;
  pm_tet_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  assert_int_equal(r.nsteiner, 0);
  check_mesh(&in, &r, 2.0, 1, 1);
  for (int32_t t = 0; t < r.ntet; ++t) {
    const int32_t *v = r.tet + 4 * t;
    double cx = (r.xyz[3 * v[0]] + r.xyz[3 * v[1]] + r.xyz[3 * v[2]] + r.xyz[3 * v[3]]) / 4;
    assert_int_equal(r.tet_tag[t], cx < 1 ? 7 : 9);
  }
  /* Each shared triangle: one of its two tets on each side. */
  int shared = 0;
  for (int32_t k = 0; k < in.ntri; ++k) {
    if (s->tag[k] != 1) continue;
    ++shared;
    const int32_t *f = s->tri + 3 * k;
    int left = 0, right = 0;
    for (int32_t t = 0; t < r.ntet; ++t) {
      const int32_t *v = r.tet + 4 * t;
      int has = 0;
      for (int j = 0; j < 4; ++j) has += v[j] == f[0] || v[j] == f[1] || v[j] == f[2];
      if (has != 3) continue;
      int32_t apex = -1;
      for (int j = 0; j < 4; ++j)
        if (v[j] != f[0] && v[j] != f[1] && v[j] != f[2]) apex = v[j];
      if (r.xyz[3 * apex] < 1) ++left;
      else ++right;
    }
    assert_int_equal(left, 1);
    assert_int_equal(right, 1);
  }
  assert_int_equal(shared, 8);
  pm_tet_result_free(&r);

  /* One seed only: the other cube's tets have no region (-1). */
  in.nregion = 1;
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  for (int32_t t = 0; t < r.ntet; ++t) {
    const int32_t *v = r.tet + 4 * t;
    double cx = (r.xyz[3 * v[0]] + r.xyz[3 * v[1]] + r.xyz[3 * v[2]] + r.xyz[3 * v[3]]) / 4;
    assert_int_equal(r.tet_tag[t], cx < 1 ? 7 : -1);
  }
  pm_tet_result_free(&r);
  surf_free(s);
  free(s);
}

/* A dangling segment between two interior points stays one tet edge, with the given points and
 * with refinement. */
static void embedded_segment(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 2, 1);
  add_cube(s, 0, 0);
  int32_t nsurf = s->npts;
  int32_t a = add_point(s, 0.25, 0.3, 0.2);
  int32_t b = add_point(s, 0.7, 0.65, 0.8);
  add_point(s, 0.6, 0.3, 0.45); /* near the segment, to make it non-trivial */
  add_point(s, 0.4, 0.6, 0.5);
  int32_t seg[2] = {a, b};
  for (int mode = 0; mode < 2; ++mode) {
    pm_tet_input in = input_of(s, mode ? PM_TET_REFINE : PM_TET_GIVEN_POINTS);
    in.nsurf = nsurf;
    in.nseg = 1;
    in.seg = seg;
    in.radius_edge = 2.0;
    in.max_volume = 0.02;
    pm_tet_result r;
    pm_error e = {0};
    PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
    if (!mode) assert_int_equal(r.nsteiner, 0);
    check_mesh(&in, &r, 1.0, -1, 1);
    int around = 0;
    for (int32_t t = 0; t < r.ntet; ++t) {
      int has = 0;
      for (int j = 0; j < 4; ++j) has += r.tet[4 * t + j] == a || r.tet[4 * t + j] == b;
      if (has == 2) ++around;
    }
    assert_true(around >= 3); /* an interior edge has at least 3 tets around it */
    pm_tet_result_free(&r);
  }
  /* A segment piercing the surface (from inside to a point outside... here: through a wall to
   * another wall point) is an intersection. */
  int32_t out_pt = add_point(s, 1.5, 0.3, 0.3);
  int32_t bad[2] = {a, out_pt};
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  in.nseg = 1;
  in.seg = bad;
  pm_tet_result r;
  pm_error e = {0};
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_BACKEND);
  assert_non_null(strstr(e.msg, "self-intersect"));
  assert_non_null(strstr(e.msg, "segment 0"));
  surf_free(s);
  free(s);
}

/* Schoenhardt's twisted prism has no tetrahedralization without an extra point: refused in
 * GIVEN_POINTS mode, done with a Steiner point when refining. */
static void schoenhardt_needs_steiner(void **state) {
  (void)state;
  double xyz[18];
  for (int i = 0; i < 3; ++i) {
    double a = 2 * M_PI * i / 3, b = a + M_PI / 6;
    xyz[3 * i] = cos(a), xyz[3 * i + 1] = sin(a), xyz[3 * i + 2] = 0;
    xyz[9 + 3 * i] = cos(b), xyz[9 + 3 * i + 1] = sin(b), xyz[9 + 3 * i + 2] = 1;
  }
  /* Side quads split along the reflex diagonals a_i b_{i+1}. */
  int32_t tri[24] = {0, 2, 1, 3, 4, 5, 0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4, 2, 0, 3, 2, 3, 5};
  pm_tet_input in;
  memset(&in, 0, sizeof in);
  in.npts = 6, in.xyz = xyz, in.nsurf = 6, in.ntri = 8, in.tri = tri;
  in.mode = PM_TET_GIVEN_POINTS;
  pm_tet_result r;
  pm_error e = {0};
  watch w = watch_begin();
  pm_status st = pm_tet_tetrahedralize(&in, &r, &e);
  long printed = watch_end(w);
  assert_int_equal(st, PM_ERR_GEOM);
  assert_non_null(strstr(e.msg, "Steiner"));
  assert_int_equal(printed, 0);
  assert_null(r.xyz);

  /* The prism's volume: the twisted prism is the convex hull minus three reflex wedges; rather
   * than derive it, compare with the refined mesh's own volume from positive tets. */
  in.mode = PM_TET_REFINE;
  in.radius_edge = 2.0;
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  assert_true(r.nsteiner >= 1);
  double sum = 0;
  for (int32_t t = 0; t < r.ntet; ++t) sum += tet_volume(r.xyz, r.tet + 4 * t);
  check_mesh(&in, &r, sum, -1, 1);
  pm_tet_result_free(&r);
}

/* Two interpenetrating tetrahedra: refused as a self-intersection naming two triangles, with no
 * crash and nothing on stdout. */
static void self_intersecting(void **state) {
  (void)state;
  double xyz[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1,
                    0.3, 0.3, 0.3, 1.3, 0.3, 0.3, 0.3, 1.3, 0.3, 0.3, 0.3, 1.3};
  int32_t tri[24] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2, 4, 6, 5, 4, 5, 7, 5, 6, 7, 4, 7, 6};
  pm_tet_input in;
  memset(&in, 0, sizeof in);
  in.npts = 8, in.xyz = xyz, in.nsurf = 8, in.ntri = 8, in.tri = tri;
  for (int mode = 0; mode < 2; ++mode) {
    in.mode = mode ? PM_TET_REFINE : PM_TET_GIVEN_POINTS;
    in.radius_edge = 2.0;
    pm_tet_result r;
    pm_error e = {0};
    watch w = watch_begin();
    pm_status st = pm_tet_tetrahedralize(&in, &r, &e);
    long printed = watch_end(w);
    assert_int_equal(st, PM_ERR_BACKEND);
    assert_non_null(strstr(e.msg, "self-intersect"));
    assert_non_null(strstr(e.msg, "triangle"));
    assert_int_equal(printed, 0);
    assert_null(r.tet);
    assert_int_equal(r.npts, 0);
  }
  /* Touching counts too: a triangle of the second tetrahedron through a vertex of the first. */
  double touch[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1,
                      1, -1, -1, 1, 1, -1, 1, 0, 1, 2, 0, 0};
  in.xyz = touch;
  in.mode = PM_TET_GIVEN_POINTS;
  pm_tet_result r;
  pm_error e = {0};
  /* Second tetrahedron: its face in the plane x = 1 contains the first one's vertex (1, 0, 0)
   * in its interior; the two solids touch at that point only. */
  int32_t ttri[24] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2, 4, 6, 5, 4, 5, 7, 5, 6, 7, 4, 7, 6};
  in.tri = ttri;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_BACKEND);
  assert_non_null(strstr(e.msg, "self-intersect"));
}

static void bad_input(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 1, 1);
  add_cube(s, 0, 0);
  pm_tet_result r;
  pm_error e = {0};
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);

  in.ntri = 0;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "no surface triangles"));
  in.ntri = s->ntri;

  s->tri[7] = 8; /* one past the last point */
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "triangle 2"));
  s->tri[7] = -1;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  s->tri[7] = s->tri[6];
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "repeats"));
  surf_free(s);
  surf_init(s, 1, 1);
  add_cube(s, 0, 0);
  in = input_of(s, PM_TET_GIVEN_POINTS);

  int32_t seg[2] = {0, 9};
  in.nseg = 1, in.seg = seg;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "segment 0"));
  in.nseg = 0, in.seg = NULL;

  assert_int_equal(pm_tet_tetrahedralize(NULL, &r, &e), PM_ERR_ARG);
  assert_int_equal(pm_tet_tetrahedralize(&in, NULL, &e), PM_ERR_ARG);
  in.npts = 3;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  in.npts = s->npts;
  in.nsurf = in.npts + 1;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  in.nsurf = in.npts;
  in.mode = (pm_tet_mode)7;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  in.mode = PM_TET_REFINE;
  in.radius_edge = 1.0;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "radius_edge"));
  in.radius_edge = 2.0;
  in.max_volume = NAN;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  in.max_volume = 0;
  in.mode = PM_TET_GIVEN_POINTS;
  double seeds[4] = {0.5, 0.5, 0.5, 0.5};
  in.nregion = 1, in.region = seeds;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG); /* tag not an integer */
  in.nregion = 0, in.region = NULL;

  double keep = s->xyz[4];
  s->xyz[4] = NAN;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "point 1"));
  s->xyz[4] = keep;

  /* Geometry: a duplicated point, a point outside the volume, a flat triangle. */
  add_point(s, 1, 1, 1);
  in.npts = s->npts;
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_GEOM);
  assert_non_null(strstr(e.msg, "coincide"));
  s->xyz[3 * 8] = 2;
  watch w = watch_begin();
  pm_status st = pm_tet_tetrahedralize(&in, &r, &e);
  long printed = watch_end(w);
  assert_int_equal(st, PM_ERR_GEOM);
  assert_non_null(strstr(e.msg, "point 8"));
  assert_int_equal(printed, 0);
  s->xyz[3 * 8] = 0.5, s->xyz[3 * 8 + 1] = 0.5, s->xyz[3 * 8 + 2] = 0; /* on the bottom face */
  assert_int_equal(pm_tet_tetrahedralize(&in, &r, &e), PM_ERR_BACKEND);
  assert_non_null(strstr(e.msg, "point 8"));
  in.npts = 8;

  double flat[12] = {0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 0, 1};
  int32_t ftri[12] = {0, 1, 2, 0, 1, 3, 1, 2, 3, 0, 2, 3};
  pm_tet_input fin;
  memset(&fin, 0, sizeof fin);
  fin.npts = 4, fin.xyz = flat, fin.ntri = 4, fin.tri = ftri;
  assert_int_equal(pm_tet_tetrahedralize(&fin, &r, &e), PM_ERR_GEOM);
  assert_non_null(strstr(e.msg, "degenerate"));

  /* An open surface (the cube without its top): nothing is enclosed. */
  in = input_of(s, PM_TET_GIVEN_POINTS);
  in.npts = in.nsurf = 8;
  in.ntri = 0;
  int32_t open_tri[3 * 12];
  for (int32_t k = 0; k < s->ntri; ++k)
    if (s->tag[k] != 5) memcpy(open_tri + 3 * in.ntri++, s->tri + 3 * k, sizeof open_tri[0] * 3);
  in.tri = open_tri;
  in.tri_tag = NULL;
  w = watch_begin();
  st = pm_tet_tetrahedralize(&in, &r, &e);
  printed = watch_end(w);
  assert_int_equal(st, PM_ERR_GEOM);
  assert_non_null(strstr(e.msg, "closed"));
  assert_int_equal(printed, 0);
  assert_null(r.tet);
  surf_free(s);
  free(s);
  pm_tet_result_free(NULL);
}

/* A dangling internal face (a square at z = 0.5 inside the cube, as in papers/003 Fig. 11) and a
 * dangling edge from a boundary corner into the volume: both kept, the face's triangles shared by
 * two tets each, one region tag everywhere. */
static void dangling_face_and_edge(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 2, 1);
  add_cube(s, 0, 0);
  int32_t p0 = add_point(s, 0.25, 0.25, 0.5), p1 = add_point(s, 0.75, 0.3, 0.5);
  int32_t p2 = add_point(s, 0.7, 0.75, 0.5), p3 = add_point(s, 0.3, 0.7, 0.5);
  add_tri(s, p0, p1, p2, 42);
  add_tri(s, p0, p2, p3, 42);
  int32_t corner = 0; /* (0, 0, 0) */
  int32_t tip = add_point(s, 0.2, 0.15, 0.3);
  int32_t seg[2] = {corner, tip};
  double seed[4] = {0.5, 0.5, 0.2, 3};
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  in.nseg = 1, in.seg = seg;
  in.nregion = 1, in.region = seed;
  pm_tet_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  assert_int_equal(r.nsteiner, 0);
  check_mesh(&in, &r, 1.0, 42, 1);
  int around = 0;
  for (int32_t t = 0; t < r.ntet; ++t) {
    assert_int_equal(r.tet_tag[t], 3);
    int has = 0;
    for (int j = 0; j < 4; ++j) has += r.tet[4 * t + j] == corner || r.tet[4 * t + j] == tip;
    if (has == 2) ++around;
  }
  assert_true(around >= 1);
  pm_tet_result_free(&r);
  surf_free(s);
  free(s);
}

/* TetGen 1.5.0 crashes (segmentation fault) on a subnormal coordinate; the adapter runs it in a
 * child process, so the caller gets an error and goes on. */
static void tetgen_crash_contained(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 1, 1);
  add_cube(s, 0, 0);
  add_point(s, 1e-310, 0.5, 0.5);
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  pm_tet_result r;
  pm_error e = {0};
  watch w = watch_begin();
  pm_status st = pm_tet_tetrahedralize(&in, &r, &e);
  long printed = watch_end(w);
  assert_int_equal(printed, 0);
  if (st == PM_OK) { /* a TetGen that copes: then the result must be right */
    check_mesh(&in, &r, 1.0, -1, 1);
    pm_tet_result_free(&r);
  } else {
    assert_int_equal(st, PM_ERR_BACKEND);
    assert_non_null(strstr(e.msg, "TetGen crashed"));
    assert_null(r.tet);
  }
  /* The process is fine: the next call works. */
  s->npts = 8;
  add_point(s, 0.3, 0.5, 0.5);
  in = input_of(s, PM_TET_GIVEN_POINTS);
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  check_mesh(&in, &r, 1.0, -1, 1);
  pm_tet_result_free(&r);
  surf_free(s);
  free(s);
}

/* The same triangle given twice (as an internal face listed by both volumes) is used once. */
static void duplicate_triangles(void **state) {
  (void)state;
  surf *s = malloc(sizeof *s);
  surf_init(s, 1, 1);
  add_cube(s, 0, 0);
  add_tri(s, s->tri[2], s->tri[1], s->tri[0], 99);
  add_point(s, 0.5, 0.4, 0.6);
  pm_tet_input in = input_of(s, PM_TET_GIVEN_POINTS);
  pm_tet_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_tet_tetrahedralize(&in, &r, &e), e);
  assert_int_equal(r.nsteiner, 0);
  in.ntri = 12;
  check_mesh(&in, &r, 1.0, -1, 1);
  pm_tet_result_free(&r);
  surf_free(s);
  free(s);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(cube_given_points),
      cmocka_unit_test(cube_given_points_grid),
      cmocka_unit_test(cube_refine),
      cmocka_unit_test(two_cubes_regions),
      cmocka_unit_test(embedded_segment),
      cmocka_unit_test(schoenhardt_needs_steiner),
      cmocka_unit_test(self_intersecting),
      cmocka_unit_test(bad_input),
      cmocka_unit_test(dangling_face_and_edge),
      cmocka_unit_test(duplicate_triangles),
      cmocka_unit_test(tetgen_crash_contained),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
