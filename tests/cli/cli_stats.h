/* Reading a --stats document from a test (the keys of docs/DESIGN.md). Tests that include this
 * link cJSON. */
#ifndef PM_TEST_CLI_STATS_H
#define PM_TEST_CLI_STATS_H

#include "cli/cli_run.h"

#include <cjson/cJSON.h>

/* The parsed JSON file at path (cJSON_Delete it); the test fails when it is missing or not JSON. */
static inline cJSON *pm_test_read_json(const char *path) {
  char *text = pm_test_slurp(path);
  if (!text) fail_msg("%s: missing", path);
  cJSON *j = cJSON_Parse(text);
  free(text);
  if (!j) fail_msg("%s: not JSON", path);
  return j;
}

/* The number at a[.b[.c]]; the test fails when it is missing. */
static inline double pm_test_stat(const cJSON *j, const char *a, const char *b, const char *c) {
  const cJSON *x = cJSON_GetObjectItemCaseSensitive(j, a);
  if (b) x = cJSON_GetObjectItemCaseSensitive(x, b);
  if (c) x = cJSON_GetObjectItemCaseSensitive(x, c);
  if (!cJSON_IsNumber(x))
    fail_msg("stats key %s%s%s%s%s missing", a, b ? "." : "", b ? b : "", c ? "." : "", c ? c : "");
  return x->valuedouble;
}

#endif /* PM_TEST_CLI_STATS_H */
