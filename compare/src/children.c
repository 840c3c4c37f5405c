/* The process groups of the helpers the engine is running (gnuplot, dpkg-query: util.c's
 * pm_cmp_run_program), so that a signal handler can end them before the process exits. The table
 * is fixed and lock-free: a slot holds a process group id or 0, so pm_cmp_children_kill_all,
 * which a SIGINT / SIGTERM handler calls, only loads atomics and calls kill (async-signal-safe).
 */
#include <signal.h>
#include <stdatomic.h>
#include <sys/types.h>

#include "compare/src/study.h"

#define GROUPS 64

static atomic_int group[GROUPS]; /* process groups to end, 0 free */

int pm_cmp_children_add(pid_t pgid) {
  for (int i = 0; i < GROUPS; ++i) {
    int expected = 0;
    if (atomic_compare_exchange_strong(&group[i], &expected, (int)pgid)) return i;
  }
  return -1;
}

void pm_cmp_children_forget(int id) {
  if (id >= 0 && id < GROUPS) atomic_store(&group[id], 0);
}

void pm_cmp_children_kill_all(void) {
  for (int i = 0; i < GROUPS; ++i) {
    int g = atomic_load(&group[i]);
    if (g > 0) kill(-g, SIGKILL);
  }
}
