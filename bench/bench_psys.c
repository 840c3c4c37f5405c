/* Benchmark of the psys mesher (papers/001): every shared CAD model meshed with the default
 * parameters (the inferred sizing field), and the throughput of one iteration at 10^4 and 10^5
 * particles on a curved face.
 *
 *   bench_psys [models|throughput|all] [--threads N] [--volume] [--peers] [--bubble]
 *              [--only A,B] [--skip A,B] [--tp-model FILE] [CAD_DIR]
 *
 * models:     per model: nodes, iterations per phase, times (per step of an iteration too),
 *             peak resident memory per particle, the mesh checker's verdict, and the triangle
 *             aspect ratio R / l_min as min / p25 / median / p75 / max (the statistic of
 *             papers/001 Fig. 11; an equilateral triangle has 0.577), overall and by site
 *             (tri.by_site: boundary, irregular, regular); with --volume the solids are also
 *             tetrahedralized (TetGen quality refinement) and their tets summarized the same
 *             way. The last column tells whether the target (median <= 0.60 and p75 <= 0.65) is
 *             met. With --peers, gmsh's Frontal-Delaunay on psys's inferred field (the field of
 *             the same psys run, psys_run_with_field) scaled to psys's node count, surface only,
 *             its time beside psys's and its median beside psys's; --bubble adds the bubble
 *             mesher on the same field. --only and --skip take comma-separated parts of file
 *             names. A table at the end repeats one line per model.
 * throughput: case:sphere (radius 1) with a uniform size giving about 10^4 and 10^5 particles,
 *             then table.brep with a uniform size (10^5 particles) and wrench.stp with the
 *             inferred field, each at 1 thread and at --threads (at least 2), with the ratio of
 *             the two rates: phase-3
 *             particle-iterations per second, seconds per iteration at the final count, the end
 *             to end rate, CPU seconds beside wall seconds (the machine may be shared), time per
 *             step and peak RSS per particle; equal rates at both sphere sizes mean a cost
 *             linear in the particle count.
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

#include "common/report/run_report.h"
#include "common/base/clock.h"
#include "common/input/input.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"
#include "bubble/bubble.h"
#include "peers/peers.h"
#include "psys/psys.h"

/* The CAD models of `throughput`: table.brep (planes and cylinders, evaluated in closed form)
 * with a uniform size of 0.5, about 10^5 particles, the figure of the throughput target at 1 and
 * 2 threads; and wrench.stp (B-spline faces evaluated by gmsh) with the inferred field, the
 * default use (--tp-model overrides it). */
#define TP_UNIFORM_MODEL "table.brep"
#define TP_UNIFORM_SIZE 0.5
#define TP_MODEL "wrench.stp"

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

/* CPU seconds of the process, all threads: beside the wall time, on a machine shared with other
 * work, the rate per CPU second says what one core does, and CPU over wall how many cores the
 * run had. */
static double cpu_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double load_average(void) {
  double load = -1;
  FILE *f = fopen("/proc/loadavg", "r");
  if (f) {
    if (fscanf(f, "%lf", &load) != 1) load = -1;
    fclose(f);
  }
  return load;
}

/* Peak resident memory. The kernel's high-water mark (VmHWM) is reset before each run by writing
 * 5 to /proc/self/clear_refs, so each model's figure is its own, not the largest so far. */
static void peak_rss_reset(void) {
  FILE *f = fopen("/proc/self/clear_refs", "w");
  if (f) fputs("5", f), fclose(f);
}

static double peak_rss_bytes(void) {
  FILE *f = fopen("/proc/self/status", "r");
  if (!f) return 0;
  char line[256];
  double kb = 0;
  while (fgets(line, sizeof line, f))
    if (!strncmp(line, "VmHWM:", 6)) kb = atof(line + 6);
  fclose(f);
  return kb * 1024;
}

/* The time of each step of the iterations (time_s.psys.*), all phases, and the phase-3 share. */
static void print_steps(const pm_stats *st) {
  static const char *const steps[] = {"neighbours", "colouring",        "energy",
                                      "step",       "surface",          "sizing.curvature",
                                      "sizing.gap", "sizing.lipschitz", "sizing.field",
                                      "population", "seeding"};
  static const char *const shown[] = {"nbr", "colour", "energy", "step", "surf", "curv",
                                      "gap", "lipschitz", "field", "pop", "seed"};
  double sum = 0, sum3 = 0;
  printf("    steps (s, all phases / phase 3):");
  for (int k = 0; k < (int)(sizeof steps / sizeof steps[0]); ++k) {
    char key[96], key3[96];
    snprintf(key, sizeof key, "psys.%s", steps[k]);
    snprintf(key3, sizeof key3, "psys.phase3.%s", steps[k]);
    double t = stat_time(st, key), t3 = stat_time(st, key3);
    sum += t, sum3 += t3;
    if (t > 0) printf(" %s %.2f/%.2f", shown[k], t, t3);
  }
  double ph = stat_time(st, "phase1") + stat_time(st, "phase2") + stat_time(st, "phase3");
  printf(" other %.2f/%.2f\n", ph - sum, stat_time(st, "phase3") - sum3);
}

/* R / l_min of the triangles by site (tri.by_site): which triangles hold a model's median and
 * p75 back -- along the curves (boundary), around lattice defects (irregular) or in the lattice
 * (regular). */
static void print_sites(const pm_quality *q) {
  printf("    by site (share, median/p75):");
  for (int k = 0; k < PM_TRI_SITES; ++k) {
    const pm_summary *s = &q->tri_site_aspect[k];
    printf(" %s %.0f%% %.4f/%.4f", pm_tri_site_name((pm_tri_site)k),
           q->tri.n ? 100.0 * (double)s->n / (double)q->tri.n : 0.0, s->median, s->p75);
  }
  printf("\n");
}

/* Nodes on vertices, curves and faces: the surface mesh's count, tet nodes left out. */
static int32_t surface_nodes(const pm_mesh *m) {
  int32_t n = 0;
  for (int32_t k = 0; k < m->nnode; ++k) n += m->node_dim[k] >= 0 && m->node_dim[k] <= 2;
  return n;
}

/* A peer method on a field, surface only: the mesh and its run time. */
static pm_status run_peer(const pm_model *m, const pm_sizing *field, const pm_method *method,
                          int threads, pm_mesh **mesh, double *seconds, pm_error *e) {
  *mesh = NULL;
  void *params = calloc(1, method->params_size ? method->params_size : 1);
  if (!params) return pm_error_setf(e, PM_ERR_NOMEM, "out of memory");
  if (method->params_init) method->params_init(params);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.size = field, in.seed = 1, in.threads = threads;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  double t0 = pm_seconds();
  pm_status st = method->run(&in, params, &out, e);
  *seconds = pm_seconds() - t0;
  free(params);
  *mesh = out.mesh;
  return st;
}

static void print_peer(const char *name, const pm_model *m, const pm_mesh *mesh, double seconds,
                       const char *how) {
  pm_check_report cr;
  pm_quality q;
  measure(mesh, m, &cr, &q);
  printf("  %-20s nodes %7d  %-18s time %7.1f s  %s ", name, mesh->nnode, how, seconds,
         cr.valid ? "valid" : "INVALID");
  print_summary("tri", &q.tri.s_aspect_ratio);
  printf("  target %s\n", target_met(&q) ? "met" : "MISSED");
  fflush(stdout);
  pm_quality_clear(&q);
  pm_check_report_clear(&cr);
}

/* The peers on psys's inferred field (the one `--size inferred` hands to other methods):
 * gmsh's Frontal-Delaunay at matched node count (the field scaled until gmsh's surface node count
 * is within 3% of psys's, as `--target-nodes` does; its time is that of the last, matched run),
 * and the bubble mesher on the field as it is. */
/* One line per model for the table at the end. */
typedef struct model_row {
  char name[64];
  int ok, valid, met;
  int32_t nodes;
  double seconds, median, p75, rss;
  double gmsh_seconds, gmsh_median; /* < 0: not run */
  int32_t gmsh_nodes;
} model_row;

static void bench_peers_on_field(const pm_model *m, const pm_sizing *field, int32_t psys_nodes,
                                 double psys_seconds, double psys_median, int threads,
                                 int bubble, model_row *row) {
  pm_error e = {0};
  pm_mesh *mesh = NULL;
  double scale = 1, seconds = 0;
  int runs = 0;
  for (;;) {
    pm_sizing *scaled = NULL;
    pm_mesh_destroy(mesh);
    mesh = NULL;
    if (pm_sizing_scaled(field, scale, &scaled, &e) ||
        run_peer(m, scaled, &peer_gmsh_frontal, threads, &mesh, &seconds, &e)) {
      printf("  %-20s FAILED: %s\n", peer_gmsh_frontal.name, e.msg);
      pm_sizing_destroy(scaled);
      pm_mesh_destroy(mesh);
      mesh = NULL;
      break;
    }
    pm_sizing_destroy(scaled);
    ++runs;
    double ratio = (double)surface_nodes(mesh) / (double)psys_nodes;
    if (fabs(ratio - 1) <= 0.03 || runs >= 6) break;
    scale *= sqrt(ratio);
  }
  if (mesh) {
    char how[64];
    snprintf(how, sizeof how, "field x %.3f", scale);
    print_peer(peer_gmsh_frontal.name, m, mesh, seconds, how);
    pm_quality q;
    pm_check_report cr;
    measure(mesh, m, &cr, &q);
    printf("    psys against gmsh-frontal at matched node count: time %.1f s / %.1f s, median "
           "R/l_min %.4f / %.4f (%s)\n",
           psys_seconds, seconds, psys_median, q.tri.s_aspect_ratio.median,
           psys_median < q.tri.s_aspect_ratio.median ? "psys better" : "gmsh better");
    row->gmsh_seconds = seconds, row->gmsh_median = q.tri.s_aspect_ratio.median;
    row->gmsh_nodes = surface_nodes(mesh);
    pm_quality_clear(&q);
    pm_check_report_clear(&cr);
  }
  pm_mesh_destroy(mesh);
  mesh = NULL;
  if (!bubble) return;
  if (run_peer(m, field, &bub_method, threads, &mesh, &seconds, &e))
    printf("  %-20s FAILED: %s\n", bub_method.name, e.msg);
  else
    print_peer(bub_method.name, m, mesh, seconds, "same field");
  pm_mesh_destroy(mesh);
}

/* One model: mesh, check, measure, print one line. Returns 1 when the target is met. */
static int bench_model(const char *path, const char *name, int threads, int volume, int peers,
                       int bubble, model_row *row) {
  pm_error e = {0};
  pm_model *m = NULL;
  pm_stats st;
  pm_stats_init(&st);
  pm_run_output out;
  memset(&out, 0, sizeof out);
  int met = 0;
  memset(row, 0, sizeof *row);
  snprintf(row->name, sizeof row->name, "%s", name);
  row->gmsh_seconds = row->gmsh_median = -1;
  peak_rss_reset();
  double t0 = pm_seconds(), c0 = cpu_seconds();
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
  pm_run_report report = {&st, NULL, NULL};
  pm_run_observer observer;
  pm_run_report_observer(&report, &observer);
  in.observer = &observer;
  pm_sizing *field = NULL;
  if (psys_run_with_field(&in, &p, &out, peers ? &field : NULL, &e)) {
    printf("%-22s FAILED after %.1f s: %s\n", name, pm_seconds() - t0, e.msg);
    fflush(stdout);
    pm_model_destroy(m);
    pm_stats_clear(&st);
    return 0;
  }
  double t_run = pm_seconds() - t0, c_run = cpu_seconds() - c0;
  double rss = peak_rss_bytes();
  pm_check_report cr;
  pm_quality q;
  measure(out.mesh, m, &cr, &q);
  const double particles = stat_extra(&st, "psys.particles");
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
  row->ok = 1, row->valid = cr.valid, row->met = met, row->nodes = surface_nodes(out.mesh);
  row->seconds = t_run, row->median = q.tri.s_aspect_ratio.median;
  row->p75 = q.tri.s_aspect_ratio.p75, row->rss = rss;
  print_sites(&q);
  if (!cr.valid)
    for (int32_t k = 0; k < cr.nproblem; ++k) printf("    problem: %s\n", cr.problem[k]);
  print_steps(&st);
  printf("    peak RSS %.0f MB, %.0f bytes per particle (%0.f particles); CPU %.1f s over wall "
         "%.1f s, load average %.2f\n",
         rss / 1048576, particles > 0 ? rss / particles : 0, particles, c_run, t_run,
         load_average());
  fflush(stdout);
  if (peers)
    bench_peers_on_field(m, field, surface_nodes(out.mesh), t_run, q.tri.s_aspect_ratio.median,
                         threads, bubble, row);
  pm_sizing_destroy(field);
  pm_quality_clear(&q);
  pm_check_report_clear(&cr);
  pm_mesh_destroy(out.mesh);
  pm_stats_clear(&st);
  pm_model_destroy(m);
  return met;
}

/* Whether name is picked by a comma-separated list of substrings (NULL: no list). */
static int listed(const char *list, const char *name) {
  if (!list) return 0;
  char buf[1024];
  snprintf(buf, sizeof buf, "%s", list);
  for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save))
    if (*t && strstr(name, t)) return 1;
  return 0;
}

static void models(const char *dir, int threads, int volume, int peers, int bubble,
                   const char *only, const char *skip) {
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
  model_row *rows = calloc((size_t)n + 1, sizeof(model_row));
  int met = 0, tried = 0;
  for (int i = 0; i < n; ++i) {
    if ((only && !listed(only, names[i])) || listed(skip, names[i])) {
      free(names[i]);
      continue;
    }
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, names[i]);
    if (rows) met += bench_model(path, names[i], threads, volume, peers, bubble, &rows[tried]);
    ++tried;
    free(names[i]);
  }
  printf("target (median <= 0.60, p75 <= 0.65) met on %d of %d models\n\n", met, tried);
  /* the table: psys beside gmsh-frontal on psys's field at matched node count */
  printf("%-26s %8s %9s %8s %8s %6s %5s | %8s %9s %8s %s\n", "model", "nodes", "time_s",
         "median", "p75", "target", "RSS_MB", "gmsh_n", "gmsh_s", "gmsh_med", "median: psys-gmsh");
  for (int k = 0; rows && k < tried; ++k) {
    const model_row *r = &rows[k];
    if (!r->ok) {
      printf("%-26s FAILED\n", r->name);
      continue;
    }
    printf("%-26s %8d %9.1f %8.4f %8.4f %6s %5.0f", r->name, r->nodes, r->seconds, r->median,
           r->p75, r->met ? "met" : "MISSED", r->rss / 1048576);
    if (r->gmsh_seconds >= 0)
      printf(" | %8d %9.1f %8.4f %+.4f%s\n", r->gmsh_nodes, r->gmsh_seconds, r->gmsh_median,
             r->median - r->gmsh_median, r->valid ? "" : " (psys mesh INVALID)");
    else
      printf("%s\n", r->valid ? "" : " (INVALID)");
  }
  printf("\n");
  free(rows);
}

/* Throughput of one run: particle-iterations per second over phase 3 (from the trace: the sum
 * of the particle counts of its iterations over its time) and end to end (final particles x all
 * iterations / the run's time, the figure a user sees). size NULL: the inferred field. Returns the
 * phase-3 rate. */
static double throughput_one(const char *input, const char *label, const pm_sizing *size,
                             int threads) {
  pm_error e = {0};
  pm_model *m = NULL;
  pm_trace *tr = NULL;
  double rate = 0;
  peak_rss_reset();
  if (pm_input_open(input, &m, NULL, &e) || pm_trace_create(&tr, &e)) {
    printf("throughput: %s\n", e.msg);
    goto out;
  }
  psys_params p;
  psys_params_init(&p);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.size = size, in.seed = 1, in.threads = threads;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  pm_stats st;
  pm_stats_init(&st);
  pm_run_report report = {&st, tr, NULL};
  pm_run_observer observer;
  pm_run_report_observer(&report, &observer);
  in.observer = &observer;
  double t0 = pm_seconds(), c0 = cpu_seconds();
  if (psys_method.run(&in, &p, &out, &e)) {
    printf("throughput: %s\n", e.msg);
    pm_stats_clear(&st);
    goto out;
  }
  double t_run = pm_seconds() - t0, c_run = cpu_seconds() - c0;
  /* particle-iterations of phase 3 from the trace (columns: iteration, phase, particles, ...) */
  double pit = 0, last_n = 0;
  int64_t its = 0;
  for (int64_t r = 0; r < pm_trace_nrow(tr); ++r) {
    const double *row = pm_trace_row(tr, r);
    if (row[1] != 3 || row[12] != 0) continue; /* phase 3's iterations, not the mesh row */
    pit += row[2], last_n = row[2], ++its;
  }
  double t3 = stat_time(&st, "phase3");
  rate = pit / t3;
  printf("%-24s threads %d  particles %8.0f  iterations %4lld (phase 3 %4lld)  time %7.2f s  "
         "phase 3: %9.0f particle-iterations/s, %.3f s per iteration at the final count;  end to "
         "end %9.0f\n",
         label, threads, last_n, (long long)out.iterations, (long long)its, t_run, rate,
         t3 / (double)its * last_n / (pit / (double)its),
         last_n * (double)out.iterations / t_run);
  printf("    CPU %.2f s over wall %.2f s = %.2f cores in use (load average now %.2f); end to end "
         "%.0f particle-iterations per CPU second\n",
         c_run, t_run, c_run / t_run, load_average(), last_n * (double)out.iterations / c_run);
  print_steps(&st);
  double rss = peak_rss_bytes();
  printf("    peak RSS %.0f MB, %.0f bytes per particle\n", rss / 1048576,
         last_n > 0 ? rss / last_n : 0);
  fflush(stdout);
  pm_mesh_destroy(out.mesh);
  pm_stats_clear(&st);
out:
  pm_trace_destroy(tr);
  pm_model_destroy(m);
  return rate;
}

static void throughput(int threads, const char *cad, const char *dir) {
  printf("throughput: case:sphere (radius 1), uniform size, and a CAD model with the inferred "
         "field\n");
  /* A hexagonal packing of edge d on the unit sphere holds about 4 pi / (sqrt(3)/2 d^2) nodes.
   * Every input on one thread and on `threads` (at least 2): the scaling figures. */
  const int tn = threads > 1 ? threads : 2;
  const double ds[2] = {0.038, 0.012};
  for (int k = 0; k < 2; ++k) {
    pm_error e = {0};
    pm_sizing *size = NULL;
    char label[64];
    snprintf(label, sizeof label, "case:sphere d=%g", ds[k]);
    if (pm_sizing_constant(ds[k], &size, &e)) {
      printf("throughput: %s\n", e.msg);
      continue;
    }
    double r1 = throughput_one("case:sphere", label, size, 1);
    double rn = throughput_one("case:sphere", label, size, tn);
    printf("%s: %d threads / 1 thread = %.2f (phase-3 rates)\n", label, tn, r1 > 0 ? rn / r1 : 0);
    pm_sizing_destroy(size);
  }
  {
    pm_error e = {0};
    pm_sizing *size = NULL;
    char path[1024], label[96];
    snprintf(path, sizeof path, "%s/%s", dir, TP_UNIFORM_MODEL);
    snprintf(label, sizeof label, "%s d=%g", TP_UNIFORM_MODEL, TP_UNIFORM_SIZE);
    if (pm_sizing_constant(TP_UNIFORM_SIZE, &size, &e)) {
      printf("throughput: %s\n", e.msg);
    } else {
      double r1 = throughput_one(path, label, size, 1);
      double rn = throughput_one(path, label, size, tn);
      printf("%s: %d threads / 1 thread = %.2f (phase-3 rates)\n", label, tn, r1 > 0 ? rn / r1 : 0);
    }
    pm_sizing_destroy(size);
  }
  const char *base = strrchr(cad, '/');
  base = base ? base + 1 : cad;
  double r1 = throughput_one(cad, base, NULL, 1);
  double rn = throughput_one(cad, base, NULL, tn);
  printf("%s: %d threads / 1 thread = %.2f (phase-3 rates)\n\n", base, tn, r1 > 0 ? rn / r1 : 0);
}

int main(int argc, char **argv) {
  const char *mode = "all", *dir = PM_CAD_DIR, *only = NULL, *skip = NULL, *tp_model = NULL;
  int threads = 1, volume = 0, peers = 0, bubble = 0;
  for (int i = 1; i < argc; ++i) {
    if (!strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--volume"))
      volume = 1;
    else if (!strcmp(argv[i], "--peers"))
      peers = 1;
    else if (!strcmp(argv[i], "--bubble"))
      bubble = 1;
    else if (!strcmp(argv[i], "--only") && i + 1 < argc)
      only = argv[++i];
    else if (!strcmp(argv[i], "--skip") && i + 1 < argc)
      skip = argv[++i];
    else if (!strcmp(argv[i], "--tp-model") && i + 1 < argc)
      tp_model = argv[++i];
    else if (!strcmp(argv[i], "models") || !strcmp(argv[i], "throughput") ||
             !strcmp(argv[i], "all"))
      mode = argv[i];
    else if (argv[i][0] != '-')
      dir = argv[i];
    else {
      fprintf(stderr, "usage: bench_psys [models|throughput|all] [--threads N] [--volume] "
                      "[--peers] [--bubble] [--only A,B] [--skip A,B] [--tp-model FILE] "
                      "[CAD_DIR]\n");
      return 2;
    }
  }
  if (threads < 1) threads = 1;
  machine_info(argc, argv, threads);
  char tp_default[1024];
  snprintf(tp_default, sizeof tp_default, "%s/%s", dir, TP_MODEL);
  if (!strcmp(mode, "throughput") || !strcmp(mode, "all"))
    throughput(threads, tp_model ? tp_model : tp_default, dir);
  if (!strcmp(mode, "models") || !strcmp(mode, "all")) models(dir, threads, volume, peers, bubble, only, skip);
  return 0;
}
