/* packmesh cases: the built-in cases (cases.h), one per line or as JSON. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_util.h"
#include "common/input/cases.h"

static int usage_text(void) {
  printf("usage: packmesh cases [--json]\n"
         "Lists the built-in cases: use them as INPUT written case:NAME.\n");
  return PM_EXIT_OK;
}

int pm_cli_cases(int argc, char **argv) {
  int json = 0, done = pm_cli_listing_args(argc, argv, "cases", usage_text, &json);
  if (done >= 0) return done;
  int n = 0;
  const pm_case_info *c = pm_cases(&n);
  if (!json) {
    printf("%-12s %-4s %-28s %s\n", "NAME", "DIM", "DEFAULT SIZE", "DESCRIPTION [SOURCE]");
    for (int i = 0; i < n; ++i) {
      const char *size = c[i].size;
      char shortened[32];
      if (strlen(size) > 27) {
        snprintf(shortened, sizeof shortened, "%.24s...", size);
        size = shortened;
      }
      printf("%-12s %-4d %-28s %s [%s]\n", c[i].name, c[i].dim, size, c[i].description,
             c[i].source);
    }
    fflush(stdout);
    return ferror(stdout) ? pm_cli_fail("cannot write to standard output") : PM_EXIT_OK;
  }
  cJSON *arr = cJSON_CreateArray();
  for (int i = 0; arr && i < n; ++i) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", c[i].name);
    cJSON_AddNumberToObject(o, "dim", c[i].dim);
    cJSON_AddStringToObject(o, "size", c[i].size);
    cJSON_AddStringToObject(o, "description", c[i].description);
    cJSON_AddStringToObject(o, "source", c[i].source);
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
