/* A scratch folder per test: pm_test_dirs_init makes the run's base folder under /tmp (NAME is
 * its prefix), pm_test_fresh_dir (a cmocka setup) a new folder in it for each test, and
 * pm_test_in_dir names a file there (four names can be live at once). The caller removes the
 * base folder at the end. */
#ifndef PM_TEST_DIRS_H
#define PM_TEST_DIRS_H

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>

static char pm_test_base[256], pm_test_dir[300];

static inline int pm_test_dirs_init(const char *name) {
  snprintf(pm_test_base, sizeof pm_test_base, "/tmp/%s_XXXXXX", name);
  return mkdtemp(pm_test_base) ? 0 : -1;
}

static inline int pm_test_fresh_dir(void **state) {
  (void)state;
  static int k;
  snprintf(pm_test_dir, sizeof pm_test_dir, "%s/t%d", pm_test_base, ++k);
  return mkdir(pm_test_dir, 0777);
}

static inline const char *pm_test_in_dir(const char *name) {
  static char buf[4][700];
  static int k;
  k = (k + 1) % 4;
  snprintf(buf[k], sizeof buf[k], "%s/%s", pm_test_dir, name);
  return buf[k];
}

#endif /* PM_TEST_DIRS_H */
