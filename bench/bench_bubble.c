/* The bubble mesher on the built-in planar cases of papers/004 (qi1..qi4) and papers/003
 * (shimada), beside the papers' figures and gmsh's Frontal-Delaunay; the default-size sweep over
 * the shared CAD models; the throughput of one RK4 step per bubble at 10^4 and 10^5 bubbles.
 *
 *   bench_bubble [planar] [cad] [throughput] [--set KEY=VALUE ...] [--threads N] [--case NAME]
 *                [--cad FILE] [--dump TRIS.dat] [--worst RR] [--extra] [--trace TRACE.csv]
 * Diagnostics: --dump writes the last mesh's triangles (x y radius_ratio, for gnuplot), --worst
 * lists the triangles below a radius ratio, --extra prints the run's extra statistics, --trace
 * writes the last run's trace.
 * With no section named, all three run. Prints figures; never a timed test.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bubble/bub_private.h"
#include "common/cases.h"
#include "common/clock.h"
#include "common/geom_analytic.h"
#include "common/geom_cad.h"
#include "common/input.h"
#include "common/mesh_check.h"
#include "common/quality.h"
#include "common/rng.h"
#include "common/vec3.h"
#include "common/stats.h"
#include "common/trace.h"
#include "peers/peers.h"

typedef struct result {
  int ok;
  char err[512];
  int32_t nodes, tris;
  double rr_mean, rr_min, amin, eps_t, eps_g, share30, size_mean;
  int64_t steps;
  double time, cpu;
  int valid;
  char stop[128];
} result;

/* CPU time of the process (the wall clock of a loaded machine overstates a run). */
static double cpu_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Diagnostics (command-line flags): triangles for gnuplot, the worst triangles, the run's extra
 * statistics, the trace. */
static const char *opt_dump, *opt_trace;
static double opt_worst = -1;
static int opt_extra;

static result run_method(const pm_method *meth, const void *params, const pm_model *m,
                         const pm_sizing *size, int threads) {
  result r;
  memset(&r, 0, sizeof r);
  pm_run_input in = {m, size, 1, threads, 0, PM_DEFAULT_MAX_NODES, NULL, NULL};
  pm_trace *tr = NULL;
  if (opt_trace) pm_trace_create(&tr, NULL);
  in.trace = tr;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  pm_stats stats;
  pm_stats_init(&stats);
  out.stats = &stats;
  pm_error e = {0};
  double t0 = pm_seconds(), c0 = cpu_seconds();
  pm_status st = meth->run(&in, params, &out, &e);
  r.time = pm_seconds() - t0;
  r.cpu = cpu_seconds() - c0;
  if (tr) {
    pm_trace_write_csv(tr, opt_trace, NULL);
    pm_trace_destroy(tr);
  }
  if (st) {
    snprintf(r.err, sizeof r.err, "%s", e.msg);
    return r;
  }
  pm_quality q;
  if (pm_quality_compute(out.mesh, size, &q, &e)) {
    snprintf(r.err, sizeof r.err, "quality: %.480s", e.msg);
    pm_mesh_destroy(out.mesh);
    return r;
  }
  pm_check_report cr;
  memset(&cr, 0, sizeof cr);
  pm_mesh_check(out.mesh, m, &cr, &e);
  r.valid = cr.valid;
  if (!cr.valid && cr.nproblem) snprintf(r.err, sizeof r.err, "%s", cr.problem[0]);
  pm_check_report_clear(&cr);
  if (opt_dump) { /* triangles for gnuplot: x y rr, blank line between */
    FILE *fd = fopen(opt_dump, "w");
    for (int32_t t = 0; fd && t < q.tri.n; ++t) {
      for (int k = 0; k < 4; ++k) {
        int32_t v = out.mesh->tri[3 * t + (k % 3)];
        fprintf(fd, "%g %g %g\n", out.mesh->xyz[3 * v], out.mesh->xyz[3 * v + 1], q.tri.radius_ratio[t]);
      }
      fprintf(fd, "\n\n");
    }
    if (fd) fclose(fd);
  }
  if (opt_worst > 0) {
    int32_t w = 0;
    for (int32_t t = 0; t < q.tri.n; ++t)
      if (q.tri.radius_ratio[t] < q.tri.radius_ratio[w]) w = t;
    for (int32_t t = 0; t < q.tri.n; ++t) {
      if (q.tri.radius_ratio[t] > opt_worst) continue;
      printf("  bad tri %d rr %.3f:", t, q.tri.radius_ratio[t]);
      for (int k = 0; k < 3; ++k) {
        int32_t v = out.mesh->tri[3 * t + k];
        printf(" [%d/%d (%.4f %.4f %.4f)]", out.mesh->node_dim[v], out.mesh->node_cell[v],
               out.mesh->xyz[3 * v], out.mesh->xyz[3 * v + 1], out.mesh->xyz[3 * v + 2]);
      }
      printf("\n");
    }
  }
  r.ok = 1;
  r.nodes = out.mesh->nnode, r.tris = out.mesh->ntri;
  r.rr_mean = q.tri.s_radius_ratio.mean, r.rr_min = q.tri.s_radius_ratio.min;
  r.amin = q.tri.s_min_angle.min, r.eps_t = q.tri.eps_t, r.eps_g = q.tri.eps_g;
  int64_t over30 = q.tri_min_angle_bins[3] + q.tri_min_angle_bins[4] + q.tri_min_angle_bins[5];
  r.share30 = q.tri.n ? (double)over30 / q.tri.n : 0;
  r.size_mean = q.tri.has_size ? q.tri.size_ratio.mean : 0;
  r.steps = out.iterations;
  if (opt_extra) {
    pm_stats_flat fl;
    if (pm_stats_flatten(&stats, &fl, &e) == PM_OK) {
      for (int32_t k = 0; k < fl.n; ++k)
        if (strncmp(fl.item[k].key, "bubble.", 7) == 0 || strncmp(fl.item[k].key, "time_s", 6) == 0) {
          if (fl.item[k].is_text) printf("  %s = %s\n", fl.item[k].key, fl.item[k].text);
          else printf("  %s = %g\n", fl.item[k].key, fl.item[k].num);
        }
      pm_stats_flat_clear(&fl);
    }
  }
  pm_stats_clear(&stats);
  snprintf(r.stop, sizeof r.stop, "%s", out.stop_reason);
  pm_quality_clear(&q);
  pm_mesh_destroy(out.mesh);
  return r;
}

static result run_one(const pm_model *m, const pm_sizing *size, const bub_params *p, int threads) {
  return run_method(&bub_method, p, m, size, threads);
}

/* The papers' figures and gmsh Frontal-Delaunay measured on the same domains and size fields. */
typedef struct paper_row {
  const char *name, *paper, *gmsh;
} paper_row;

static const paper_row paper[] = {
    {"qi1", "004 T5: rr 0.9532 (FNPBS 0.9626)", "gmsh-frontal: rr 0.992, min angle 41.8"},
    {"qi2", "004 T5: rr 0.9564 (FNPBS 0.9087)", "-"},
    {"qi3", "004 T5: rr 0.9453, 712 nodes, 29 s", "gmsh-frontal: 736 nodes, rr 0.967, min 0.611, 31.8 deg, eps_t 0.30, 20 ms"},
    {"qi4", "004 T5: rr 0.9362", "-"},
    {"shimada", "003 T1 (100 it): eps_t 0.42, eps_g 0.04", "-"},
};

static void print_row(const char *name, const result *r) {
  printf("%-8s %6d %6d %7.4f %7.4f %7.2f %6.3f %6.3f %7.3f %6lld %7.3f %6.3f %5s  %s\n", name,
         r->nodes, r->tris, r->rr_mean, r->rr_min, r->amin, r->eps_t, r->eps_g, r->size_mean,
         (long long)r->steps, r->time, r->cpu, r->valid ? "yes" : "NO", r->stop);
}

static void section_planar(const bub_params *p, int threads, const char *only) {
  printf("\nplanar cases (threads %d)\n", threads);
  printf("%-8s %6s %6s %7s %7s %7s %6s %6s %7s %6s %7s %6s %5s  %s\n", "case", "nodes", "tris",
         "rr_mean", "rr_min", "minang", "eps_t", "eps_g", "size", "steps", "wall_s", "cpu_s",
         "valid", "stop");
  for (size_t k = 0; k < sizeof paper / sizeof paper[0]; ++k) {
    if (only && strcmp(only, paper[k].name) != 0) continue;
    pm_model *m = NULL;
    pm_sizing *size = NULL;
    pm_error e = {0};
    if (pm_case_open(paper[k].name, &m, &size, &e)) {
      printf("%-8s failed to open: %s\n", paper[k].name, e.msg);
      continue;
    }
    result r = run_one(m, size, p, threads);
    if (!r.ok) {
      printf("%-8s FAILED: %s\n", paper[k].name, r.err);
    } else {
      print_row(paper[k].name, &r);
      printf("         paper: %s | reference: %s\n", paper[k].paper, paper[k].gmsh);
    }
    /* gmsh's Frontal-Delaunay on the same domain and size field, and the bubble mesher with the
     * size field scaled until its node count is within 1% of gmsh's (the comparison at the same
     * node count). */
    char gp[256];
    peer_gmsh_params_init(gp);
    result g = run_method(&peer_gmsh_frontal, gp, m, size, 1);
    if (g.ok) {
      print_row("  gmsh", &g);
      double f = 1;
      result mr = r;
      for (int it = 0; it < 6 && r.ok && mr.ok && fabs((double)mr.nodes / g.nodes - 1) > 0.01; ++it) {
        f *= sqrt((double)mr.nodes / g.nodes);
        pm_sizing *sc = NULL;
        if (pm_sizing_scaled(size, f, &sc, &e)) break;
        mr = run_one(m, sc, p, threads);
        pm_sizing_destroy(sc);
      }
      if (mr.ok) {
        char lab[32];
        snprintf(lab, sizeof lab, "  @%.3fd", f);
        print_row(lab, &mr);
      }
    } else {
      printf("  gmsh    failed: %s\n", g.err);
    }
    pm_sizing_destroy(size);
    pm_model_destroy(m);
  }
}

static const char *const cad_files[] = {
    "base_interface.step", "bearing.iges",        "bottle.brep",        "box_sides.step",
    "bspline_sphere.brep", "crack.brep",          "cube_fillet.stp",    "cyl_loop_seam.brep",
    "cylinder_head.stp",   "engine_block.stp",    "featuretype.step",   "fusee.stp",
    "planar_step.brep",    "screw.step",          "slender_face.brep",  "solid56.step",
    "synth_box_hole.brep", "synth_box_hole.step", "synth_bspline_patch.brep",
    "synth_cone.brep",     "synth_sphere.brep",   "synth_torus.brep",   "synth_torus.step",
    "t20_component8.step", "table.brep",          "wrench.stp",
};

static void section_cad(const bub_params *p, int threads, const char *only) {
  printf("\nCAD models, default size (diagonal / %g, reduced at small features; threads %d)\n",
         p->size_div, threads);
  printf("%-26s %7s %7s %7s %7s %8s %6s %8s %8s %5s  %s\n", "model", "nodes", "tris", "rr_mean",
         ">=30deg", "minang", "steps", "wall_s", "cpu_s", "valid", "stop / problem");
  for (size_t k = 0; k < sizeof cad_files / sizeof cad_files[0]; ++k) {
    if (only && strcmp(only, cad_files[k]) != 0) continue;
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", PM_CAD_DIR, cad_files[k]);
    pm_model *m = NULL;
    pm_error e = {0};
    if (pm_cad_load(path, &m, &e)) {
      printf("%-26s load failed: %s\n", cad_files[k], e.msg);
      continue;
    }
    /* The run uses the exact default rule; quality's size ratios against the same rule. */
    pm_sizing *size = NULL;
    void *rule = NULL;
    if (bub_size_rule_create(m, p, &size, &rule, &e)) {
      printf("%-26s size rule failed: %s\n", cad_files[k], e.msg);
      pm_model_destroy(m);
      continue;
    }
    result r = run_one(m, size, p, threads);
    if (!r.ok)
      printf("%-26s FAILED after %.2f s: %s\n", cad_files[k], r.time, r.err);
    else
      printf("%-26s %7d %7d %7.4f %6.1f%% %8.2f %6lld %8.2f %8.2f %5s  %s%s%s\n", cad_files[k], r.nodes,
             r.tris, r.rr_mean, 100 * r.share30, r.amin, (long long)r.steps, r.time, r.cpu,
             r.valid ? "yes" : "NO", r.stop, r.valid ? "" : " | ", r.valid ? "" : r.err);
    fflush(stdout);
    pm_sizing_destroy(size);
    bub_size_rule_free(rule);
    pm_model_destroy(m);
  }
}

/* Bubble-steps per second: face bubbles on a jittered hexagonal lattice in face 0's parameter
 * space (scaled by the mean |Su|, |Sv|, as the placement does), its spacing calibrated until
 * there are n bubbles within 3%, then RK4 steps without population control (the jitter keeps the
 * bubbles moving, so lists get rebuilt as in a real run). */
static int32_t lattice(bub_state *s, const pm_cell *f, double h, double jitter) {
  double su = 0, sv = 0;
  for (int a = 0; a < 8; ++a)
    for (int b = 0; b < 8; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (a + 0.5) / 8,
                      f->lo[1] + (f->hi[1] - f->lo[1]) * (b + 0.5) / 8};
      pm_face_point fp;
      pm_face_eval(f, uv, 1, &fp);
      su += pm_v3_norm(fp.su) / 64, sv += pm_v3_norm(fp.sv) / 64;
    }
  double W = (f->hi[0] - f->lo[0]) * su, H = (f->hi[1] - f->lo[1]) * sv;
  pm_rng r;
  pm_rng_init(&r, 5, 0);
  pm_error e = {0};
  s->n = 0;
  int nj = (int)(H / (0.8660254 * h)) + 1, ni = (int)(W / h) + 2;
  for (int j = 0; j < nj; ++j)
    for (int i = 0; i < ni; ++i) {
      double U = (i + 0.5 * (j & 1) + 0.25) * h + jitter * h * pm_rng_range(&r, -1, 1);
      double V = (j + 0.5) * 0.8660254 * h + jitter * h * pm_rng_range(&r, -1, 1);
      double uv[2] = {f->lo[0] + U / su, f->lo[1] + V / sv};
      if (!(U > 0 && U < W && V > 0 && V < H) || !pm_face_inside(f, uv)) continue;
      if (bub_state_add(s, BUB_KFACE, f->index, uv, NULL, 0, NULL, &e)) return -1;
    }
  bub_state_compact(s, &e);
  return s->n;
}

static void throughput(const char *label, const pm_model *m, int64_t n, int threads,
                       const bub_params *base) {
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  bub_params p = *base;
  pm_sizing *size = NULL;
  pm_error e = {0};
  pm_sizing_constant(1, &size, &e);
  bub_state *s = NULL;
  bub_state_create(m, size, &p, threads, 1, &s, &e);
  double h = sqrt((f->hi[0] - f->lo[0]) * (f->hi[1] - f->lo[1]) / (0.866 * (double)n));
  for (int it = 0; it < 8; ++it) {
    int32_t got = lattice(s, f, h, 0);
    if (got <= 0) break;
    double ratio = (double)got / (double)n;
    if (fabs(ratio - 1) < 0.03) break;
    h *= sqrt(ratio);
  }
  /* The bubbles' diameter: the lattice spacing; the jitter makes them move. */
  pm_sizing_destroy(size);
  pm_sizing_constant(h, &size, &e);
  s->size = size;
  lattice(s, f, h, 0.1);
  bub_step_info info;
  bub_dynamics_step(s, &info, &e); /* warm-up: lists */
  int steps = 0;
  double t0 = pm_seconds(), t = 0;
  do {
    if (bub_dynamics_step(s, &info, &e)) {
      printf("  %-22s step failed: %s\n", label, e.msg);
      break;
    }
    ++steps;
    t = pm_seconds() - t0;
  } while (t < 3.0 && steps < 200);
  int32_t moving = s->nf - s->nv;
  printf("  %-22s %8d bubbles  %4d steps  %8.4f s/step  %6.2f us/bubble-step  %10.3g bubble-steps/s  (list builds %lld)\n",
         label, (int)moving, steps, t / steps, 1e6 * t / steps / moving, moving * (double)steps / t,
         (long long)s->list_builds);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
}

static void section_throughput(const bub_params *p, int threads) {
  printf("\nthroughput: one RK4 step of one bubble (threads %d)\n", threads);
  pm_model *sq = NULL, *torus = NULL;
  pm_error e = {0};
  const pm_planar_piece pc[4] = {{PM_PIECE_LINE, {0, 0}, {0, 0}, 0}, {PM_PIECE_LINE, {1, 0}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {1, 1}, {0, 0}, 0}, {PM_PIECE_LINE, {0, 1}, {0, 0}, 0}};
  pm_planar_loop lp = {4, pc};
  if (pm_planar_model("square", 1, &lp, &sq, &e) == PM_OK) {
    throughput("planar square 1e4", sq, 10000, threads, p);
    throughput("planar square 1e5", sq, 100000, threads, p);
  }
  if (pm_cad_case("torus", &torus, &e) == PM_OK) {
    throughput("torus face 1e4", torus, 10000, threads, p);
    throughput("torus face 1e5", torus, 100000, threads, p);
  } else {
    printf("  torus: %s\n", e.msg);
  }
  pm_model_destroy(sq);
  pm_model_destroy(torus);
}

int main(int argc, char **argv) {
  bub_params p;
  bub_params_init(&p);
  int threads = 1, want_planar = 0, want_cad = 0, want_tp = 0;
  const char *only_case = NULL, *only_cad = NULL;
  for (int i = 1; i < argc; ++i) {
    pm_error e = {0};
    if (strcmp(argv[i], "planar") == 0) want_planar = 1;
    else if (strcmp(argv[i], "cad") == 0) want_cad = 1;
    else if (strcmp(argv[i], "throughput") == 0) want_tp = 1;
    else if (strcmp(argv[i], "--threads") == 0 && i + 1 < argc) threads = atoi(argv[++i]);
    else if (strcmp(argv[i], "--case") == 0 && i + 1 < argc) only_case = argv[++i];
    else if (strcmp(argv[i], "--cad") == 0 && i + 1 < argc) only_cad = argv[++i];
    else if (strcmp(argv[i], "--dump") == 0 && i + 1 < argc) opt_dump = argv[++i];
    else if (strcmp(argv[i], "--trace") == 0 && i + 1 < argc) opt_trace = argv[++i];
    else if (strcmp(argv[i], "--worst") == 0 && i + 1 < argc) opt_worst = atof(argv[++i]);
    else if (strcmp(argv[i], "--extra") == 0) opt_extra = 1;
    else if (strcmp(argv[i], "--set") == 0 && i + 1 < argc) {
      if (pm_params_set_pair(&bub_params_table, &p, argv[++i], &e)) return fprintf(stderr, "%s\n", e.msg), 2;
    } else {
      fprintf(stderr, "usage: bench_bubble [planar] [cad] [throughput] [--set KEY=VALUE] "
                      "[--threads N] [--case NAME] [--cad FILE] [--dump F] [--worst RR] "
                      "[--extra] [--trace F]\n");
      return 2;
    }
  }
  if (!want_planar && !want_cad && !want_tp) want_planar = want_cad = want_tp = 1;
  printf("bench_bubble: packmesh %s\n", pm_version());
  if (want_planar) section_planar(&p, threads, only_case);
  if (want_tp) section_throughput(&p, threads);
  if (want_cad) section_cad(&p, threads, only_cad);
  return 0;
}
