/* packmesh quality MESH [--size EXPR|NUMBER] [--geometry INPUT] [--json | --csv]
 *
 * Measures a mesh file with the one quality implementation (quality.h) and checks it
 * (mesh_check.h). --size adds the size conformity (edge length over the size field at each
 * edge's midpoint). --geometry names the model the mesh discretizes: the checker then runs its
 * model checks (the file's entity tags t read as cells t - 1, mesh_io.h) and the two-sided
 * distance to the model is measured (distance.h). Output, all on stdout and only once everything
 * succeeded:
 *   default  a readable table;
 *   --json   the stats JSON (stats.h) with method "external" and input = MESH;
 *   --csv    one row per element (kind, index, cell, radius ratio, aspect ratio, min and max
 *            angle; dihedral angles for tets) for box plots.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_util.h"
#include "common/measure/distance.h"
#include "common/geom/geom.h"
#include "common/input/input.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/mesh/mesh_io.h"
#include "common/measure/quality.h"
#include "common/sizing/sizing.h"
#include "common/report/stats.h"

static const char *const usage_text =
    "usage: packmesh quality MESH [--size EXPR|NUMBER] [--geometry INPUT] [--json | --csv]\n"
    "\n"
    "Measure the elements of MESH (.msh, .vtk, .vtu, .stl, .mesh or .obj) and check its validity.\n"
    "  --size S      the desired edge length d(x, y, z), a number or an expression in x, y, z, r\n"
    "                (\"0.1\", \"0.2*abs(r-2)+0.15\"): adds edge length / d at the edge midpoints\n"
    "  --geometry IN the model MESH discretizes: a CAD file (.step, .stp, .iges, .igs, .brep),\n"
    "                case:NAME or a case file (.json). The checker then verifies conformity,\n"
    "                closed shells and orientation against it (element entity tag t = cell t-1),\n"
    "                and the two-sided distance between mesh and model is measured. A case's own\n"
    "                size field is used when --size is not given.\n"
    "  --json   the stats JSON (the keys of packmesh mesh --stats) on stdout\n"
    "  --csv    per-element measures, one row per element:\n"
    "           kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg\n"
    "           (for tets the angles are dihedral angles)\n"
    "  --help   this text\n"
    "Measures: radius ratio 2r/R (triangles, 1 = equilateral) and 3r/R (tets); aspect ratio\n"
    "R/l_min; min/max angles; eps_t and eps_g of Shimada & Gossard (1995, eq. 8-9); R/l_min\n"
    "of the triangles by site: boundary (a corner on a curve or vertex), irregular (an interior\n"
    "corner of degree other than 6), regular (three interior corners of degree 6).\n";

static void row(FILE *f, const char *name, const pm_summary *s) {
  fprintf(f, "  %-18s %11.6g %11.6g %11.6g %11.6g %11.6g %11.6g\n", name, s->min, s->p25,
          s->median, s->p75, s->max, s->mean);
}

static void table(FILE *f, const char *path, const char *geometry, const pm_mesh *m,
                  const pm_quality *q, const pm_check_report *r, const pm_needles *nd,
                  const pm_distance *d, double seconds) {
  fprintf(f, "mesh       %s\n", path);
  if (geometry) fprintf(f, "geometry   %s\n", geometry);
  fprintf(f, "elements   %ld nodes, %ld segments, %ld triangles, %ld tetrahedra\n",
          (long)m->nnode, (long)m->nseg, (long)m->ntri, (long)m->ntet);
  fprintf(f, "valid      %s\n", r->valid ? "yes" : "no");
  for (int32_t i = 0; i < r->nproblem; ++i) fprintf(f, "  problem: %s\n", r->problem[i]);
  for (int32_t i = 0; i < r->nshell; ++i) {
    const pm_check_shell *s = &r->shell[i];
    if (s->triangles == 0) continue;
    if (s->volume >= 0)
      fprintf(f, "volume %-3d ", s->volume);
    else
      fprintf(f, "surface    ");
    fprintf(f, "V - E + F = %lld, %d component%s, %s", (long long)s->euler,
            s->components, s->components == 1 ? "" : "s", s->closed ? "closed" : "open");
    if (s->genus >= 0) fprintf(f, ", genus %d", s->genus);
    fputc('\n', f);
  }
  const pm_kind_quality *k[2] = {&q->tri, &q->tet};
  static const char *const title[2] = {"triangles", "tetrahedra"};
  static const char *const ang[2][2] = {{"min angle (deg)", "max angle (deg)"},
                                        {"min dihedral (deg)", "max dihedral (deg)"}};
  for (int j = 0; j < 2; ++j) {
    if (k[j]->n == 0) continue;
    fprintf(f, "\n%-20s %11s %11s %11s %11s %11s %11s\n", title[j], "min", "p25", "median",
            "p75", "max", "mean");
    row(f, "radius ratio", &k[j]->s_radius_ratio);
    row(f, "aspect ratio", &k[j]->s_aspect_ratio);
    row(f, ang[j][0], &k[j]->s_min_angle);
    row(f, ang[j][1], &k[j]->s_max_angle);
    if (k[j]->eps_t_nodes > 0)
      fprintf(f, "  eps_t %.6g over %ld interior nodes, eps_g %.6g\n", k[j]->eps_t,
              (long)k[j]->eps_t_nodes, k[j]->eps_g);
    else
      fprintf(f, "  eps_t: no interior nodes, eps_g %.6g\n", k[j]->eps_g);
    if (k[j]->has_size)
      fprintf(f, "  edge length / size: mean %.6g, std %.6g over %lld edges\n",
              k[j]->size_ratio.mean, k[j]->size_ratio_std, (long long)k[j]->nedge);
    if (k[j]->degenerate) fprintf(f, "  degenerate: %ld\n", (long)k[j]->degenerate);
    if (j == 0) {
      const int64_t *b = q->tri_min_angle_bins, *o = q->tri_max_angle_over;
      fprintf(f,
              "  min angle in [0,10) %lld  [10,20) %lld  [20,30) %lld  [30,40) %lld  "
              "[40,50) %lld  [50,60] %lld\n",
              (long long)b[0], (long long)b[1], (long long)b[2], (long long)b[3],
              (long long)b[4], (long long)b[5]);
      fprintf(f, "  max angle > 90 %lld  > 120 %lld  > 150 %lld\n", (long long)o[0],
              (long long)o[1], (long long)o[2]);
      fprintf(f, "  needles (an angle below %g deg): %lld, forced %lld (sharp corners %lld, "
                 "features below the floor %lld), unforced %lld\n",
              PM_NEEDLE_DEG, (long long)nd->count, (long long)(nd->corner + nd->feature),
              (long long)nd->corner, (long long)nd->feature, (long long)nd->unforced);
      const pm_summary *a = q->tri_site_aspect;
      fprintf(f, "  triangles by site: boundary %lld, irregular %lld, regular %lld\n",
              (long long)a[PM_TRI_BOUNDARY].n, (long long)a[PM_TRI_IRREGULAR].n,
              (long long)a[PM_TRI_REGULAR].n);
      for (int w = 0; w < PM_TRI_SITES; ++w) {
        if (a[w].n == 0) continue;
        char name[40];
        snprintf(name, sizeof name, "R/l_min %s", pm_tri_site_name((pm_tri_site)w));
        row(f, name, &a[w]);
      }
    }
  }
  if (d) {
    fprintf(f, "\ndistance   mean %.6g, max %.6g (model diagonal %.6g)\n", d->mean, d->max,
            d->bbox_diagonal);
    if (d->has_size)
      fprintf(f, "           relative to the size field: mean %.6g, max %.6g\n", d->rel_mean,
              d->rel_max);
  }
  fprintf(f, "\ntime       %.3f s\n", seconds);
}

int pm_cli_quality(int argc, char **argv) {
  const char *path = NULL, *size_text = NULL, *geometry = NULL;
  int json = 0, csv = 0;
  for (int i = 1; i < argc;) {
    const char *a = argv[i];
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      fputs(usage_text, stdout);
      return PM_EXIT_OK;
    }
    const char *value = NULL;
    int got = pm_cli_option(argc, argv, &i, "size", &value);
    if (got < 0) return pm_cli_usage("quality", "--size needs a value");
    if (got > 0) {
      if (size_text) return pm_cli_usage("quality", "--size given twice");
      size_text = value;
      continue;
    }
    got = pm_cli_option(argc, argv, &i, "geometry", &value);
    if (got < 0) return pm_cli_usage("quality", "--geometry needs a value");
    if (got > 0) {
      if (geometry) return pm_cli_usage("quality", "--geometry given twice");
      geometry = value;
      continue;
    }
    if (pm_cli_flag(a, "json")) {
      json = 1;
      ++i;
    } else if (pm_cli_flag(a, "csv")) {
      csv = 1;
      ++i;
    } else if (a[0] == '-' && a[1] != '\0') {
      return pm_cli_usage("quality", "unknown option '%s'", a);
    } else {
      if (path) return pm_cli_usage("quality", "one mesh file expected, got '%s' too", a);
      path = a;
      ++i;
    }
  }
  if (!path) return pm_cli_usage("quality", "no mesh file given");
  if (json && csv) return pm_cli_usage("quality", "--json and --csv exclude each other");

  double t0 = pm_cli_now();
  pm_error e = {0};
  pm_mesh *m = NULL;
  pm_quality q = {0};
  pm_check_report r = {0};
  pm_stats st;
  pm_stats_init(&st);
  pm_sizing *size = NULL, *input_size = NULL;
  pm_model *model = NULL;
  pm_distance dist;
  int has_dist = 0;
  char *out = NULL;
  size_t len = 0;
  int code = PM_EXIT_FAIL;
  /* The size field first: a bad --size is reported before any file is read. */
  if (size_text && pm_sizing_parse(size_text, &size, &e)) {
    code = pm_cli_usage("quality", "--size: %s", e.msg);
    goto done;
  }
  if (geometry && pm_input_open(geometry, &model, &input_size, &e)) {
    code = pm_cli_fail("--geometry: %s", e.msg);
    goto done;
  }
  const pm_sizing *field = size ? size : input_size;
  pm_needles nd;
  if (pm_mesh_read(path, &m, &e) || pm_quality_compute(m, field, &q, &e) ||
      pm_mesh_check(m, model, &r, &e) ||
      pm_needles_classify(m, model, PM_NEEDLE_DEG, &nd, NULL, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  if (model && (m->ntri > 0 || m->nseg > 0)) {
    pm_distance_params dp;
    pm_distance_params_init(&dp);
    if (pm_mesh_distance(m, model, field, &dp, &dist, &e)) {
      code = pm_cli_fail("distance to %s: %s", geometry, e.msg);
      goto done;
    }
    has_dist = 1;
  }
  double seconds = pm_cli_now() - t0;
  if (json) {
    pm_stats_set_run(&st, "external", path);
    pm_stats_set_mesh(&st, m);
    pm_stats_set_quality(&st, &q);
    if (has_dist) {
      pm_stats_set_distance(&st, dist.mean, dist.max, dist.bbox_diagonal);
      if (dist.has_size &&
          (pm_stats_add_number(&st, "distance.rel_mean", dist.rel_mean, &e) ||
           pm_stats_add_number(&st, "distance.rel_max", dist.rel_max, &e))) {
        code = pm_cli_error(&e);
        goto done;
      }
    }
    if (pm_stats_set_check(&st, &r, &e) || pm_stats_set_time(&st, "total", seconds, &e) ||
        (m->ntri > 0 && pm_stats_set_needles(&st, &nd, PM_NEEDLE_DEG, &e)) ||
        (field && pm_stats_add_text(&st, "size", pm_sizing_describe(field), &e)) ||
        (geometry && pm_stats_add_text(&st, "geometry", geometry, &e)) ||
        pm_stats_to_json(&st, &out, &e)) {
      code = pm_cli_error(&e);
      goto done;
    }
    len = strlen(out);
  } else {
    /* Built in memory first: nothing reaches stdout unless all of it is ready. */
    FILE *f = open_memstream(&out, &len);
    if (!f) {
      code = pm_cli_fail("out of memory");
      goto done;
    }
    pm_status s = PM_OK;
    if (csv)
      s = pm_stats_write_elements_csv(f, m, &q, &e);
    else
      table(f, path, geometry, m, &q, &r, &nd, has_dist ? &dist : NULL, seconds);
    if (fclose(f) != 0 && !s) s = pm_error_setf(&e, PM_ERR_NOMEM, "out of memory");
    if (s) {
      code = pm_cli_error(&e);
      goto done;
    }
  }
  code = pm_cli_emit(out, len);
done:
  pm_sizing_destroy(size);
  pm_sizing_destroy(input_size);
  pm_model_destroy(model);
  free(out);
  pm_stats_clear(&st);
  pm_check_report_clear(&r);
  pm_quality_clear(&q);
  pm_mesh_destroy(m);
  return code;
}
