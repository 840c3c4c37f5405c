/* packmesh references: the full citations behind the papers/NNN keys (cli_references.h).
 *
 *   packmesh references [--json]
 *
 * The citations are taken from the papers' own first pages; where a first page does not print
 * the venue (000 gives no institution or year), the citation says only what the document says.
 */
#include "cli/cli_references.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_util.h"

static const pm_cli_reference refs[] = {
    {"000",
     "Saurabh Saini. Implementation and Analysis of a Bubble Packing Method for Surface Mesh "
     "Generation. Thesis (thesis director: Suneeta Ramaswami).",
     "the bubble method's details the 1995 paper leaves out: rhombic quadtree, cut-offs, "
     "population control order, stopping criteria, the k0 sweep"},
    {"001",
     "Jonathan R. Bronson, Joshua A. Levine, Ross T. Whitaker. Particle Systems for Adaptive, "
     "Isotropic Meshing of CAD Models. Engineering with Computers 30(3), 331-343, 2014; first in "
     "Proceedings of the 19th International Meshing Roundtable, Springer, 2010, 279-296.",
     "the psys method: energy, split and delete rules, parameter-space movement, the inferred "
     "sizing field, phases, the aspect-ratio box plots (Fig. 11)"},
    {"003",
     "Kenji Shimada, David C. Gossard. Bubble Mesh: Automated Triangular Meshing of Non-Manifold "
     "Geometry by Sphere Packing. Proceedings of the Third ACM Symposium on Solid Modeling and "
     "Applications (Solid Modeling '95), Salt Lake City, Utah, May 1995, 409-419. ACM, ISBN "
     "0-89791-672-7.",
     "the bubble method: cubic force, RK4 dynamics, confinement to curves and faces, overlap "
     "ratio and population control, the irregularities eps_t and eps_g"},
    {"004",
     "Nan Qi, Yufeng Nie, Weiwei Zhang. Acceleration Strategies Based on an Improved Bubble "
     "Packing Method. Communications in Computational Physics 16(1), 115-135, 2014.",
     "bubble's normalized force, variable viscosity, insertion weights, self-adaptive "
     "termination, the radius ratio and the four planar test domains qi1..qi4"},
};

int pm_cli_reference_count(void) { return (int)(sizeof refs / sizeof refs[0]); }

const pm_cli_reference *pm_cli_reference_at(int i) {
  return i >= 0 && i < pm_cli_reference_count() ? &refs[i] : NULL;
}

static int usage_text(void) {
  printf("usage: packmesh references [--json]\n"
         "The papers that help texts and reports cite as papers/NNN (or NNN in a parameter's\n"
         "[SOURCE]), with their full citations and what packmesh takes from each.\n");
  return PM_EXIT_OK;
}

int pm_cli_references(int argc, char **argv) {
  int json = 0, done = pm_cli_listing_args(argc, argv, "references", usage_text, &json);
  if (done >= 0) return done;
  if (!json) {
    for (int i = 0; i < pm_cli_reference_count(); ++i)
      printf("%spapers/%s  %s\n            used for %s.\n", i ? "\n" : "", refs[i].key,
             refs[i].citation, refs[i].used_for);
    return ferror(stdout) ? pm_cli_fail("cannot write to standard output") : PM_EXIT_OK;
  }
  cJSON *arr = cJSON_CreateArray();
  int bad = !arr;
  for (int i = 0; i < pm_cli_reference_count() && !bad; ++i) {
    cJSON *o = cJSON_CreateObject();
    char key[16];
    snprintf(key, sizeof key, "papers/%s", refs[i].key);
    bad = !o || !cJSON_AddItemToArray(arr, o) || !cJSON_AddStringToObject(o, "key", key) ||
          !cJSON_AddStringToObject(o, "citation", refs[i].citation) ||
          !cJSON_AddStringToObject(o, "used_for", refs[i].used_for);
  }
  char *text = bad ? NULL : cJSON_Print(arr);
  cJSON_Delete(arr);
  if (!text) return pm_cli_fail("out of memory");
  size_t n = strlen(text);
  int rc = pm_cli_emit(text, n);
  if (!rc) rc = pm_cli_emit("\n", 1);
  free(text);
  return rc;
}
