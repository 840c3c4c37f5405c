/* packmesh references: the full citations behind the papers/NNN keys (the table is the
 * comparison engine's, compare.h: pm_cmp_reference_count, pm_cmp_reference_at).
 *
 *   packmesh references [--json]
 */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_util.h"
#include "compare/src/compare.h"

void pm_cli_references_usage(FILE *f) {
  fputs("usage: packmesh references [--json]\n"
        "The papers that help texts and reports cite as papers/NNN (or NNN in a parameter's\n"
        "[SOURCE]), with their full citations and what packmesh takes from each.\n"
        "  --json  the same as a JSON array of objects (key, citation, used_for)\n"
        "  --help  this text\n",
        f);
}

int pm_cli_references(int argc, char **argv) {
  int json = 0, done = pm_cli_listing_args(argc, argv, "references", pm_cli_references_usage, &json);
  if (done >= 0) return done;
  if (!json) {
    for (int i = 0; i < pm_cmp_reference_count(); ++i) {
      const pm_cmp_reference *r = pm_cmp_reference_at(i);
      printf("%spapers/%s  %s\n            used for %s.\n", i ? "\n" : "", r->key, r->citation,
             r->used_for);
    }
    return ferror(stdout) ? pm_cli_fail("cannot write to standard output") : PM_EXIT_OK;
  }
  cJSON *arr = cJSON_CreateArray();
  int bad = !arr;
  for (int i = 0; i < pm_cmp_reference_count() && !bad; ++i) {
    const pm_cmp_reference *r = pm_cmp_reference_at(i);
    cJSON *o = cJSON_CreateObject();
    char key[16];
    snprintf(key, sizeof key, "papers/%s", r->key);
    bad = !o || !cJSON_AddItemToArray(arr, o) || !cJSON_AddStringToObject(o, "key", key) ||
          !cJSON_AddStringToObject(o, "citation", r->citation) ||
          !cJSON_AddStringToObject(o, "used_for", r->used_for);
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
