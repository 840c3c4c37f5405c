/* Atomic outputs (atomic_file.h): files get 0666 less the umask, a set of outputs appears whole
 * or not at all (a failed rename undoes the ones before it), folders are made and merged, the
 * same file cannot be reserved twice, and the live temporaries are removed by
 * pm_tmp_remove_all (what the command's signal handler calls). */
#include "test_support.h"
#include "test_dirs.h"

#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/base/atomic_file.h"

static int exists(const char *p) {
  struct stat st;
  return stat(p, &st) == 0;
}

/* Entries of folder d (not . and ..). */
static int entries(const char *d) {
  DIR *h = opendir(d);
  if (!h) return -1;
  int n = 0;
  struct dirent *de;
  while ((de = readdir(h)))
    if (strcmp(de->d_name, ".") && strcmp(de->d_name, "..")) ++n;
  closedir(h);
  return n;
}

static void write_text(const char *path, const char *text) {
  FILE *f = fopen(path, "w");
  assert_non_null(f);
  fputs(text, f);
  fclose(f);
}

static void files_respect_the_umask(void **state) {
  (void)state;
  pm_error e = {0};
  const mode_t masks[3] = {022, 077, 002};
  const mode_t want[3] = {0644, 0600, 0664};
  for (int k = 0; k < 3; ++k) {
    mode_t old = umask(masks[k]);
    const char *p = pm_test_in_dir("mode.txt");
    PM_ASSERT_OK(pm_atomic_write(p, "x", 1, &e), e);
    struct stat st;
    assert_int_equal(stat(p, &st), 0);
    if ((st.st_mode & 0777) != want[k])
      fail_msg("umask %03o: mode %03o, want %03o", (unsigned)masks[k], (unsigned)(st.st_mode & 0777),
               (unsigned)want[k]);
    unlink(p);
    /* A set's file and folder too. */
    pm_outputs *s = pm_outputs_create();
    const char *tf, *td;
    PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("set.txt"), 0, &tf, &e), e);
    PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("setdir"), 1, &td, &e), e);
    PM_ASSERT_OK(pm_outputs_commit(s, &e), e);
    pm_outputs_destroy(s);
    assert_int_equal(stat(pm_test_in_dir("set.txt"), &st), 0);
    assert_int_equal(st.st_mode & 0777, want[k]);
    assert_int_equal(stat(pm_test_in_dir("setdir"), &st), 0);
    assert_int_equal(st.st_mode & 0777, 0777 & ~masks[k]);
    unlink(pm_test_in_dir("set.txt"));
    rmdir(pm_test_in_dir("setdir"));
    umask(old);
  }
}

static void a_set_is_all_or_nothing(void **state) {
  (void)state;
  pm_error e = {0};
  /* Written and committed: all three in place, no temporary left. */
  pm_outputs *s = pm_outputs_create();
  const char *t1, *t2, *t3;
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("a.msh"), 0, &t1, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("a.json"), 0, &t2, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("sub/deeper/frames"), 1, &t3, &e), e);
  assert_non_null(strstr(t1, ".pmtmp-"));
  assert_true(strlen(t1) > 4 && strcmp(t1 + strlen(t1) - 4, ".msh") == 0); /* same extension */
  assert_true(exists(t1) && exists(t2) && exists(t3));
  assert_true(exists(pm_test_in_dir("sub/deeper")));
  assert_false(exists(pm_test_in_dir("a.msh")));
  write_text(t1, "mesh");
  write_text(t2, "stats");
  char f[700];
  snprintf(f, sizeof f, "%s/frame_0.vtu", t3);
  write_text(f, "frame");
  PM_ASSERT_OK(pm_outputs_commit(s, &e), e);
  pm_outputs_destroy(s);
  assert_true(exists(pm_test_in_dir("a.msh")) && exists(pm_test_in_dir("a.json")));
  assert_true(exists(pm_test_in_dir("sub/deeper/frames/frame_0.vtu")));
  assert_int_equal(entries(pm_test_dir), 3); /* a.msh, a.json, sub */

  /* Not committed: the temporaries and the folders made for them are gone. */
  s = pm_outputs_create();
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("b.msh"), 0, &t1, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("new/parent/frames"), 1, &t3, &e), e);
  pm_outputs_destroy(s);
  assert_int_equal(entries(pm_test_dir), 3);

  /* A later rename fails (its temporary vanished): the earlier output is undone. */
  s = pm_outputs_create();
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("c.msh"), 0, &t1, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("c.json"), 0, &t2, &e), e);
  write_text(t1, "mesh");
  unlink(t2);
  assert_int_equal(pm_outputs_commit(s, &e), PM_ERR_IO);
  assert_non_null(strstr(e.msg, "c.json"));
  pm_outputs_destroy(s);
  assert_false(exists(pm_test_in_dir("c.msh")));
  assert_false(exists(pm_test_in_dir("c.json")));
  assert_int_equal(entries(pm_test_dir), 3);

  /* Frames into an existing folder with files: moved in, the old ones kept. */
  s = pm_outputs_create();
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("sub/deeper/frames/"), 1, &t3, &e), e);
  snprintf(f, sizeof f, "%s/frame_1.vtu", t3);
  write_text(f, "frame 1");
  PM_ASSERT_OK(pm_outputs_commit(s, &e), e);
  pm_outputs_destroy(s);
  assert_int_equal(entries(pm_test_in_dir("sub/deeper/frames")), 2);
  assert_int_equal(entries(pm_test_in_dir("sub/deeper")), 1);
}

static void unwritable_and_repeated_outputs(void **state) {
  (void)state;
  pm_error e = {0};
  pm_outputs *s = pm_outputs_create();
  const char *t;
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("x.msh"), 0, &t, &e), e);
  /* The same file under other names. */
  char other[700];
  snprintf(other, sizeof other, "%s/./x.msh", pm_test_dir);
  assert_int_equal(pm_outputs_add(s, other, 0, &t, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "names the same file"));
  mkdir(pm_test_in_dir("d"), 0777);
  snprintf(other, sizeof other, "%s/d/../x.msh", pm_test_dir);
  assert_int_equal(pm_outputs_add(s, other, 0, &t, &e), PM_ERR_ARG);
  /* A folder where a file is asked for, a missing folder, a file in the way of a folder. */
  assert_int_equal(pm_outputs_add(s, pm_test_in_dir("d"), 0, &t, &e), PM_ERR_IO);
  assert_non_null(strstr(e.msg, "it is a folder"));
  assert_int_equal(pm_outputs_add(s, pm_test_in_dir("nodir/s.json"), 0, &t, &e), PM_ERR_IO);
  assert_non_null(strstr(e.msg, "nodir/s.json"));
  write_text(pm_test_in_dir("plain"), "x");
  assert_int_equal(pm_outputs_add(s, pm_test_in_dir("plain/s.json"), 0, &t, &e), PM_ERR_IO);
  assert_int_equal(pm_outputs_add(s, pm_test_in_dir("plain"), 1, &t, &e), PM_ERR_IO);
  assert_int_equal(pm_outputs_add(s, pm_test_in_dir("plain/frames"), 1, &t, &e), PM_ERR_IO);
  pm_outputs_destroy(s);
  unlink(pm_test_in_dir("plain"));
  rmdir(pm_test_in_dir("d"));
  assert_int_equal(entries(pm_test_dir), 0);
  assert_true(pm_path_same("a/b.msh", "a/b.msh/"));
  assert_false(pm_path_same("a/b.msh", "b.msh"));
}

static void signals_find_the_temporaries(void **state) {
  (void)state;
  pm_error e = {0};
  pm_atomic_file a;
  PM_ASSERT_OK(pm_atomic_begin(&a, pm_test_in_dir("one.vtu"), 1, &e), e);
  fputs("partial", a.f);
  fflush(a.f);
  pm_outputs *s = pm_outputs_create();
  const char *t1, *t3;
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("two.msh"), 0, &t1, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, pm_test_in_dir("p/q/frames"), 1, &t3, &e), e);
  char f[700];
  snprintf(f, sizeof f, "%s/frame_0.vtu", t3);
  write_text(f, "frame");
  int extra = pm_tmp_track(pm_test_in_dir(".tmp-plot.svg"), 0);
  write_text(pm_test_in_dir(".tmp-plot.svg"), "svg");
  assert_true(entries(pm_test_dir) >= 4);
  pm_tmp_remove_all();
  assert_int_equal(entries(pm_test_dir), 0); /* files, the frames folder and the folders made for it */
  pm_tmp_untrack(extra);
  fclose(a.f);
  a.f = NULL;
  pm_atomic_abort(&a);
  pm_outputs_destroy(s);
  assert_int_equal(entries(pm_test_dir), 0);
}

int main(void) {
  if (pm_test_dirs_init("pm_test_atomic")) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(files_respect_the_umask, pm_test_fresh_dir),
      cmocka_unit_test_setup(a_set_is_all_or_nothing, pm_test_fresh_dir),
      cmocka_unit_test_setup(unwritable_and_repeated_outputs, pm_test_fresh_dir),
      cmocka_unit_test_setup(signals_find_the_temporaries, pm_test_fresh_dir),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  char cmd[300];
  snprintf(cmd, sizeof cmd, "rm -rf %s", pm_test_base);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
