/* What `packmesh compare` and `packmesh demo` share (cli_compare.c): their common options and
 * running a suite through the comparison engine (compare/src/compare.h) with the command's
 * messages, signal handling and exit codes. */
#ifndef PM_CLI_COMPARE_H
#define PM_CLI_COMPARE_H

#include "compare/src/compare.h"

typedef struct pm_cli_compare_options {
  int jobs;            /* parallel runs; 0: the number of cores */
  double timeout_s;    /* > 0: overrides the suite's time limit per run */
  int retry_failed;    /* rerun rows that failed in an earlier invocation */
  int quiet;           /* no progress */
  /* compare only (demo leaves them 0): */
  int slurm;           /* --engine slurm: submit the study to Slurm */
  int wait;            /* --wait: follow the Slurm jobs until the report exists */
  char **sbatch_args;  /* [nsbatch_arg] --slurm-opt's words (owned by the caller) */
  int nsbatch_arg;
  int collect;         /* --collect: the tables, figures and report from the folder */
  int task;            /* --slurm-task ROW: run one row (a Slurm array task) */
  int task_row;
  const char *suite_path; /* the suite file (the Slurm engine's jobs load it again) */
} pm_cli_compare_options;

/* Run the suite (moved in: cleared on return) into dir: the runs, results.csv, elements.csv,
 * plots/, report.md and report.html. `invocation` is the command line shown in the report.
 * Prints progress and, at the end, where the report is. Returns the exit code: 0 when the
 * study completed (whatever some runs did: their errors are in their rows), 1 when it could
 * not (a folder that cannot be written), 130 / 143 when interrupted by SIGINT / SIGTERM.
 * With o->slurm, o->collect or o->task it submits the study, collects it or runs one row
 * instead (packmesh compare --help). */
int pm_cli_compare_execute(pm_cmp_suite *s, const char *dir, const pm_cli_compare_options *o,
                           const char *invocation);

/* The study options that compare and demo share: -o DIR / --output DIR, --jobs N, --quiet.
 * Returns 1 when argv[*i] is one of them (consumed; *i moves past it), with *code the usage
 * exit code when its value is wrong (0 when fine); 0 when it is not one of them. */
int pm_cli_compare_option(const char *command, int argc, char **argv, int *i, const char **dir,
                          pm_cli_compare_options *o, int *code);

#endif /* PM_CLI_COMPARE_H */
