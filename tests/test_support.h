/* Shared helpers for the tests (cmocka). */
#ifndef PM_TEST_SUPPORT_H
#define PM_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <unistd.h>

/* Fail with the library's message when a call does not return PM_OK:
 *   pm_error e = {0}; PM_ASSERT_OK(pm_sizing_parse("0.1", &s, &e), e); */
#define PM_ASSERT_OK(call, errvar)                                             \
  do {                                                                         \
    pm_status _s = (call);                                                     \
    if (_s != PM_OK) fail_msg("%s failed: %s", #call, (errvar).msg);           \
  } while (0)

/* Assert |a - b| <= tol with the values in the message. */
#define PM_ASSERT_NEAR(a, b, tol)                                                        \
  do {                                                                                   \
    double _a = (a), _b = (b), _t = (tol);                                               \
    if (!(fabs(_a - _b) <= _t))                                                          \
      fail_msg("%s = %.15g, expected %s = %.15g within %g", #a, _a, #b, _b, _t);         \
  } while (0)

/* Path of a shared CAD model, or skip the test when the folder is not there. */
static inline const char *pm_test_cad(const char *file, char *buf, size_t len) {
  snprintf(buf, len, "%s/%s", PM_CAD_DIR, file);
  return buf;
}
static inline int pm_test_have_cad(void) { return access(PM_CAD_DIR "/CATALOG.md", R_OK) == 0; }

/* The number of newlines in s. */
static inline int pm_test_count_lines(const char *s) {
  int n = 0;
  for (; *s; ++s) n += *s == '\n';
  return n;
}

#endif /* PM_TEST_SUPPORT_H */
