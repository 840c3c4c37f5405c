/* The comparison engine's own declarations (compare.h is what its callers use), one concern per
 * file of compare/src:
 *   suite.c       read and check a suite, expand it into rows
 *   run.c         run the rows as child processes (parallel, time-limited, resumable); the
 *                 rows' records (runs/ID/status.json)
 *   slurm.c       the Slurm engine: job arrays of rows, following them, collecting the study
 *   results.c     results.csv, elements.csv, per-row values for tables and plots
 *   plot.c        gnuplot figures (script + data beside each figure; SVG, PNG, PDF)
 *   report.c      report.md and report.html
 *   sysinfo.c     library versions and the machine, for the report
 *   references.c  the papers cited as papers/NNN
 *   children.c    the helper process groups a signal handler must end
 *   util.c        growing strings, quoting, files, folders, running a helper program
 *
 * Every run is its own `packmesh mesh` process (the binary running the engine, found through
 * /proc/self/exe), started in the study folder, so the command recorded for a row is exactly
 * the one that made it, and a crash or hang of a library costs one row, never the study.
 */
#ifndef PM_COMPARE_STUDY_H
#define PM_COMPARE_STUDY_H

#include <stddef.h>
#include <stdio.h>
#include <sys/types.h>

#include "common/backends/versions.h"
#include "compare/src/compare.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- rows ---------------------------------------------------------------------------------- */

const char *pm_cmp_status_name(pm_cmp_status s);

/* Labels for messages: "qi3 bubble seed 2 k0=30". */
void pm_cmp_row_title(const pm_cmp_study *st, const pm_cmp_row *r, char *buf, size_t len);

/* The sweep value text of a row ("" without a sweep). */
const char *pm_cmp_row_sweep(const pm_cmp_study *st, const pm_cmp_row *r);

/* ---- records (run.c) ------------------------------------------------------------------------ */

/* The file a Slurm task writes into runs/ID/ when it starts its row: the job ("12_3"), the job's
 * own id, the node, the time. Whoever collects the study asks Slurm about that job when the row
 * has no status.json. */
#define PM_CMP_SLURM_MARKER "slurm.json"

/* The --threads of every run: the suite's; else cores / jobs; jobs <= 0: 1 (the Slurm engine,
 * whose tasks get the suite's threads as CPUs, else one). */
int pm_cmp_run_threads(const pm_cmp_suite *s, int jobs);

/* Every row's state from the records in the study folder, running nothing: a row whose
 * runs/ID/status.json records its command (built with `threads`; a matched row's with its
 * reference's node count) takes the recorded status, error, wall time, host and job, and the
 * stats of a successful run (reused = 1); a row whose reference has a record and did not succeed
 * is SKIPPED; any other row is PENDING (with its command, or "" while its reference has no
 * record). Failed records are taken as they are (retrying is the caller's decision). */
pm_status pm_cmp_records_read(pm_cmp_study *st, int threads, pm_error *err);

/* Write a row's record, runs/ID/status.json, atomically. */
pm_status pm_cmp_record_write(const pm_cmp_study *st, const pm_cmp_row *r, pm_error *err);

/* ---- results ------------------------------------------------------------------------------- */

/* Read runs/ID/stats.json of every OK row into row->flat (done by the runner too). */
pm_status pm_cmp_results_load(pm_cmp_study *st, pm_error *err);

/* A numeric stats value of a row (NaN when missing or not a number). */
double pm_cmp_row_value(const pm_cmp_row *r, const char *key);

/* The per-element values of one column ("aspect_ratio", ...) of one kind ("tri", "tet") in
 * runs/ID/elements.csv, appended to *v (realloc'ed; *n and *cap updated). */
pm_status pm_cmp_row_elements(const pm_cmp_study *st, const pm_cmp_row *r, const char *kind,
                              const char *column, double **v, size_t *n, size_t *cap,
                              pm_error *err);

/* ---- environment --------------------------------------------------------------------------- */

typedef struct pm_cmp_sysinfo {
  pm_lib_versions lib;
  char os[256];        /* uname: system, release, machine */
  char cpu[256];       /* model name of /proc/cpuinfo */
  int cores;           /* online processors */
  double mem_gib;      /* MemTotal of /proc/meminfo */
  char gnuplot[128];   /* `gnuplot --version`, "" when there is none */
  char packages[2048]; /* Debian package versions of the libraries (dpkg-query), or "" */
} pm_cmp_sysinfo;

void pm_cmp_sysinfo_get(pm_cmp_sysinfo *si);

/* ---- helpers shared by the files above ----------------------------------------------------- */

/* Append text to a growing string (*buf malloc'ed); 0 on success, -1 out of memory. */
int pm_cmp_strcat(char **buf, size_t *len, size_t *cap, const char *text);
int pm_cmp_appendf(char **buf, size_t *len, size_t *cap, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* Read a whole file (NUL-terminated, malloc'ed); NULL when it cannot be read. */
char *pm_cmp_read_file(const char *path, size_t *len);

/* mkdir -p. */
pm_status pm_cmp_mkdirs(const char *path, pm_error *err);

/* Run argv (argv[0] a program name looked up in PATH, or a path) in cwd with a time limit;
 * stdout to out_path (NULL: /dev/null), stderr to err_path (NULL: /dev/null). Returns the
 * wait status in *wstatus and sets *timed_out. -1 when the program could not be started. */
int pm_cmp_run_program(char *const argv[], const char *cwd, const char *out_path,
                       const char *err_path, double timeout_s, int *wstatus, int *timed_out);

/* Run argv (a program looked up in PATH; env: NULL, or "NAME=VALUE" entries added to its
 * environment) with a time limit, capturing its stdout into *out and its stderr into *errtext
 * (malloc'ed, NUL-terminated; pass NULL to drop one). Returns 0 with the wait status in *wstatus
 * and *timed_out set; -1 when the program could not be started (not installed) or out of
 * memory, with nothing captured. */
int pm_cmp_capture(char *const argv[], char *const env[], double timeout_s, char **out,
                   char **errtext, int *wstatus, int *timed_out);

/* Record a helper's process group, ended by pm_cmp_children_kill_all; returns its record, -1
 * when the table is full. pm_cmp_children_forget releases it (accepts -1). */
int pm_cmp_children_add(pid_t pgid);
void pm_cmp_children_forget(int id);

#ifdef __cplusplus
}
#endif

#endif /* PM_COMPARE_STUDY_H */
