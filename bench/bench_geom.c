/* Benchmark of the CAD geometry backend (geom_cad): the load time of every shared model, and
 * the cost of one evaluation of a plane, a quadric and a B-spline face (order 0, 1, 2) through
 * gmsh directly (one point per call and batched) and through pm_face_eval (closed forms where
 * fitted), plus the inside test and projection.
 *
 *   bench_geom [CAD_DIR]      (default: the build's PM_CAD_DIR)
 *
 * Prints figures only; never a test.
 */
#include <gmshc.h>

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include "common/geom/geom.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/base/rng.h"

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void machine_info(int argc, char **argv) {
  printf("command:");
  for (int i = 0; i < argc; ++i) printf(" %s", argv[i]);
  printf("\n");
  struct utsname u;
  if (uname(&u) == 0) printf("system: %s %s %s\n", u.sysname, u.release, u.machine);
  FILE *f = fopen("/proc/cpuinfo", "r");
  if (f) {
    char line[256];
    while (fgets(line, sizeof line, f))
      if (!strncmp(line, "model name", 10)) {
        char *c = strchr(line, ':');
        printf("cpu:%s", c ? c + 1 : line);
        break;
      }
    fclose(f);
  }
  printf("cores online: %ld\n", sysconf(_SC_NPROCESSORS_ONLN));
  char *ver = NULL;
  int ierr = 0;
  pm_gmsh_lock();
  gmshOptionGetString("General.Version", &ver, &ierr);
  pm_gmsh_unlock();
  printf("gmsh: %s, packmesh %s, single thread\n\n", ver ? ver : "?", pm_version());
  if (ver) gmshFree(ver);
}

static int is_cad_file(const char *name) {
  const char *dot = strrchr(name, '.');
  return dot &&
         (!strcasecmp(dot, ".step") || !strcasecmp(dot, ".stp") || !strcasecmp(dot, ".iges") ||
          !strcasecmp(dot, ".igs") || !strcasecmp(dot, ".brep"));
}

static int cmp_str(const void *a, const void *b) {
  return strcmp(*(char *const *)a, *(char *const *)b);
}

static void load_table(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) {
    printf("no CAD folder %s: load times skipped\n\n", dir);
    return;
  }
  char *names[256];
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d)) && n < 256)
    if (is_cad_file(e->d_name)) names[n++] = strdup(e->d_name);
  closedir(d);
  qsort(names, (size_t)n, sizeof(char *), cmp_str);
  printf(
      "load times (pm_cad_load: gmsh import + cell complex + fits + loops + finish; best of 3)\n");
  printf("%-24s %9s  %-20s %11s %13s\n", "model", "load [s]", "V/E/F/R", "fast faces",
         "fast curves");
  double total = 0;
  for (int i = 0; i < n; ++i) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, names[i]);
    double best = 1e30;
    pm_model *m = NULL;
    for (int rep = 0; rep < 3; ++rep) {
      pm_error err = {0};
      pm_model_destroy(m);
      m = NULL;
      double t0 = now_s();
      pm_status s = pm_cad_load(path, &m, &err);
      double t = now_s() - t0;
      if (s) {
        printf("%-24s FAILED: %s\n", names[i], err.msg);
        break;
      }
      if (t < best) best = t;
    }
    if (m) {
      int ff = 0, fc = 0;
      for (int32_t k = 0; k < m->count[PM_FACE]; ++k)
        ff += pm_cad_cell_is_fast(pm_model_cell(m, PM_FACE, k)) == 1;
      for (int32_t k = 0; k < m->count[PM_CURVE]; ++k)
        fc += pm_cad_cell_is_fast(pm_model_cell(m, PM_CURVE, k)) == 1;
      char counts[64];
      snprintf(counts, sizeof counts, "%d/%d/%d/%d", m->count[0], m->count[1], m->count[2],
               m->count[3]);
      printf("%-24s %9.4f  %-20s %5d/%-5d %6d/%-6d\n", names[i], best, counts, ff, m->count[2], fc,
             m->count[1]);
      total += best;
      pm_model_destroy(m);
    }
    free(names[i]);
  }
  printf("%-24s %9.3f\n\n", "total", total);
}

/* ---- evaluation costs --------------------------------------------------------------------- */

enum { NPTS = 4096, BATCH = 256 };

/* out = ns per point of `reps` passes of `body` over `npts` points. */
#define TIME_NS(out, reps, npts, ...)                                \
  do {                                                               \
    double t0_ = now_s();                                            \
    for (int r_ = 0; r_ < (reps); ++r_) {                            \
      __VA_ARGS__;                                                   \
    }                                                                \
    out = 1e9 * (now_s() - t0_) / ((double)(reps) * (double)(npts)); \
  } while (0)

static volatile double sink;

static void gmsh_eval(int tag, const double *uv, size_t n, int order) {
  double *x = NULL;
  size_t nx = 0;
  int ierr = 0;
  gmshModelGetValue(2, tag, (double *)uv, 2 * n, &x, &nx, &ierr);
  sink += x[0];
  gmshFree(x);
  if (order >= 1) {
    gmshModelGetDerivative(2, tag, (double *)uv, 2 * n, &x, &nx, &ierr);
    sink += x[0];
    gmshFree(x);
  }
  if (order >= 2) {
    gmshModelGetSecondDerivative(2, tag, (double *)uv, 2 * n, &x, &nx, &ierr);
    sink += x[0];
    gmshFree(x);
  }
}

static void bench_face(const char *label, const pm_model *m, const pm_cell *f) {
  static double uv[2 * NPTS];
  static pm_face_point out[NPTS];
  pm_rng rng;
  pm_rng_init(&rng, 1, (uint64_t)f->tag);
  int nin = 0;
  for (int i = 0; i < NPTS; ++i) {
    uv[2 * i] = pm_rng_range(&rng, f->lo[0], f->hi[0]);
    uv[2 * i + 1] = pm_rng_range(&rng, f->lo[1], f->hi[1]);
  }
  printf("%s: %s face %d of %s (%s)\n", label, f->cls->name, f->tag, m->name,
         pm_cad_cell_is_fast(f) == 1 ? "closed form fitted" : "evaluated by gmsh");
  printf("  %-44s %10s %10s %10s\n", "ns per point", "order 0", "order 1", "order 2");
  double t[3];
  /* gmsh directly, our model current for the whole run (no guard). */
  pm_gmsh_scope sc;
  pm_error e = {0};
  pm_gmsh_lock();
  pm_gmsh_scope_enter(&sc, pm_cad_gmsh_model(m), 0, &e);
  for (int o = 0; o < 3; ++o)
    TIME_NS(t[o], 6, NPTS, for (int i = 0; i < NPTS; ++i) gmsh_eval(f->tag, uv + 2 * i, 1, o));
  printf("  %-44s %10.1f %10.1f %10.1f\n", "gmsh, one point per call", t[0], t[1], t[2]);
  for (int o = 0; o < 3; ++o)
    TIME_NS(t[o], 8, NPTS,
            for (int i = 0; i < NPTS; i += BATCH) gmsh_eval(f->tag, uv + 2 * i, BATCH, o));
  printf("  %-44s %10.1f %10.1f %10.1f\n", "gmsh, batches of 256", t[0], t[1], t[2]);
  pm_gmsh_scope_leave(&sc, 0);
  pm_gmsh_unlock();
  int reps = pm_cad_cell_is_fast(f) == 1 ? 200 : 6;
  for (int o = 0; o < 3; ++o)
    TIME_NS(t[o], reps, NPTS,
            for (int i = 0; i < NPTS; ++i) pm_face_eval(f, uv + 2 * i, o, out + i));
  printf("  %-44s %10.1f %10.1f %10.1f\n", "pm_face_eval (backend, lock + model check)", t[0], t[1],
         t[2]);
  for (int o = 0; o < 3; ++o) TIME_NS(t[o], reps * 4, NPTS, pm_face_eval_many(f, NPTS, uv, o, out));
  printf("  %-44s %10.1f %10.1f %10.1f\n", "pm_face_eval_many (4096 points)", t[0], t[1], t[2]);
  double ti;
  TIME_NS(ti, 50, NPTS, for (int i = 0; i < NPTS; ++i) nin += pm_face_inside(f, uv + 2 * i));
  sink += nin;
  /* gmshModelIsInside for comparison (slow: a sample of 256 points). */
  pm_gmsh_lock();
  pm_gmsh_scope_enter(&sc, pm_cad_gmsh_model(m), 0, &e);
  int ierr = 0;
  double tg;
  TIME_NS(tg, 1, 256,
          for (int i = 0; i < 256; ++i) nin += gmshModelIsInside(2, f->tag, uv + 2 * i, 2, &ierr));
  pm_gmsh_scope_leave(&sc, 0);
  pm_gmsh_unlock();
  printf("  %-44s %10.1f   (gmshModelIsInside: %.0f)\n", "pm_face_inside", ti, tg);
  /* Projection of surface points: without a guess, and with the exact parameters as the guess
   * (the particle case). */
  enum { NPROJ = 200 };
  static double xyz[3 * NPROJ];
  for (int i = 0; i < NPROJ; ++i) {
    pm_face_point p;
    pm_face_eval(f, uv + 2 * i, 1, &p);
    double n[3] = {p.su[1] * p.sv[2] - p.su[2] * p.sv[1], p.su[2] * p.sv[0] - p.su[0] * p.sv[2],
                   p.su[0] * p.sv[1] - p.su[1] * p.sv[0]};
    double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; ++k)
      xyz[3 * i + k] = p.p[k] + (ln > 0 ? 1e-3 * m->diagonal * n[k] / ln : 0);
  }
  double par[2];
  int preps = pm_cad_cell_is_fast(f) == 1 ? 20 : 4;
  double tp;
  TIME_NS(tp, preps, NPROJ,
          for (int i = 0; i < NPROJ; ++i)
              pm_cell_project(f, xyz + 3 * i, NULL, par, NULL, NULL, NULL));
  double tq;
  TIME_NS(tq, preps, NPROJ,
          for (int i = 0; i < NPROJ; ++i)
              pm_cell_project(f, xyz + 3 * i, uv + 2 * i, par, NULL, NULL, NULL));
  pm_gmsh_lock();
  pm_gmsh_scope_enter(&sc, pm_cad_gmsh_model(m), 0, &e);
  double tr;
  TIME_NS(
      tr, 1, NPROJ, for (int i = 0; i < NPROJ; ++i) {
        double *r = NULL;
        size_t nr = 0;
        gmshModelGetParametrization(2, f->tag, xyz + 3 * i, 3, &r, &nr, &ierr);
        if (r) gmshFree(r);
      });
  pm_gmsh_scope_leave(&sc, 0);
  pm_gmsh_unlock();
  printf("  %-44s %10.1f   (with a guess: %.1f; gmshModelGetParametrization: %.1f)\n\n",
         "pm_cell_project, point 1e-3 x diag off", tp, tq, tr);
}

static void bench_curve(const char *label, const pm_model *m, const pm_cell *c) {
  static double t[NPTS];
  pm_rng rng;
  pm_rng_init(&rng, 2, (uint64_t)c->tag);
  for (int i = 0; i < NPTS; ++i) t[i] = pm_rng_range(&rng, c->lo[0], c->hi[0]);
  pm_curve_point p;
  int reps = pm_cad_cell_is_fast(c) == 1 ? 200 : 2;
  double o[3];
  for (int k = 0; k < 3; ++k)
    TIME_NS(o[k], reps, NPTS, for (int i = 0; i < NPTS; ++i) pm_curve_eval(c, t[i], k, &p));
  printf("%s: %s curve %d of %s (%s): pm_curve_eval %.1f / %.1f / %.1f ns (order 0 / 1 / 2)\n",
         label, c->cls->name, c->tag, m->name, pm_cad_cell_is_fast(c) == 1 ? "closed form" : "gmsh",
         o[0], o[1], o[2]);
  sink += p.p[0];
}

static const pm_cell *by_tag(const pm_model *m, int dim, int tag) {
  for (int32_t i = 0; i < m->count[dim]; ++i)
    if (m->cells[dim][i].tag == tag) return &m->cells[dim][i];
  return NULL;
}

int main(int argc, char **argv) {
  const char *dir = argc > 1 ? argv[1] : PM_CAD_DIR;
  pm_error e = {0};
  if (pm_gmsh_begin(&e)) {
    fprintf(stderr, "bench_geom: %s\n", e.msg);
    return 1;
  }
  machine_info(argc, argv);
  load_table(dir);

  /* The three faces: a plane with a hole, a torus, a B-spline (all from the shared models). */
  struct {
    const char *label, *file;
    int tag;
  } faces[] = {{"plane", "synth_box_hole.brep", 3},
               {"quadric", "synth_torus.brep", 1},
               {"quadric", "synth_box_hole.brep", 7},
               {"B-spline", "t20_component8.step", 2},
               {"B-spline", "fusee.stp", 40}};
  printf("evaluation costs\n");
  for (size_t i = 0; i < sizeof faces / sizeof faces[0]; ++i) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, faces[i].file);
    pm_model *m = NULL;
    if (pm_cad_load(path, &m, &e)) {
      printf("%s: %s\n", faces[i].label, e.msg);
      continue;
    }
    const pm_cell *f = by_tag(m, PM_FACE, faces[i].tag);
    if (f) bench_face(faces[i].label, m, f);
    pm_model_destroy(m);
  }
  struct {
    const char *label, *file;
    int tag;
  } curves[] = {{"line", "synth_box_hole.brep", 1},
                {"circle", "synth_box_hole.brep", 10},
                {"B-spline", "t20_component8.step", 7}};
  for (size_t i = 0; i < sizeof curves / sizeof curves[0]; ++i) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, curves[i].file);
    pm_model *m = NULL;
    if (pm_cad_load(path, &m, &e)) continue;
    const pm_cell *c = by_tag(m, PM_CURVE, curves[i].tag);
    if (c) bench_curve(curves[i].label, m, c);
    pm_model_destroy(m);
  }
  pm_gmsh_shutdown();
  return 0;
}
