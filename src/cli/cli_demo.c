/* packmesh demo [-o DIR]: the default comparison study on built-in cases -- the local-density
 * square of papers/004 (qi3), Shimada's sinusoidal field (papers/003 eq. 17) and a CAD solid
 * built with OpenCASCADE (boxhole: a box with a cylindrical hole, meshed with tets) -- with
 * bubble, psys, gmsh's Frontal-Delaunay and CGAL (planar cases only), node counts matched to
 * bubble's as papers/001 section 5.1 matched them by hand. It needs no file: the suite is built
 * here (and saved as DIR/suite.json, so it can be edited and rerun with packmesh compare).
 * Methods this build does not have are left out and named in the report.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <packmesh/packmesh.h>

#include "cli/cli.h"
#include "cli/cli_compare.h"
#include "cli/cli_util.h"

static const char *const usage_text =
    "usage: packmesh demo [-o DIR] [--jobs N] [--quiet]\n"
    "\n"
    "Runs the default comparison on built-in cases (qi3, shimada, and the CAD solid boxhole\n"
    "with tets) with bubble, psys, gmsh-frontal and cgal (planar cases), node counts matched\n"
    "to bubble's, and writes the study into DIR: results.csv, elements.csv, plots/ and\n"
    "report.html / report.md. Running it again resumes. See 'packmesh compare --help' for what\n"
    "the folder holds.\n"
    "  -o, --output DIR  the study's folder (default ./packmesh-demo)\n"
    "  --jobs N          runs at once (default: the number of cores)\n"
    "  --quiet           no progress on stderr\n"
    "  --help            this text\n";

void pm_cli_demo_usage(FILE *f) { fputs(usage_text, f); }

/* Per-run time limit: the demo is meant to finish in two minutes on two cores. */
#define DEMO_TIMEOUT_S 90

typedef struct demo_method {
  const char *name, *entry;
} demo_method;

static const demo_method candidates[] = {
    {"bubble", "{\"method\": \"bubble\"}"},
    {"psys", "{\"method\": \"psys\"}"},
    {"gmsh-frontal", "{\"method\": \"gmsh-frontal\"}"},
    {"cgal", "{\"method\": \"cgal\", \"cases\": [\"qi3\", \"shimada\"]}"},
};
#define NCAND ((int)(sizeof candidates / sizeof candidates[0]))

int pm_cli_demo(int argc, char **argv) {
  const char *dir = "packmesh-demo";
  pm_cli_compare_options o = {0};
  for (int i = 1; i < argc;) {
    const char *a = argv[i];
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      fputs(usage_text, stdout);
      return PM_EXIT_OK;
    }
    int code = 0;
    if (pm_cli_compare_option("demo", argc, argv, &i, &dir, &o, &code)) {
      if (code) return code;
      continue;
    }
    return pm_cli_usage("demo", "unknown argument '%s'", a);
  }

  /* The methods of this build, in the order above; the first present is the reference. */
  char methods[1024] = "", missing[256] = "";
  const char *reference = NULL;
  for (int k = 0; k < NCAND; ++k) {
    if (pm_method_find(candidates[k].name)) {
      if (!reference) reference = candidates[k].name;
      strncat(methods, methods[0] ? ",\n    " : "    ", sizeof methods - strlen(methods) - 1);
      strncat(methods, candidates[k].entry, sizeof methods - strlen(methods) - 1);
    } else {
      strncat(missing, missing[0] ? ", " : "", sizeof missing - strlen(missing) - 1);
      strncat(missing, candidates[k].name, sizeof missing - strlen(missing) - 1);
    }
  }
  if (!reference) return pm_cli_fail("this build has none of the demo's methods (bubble, psys, gmsh-frontal, cgal)");
  char text[4096];
  snprintf(text, sizeof text,
           "{\n"
           "  \"name\": \"demo\",\n"
           "  \"description\": \"The default comparison: the local-density square of Qi et al. "
           "(papers/004 section 3.3), Shimada's sinusoidal field (papers/003 eq. 17) and a CAD "
           "solid (a box with a cylindrical hole, built with OpenCASCADE, meshed with tets), each "
           "method's node count matched to %s's within 3%%, as papers/001 section 5.1 matched "
           "them by hand.%s%s%s\",\n"
           "  \"cases\": [\n"
           "    \"case:qi3\",\n"
           "    \"case:shimada\",\n"
           "    {\"input\": \"case:boxhole\", \"volume\": true}\n"
           "  ],\n"
           "  \"methods\": [\n%s\n  ],\n"
           "  \"seeds\": [1],\n"
           "  \"options\": {\"match_nodes\": true, \"reference\": \"%s\", \"timeout_s\": %d}\n"
           "}\n",
           reference, missing[0] ? " Not in this build, so left out: " : "", missing,
           missing[0] ? "." : "", methods, reference, DEMO_TIMEOUT_S);
  pm_error e = {0};
  pm_cmp_suite s;
  if (pm_cmp_suite_parse(text, NULL, "", &s, &e)) return pm_cli_error(&e);
  char inv[4200];
  snprintf(inv, sizeof inv, "packmesh demo -o %s", dir);
  if (o.jobs) snprintf(inv + strlen(inv), sizeof inv - strlen(inv), " --jobs %d", o.jobs);
  return pm_cli_compare_execute(&s, dir, &o, inv);
}
