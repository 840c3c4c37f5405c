/* The classic peers on the built-in planar cases and on shared CAD models: per case and peer,
 * nodes, triangles, mean and minimum radius ratio, minimum angle, eps_t (papers/003 eq. 8), the
 * mean edge length over d, and the time of the run.
 *
 * Each row runs in its own child process (as the comparison harness does), so a backend that
 * crashes on a model costs its row only; such a row says which signal ended it.
 *
 * Usage: bench_peers [planar|cad|all]   (default all)
 * The figure to compare with: gmsh's Frontal-Delaunay on qi3 with its default size field gives
 * about 736 nodes, mean radius ratio 0.967, minimum 0.611, minimum angle 31.8 degrees. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/input/cases.h"
#include "common/base/clock.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"
#include "peers/peers.h"

typedef struct variant {
  const pm_method *method;
  const char *label;
  const char *set; /* one KEY=VALUE or NULL */
} variant;

static const variant planar_variants[] = {
    {&peer_gmsh_meshadapt, "gmsh-meshadapt", NULL},
    {&peer_gmsh_delaunay, "gmsh-delaunay", NULL},
    {&peer_gmsh_frontal, "gmsh-frontal", NULL},
    {&peer_cgal, "cgal", NULL},
    {&peer_cgal, "cgal lloyd", "optimizer=lloyd"},
    {&peer_cgal, "cgal odt", "optimizer=odt"},
};

/* One row, in the calling (child) process. */
static int row(const char *input, const variant *v, int volume) {
  pm_error e = {0};
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  pm_status s;
  if (strncmp(input, "case:", 5) == 0) {
    s = pm_case_open(input + 5, &md, &sz, &e);
  } else {
    char path[512];
    snprintf(path, sizeof path, "%s/%s", PM_CAD_DIR, input);
    s = pm_cad_load(path, &md, &e);
    /* The CAD rows use the peers' default size, 1/30 of the diagonal. */
  }
  if (s) {
    printf("%-22s %-16s error: %s\n", input, v->label, e.msg);
    return 1;
  }
  void *params = calloc(1, v->method->params_size);
  v->method->params_init(params);
  if (v->set) pm_params_set_pair(v->method->params, params, v->set, NULL);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = md, in.size = sz, in.seed = 1, in.threads = 1, in.volume = volume;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  double t0 = pm_seconds();
  s = v->method->run(&in, params, &out, &e);
  double t = pm_seconds() - t0;
  if (s) {
    printf("%-22s %-16s error: %s\n", input, v->label, e.msg);
  } else {
    pm_sizing *own = NULL;
    const pm_sizing *field = sz;
    if (!field) v->method->default_size(md, params, 1, 1, &own, NULL), field = own;
    pm_quality q;
    pm_check_report r;
    pm_quality_compute(out.mesh, field, &q, NULL);
    pm_mesh_check(out.mesh, md, &r, NULL);
    printf("%-22s %-16s %7d %8d %7d  %.3f  %.3f  %6.2f  %.3f  %.3f  %s  %7.3f\n", input, v->label,
           out.mesh->nnode, out.mesh->ntri, out.mesh->ntet, q.tri.s_radius_ratio.mean,
           q.tri.s_radius_ratio.min, q.tri.s_min_angle.min, q.tri.eps_t, q.tri.size_ratio.mean,
           r.valid ? "yes" : "NO ", t);
    if (out.mesh->ntet)
      printf("%-22s %-16s   tets: radius ratio mean %.3f min %.3f, min dihedral %.2f\n", "",
             "", q.tet.s_radius_ratio.mean, q.tet.s_radius_ratio.min, q.tet.s_min_angle.min);
    pm_check_report_clear(&r);
    pm_quality_clear(&q);
    pm_sizing_destroy(own);
  }
  fflush(stdout);
  pm_mesh_destroy(out.mesh);
  free(params);
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
  pm_gmsh_shutdown();
  return s ? 1 : 0;
}

static void in_child(const char *input, const variant *v, int volume) {
  fflush(stdout);
  pid_t pid = fork();
  if (pid == 0) _exit(row(input, v, volume));
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) < 0) {
    printf("%-22s %-16s could not start a child process\n", input, v->label);
    return;
  }
  if (WIFSIGNALED(status))
    printf("%-22s %-16s crashed (signal %d)\n", input, v->label, WTERMSIG(status));
}

int main(int argc, char **argv) {
  const char *which = argc > 1 ? argv[1] : "all";
  int planar = strcmp(which, "cad") != 0, cad = strcmp(which, "planar") != 0;
  printf("%-22s %-16s %7s %8s %7s  %-5s  %-5s  %-6s  %-5s  %-5s  %-3s  %7s\n", "input", "peer",
         "nodes", "tris", "tets", "rr", "rrmin", "angmin", "eps_t", "l/d", "ok", "time_s");
  if (planar) {
    static const char *const cases[] = {"case:qi1", "case:qi2", "case:qi3", "case:qi4",
                                        "case:shimada"};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c)
      for (size_t k = 0; k < sizeof planar_variants / sizeof planar_variants[0]; ++k)
        in_child(cases[c], &planar_variants[k], 0);
  }
  if (cad) {
    static const char *const models[] = {"case:sphere", "case:torus", "case:boxhole",
                                         "screw.step", "t20_component8.step", "bottle.brep",
                                         "planar_step.brep", "cylinder_head.stp"};
    for (size_t c = 0; c < sizeof models / sizeof models[0]; ++c)
      for (size_t k = 0; k < 3; ++k) in_child(models[c], &planar_variants[k], 0);
    static const variant tetgen = {&peer_gmsh_frontal, "frontal+tetgen", "volume=tetgen"};
    in_child("case:boxhole", &planar_variants[2], 1);
    in_child("case:boxhole", &tetgen, 1);
    in_child("screw.step", &planar_variants[2], 1);
    in_child("screw.step", &tetgen, 1);
  }
  return 0;
}
