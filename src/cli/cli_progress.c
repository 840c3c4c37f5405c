/* The progress line (cli_progress.h). */
#include "cli/cli_progress.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli/cli_util.h"

/* A terminal line at most 4 times a second; into a file or pipe (--progress) one every 2 s. */
#define TTY_PERIOD 0.25
#define PIPE_PERIOD 2.0

void pm_cli_progress_init(pm_cli_progress *p, pm_cli_progress_mode mode, const char *method) {
  memset(p, 0, sizeof *p);
  p->tty = isatty(STDERR_FILENO);
  p->active = mode == PM_PROGRESS_ON || (mode == PM_PROGRESS_AUTO && p->tty);
  p->method = method;
  p->t0 = pm_cli_now();
  p->last = -1e30;
}

static void put(pm_cli_progress *p, const char *text) {
  double t = pm_cli_now() - p->t0;
  int min = (int)(t / 60);
  if (p->tty)
    fprintf(stderr, "\r\033[K%s: %s, %d:%04.1f", p->method, text, min, t - 60 * min);
  else
    fprintf(stderr, "packmesh: %s: %s, %d:%04.1f\n", p->method, text, min, t - 60 * min);
  fflush(stderr);
  p->shown = p->tty;
}

void pm_cli_progress_stage(pm_cli_progress *p, const char *stage) {
  if (!p->active) return;
  p->last = pm_cli_now();
  put(p, stage);
}

/* The column named one of names, or -1. */
static int column(const pm_progress *r, const char *const *names) {
  for (int c = 0; c < r->ncol; ++c)
    for (int k = 0; names[k]; ++k)
      if (strcmp(r->columns[c], names[k]) == 0) return c;
  return -1;
}

int pm_cli_progress_report(void *user, const pm_progress *r) {
  pm_cli_progress *p = user;
  if (!p->active) return 0;
  char run[64] = "";
  if (p->runs > 1 && r->run >= 1)
    snprintf(run, sizeof run, " (run %d of at most %d)", r->run, p->runs);
  if (strcmp(r->stage, "meshing") == 0) {
    char text[96];
    snprintf(text, sizeof text, "meshing%s", run);
    pm_cli_progress_stage(p, text);
    return 0;
  }
  if (strcmp(r->stage, "iteration") != 0) return 0;
  double now = pm_cli_now();
  if (now - p->last < (p->tty ? TTY_PERIOD : PIPE_PERIOD)) return 0;
  p->last = now;
  char text[200];
  int n = snprintf(text, sizeof text, "placing nodes, ");
  pm_cli_progress_where(r, text + n, sizeof text - (size_t)n);
  n = (int)strlen(text);
  snprintf(text + n, sizeof text - (size_t)n, "%s", run);
  put(p, text);
  return 0;
}

void pm_cli_progress_where(const pm_progress *r, char *buf, size_t len) {
  if (strcmp(r->stage, "iteration") != 0) {
    snprintf(buf, len, "%s", strcmp(r->stage, "done") == 0 ? "after the method's run" : r->stage);
    return;
  }
  static const char *const phase_names[] = {"phase", NULL};
  static const char *const step_names[] = {"step", "iteration", NULL};
  static const char *const count_names[] = {"bubbles", "particles", NULL};
  int cp = column(r, phase_names), cs = column(r, step_names), cn = column(r, count_names);
  int n = 0;
  buf[0] = '\0';
  if (cp >= 0) n += snprintf(buf + n, len - (size_t)n, "phase %.0f, ", r->values[cp]);
  if (cs >= 0 && (size_t)n < len)
    n += snprintf(buf + n, len - (size_t)n, "iteration %.0f, ", r->values[cs]);
  if (cn >= 0 && (size_t)n < len)
    n += snprintf(buf + n, len - (size_t)n, "%.0f %s, ", r->values[cn], r->columns[cn]);
  /* without the last ", " */
  if (n >= 2 && (size_t)n <= len) buf[n - 2] = '\0';
  else if (n == 0) snprintf(buf, len, "iteration %lld", (long long)r->iteration);
}

void pm_cli_progress_done(pm_cli_progress *p) {
  if (p->shown) {
    fputs("\r\033[K", stderr);
    fflush(stderr);
  }
  p->shown = 0;
}
