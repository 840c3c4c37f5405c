/* Traces (CSV written whole, read back) and frames (.vtu per snapshot, .pvd index, SVG for
 * planar models). */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/input/cases.h"
#include "common/report/frames.h"
#include "common/report/trace.h"

static char dir[256];

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *s = malloc((size_t)n + 1);
  size_t got = fread(s, 1, (size_t)n, f);
  s[got] = '\0';
  fclose(f);
  return s;
}

static void trace_csv(void **state) {
  (void)state;
  pm_trace *t = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_trace_create(&t, &e), e);
  double row[2] = {1, 2};
  assert_int_equal(pm_trace_add(t, row, &e), PM_ERR_INTERNAL); /* no columns yet */
  const char *cols[2] = {"step", "energy"};
  PM_ASSERT_OK(pm_trace_columns(t, 2, cols, &e), e);
  for (int i = 0; i < 3; ++i) {
    row[0] = i, row[1] = 0.5 * i;
    PM_ASSERT_OK(pm_trace_add(t, row, &e), e);
  }
  assert_int_equal(pm_trace_nrow(t), 3);
  PM_ASSERT_NEAR(pm_trace_row(t, 2)[1], 1.0, 0);
  char path[300];
  snprintf(path, sizeof path, "%s/trace.csv", dir);
  PM_ASSERT_OK(pm_trace_write_csv(t, path, &e), e);
  char *text = slurp(path);
  assert_non_null(text);
  assert_string_equal(text, "step,energy\n0,0\n1,0.5\n2,1\n");
  free(text);
  /* An unwritable place gives an error and leaves nothing. */
  assert_int_equal(pm_trace_write_csv(t, "/nonexistent/dir/trace.csv", &e), PM_ERR_IO);
  pm_trace_destroy(t);
}

static void frames_planar(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("qi2", &m, NULL, &e), e);
  char fdir[300];
  snprintf(fdir, sizeof fdir, "%s/frames/run", dir);
  pm_frames *f = NULL;
  PM_ASSERT_OK(pm_frames_create(fdir, m, &f, &e), e);
  double xyz[6] = {0.5, 0.5, 0, -0.5, 0.5, 0}, r[2] = {0.1, 0.05};
  int8_t d[2] = {2, 1};
  double energy[2] = {1.0, 3.0};
  /* No cells: no triangulation; the second frame is coloured by energy, drawn at half size. */
  pm_run_frame fr = {0, 2, "surface", 2, xyz, r, 1.0, d, NULL, NULL, NULL};
  PM_ASSERT_OK(pm_frames_add(f, &fr, &e), e);
  fr.step = 20, fr.energy = energy, fr.draw_scale = 0.5;
  PM_ASSERT_OK(pm_frames_add(f, &fr, &e), e);
  PM_ASSERT_OK(pm_frames_finish(f, &e), e);
  assert_int_equal(pm_frames_count(f), 2);
  char path[400];
  snprintf(path, sizeof path, "%s/frames.pvd", fdir);
  char *pvd = slurp(path);
  assert_non_null(pvd);
  assert_non_null(strstr(pvd, "timestep=\"20\" file=\"frame_000001.vtu\""));
  free(pvd);
  snprintf(path, sizeof path, "%s/frame_000001.vtu", fdir);
  char *vtu = slurp(path);
  assert_non_null(strstr(vtu, "NumberOfPoints=\"2\""));
  assert_non_null(strstr(vtu, "Name=\"radius\""));
  free(vtu);
  snprintf(path, sizeof path, "%s/frame_000001.svg", fdir);
  char *svg = slurp(path);
  assert_non_null(svg);
  assert_non_null(strstr(svg, "<svg"));
  assert_non_null(strstr(svg, "phase 2 (surface): step 20, 2 particles, coloured by energy"));
  /* The energy scale's ends: the lower energy dark (viridis' first stop), the higher yellow. */
  assert_non_null(strstr(svg, "fill=\"#440154\""));
  assert_non_null(strstr(svg, "fill=\"#fde725\""));
  assert_null(strstr(svg, "<path"));
  /* Two circles, and the five boundary curves (four sides and the hole). */
  int circles = 0, lines = 0;
  for (const char *p = svg; (p = strstr(p, "<circle")); ++p) ++circles;
  for (const char *p = svg; (p = strstr(p, "<polyline")); ++p) ++lines;
  assert_int_equal(circles, 2);
  assert_int_equal(lines, 5);
  /* The circles at draw_scale x radius: 0.05 and 0.025 of a 2.12-wide box (2 and its padding) drawn 800 px wide. */
  assert_non_null(strstr(svg, "r=\"18.87\""));
  assert_non_null(strstr(svg, "r=\"9.43\""));
  free(svg);
  /* The same picture's numbers for gnuplot: the header, three blocks, a row per particle. */
  snprintf(path, sizeof path, "%s/frame_000001.dat", fdir);
  char *dat = slurp(path);
  assert_non_null(dat);
  assert_non_null(strstr(dat, "# title: phase 2 (surface): step 20, 2 particles"));
  assert_non_null(strstr(dat, "# triangles: 0\n"));
  assert_non_null(strstr(dat, "\n0.5 0.5 0.05 4456788\n")); /* 0x440154 */
  assert_non_null(strstr(dat, "\n-0.5 0.5 0.025 16639781\n")); /* 0xfde725 */
  free(dat);
  pm_frames_destroy(f);
  /* A file where the folder should be. */
  snprintf(path, sizeof path, "%s/trace.csv", dir);
  assert_int_equal(pm_frames_create(path, m, &f, &e), PM_ERR_IO);
  pm_model_destroy(m);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_frames_%d", (int)getpid());
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
  if (system(cmd) != 0) return 1;
  const struct CMUnitTest tests[] = {cmocka_unit_test(trace_csv), cmocka_unit_test(frames_planar)};
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
