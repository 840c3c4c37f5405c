/* packmesh cases: the built-in cases (pm_case_* of packmesh.h), one per line or as JSON. */
#include <packmesh/packmesh.h>

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_util.h"

void pm_cli_cases_usage(FILE *f) {
  fputs("usage: packmesh cases [--json]\n"
        "Lists the built-in cases: use them as INPUT written case:NAME. Each has a dimension (2:\n"
        "a planar domain, 3: a solid), a default size field and the paper or construction it\n"
        "comes from.\n"
        "  --json  the same as a JSON array of objects (name, dim, size, description, source)\n"
        "  --help  this text\n",
        f);
}

int pm_cli_cases(int argc, char **argv) {
  int json = 0, done = pm_cli_listing_args(argc, argv, "cases", pm_cli_cases_usage, &json);
  if (done >= 0) return done;
  const int n = pm_case_count();
  if (!json) {
    printf("%-12s %-4s %-28s %s\n", "NAME", "DIM", "DEFAULT SIZE", "DESCRIPTION [SOURCE]");
    for (int i = 0; i < n; ++i) {
      const char *size = pm_case_default_size(i);
      char shortened[32];
      if (strlen(size) > 27) {
        snprintf(shortened, sizeof shortened, "%.24s...", size);
        size = shortened;
      }
      printf("%-12s %-4d %-28s %s [%s]\n", pm_case_name(i), pm_case_dimension(i), size,
             pm_case_description(i), pm_case_source(i));
    }
    fflush(stdout);
    return ferror(stdout) ? pm_cli_fail("cannot write to standard output") : PM_EXIT_OK;
  }
  cJSON *arr = cJSON_CreateArray();
  for (int i = 0; arr && i < n; ++i) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", pm_case_name(i));
    cJSON_AddNumberToObject(o, "dim", pm_case_dimension(i));
    cJSON_AddStringToObject(o, "size", pm_case_default_size(i));
    cJSON_AddStringToObject(o, "description", pm_case_description(i));
    cJSON_AddStringToObject(o, "source", pm_case_source(i));
    cJSON_AddItemToArray(arr, o);
  }
  char *text = arr ? cJSON_Print(arr) : NULL;
  cJSON_Delete(arr);
  if (!text) return pm_cli_fail("out of memory");
  size_t len = strlen(text);
  text = realloc(text, len + 2);
  text[len] = '\n', text[len + 1] = '\0';
  int rc = pm_cli_emit(text, len + 1);
  free(text);
  return rc;
}
