/* The progress line of `packmesh mesh`: method, phase, iteration, particles and elapsed time of
 * the run in flight, one line rewritten in place on a terminal (stderr), nothing when stderr is
 * not one unless asked (--progress: then a line every few seconds), nothing at all with --quiet.
 * It reads the rows the particle methods report (pm_progress of packmesh.h, with their trace
 * columns "phase", "step" or "iteration", "bubbles" or "particles"); methods that report none
 * show the stages the command itself runs (loading, meshing, measuring). */
#ifndef PM_CLI_PROGRESS_H
#define PM_CLI_PROGRESS_H

#include <packmesh/packmesh.h>

#include <stddef.h>

typedef enum pm_cli_progress_mode {
  PM_PROGRESS_AUTO = 0, /* on a terminal only */
  PM_PROGRESS_ON,       /* --progress: also into a file or pipe */
  PM_PROGRESS_OFF       /* --quiet */
} pm_cli_progress_mode;

typedef struct pm_cli_progress {
  int active;        /* lines are shown */
  int tty;           /* stderr is a terminal: one line rewritten in place */
  const char *method;
  double t0, last;   /* start and last line, pm_cli_now() seconds */
  int shown;         /* a line is on the terminal (to be cleared before other output) */
  int runs;          /* a node-target search's most runs (0: one run): each line then says
                        which run it is, the one measure of what is left that can be given --
                        the relaxations stop on convergence, after a number of iterations
                        nobody knows in advance */
} pm_cli_progress;

void pm_cli_progress_init(pm_cli_progress *p, pm_cli_progress_mode mode, const char *method);

/* A stage of the command ("loading", "measuring"): shown at once. */
void pm_cli_progress_stage(pm_cli_progress *p, const char *stage);

/* The progress callback of pm_generate (user: the pm_cli_progress); never cancels. */
int pm_cli_progress_report(void *user, const pm_progress *r);

/* Where a run is, from one of its progress reports: "phase 3, iteration 120, 51234 particles"
 * for an iteration (the columns the method has), else the stage ("meshing", "after the
 * method's run"). Into buf (len bytes). */
void pm_cli_progress_where(const pm_progress *r, char *buf, size_t len);

/* Clear the line (before the command's own output and at the end). */
void pm_cli_progress_done(pm_cli_progress *p);

#endif /* PM_CLI_PROGRESS_H */
