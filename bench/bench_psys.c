/* Benchmark of the psys mesher (papers/001): every shared CAD model meshed with the default
 * parameters (the inferred sizing field), and the throughput of one iteration at 10^4 and 10^5
 * particles on a curved face.
 *
 *   bench_psys [models|throughput|all] [--threads N] [--volume] [--peers] [--only NAME] [CAD_DIR]
 *
 * models:     per model: nodes, iterations per phase, times, the mesh checker's verdict, and the
 *             triangle aspect ratio R / l_min as min / p25 / median / p75 / max (the statistic of
 *             papers/001 Fig. 11; an equilateral triangle has 0.577); with --volume the solids
 *             are also tetrahedralized (TetGen quality refinement) and their tets summarized the
 *             same way. The last column tells whether the target (median <= 0.60 and
 *             p75 <= 0.65) is met. With --peers, two more rows per model: gmsh's Frontal-Delaunay
 *             and the bubble mesher on psys's inferred field (psys_infer_size, the field
 *             `--size inferred` gives), surface only, summarized the same way: the same field,
 *             so a difference is a difference in node placement and connection.
 * throughput: case:sphere (radius 1) with a uniform size giving about 10^4 and 10^5 particles:
 *             phase-3 particle-iterations per second and seconds per iteration at the final
 *             count; equal rates at both sizes mean a cost linear in the particle count.
 *
 * Prints figures only; never a test.
 */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include "common/clock.h"
#include "common/input.h"
#include "common/mesh_check.h"
#include "common/quality.h"
#include "bubble/bubble.h"
#include "peers/peers.h"
#include "psys/psys.h"

static void machine_info(int argc, char **argv, int threads) {
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
  double load[3] = {0, 0, 0};
  f = fopen("/proc/loadavg", "r");
  if (f) {
    if (fscanf(f, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3) load[0] = -1;
    fclose(f);
  }
  printf("cores online: %ld, load average %.2f, threads %d, packmesh %s\n\n",
         sysconf(_SC_NPROCESSORS_ONLN), load[0], threads, pm_version());
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

static void print_summary(const char *what, const pm_summary *s) {
  /* four decimals: the target compares the median with 0.60 */
  printf(" %s %.3f/%.4f/%.4f/%.4f/%.3g", what, s->min, s->p25, s->median, s->p75, s->max);
}

static double stat_time(const pm_stats *st, const char *key) {
  for (int32_t k = 0; k < st->ntime; ++k)
    if (!strcmp(st->time[k].key, key)) return st->time[k].num;
  return 0;
}

static double stat_extra(const pm_stats *st, const char *key) {
  for (int32_t k = 0; k < st->nextra; ++k)
    if (!strcmp(st->extra[k].key, key)) return st->extra[k].num;
  return 0;
}

/* The checker's verdict and the quality measures of a mesh. */
static void measure(const pm_mesh *mesh, const pm_model *m, pm_check_report *cr, pm_quality *q) {
  pm_error e = {0};
  memset(cr, 0, sizeof *cr);
  memset(q, 0, sizeof *q);
  pm_mesh_check(mesh, m, cr, &e);
  pm_quality_compute(mesh, NULL, q, &e);
}

/* The target for triangles: median R / l_min <= 0.60 and p75 <= 0.65. */
static int target_met(const pm_quality *q) {
  return q->tri.s_aspect_ratio.median <= 0.60 && q->tri.s_aspect_ratio.p75 <= 0.65;
}

/* A peer method on psys's inferred field: one summary row. */
static void bench_peer(const pm_model *m, const pm_sizing *field, const pm_method *method,
                       int threads) {
  pm_error e = {0};
  void *params = calloc(1, method->params_size);
  if (!params) return;
  method->params_init(params);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.size = field, in.seed = 1, in.threads = threads;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  double t0 = pm_seconds();
  if (method->run(&in, params, &out, &e)) {
    printf("  %-20s FAILED: %s\n", method->name, e.msg);
  } else {
    pm_check_report cr;
    pm_quality q;
    measure(out.mesh, m, &cr, &q);
    printf("  %-20s nodes %7d  same field  time %7.1f s  %s ", method->name, out.mesh->nnode,
           pm_seconds() - t0, cr.valid ? "valid" : "INVALID");
    print_summary("tri", &q.tri.s_aspect_ratio);
    printf("  target %s\n", target_met(&q) ? "met" : "MISSED");
    pm_quality_clear(&q);
    pm_check_report_clear(&cr);
  }
  fflush(stdout);
  pm_mesh_destroy(out.mesh);
  free(params);
}

/* The peers on psys's inferred field (the one `--size inferred` hands to other methods). */
static void bench_peers_on_field(const pm_model *m, int threads) {
  pm_error e = {0};
  pm_sizing *field = NULL;
  if (psys_infer_size(m, NULL, 1, threads, &field, &e)) {
    printf("  peers: no inferred field: %s\n", e.msg);
    return;
  }
  bench_peer(m, field, &peer_gmsh_frontal, threads);
  bench_peer(m, field, &bub_method, threads);
  pm_sizing_destroy(field);
}

/* One model: mesh, check, measure, print one line. Returns 1 when the target is met. */
static int bench_model(const char *path, const char *name, int threads, int volume, int peers) {
  pm_error e = {0};
  pm_model *m = NULL;
  pm_stats st;
  pm_stats_init(&st);
  pm_run_output out;
  memset(&out, 0, sizeof out);
  int met = 0;
  double t0 = pm_seconds();
  if (pm_input_open(path, &m, NULL, &e)) {
    printf("%-22s FAILED to load: %s\n", name, e.msg);
    return 0;
  }
  psys_params p;
  psys_params_init(&p);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m;
  in.seed = 1;
  in.threads = threads;
  in.volume = volume && m->count[PM_VOLUME] > 0;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  out.stats = &st;
  if (psys_method.run(&in, &p, &out, &e)) {
    printf("%-22s FAILED after %.1f s: %s\n", name, pm_seconds() - t0, e.msg);
    fflush(stdout);
    pm_model_destroy(m);
    pm_stats_clear(&st);
    return 0;
  }
  double t_run = pm_seconds() - t0;
  pm_check_report cr;
  pm_quality q;
  measure(out.mesh, m, &cr, &q);
  printf("%-22s nodes %7d  it %4.0f/%4.0f/%4.0f  time %7.1f s (p1 %.1f p2 %.1f p3 %.1f conn %.1f)"
         "  %s ",
         name, out.mesh->nnode, stat_extra(&st, "psys.iterations.phase1"),
         stat_extra(&st, "psys.iterations.phase2"), stat_extra(&st, "psys.iterations.phase3"),
         t_run, stat_time(&st, "phase1"), stat_time(&st, "phase2"), stat_time(&st, "phase3"),
         stat_time(&st, "connect"), cr.valid ? "valid" : "INVALID");
  print_summary("tri", &q.tri.s_aspect_ratio);
  if (out.mesh->ntet) print_summary(" tet", &q.tet.s_aspect_ratio);
  met = target_met(&q);
  printf("  target %s\n", met ? "met" : "MISSED");
  if (!cr.valid)
    for (int32_t k = 0; k < cr.nproblem; ++k) printf("    problem: %s\n", cr.problem[k]);
  fflush(stdout);
  if (peers) bench_peers_on_field(m, threads);
  pm_quality_clear(&q);
  pm_check_report_clear(&cr);
  pm_mesh_destroy(out.mesh);
  pm_stats_clear(&st);
  pm_model_destroy(m);
  return met;
}

static void models(const char *dir, int threads, int volume, int peers, const char *only) {
  DIR *d = opendir(dir);
  if (!d) {
    printf("no CAD folder %s: models skipped\n\n", dir);
    return;
  }
  char *names[256];
  int n = 0;
  struct dirent *ent;
  while ((ent = readdir(d)) && n < 256)
    if (is_cad_file(ent->d_name)) names[n++] = strdup(ent->d_name);
  closedir(d);
  qsort(names, (size_t)n, sizeof(char *), cmp_str);
  printf("models (default parameters, inferred field, seed 1%s): nodes, iterations of phases 1/2/3,"
         " wall time, checker, R/l_min min/p25/median/p75/max\n",
         volume ? ", solids with tets" : "");
  int met = 0, tried = 0;
  for (int i = 0; i < n; ++i) {
    if (only && !strstr(names[i], only)) {
      free(names[i]);
      continue;
    }
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, names[i]);
    met += bench_model(path, names[i], threads, volume, peers);
    ++tried;
    free(names[i]);
  }
  printf("target (median <= 0.60, p75 <= 0.65) met on %d of %d models\n\n", met, tried);
}

/* Throughput on case:sphere with a uniform size d: phase-3 particle-iterations per second. */
static void throughput_one(double d, int threads) {
  pm_error e = {0};
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  pm_trace *tr = NULL;
  if (pm_input_open("case:sphere", &m, NULL, &e) || pm_sizing_constant(d, &size, &e) ||
      pm_trace_create(&tr, &e)) {
    printf("throughput: %s\n", e.msg);
    goto out;
  }
  psys_params p;
  psys_params_init(&p);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.size = size, in.seed = 1, in.threads = threads;
  in.max_nodes = PM_DEFAULT_MAX_NODES, in.trace = tr;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  pm_stats st;
  pm_stats_init(&st);
  out.stats = &st;
  if (psys_method.run(&in, &p, &out, &e)) {
    printf("throughput: %s\n", e.msg);
    pm_stats_clear(&st);
    goto out;
  }
  /* particle-iterations of phase 3 from the trace (columns: iteration, phase, particles, ...) */
  double pit = 0, last_n = 0;
  int64_t its = 0;
  for (int64_t r = 0; r < pm_trace_nrow(tr); ++r) {
    const double *row = pm_trace_row(tr, r);
    if (row[1] != 3) continue;
    pit += row[2], last_n = row[2], ++its;
  }
  double t3 = stat_time(&st, "phase3");
  printf("d = %-8g particles %8.0f  phase-3 iterations %4lld  time %7.2f s  "
         "%9.0f particle-iterations/s  %.3f s per iteration at the final count\n",
         d, last_n, (long long)its, t3, pit / t3, t3 / (double)its * last_n / (pit / (double)its));
  pm_mesh_destroy(out.mesh);
  pm_stats_clear(&st);
out:
  pm_trace_destroy(tr);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

static void throughput(int threads) {
  printf("throughput: case:sphere (radius 1), uniform size, phase 3 (face particles, curve and "
         "pole particles fixed)\n");
  /* A hexagonal packing of edge d on the unit sphere holds about 4 pi / (sqrt(3)/2 d^2) nodes. */
  throughput_one(0.038, threads);
  throughput_one(0.012, threads);
  printf("\n");
}

int main(int argc, char **argv) {
  const char *mode = "all", *dir = PM_CAD_DIR, *only = NULL;
  int threads = 1, volume = 0, peers = 0;
  for (int i = 1; i < argc; ++i) {
    if (!strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--volume"))
      volume = 1;
    else if (!strcmp(argv[i], "--peers"))
      peers = 1;
    else if (!strcmp(argv[i], "--only") && i + 1 < argc)
      only = argv[++i];
    else if (!strcmp(argv[i], "models") || !strcmp(argv[i], "throughput") ||
             !strcmp(argv[i], "all"))
      mode = argv[i];
    else if (argv[i][0] != '-')
      dir = argv[i];
    else {
      fprintf(stderr, "usage: bench_psys [models|throughput|all] [--threads N] [--volume] "
                      "[--peers] [--only NAME] [CAD_DIR]\n");
      return 2;
    }
  }
  if (threads < 1) threads = 1;
  machine_info(argc, argv, threads);
  if (!strcmp(mode, "throughput") || !strcmp(mode, "all")) throughput(threads);
  if (!strcmp(mode, "models") || !strcmp(mode, "all")) models(dir, threads, volume, peers, only);
  return 0;
}
