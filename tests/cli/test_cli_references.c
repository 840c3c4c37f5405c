/* packmesh references: every paper key that the help texts and a comparison report cite (papers/NNN,
 * or NNN in a parameter's [SOURCE]) has a full citation, and the report lists the papers it cites
 * with their citations under "References". */
#include "test_support.h"

#include <ctype.h>
#include <sys/stat.h>

#include "cli/cli_run.h"

static char dir[256];

/* Adds to keys[] (as "000".."099", up to 32) every paper key in text: "papers/NNN" and a bare
 * three-digit number starting with 0 that is not part of a longer number ("003 eq. 11",
 * "(papers/003, 000, 004)"). */
static void collect_keys(const char *text, char keys[][4], int *n) {
  for (const char *c = text; *c; ++c) {
    if (c[0] != '0' || !isdigit((unsigned char)c[1]) || !isdigit((unsigned char)c[2])) continue;
    if (c > text && (isdigit((unsigned char)c[-1]) || c[-1] == '.' || isalpha((unsigned char)c[-1])))
      continue;
    if (isdigit((unsigned char)c[3]) || isalpha((unsigned char)c[3]) ||
        (c[3] == '.' && isdigit((unsigned char)c[4])))
      continue;
    char k[4] = {c[0], c[1], c[2], 0};
    int have = 0;
    for (int i = 0; i < *n; ++i) have |= strcmp(keys[i], k) == 0;
    if (!have && *n < 32) memcpy(keys[(*n)++], k, 4);
  }
}

static char *run_ok(const char *args) {
  char *out = NULL, *err = NULL;
  int rc = pm_test_cli(dir, args, &out, &err);
  if (rc != 0) fail_msg("packmesh %s: exit %d: %s", args, rc, err);
  free(err);
  return out;
}

/* The citation `references` prints for key, or fail. */
static void assert_cited(const char *refs, const char *key, const char *where) {
  char head[160];
  snprintf(head, sizeof head, "papers/%s  ", key);
  const char *at = strstr(refs, head);
  if (!at) fail_msg("%s cites %s, which 'packmesh references' does not list", where, key);
  const char *end = strchr(at, '\n');
  /* Authors, a title and where it appeared: more than a name. */
  if (!end || end - at < 80) fail_msg("papers/%s: citation too short: %.*s", key, (int)(end ? end - at : 40), at);
}

static void help_keys_are_cited(void **state) {
  (void)state;
  char *refs = run_ok("references");
  char keys[32][4];
  int n = 0;
  const char *fixed[] = {"--help", "mesh --help", "cases", "cases --json", "quality --help",
                         "compare --help", "demo --help"};
  for (size_t k = 0; k < sizeof fixed / sizeof fixed[0]; ++k) {
    char *t = run_ok(fixed[k]);
    collect_keys(t, keys, &n);
    free(t);
  }
  /* Every method's --help: the names from `mesh --help`'s "methods:" line. */
  char *mh = run_ok("mesh --help");
  const char *line = strstr(mh, "methods: ");
  assert_non_null(line);
  line += strlen("methods: ");
  int nmethods = 0;
  while (*line && *line != '(' && *line != '\n') {
    char name[64];
    int len = 0;
    while (*line && *line != ',' && *line != ' ' && len < 63) name[len++] = *line++;
    name[len] = '\0';
    while (*line == ',' || *line == ' ') ++line;
    if (!len) break;
    char args[128];
    snprintf(args, sizeof args, "mesh --method %s --help", name);
    char *t = run_ok(args);
    collect_keys(t, keys, &n);
    free(t);
    ++nmethods;
  }
  free(mh);
  assert_int_equal(nmethods, 6);
  /* The four papers are cited in help: bubble's three, psys's one. */
  assert_int_equal(n, 4);
  for (int i = 0; i < n; ++i) assert_cited(refs, keys[i], "help");
  assert_non_null(strstr(refs, "Shimada"));
  assert_non_null(strstr(refs, "Solid Modeling '95"));
  assert_non_null(strstr(refs, "Bronson"));
  assert_non_null(strstr(refs, "Communications in Computational Physics"));
  free(refs);
  /* The JSON form has the same keys. */
  char *js = run_ok("references --json");
  assert_non_null(strstr(js, "\"key\":\t\"papers/003\""));
  free(js);
  pm_test_cli_error(dir, "references --bogus", 2, "see 'packmesh references --help'");
}

/* A small study: its report cites papers/003 (eps_t, eps_g) and lists it in full, in Markdown
 * and HTML, and every key the report cites is in its References. */
static void report_lists_its_references(void **state) {
  (void)state;
  char suite[400], args[1200], path[400];
  snprintf(suite, sizeof suite, "%s/s.json", dir);
  FILE *f = fopen(suite, "w");
  assert_non_null(f);
  fputs("{\"name\": \"refs\", \"description\": \"qi1 as in papers/004 section 3.1\","
        " \"cases\": [\"case:qi1\"], \"size\": 0.5, \"methods\": [\"gmsh-frontal\"],"
        " \"seeds\": [1]}\n", f);
  fclose(f);
  snprintf(args, sizeof args, "compare '%s' -o '%s/study'", suite, dir);
  free(run_ok(args));
  snprintf(path, sizeof path, "%s/study/report.md", dir);
  char *md = pm_test_slurp(path);
  assert_non_null(md);
  const char *refs = strstr(md, "\n## References\n");
  if (!refs) fail_msg("report.md has no References section");
  assert_non_null(strstr(refs, "papers/003: Kenji Shimada, David C. Gossard. Bubble Mesh"));
  assert_non_null(strstr(refs, "papers/004: Nan Qi"));
  char keys[32][4];
  int n = 0;
  for (const char *c = md; (c = strstr(c, "papers/")); c += 7) collect_keys(c + 7, keys, &n);
  for (int i = 0; i < n; ++i) {
    char want[160];
    snprintf(want, sizeof want, "papers/%s: ", keys[i]);
    if (!strstr(refs, want)) fail_msg("report.md cites papers/%s without its reference", keys[i]);
  }
  free(md);
  snprintf(path, sizeof path, "%s/study/report.html", dir);
  char *html = pm_test_slurp(path);
  assert_non_null(html);
  assert_non_null(strstr(html, "<h2>References</h2>"));
  assert_non_null(strstr(html, "papers/003: Kenji Shimada"));
  free(html);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_cli_references_%d", (int)getpid());
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
  if (system(cmd) != 0) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(help_keys_are_cited),
      cmocka_unit_test(report_lists_its_references),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
