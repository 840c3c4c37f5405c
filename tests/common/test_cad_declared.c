/* What CAD files declare about themselves (cad_declared.h): every shared STEP, IGES and BREP
 * model passes; the same files cut short anywhere, or with an entity removed, are refused by name
 * -- by pm_cad_check_declared and by pm_cad_load, which imported bearing.iges cut in half as 43
 * of its 213 faces without an error before; a BREP record that makes OpenCASCADE's reader loop
 * forever is refused after the trial read's time limit. */
#include "test_support.h"

#include <dirent.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/cad_declared.h"
#include "common/geom/geom.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"

static char dir[256];

static char *slurp(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc((size_t)n + 1);
  *len = fread(b, 1, (size_t)n, f);
  fclose(f);
  return b;
}

static int is_step(const char *n) {
  size_t k = strlen(n);
  return (k > 5 && !strcmp(n + k - 5, ".step")) || (k > 4 && !strcmp(n + k - 4, ".stp"));
}
static int is_iges(const char *n) {
  size_t k = strlen(n);
  return (k > 5 && !strcmp(n + k - 5, ".iges")) || (k > 4 && !strcmp(n + k - 4, ".igs"));
}
static int is_brep(const char *n) {
  size_t k = strlen(n);
  return k > 5 && !strcmp(n + k - 5, ".brep");
}

/* Every STEP / IGES / BREP file of folder d: its declarations hold, and cut at 5 to 7 places it
 * is refused. */
static int check_folder(const char *d) {
  DIR *h = opendir(d);
  if (!h) return 0;
  int files = 0;
  struct dirent *de;
  while ((de = readdir(h))) {
    if (!is_step(de->d_name) && !is_iges(de->d_name) && !is_brep(de->d_name)) continue;
    char path[600];
    snprintf(path, sizeof path, "%s/%s", d, de->d_name);
    size_t len;
    char *text = slurp(path, &len);
    assert_non_null(text);
    pm_error e = {0};
    if (pm_cad_check_declared(path, &e)) fail_msg("%s", e.msg);
    const double cut[7] = {0.01, 0.25, 0.5, 0.75, 0.9, 0.99, 0.999};
    /* Some BREP files carry text after their root shape (statreport__A319.brep): cut them
     * before it. */
    for (int k = 0; k < (is_brep(de->d_name) ? 5 : 7); ++k) {
      size_t n = (size_t)(cut[k] * (double)len);
      pm_cad_kind kind = is_step(de->d_name) ? PM_CAD_STEP : is_iges(de->d_name) ? PM_CAD_IGES : PM_CAD_BREP;
      pm_status s = pm_cad_check_declared_text(path, kind, text, n, &e);
      if (s != PM_ERR_PARSE || !strstr(e.msg, de->d_name))
        fail_msg("%s cut at %zu of %zu bytes: status %d, '%s'", de->d_name, n, len, (int)s, e.msg);
    }
    free(text);
    ++files;
  }
  closedir(h);
  return files;
}

static void shared_models_and_their_cuts(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  int n = check_folder(PM_CAD_DIR) + check_folder(PM_CAD_DIR "/robust");
  if (n < 60) fail_msg("only %d STEP, IGES and BREP models found", n); /* 68 in the shared folders */
}

static void damaged_files(void **state) {
  (void)state;
  pm_error e = {0};
  const char *step_ok =
      "ISO-10303-21;\nHEADER;\nFILE_NAME('a#1;b','',(''),(''),'','','');\nENDSEC;\nDATA;\n"
      "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=VERTEX_POINT('it''s #9',#1);\n/* #77 */\n"
      "#3=(A(#1)B(#2));\nENDSEC;\nEND-ISO-10303-21;\n";
  PM_ASSERT_OK(pm_cad_check_declared_text("ok.step", PM_CAD_STEP, step_ok, strlen(step_ok), &e), e);
  struct {
    const char *text, *expect;
  } bad[] = {
      {"ISO-10303-21;\nDATA;\n#1=A(#2);\nENDSEC;\nEND-ISO-10303-21;\n", "#2 is referred to but not defined"},
      {"ISO-10303-21;\nDATA;\n#1=A();\n#1=B();\nENDSEC;\nEND-ISO-10303-21;\n", "#1 is defined twice"},
      {"ISO-10303-21;\nDATA;\n#1=A();\n", "not closed by ENDSEC"},
      {"ISO-10303-21;\nDATA;\n#1=A();\nENDSEC;\n", "does not end with END-ISO-10303-21"},
      {"HEADER;\n", "not a STEP file"},
      {"ISO-10303-21;\nHEADER;\nENDSEC;\nEND-ISO-10303-21;\n", "no DATA section"},
  };
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    pm_status s = pm_cad_check_declared_text("x.step", PM_CAD_STEP, bad[k].text, strlen(bad[k].text), &e);
    if (s != PM_ERR_PARSE || !strstr(e.msg, bad[k].expect)) fail_msg("step %zu: '%s'", k, e.msg);
  }
  /* IGES: 80-column records. */
  char iges[4096] = "";
#define REC(text, sec, seq)                                                      \
  do {                                                                           \
    char r[96];                                                                  \
    snprintf(r, sizeof r, "%-72s%c%7d\n", text, sec, seq);                       \
    strcat(iges, r);                                                             \
  } while (0)
  REC("start", 'S', 1);
  REC("1H,,1H;;", 'G', 1);
  REC("     116       1       0       0       0       0       0       000000000", 'D', 1);
  REC("     116       0       0       1       0                               0", 'D', 2);
  REC("116,0.,0.,0.;                                                    1", 'P', 1);
  char good[4096];
  snprintf(good, sizeof good, "%s", iges);
  REC("S      1G      1D      2P      1", 'T', 1);
  PM_ASSERT_OK(pm_cad_check_declared_text("ok.igs", PM_CAD_IGES, iges, strlen(iges), &e), e);
  assert_int_equal(pm_cad_check_declared_text("t.igs", PM_CAD_IGES, good, strlen(good), &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "no Terminate record"));
  snprintf(iges, sizeof iges, "%s", good);
  REC("S      1G      1D      2P      4", 'T', 1);
  assert_int_equal(pm_cad_check_declared_text("p.igs", PM_CAD_IGES, iges, strlen(iges), &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "declares 4 Parameter records, the file holds 1"));
  /* A Directory entry pointing past the Parameter section. */
  snprintf(iges, sizeof iges, "%s", good);
  char *ptr = strstr(iges, "     116       1       0");
  memcpy(ptr + 8, "       7", 8);
  REC("S      1G      1D      2P      1", 'T', 1);
  assert_int_equal(pm_cad_check_declared_text("d.igs", PM_CAD_IGES, iges, strlen(iges), &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "Directory entry 1 (entity type 116) has its parameters on records 7 to 7"));
  assert_int_equal(pm_cad_check_declared_text("s.igs", PM_CAD_IGES, "short line\n", 11, &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "not an 80-column IGES record"));
#undef REC
}

/* pm_cad_load refuses the truncated file instead of importing part of it. */
static void load_refuses_a_truncated_file(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  size_t len;
  char *text = slurp(PM_CAD_DIR "/bearing.iges", &len);
  assert_non_null(text);
  char path[400];
  snprintf(path, sizeof path, "%s/bearing_half.iges", dir);
  FILE *f = fopen(path, "wb");
  fwrite(text, 1, len / 2, f);
  fclose(f);
  free(text);
  pm_model *m = NULL;
  pm_error e = {0};
  assert_int_equal(pm_cad_load(path, &m, &e), PM_ERR_PARSE);
  assert_null(m);
  assert_non_null(strstr(e.msg, "bearing_half.iges"));
  assert_non_null(strstr(e.msg, "truncated"));
  PM_ASSERT_OK(pm_cad_load(PM_CAD_DIR "/bearing.iges", &m, &e), e);
  assert_int_equal(pm_model_count(m, PM_FACE), 213);
  pm_model_destroy(m);
  unlink(path);
}

/* A BREP edge record with its tolerance line repeated keeps every count, and OpenCASCADE's reader
 * never ends on it: the trial read in a child process is stopped at its time limit. A sound BREP
 * file passes the trial and loads, in a process where gmsh already holds a model. */
static void brep_trial_read(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  const char *damaged = PM_SOURCE_DIR "/tests/data/hostile/generated/boxhole.dupline1.brep";
  PM_ASSERT_OK(pm_cad_load(PM_SOURCE_DIR "/tests/data/hostile/seeds/boxhole.brep", &m, &e), e);
  assert_int_equal(pm_model_count(m, PM_FACE), 7);
  pm_model *bad = NULL;
  assert_int_equal(pm_cad_load(damaged, &bad, &e), PM_ERR_PARSE);
  assert_null(bad);
  assert_non_null(strstr(e.msg, "did not finish reading it within 10 s"));
  pm_model_destroy(m);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_cad_declared_XXXXXX");
  if (!mkdtemp(dir)) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(shared_models_and_their_cuts),
      cmocka_unit_test(damaged_files),
      cmocka_unit_test(load_refuses_a_truncated_file),
      cmocka_unit_test(brep_trial_read),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  rmdir(dir);
  return rc;
}
