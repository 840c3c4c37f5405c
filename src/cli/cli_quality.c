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

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include "cli/cli.h"
#include "cli/cli_commands.h"
#include "cli/cli_util.h"

static const char *const usage_text =
    "usage: packmesh quality MESH.(msh|vtk|vtu|stl|obj|mesh) [--size EXPR|NUMBER]\n"
    "                        [--geometry INPUT] [--json | --csv]\n"
    "\n"
    "Measure the elements of MESH (.msh, .vtk, .vtu, .stl, .mesh or .obj) and check its validity.\n"
    "  --size S          the desired edge length d(x, y, z), a number or an expression in x, y,\n"
    "                    z, r (\"0.1\", \"0.2*abs(r-2)+0.15\"): adds edge length / d at the edge\n"
    "                    midpoints\n"
    "  --geometry INPUT  the model MESH discretizes: a CAD file (" PM_CLI_CAD_EXTENSIONS "),\n"
    "                    case:NAME or a case file (.json). The checker then verifies conformity,\n"
    "                    closed shells and orientation against it (element entity tag t = cell\n"
    "                    t-1), and the two-sided distance between mesh and model is measured.\n"
    "                    Nodes that the file does not put on cells (.stl, .mesh, .obj, other\n"
    "                    tools' files) are classified onto the model's vertices, curves, faces\n"
    "                    and volumes first. A case's own size field is used when --size is not\n"
    "                    given.\n"
    "  --json            the stats JSON (the keys of packmesh mesh --stats) on stdout\n"
    "  --csv             per-element measures, one row per element:\n"
    "                    kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg\n"
    "                    (for tets the angles are dihedral angles)\n"
    "  --help            this text\n"
    "Measures: radius ratio 2r/R (triangles, 1 = equilateral) and 3r/R (tets); aspect ratio\n"
    "R/l_min; min/max angles; eps_t and eps_g of Shimada & Gossard (1995, eq. 8-9); R/l_min\n"
    "of the triangles by site: boundary (a corner on a curve or vertex), irregular (an interior\n"
    "corner of degree other than 6), regular (three interior corners of degree 6).\n";

void pm_cli_quality_usage(FILE *f) { fputs(usage_text, f); }

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
  pm_report *report = NULL;
  pm_sizing *size = NULL, *input_size = NULL;
  pm_model *model = NULL;
  char *out = NULL;
  size_t len = 0;
  int code = PM_EXIT_FAIL;
  /* The size field first: a bad --size is reported before any file is read. */
  if (size_text && pm_sizing_parse(size_text, &size, &e)) {
    code = pm_cli_usage("quality", "--size: %s", e.msg);
    goto done;
  }
  if (geometry && pm_model_open(geometry, &model, &input_size, &e)) {
    code = pm_cli_fail("--geometry: %s", e.msg);
    goto done;
  }
  const pm_sizing *field = size ? size : input_size;
  /* A mesh without entity tags is put on the model's cells first, so that its interior nodes
   * and sites are those of the same mesh with its tags (pm_mesh_classify). */
  int32_t classified = 0, unmatched = 0;
  if (pm_mesh_read(path, &m, &e) || pm_report_create("external", path, &report, &e) ||
      (model && pm_mesh_classify(m, model, &classified, &unmatched, &e)) ||
      (classified > 0 && (pm_report_add_number(report, "classified.nodes", classified, &e) ||
                          pm_report_add_number(report, "classified.unmatched", unmatched, &e))) ||
      pm_report_measure(report, m, model, field, PM_REPORT_CHECK | PM_REPORT_QUALITY, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  if (model && pm_report_measure(report, m, model, field, PM_REPORT_DISTANCE, &e)) {
    code = pm_cli_fail("distance to %s: %s", geometry, e.msg);
    goto done;
  }
  if (pm_report_set_time(report, "total", pm_cli_now() - t0, &e) ||
      (field && pm_report_add_text(report, "size", pm_sizing_describe(field), &e)) ||
      (geometry && pm_report_add_text(report, "geometry", geometry, &e))) {
    code = pm_cli_error(&e);
    goto done;
  }
  if (json) {
    if (pm_report_stats_json(report, &out, &e)) {
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
    pm_status s = csv ? pm_report_write_elements_csv(report, m, f, &e)
                      : pm_report_write_table(report, geometry, f, &e);
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
  pm_report_destroy(report);
  pm_mesh_destroy(m);
  return code;
}
