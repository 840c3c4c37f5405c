/* packmesh demo (long): on this machine's two cores the whole study -- runs, tables, figures,
 * report -- takes under two minutes, every run succeeds, every method's node count is within 3%
 * of the reference's, the report has a picture of every mesh, and its 3D viewer draws in
 * headless Chromium without a console error. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc((size_t)n + 1);
  if (b && fread(b, 1, (size_t)n, f) != (size_t)n) n = 0;
  if (b) b[n] = '\0';
  fclose(f);
  return b;
}

/* Field k (0-based) of a CSV line without quoted commas before it. */
static void field(const char *line, int k, char *out, size_t len) {
  for (int i = 0; i < k && line; ++i) {
    if (*line == '"') { /* skip a quoted field */
      line = strchr(line + 1, '"');
      while (line && line[1] == '"') line = strchr(line + 2, '"');
      if (line) line++;
    } else {
      line = strchr(line, ',');
    }
    if (line && *line == ',') line++;
  }
  size_t n = line ? strcspn(line, ",\n") : 0;
  snprintf(out, len, "%.*s", (int)(n < len ? n : len - 1), line ? line : "");
}

static void test_demo(void **state) {
  (void)state;
  char dir[512];
  snprintf(dir, sizeof dir, "%s/tests/compare/demo-XXXXXX", PM_BINARY_DIR);
  assert_non_null(mkdtemp(dir));
  char cmd[2048];
  snprintf(cmd, sizeof cmd, "'%s' demo -o '%s/study' --jobs 2 > '%s/out.txt' 2> '%s/err.txt'",
           PM_CLI, dir, dir, dir);
  struct timespec a, b;
  clock_gettime(CLOCK_MONOTONIC, &a);
  int rc = system(cmd);
  clock_gettime(CLOCK_MONOTONIC, &b);
  double secs = (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
  print_message("packmesh demo: %.1f s\n", secs);
  assert_true(WIFEXITED(rc) && WEXITSTATUS(rc) == 0);
  assert_true(secs < 120);
  char p[1024];
  snprintf(p, sizeof p, "%s/out.txt", dir);
  char *out = slurp(p);
  assert_non_null(strstr(out, "report: "));
  free(out);
  snprintf(p, sizeof p, "%s/study/report.html", dir);
  assert_int_equal(access(p, R_OK), 0);

  /* Every run ok; node counts within 3% of the reference of their case (target_nodes). */
  snprintf(p, sizeof p, "%s/study/results.csv", dir);
  char *csv = slurp(p);
  assert_non_null(csv);
  char *hdr = csv, *line = strchr(csv, '\n');
  *line++ = '\0';
  int c_nodes = -1, c_target = -1, c_status = 5, c_row = -1, k = 0;
  for (char *t = strtok(hdr, ","); t; t = strtok(NULL, ","), ++k) {
    if (strcmp(t, "nodes") == 0) c_nodes = k;
    if (strcmp(t, "target_nodes") == 0) c_target = k;
    if (strcmp(t, "row") == 0) c_row = k;
  }
  assert_true(c_nodes > 0 && c_row > 0);
  int rows = 0, matched = 0;
  while (line && *line) {
    /* The command column is quoted when it holds commas; fields before "row" are read with the
     * quoted-field skip above. */
    char st[64], nodes[64], target[64], row[256];
    field(line, c_status, st, sizeof st);
    field(line, c_row, row, sizeof row);
    field(line, c_nodes, nodes, sizeof nodes);
    if (strcmp(st, "ok") != 0) fail_msg("demo run %s: %s", row, st);
    if (c_target > 0) {
      field(line, c_target, target, sizeof target);
      if (target[0]) {
        double n = atof(nodes), t = atof(target);
        if (!(fabs(n / t - 1) <= 0.03)) fail_msg("%s: %g nodes, target %g", row, n, t);
        matched++;
      }
    }
    rows++;
    line = strchr(line, '\n');
    if (line) line++;
  }
  print_message("%d runs, %d matched to their reference\n", rows, matched);
  assert_true(rows >= 3);
  free(csv);

  /* A picture of every mesh and its zoom, and the 3D viewer: in headless Chromium the report
   * loads with no console error and the viewer's canvas is drawn (tests/scripts/page_check.py;
   * not checked without chromium, exit 77). */
  snprintf(p, sizeof p, "%s/study/report.html", dir);
  char *html = slurp(p);
  assert_non_null(html);
  int pictures = 0;
  for (const char *q = html; (q = strstr(q, "<img src=\"plots/mesh_")) != NULL; ++q) pictures++;
  assert_int_equal(pictures, 2 * rows);
  free(html);
  snprintf(cmd, sizeof cmd,
           "/usr/bin/python3 '%s/tests/scripts/page_check.py' '%s/study/report.html' --canvas "
           "'#pm-viewer-canvas' --expect-text '3D viewer' > '%s/page.txt' 2>&1",
           PM_SOURCE_DIR, dir, dir);
  rc = system(cmd);
  snprintf(p, sizeof p, "%s/page.txt", dir);
  char *page = slurp(p);
  if (WIFEXITED(rc) && WEXITSTATUS(rc) == 77)
    print_message("chromium is not installed: the report is not loaded\n");
  else if (!WIFEXITED(rc) || WEXITSTATUS(rc) != 0)
    fail_msg("report.html in Chromium: %s", page ? page : "(no output)");
  free(page);
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  assert_int_equal(system(cmd), 0);
}

int main(void) {
  const struct CMUnitTest tests[] = {cmocka_unit_test(test_demo)};
  return cmocka_run_group_tests(tests, NULL, NULL);
}
