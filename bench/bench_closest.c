/* Benchmark of the Embree checks: BVH build time and closest-point queries per second
 * (closest_embree.c), and the self-intersection check (self_intersect.c), on closed UV spheres of
 * 10^4 .. 10^6 triangles. Also compares the build with Embree's own thread pool (default device,
 * build_tbb) against the single-thread device that pm_bvh uses (build_1th, Embree's default build
 * quality; build_s is pm_bvh's own, at the low quality), and times the two-sided distance
 * (distance.c) of the same spheres against the built-in case "sphere".
 *
 * Usage: bench_closest [max_triangles]   (default 1000000)
 * Figures go to stdout; nothing is asserted (the tests check correctness). */
#include <embree3/rtcore.h>

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "common/backends/closest_embree.h"
#include "common/measure/distance.h"
#include "common/geom/geom_cad.h"
#include "common/input/cases.h"
#include "common/mesh/mesh.h"
#include "common/base/rng.h"
#include "common/mesh/self_intersect.h"

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* A UV sphere of radius 1: nv - 1 rings of nu nodes and two poles; 2 nu (nv - 1) triangles. */
static void uv_sphere(int nu, int nv, double **xyz, int32_t *nnode, int32_t **tri, int32_t *ntri) {
  *nnode = nu * (nv - 1) + 2;
  *ntri = 2 * nu * (nv - 1);
  *xyz = malloc(sizeof(double) * 3 * (size_t)*nnode);
  *tri = malloc(sizeof(int32_t) * 3 * (size_t)*ntri);
  const double pi = 3.14159265358979323846;
  for (int j = 1; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      double th = pi * j / nv, ph = 2 * pi * i / nu;
      double *p = &(*xyz)[3 * ((j - 1) * nu + i)];
      p[0] = sin(th) * cos(ph), p[1] = sin(th) * sin(ph), p[2] = cos(th);
    }
  int32_t north = nu * (nv - 1), south = north + 1;
  double *pn = &(*xyz)[3 * north], *ps = &(*xyz)[3 * south];
  pn[0] = pn[1] = 0, pn[2] = 1, ps[0] = ps[1] = 0, ps[2] = -1;
  int32_t k = 0;
  for (int i = 0; i < nu; ++i) {
    int32_t *t = &(*tri)[3 * k++];
    t[0] = north, t[1] = i, t[2] = (i + 1) % nu;
  }
  for (int j = 1; j < nv - 1; ++j)
    for (int i = 0; i < nu; ++i) {
      int32_t a = (j - 1) * nu + i, b = (j - 1) * nu + (i + 1) % nu, c = j * nu + i, d = j * nu + (i + 1) % nu;
      int32_t *t = &(*tri)[3 * k];
      t[0] = a, t[1] = c, t[2] = d, t[3] = a, t[4] = d, t[5] = b;
      k += 2;
    }
  for (int i = 0; i < nu; ++i) {
    int32_t *t = &(*tri)[3 * k++];
    t[0] = south, t[1] = (nv - 2) * nu + (i + 1) % nu, t[2] = (nv - 2) * nu + i;
  }
}

/* Raw Embree build of the same user primitives with a given device configuration (for the
 * thread-pool comparison only). */
typedef struct raw {
  const double *xyz;
  const int32_t *tri;
} raw;

static void raw_bounds(const struct RTCBoundsFunctionArguments *a) {
  const raw *r = a->geometryUserPtr;
  const int32_t *v = &r->tri[3 * (size_t)a->primID];
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int q = 0; q < 3; ++q)
    for (int k = 0; k < 3; ++k) {
      float x = (float)r->xyz[3 * (size_t)v[q] + k];
      lo[k] = fminf(lo[k], x), hi[k] = fmaxf(hi[k], x);
    }
  a->bounds_o->lower_x = lo[0], a->bounds_o->lower_y = lo[1], a->bounds_o->lower_z = lo[2];
  a->bounds_o->upper_x = hi[0], a->bounds_o->upper_y = hi[1], a->bounds_o->upper_z = hi[2];
}

static double raw_build(const char *config, const double *xyz, const int32_t *tri, int32_t ntri) {
  raw r = {xyz, tri};
  double t0 = now();
  RTCDevice d = rtcNewDevice(config);
  RTCScene s = rtcNewScene(d);
  RTCGeometry g = rtcNewGeometry(d, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(g, (unsigned)ntri);
  rtcSetGeometryUserData(g, &r);
  rtcSetGeometryBoundsFunction(g, raw_bounds, &r);
  rtcCommitGeometry(g);
  rtcAttachGeometry(s, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(s);
  double t = now() - t0;
  rtcReleaseScene(s);
  rtcReleaseDevice(d);
  return t;
}

int main(int argc, char **argv) {
  long maxtri = argc > 1 ? atol(argv[1]) : 1000000;
  int nthreads = omp_get_max_threads();
  printf("# bench_closest: UV spheres, %d OpenMP threads available\n", nthreads);
  printf("# %9s %9s %9s %9s %12s %12s %12s %9s %11s\n", "ntri", "build_s", "build_tbb",
         "build_1th", "q/s_near_1t", "q/s_near_mt", "q/s_far_1t", "selfint_s", "candidates");
  for (long target = 10000; target <= maxtri; target *= 10) {
    /* nu = 2 nv gives near-square cells; 2 nu (nv - 1) ~ target. */
    int nv = (int)ceil(sqrt((double)target / 4.0)), nu = 2 * nv;
    double *xyz;
    int32_t *tri, nnode, ntri;
    uv_sphere(nu, nv, &xyz, &nnode, &tri, &ntri);
    pm_error e = {0};
    pm_bvh *bvh = NULL;
    double t0 = now();
    if (pm_bvh_create(xyz, nnode, tri, ntri, &bvh, &e)) {
      fprintf(stderr, "bench_closest: %s\n", e.msg);
      return 1;
    }
    double t_build = now() - t0;
    double t_tbb = raw_build(NULL, xyz, tri, ntri);
    double t_1th = raw_build("threads=1", xyz, tri, ntri);

    /* Query points: near the surface (radius in [0.95, 1.05]) and far outside (radius in
     * [1.5, 3]). Points near the centre are the worst case of any closest-point search on a
     * sphere (every triangle is nearly as close as the closest) and are left out. */
    enum { NQ = 200000 };
    double *near = malloc(sizeof(double) * 3 * NQ), *far = malloc(sizeof(double) * 3 * NQ);
    pm_rng r;
    pm_rng_init(&r, 42, (uint64_t)target);
    for (int i = 0; i < NQ; ++i) {
      double d[3], n2 = 0;
      for (int k = 0; k < 3; ++k) d[k] = pm_rng_range(&r, -1, 1), n2 += d[k] * d[k];
      double s = pm_rng_range(&r, 0.95, 1.05) / sqrt(n2 > 0 ? n2 : 1);
      double sf = pm_rng_range(&r, 1.5, 3.0) / sqrt(n2 > 0 ? n2 : 1);
      for (int k = 0; k < 3; ++k) near[3 * i + k] = d[k] * s, far[3 * i + k] = d[k] * sf;
    }
    double sum = 0;
    t0 = now();
    for (int i = 0; i < NQ; ++i) {
      pm_bvh_hit h;
      pm_bvh_closest(bvh, &near[3 * i], INFINITY, &h);
      sum += h.dist;
    }
    double q_near1 = NQ / (now() - t0);
    t0 = now();
#pragma omp parallel for reduction(+ : sum) schedule(dynamic, 256)
    for (int i = 0; i < NQ; ++i) {
      pm_bvh_hit h;
      pm_bvh_closest(bvh, &near[3 * i], INFINITY, &h);
      sum += h.dist;
    }
    double q_nearm = NQ / (now() - t0);
    t0 = now();
    for (int i = 0; i < NQ; ++i) {
      pm_bvh_hit h;
      pm_bvh_closest(bvh, &far[3 * i], INFINITY, &h);
      sum += h.dist;
    }
    double q_far1 = NQ / (now() - t0);
    pm_bvh_destroy(bvh);

    pm_selfint_report rep;
    t0 = now();
    if (pm_triangles_self_intersections(xyz, nnode, tri, ntri, 10, &rep, &e)) {
      fprintf(stderr, "bench_closest: %s\n", e.msg);
      return 1;
    }
    double t_si = now() - t0;
    printf("  %9d %9.4f %9.4f %9.4f %12.0f %12.0f %12.0f %9.4f %11lld%s\n", (int)ntri, t_build,
           t_tbb, t_1th, q_near1, q_nearm, q_far1, t_si, (long long)rep.ncandidates,
           rep.count ? "  (intersections found!)" : "");
    pm_selfint_report_free(&rep);
    free(near), free(far), free(xyz), free(tri);
    if (sum < 0) printf("%g\n", sum); /* keep the loops */
  }
  /* The two-sided distance to the exact sphere, with default parameters. Loading a CAD case
   * initializes gmsh, which resets the OpenMP thread count of this thread to 1: restore it. */
  pm_model *m = NULL;
  pm_error e = {0};
  if (pm_case_open("sphere", &m, NULL, &e)) {
    fprintf(stderr, "bench_closest: %s\n", e.msg);
    return 1;
  }
  omp_set_num_threads(nthreads);
  printf("# %9s %9s %12s %12s %12s %12s %12s %9s %9s\n", "ntri", "dist_s", "unpruned_s",
         "unsplit_s", "max", "mesh->model", "model->mesh", "nmesh", "nmodel");
  for (long target = 10000; target <= maxtri && target <= 100000; target *= 10) {
    int nv = (int)ceil(sqrt((double)target / 4.0)), nu = 2 * nv;
    double *xyz;
    int32_t *tri, nnode, ntri;
    uv_sphere(nu, nv, &xyz, &nnode, &tri, &ntri);
    pm_mesh *me = pm_mesh_create();
    if (!me || pm_mesh_reserve(me, nnode, 0, ntri, 0, &e)) return 1;
    for (int32_t i = 0; i < nnode; ++i) pm_mesh_add_node(me, &xyz[3 * i], -1, -1, NULL, NULL, &e);
    for (int32_t t = 0; t < ntri; ++t) pm_mesh_add_tri(me, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2], -1, &e);
    pm_distance d, d0;
    pm_distance_params dp;
    pm_distance_params_init(&dp);
    double t0 = now();
    if (pm_mesh_distance(me, m, NULL, &dp, &d, &e)) {
      fprintf(stderr, "bench_closest: %s\n", e.msg);
      return 1;
    }
    double t_pruned = now() - t0;
    /* The previous code path: every search done (distance.h: prune = 0), same figures. */
    dp.prune = 0;
    t0 = now();
    if (pm_mesh_distance(me, m, NULL, &dp, &d0, &e)) {
      fprintf(stderr, "bench_closest: %s\n", e.msg);
      return 1;
    }
    double t_full = now() - t0;
    /* The previous reference: every point through the constrained triangulation (distance.h:
     * ref_split = 0); the figures agree to rounding, the reference only starts projections. */
    pm_distance d1;
    dp.prune = 1, dp.ref_split = 0;
    t0 = now();
    if (pm_mesh_distance(me, m, NULL, &dp, &d1, &e)) {
      fprintf(stderr, "bench_closest: %s\n", e.msg);
      return 1;
    }
    double t_unsplit = now() - t0;
    const int same = d.mean == d0.mean && d.max == d0.max && fabs(d.mean - d1.mean) <= 1e-9 * d.mean &&
                     fabs(d.max - d1.max) <= 1e-9 * d.max;
    printf("  %9d %9.3f %12.3f %12.3f %12.5g %12.5g %12.5g %9lld %9lld%s\n", (int)ntri, t_pruned,
           t_full, t_unsplit, d.max, d.mesh_to_model_max, d.model_to_mesh_max,
           (long long)d.nsamples_mesh, (long long)d.nsamples_model, same ? "" : "  (figures differ!)");
    pm_mesh_destroy(me);
    free(xyz), free(tri);
  }
  pm_model_destroy(m);
  printf("# build_s: pm_bvh_create (copy + checks + single-thread Embree build, low quality);\n"
         "# build_tbb / build_1th: Embree's build at its default quality with the default device\n"
         "# (TBB pool) / threads=1;\n"
         "# q/s: pm_bvh_closest per second, 1 thread or all OpenMP threads; near: points within 5%% of\n"
         "# the surface, far: at radius 1.5 .. 3; selfint_s: pm_triangles_self_intersections;\n"
         "# dist_s: pm_mesh_distance against case:sphere (default parameters, unclassified mesh);\n"
         "# unpruned_s: the same with prune = 0 (every search done: the previous code path);\n"
         "# unsplit_s: the same with ref_split = 0 (the whole reference grid through the\n"
         "# constrained triangulation: the previous code path).\n");
  return 0;
}
