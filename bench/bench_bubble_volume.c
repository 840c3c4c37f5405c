/* Tets of the bubble method against TetGen's refinement and gmsh's 3D Delaunay (bubble
 * volumes). For the built-in solids at their default (uniform) size and a few shared CAD solids
 * at diagonal / 15:
 *   bubble    volume bubbles as interior nodes, no Steiner point (--set tets=bubbles);
 *   tetgen    the same kind of bubble surface filled by TetGen's quality refinement (tets=tetgen);
 *   gmsh-del  gmsh's own surface and 3D Delaunay (peer gmsh-delaunay, volume=gmsh);
 * tet count, radius ratio min / p25 / median / mean, the smallest dihedral angle, the share of
 * tets with a dihedral angle below 10 degrees, the mesh checker's verdict and the wall time.
 *
 *   bench_bubble_volume [--case NAME]... [--cad FILE]... [--no-cad] [--set KEY=VALUE]...
 *                       [--threads N]
 * Prints figures; never a timed test.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubble/bubble.h"
#include "common/base/clock.h"
#include "common/geom/geom_cad.h"
#include "common/input/cases.h"
#include "common/mesh/mesh_check.h"
#include "common/base/params.h"
#include "common/measure/quality.h"
#include "common/sizing/sizing.h"
#include "peers/peers.h"

#ifndef PM_CAD_DIR
#define PM_CAD_DIR "/work/shared/cad"
#endif

typedef struct row {
  int ok, valid;
  char err[256];
  int32_t nodes, tets;
  pm_summary rr;
  double min_dih, share10, time;
} row;

static row run(const pm_method *meth, const void *params, const pm_model *m, const pm_sizing *size,
               int threads) {
  row r;
  memset(&r, 0, sizeof r);
  pm_run_input in = {m, size, 1, threads, 1, PM_DEFAULT_MAX_NODES, NULL};
  pm_run_output out;
  memset(&out, 0, sizeof out);
  pm_error e = {0};
  double t0 = pm_seconds();
  pm_status st = meth->run(&in, params, &out, &e);
  r.time = pm_seconds() - t0;
  if (st) {
    snprintf(r.err, sizeof r.err, "%.250s", e.msg);
    return r;
  }
  pm_quality q;
  if (pm_quality_compute(out.mesh, size, &q, &e)) {
    snprintf(r.err, sizeof r.err, "quality: %.240s", e.msg);
    pm_mesh_destroy(out.mesh);
    return r;
  }
  pm_check_report cr;
  memset(&cr, 0, sizeof cr);
  pm_mesh_check(out.mesh, m, &cr, &e);
  r.valid = cr.valid;
  if (!cr.valid && cr.nproblem) snprintf(r.err, sizeof r.err, "%.250s", cr.problem[0]);
  pm_check_report_clear(&cr);
  r.ok = 1;
  r.nodes = out.mesh->nnode, r.tets = out.mesh->ntet;
  r.rr = q.tet.s_radius_ratio;
  r.min_dih = q.tet.s_min_angle.min;
  int32_t below = 0;
  for (int32_t t = 0; t < q.tet.n; ++t) below += q.tet.min_angle[t] < 10;
  r.share10 = q.tet.n ? (double)below / q.tet.n : 0;
  pm_quality_clear(&q);
  pm_mesh_destroy(out.mesh);
  return r;
}

static void print_row(const char *name, const row *r) {
  if (!r->ok) {
    printf("  %-9s failed: %s\n", name, r->err);
    return;
  }
  printf("  %-9s %7d %8d  %.3f %.3f %.3f %.3f  %6.2f  %6.2f%%  %-5s %7.2f\n", name, r->nodes,
         r->tets, r->rr.min, r->rr.p25, r->rr.median, r->rr.mean, r->min_dih, 100 * r->share10,
         r->valid ? "yes" : "NO", r->time);
  if (!r->valid && r->err[0]) printf("            check: %s\n", r->err);
}

static void bench_model(const char *label, const pm_model *m, double d, const bub_params *bp,
                        int threads) {
  pm_sizing *size = NULL;
  pm_error e = {0};
  if (pm_sizing_constant(d, &size, &e)) {
    printf("%s: %s\n", label, e.msg);
    return;
  }
  printf("%s (size %g)\n", label, d);
  printf("  %-9s %7s %8s  %-23s  %6s  %7s  %-5s %7s\n", "method", "nodes", "tets",
         "rr min/p25/median/mean", "mindih", "<10deg", "valid", "time s");
  bub_params p = *bp;
  p.tets = BUB_TETS_BUBBLES;
  row a = run(&bub_method, &p, m, size, threads);
  print_row("bubble", &a);
  p.tets = BUB_TETS_TETGEN;
  row b = run(&bub_method, &p, m, size, threads);
  print_row("tetgen", &b);
  peer_gmsh_params gp;
  peer_gmsh_params_init(&gp);
  gp.volume = PEER_GMSH_VOLUME_GMSH;
  row g = run(&peer_gmsh_delaunay, &gp, m, size, 1);
  print_row("gmsh-del", &g);
  pm_sizing_destroy(size);
}

int main(int argc, char **argv) {
  bub_params bp;
  bub_params_init(&bp);
  int threads = 1, no_cad = 0, ncase = 0, ncad = 0;
  const char *cases[16], *cads[16];
  for (int k = 1; k < argc; ++k) {
    pm_error e = {0};
    if (!strcmp(argv[k], "--case") && k + 1 < argc && ncase < 16) {
      cases[ncase++] = argv[++k];
    } else if (!strcmp(argv[k], "--cad") && k + 1 < argc && ncad < 16) {
      cads[ncad++] = argv[++k];
    } else if (!strcmp(argv[k], "--no-cad")) {
      no_cad = 1;
    } else if (!strcmp(argv[k], "--threads") && k + 1 < argc) {
      threads = atoi(argv[++k]);
    } else if (!strcmp(argv[k], "--set") && k + 1 < argc) {
      if (pm_params_set_pair(&bub_params_table, &bp, argv[++k], &e)) {
        fprintf(stderr, "%s\n", e.msg);
        return 2;
      }
    } else {
      fprintf(stderr, "usage: %s [--case NAME]... [--cad FILE]... [--no-cad] [--set KEY=VALUE]... "
                      "[--threads N]\n", argv[0]);
      return 2;
    }
  }
  int nbuilt = 0;
  const pm_case_info *info = pm_cases(&nbuilt);
  for (int i = 0; i < nbuilt; ++i) {
    if (info[i].dim != 3) continue;
    int want = ncase == 0 && ncad == 0;
    for (int k = 0; k < ncase; ++k) want |= !strcmp(cases[k], info[i].name);
    if (!want) continue;
    pm_model *m = NULL;
    pm_error e = {0};
    if (pm_case_open(info[i].name, &m, NULL, &e)) {
      printf("case:%s: %s\n", info[i].name, e.msg);
      continue;
    }
    char label[64];
    snprintf(label, sizeof label, "case:%s", info[i].name);
    bench_model(label, m, atof(info[i].size), &bp, threads);
    pm_model_destroy(m);
  }
  static const char *const shared[] = {"crack.brep", "synth_box_hole.step", "planar_step.brep",
                                       "synth_torus.brep", "screw.step"};
  int nfile = ncad ? ncad : (no_cad || ncase ? 0 : (int)(sizeof shared / sizeof shared[0]));
  for (int i = 0; i < nfile; ++i) {
    char path[1024];
    const char *f = ncad ? cads[i] : shared[i];
    if (strchr(f, '/')) snprintf(path, sizeof path, "%s", f);
    else snprintf(path, sizeof path, "%s/%s", PM_CAD_DIR, f);
    pm_model *m = NULL;
    pm_error e = {0};
    if (pm_cad_load(path, &m, &e)) {
      printf("%s: %s\n", f, e.msg);
      continue;
    }
    if (m->count[PM_VOLUME] == 0) {
      printf("%s: no volume\n", f);
      pm_model_destroy(m);
      continue;
    }
    bench_model(f, m, m->diagonal / 15, &bp, threads);
    pm_model_destroy(m);
  }
  return 0;
}
