/* SIGINT and SIGTERM in the packmesh command (see cli_signal.h). Everything the handler touches
 * is set up before it can run and read without locks; it calls only async-signal-safe
 * functions (kill, unlink, rmdir, write, _exit, pthread_kill, pthread_self) and
 * pm_cmp_children_kill_all, which ends the comparison engine's helper process groups with kill. */
#include "cli/cli_signal.h"

#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <packmesh/packmesh_extended.h>

#include "compare/src/compare.h"

static pid_t owner;
static pthread_t owner_thread;
static char head[96];
static char detail[160];
static volatile sig_atomic_t handling;

static void put(const char *s) {
  size_t n = strlen(s);
  while (n > 0) {
    ssize_t w = write(2, s, n);
    if (w <= 0) return;
    s += w, n -= (size_t)w;
  }
}

static void on_signal(int sig) {
  if (getpid() != owner) {
    /* A forked helper: end as without a handler (the signal is delivered on return). */
    signal(sig, SIG_DFL);
    raise(sig);
    return;
  }
  if (!pthread_equal(pthread_self(), owner_thread)) {
    pthread_kill(owner_thread, sig);
    return;
  }
  if (handling) return;
  handling = 1;
  pm_cmp_children_kill_all();
  pm_tmp_remove_all();
  put(head);
  put(sig == SIGINT ? "SIGINT" : "SIGTERM");
  put(detail);
  put("\n");
  _exit(128 + sig);
}

void pm_cli_signals_install(const char *command) {
  owner = getpid();
  owner_thread = pthread_self();
  snprintf(head, sizeof head, "packmesh: %s interrupted by ", command);
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaddset(&sa.sa_mask, SIGINT);
  sigaddset(&sa.sa_mask, SIGTERM);
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
}

void pm_cli_signals_detail(const char *text) {
  sigset_t s, old;
  sigemptyset(&s);
  sigaddset(&s, SIGINT);
  sigaddset(&s, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &s, &old);
  snprintf(detail, sizeof detail, "%s", text ? text : "");
  pthread_sigmask(SIG_SETMASK, &old, NULL);
}
