/* The comparison engine's own declarations (compare.h is what its callers use), one concern per
 * file of compare/src:
 *   suite.c       read and check a suite, expand it into rows
 *   run.c         run the rows as child processes (parallel, time-limited, resumable); the
 *                 rows' records (runs/ID/status.json)
 *   slurm.c       the Slurm engine: job arrays of rows, following them, collecting the study
 *   results.c     results.csv, elements.csv, per-row values for tables and plots
 *   spread.c      statistics over repeats: identical meshes, mean and sd, box-plot whiskers
 *   plot.c        gnuplot figures (script + data beside each figure; SVG, PNG, PDF)
 *   plot_convergence.c  the convergence figures from the traces
 *   plot_gnuplot.c      what the figures share (plot_gnuplot.h)
 *   plot_mesh.c   pictures of the meshes (PNG through raster.c and png.c, SVG)
 *   raster.c      a small rasterizer for them; png.c its PNG encoder (raster.h)
 *   viewer.c      the 3D viewer's folder: three.js, viewer.js, the meshes as JS data
 *   report.c      report.md and report.html
 *   animate.c     a run's frames as a GIF and an HTML player (packmesh animate)
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
#include "common/mesh/element_measure.h"
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

/* The first successful row of (case c, method m), in row order (its first seed and sweep
 * value); -1 when there is none. */
int pm_cmp_first_ok_row(const pm_cmp_study *st, int c, int m);

/* A row's mesh (runs/ID/mesh.msh) and the measures of its elements (element_measure.h). On
 * success the caller owns both (pm_mesh_destroy, pm_element_values_clear); on failure both are
 * left empty. */
pm_status pm_cmp_row_mesh(const pm_cmp_study *st, const pm_cmp_row *r, pm_mesh **mesh,
                          pm_element_values *values, pm_error *err);

/* ---- statistics over the repeats (spread.c) ------------------------------------------------ */

/* Mark every successful row whose mesh.msh is byte-identical to an earlier row's of the same
 * case, method and sweep value: row->same_mesh_as = that row (the first to make the mesh), else
 * -1. Such rows are one result in the tables and the box plots. */
pm_status pm_cmp_duplicates_mark(pm_cmp_study *st, pm_error *err);

/* The number of distinct results of (case c, method m, sweep value w; w < 0: all): successful
 * rows that repeat no earlier row's mesh. */
int pm_cmp_distinct_count(const pm_cmp_study *st, int c, int m, int w);

/* Mean and sample standard deviation of a stats key over the distinct results of the group (over
 * every successful run for time keys, time_s.*: a repeated mesh is still a timing of its own);
 * *n values. NaN when there are none (sd: fewer than two). */
void pm_cmp_mean_sd(const pm_cmp_study *st, int c, int m, int w, const char *key, double *mean,
                    double *sd, int *n);

/* A box plot's numbers from n >= 1 sorted values: quartiles, and whiskers at Tukey's fences
 * (the furthest values within 1.5 IQR of the box) or, with minmax, at the min and max. The
 * values outside the whiskers, drawn as points, are v[0 .. lo_end) and v[hi_begin .. n). */
typedef struct pm_cmp_box {
  int64_t n;
  double min, p25, median, p75, max;
  double whisker_lo, whisker_hi;
  size_t lo_end, hi_begin;
} pm_cmp_box;
void pm_cmp_box_of_sorted(const double *v, size_t n, int minmax, pm_cmp_box *b);

/* ---- the 3D viewer (viewer.c) -------------------------------------------------------------- */

typedef struct pm_cmp_viewer {
  int available;      /* three.js was found and copied: report.html shows the viewer */
  char note[768];     /* where three.js came from, or why the viewer is not available */
  int *case_written;  /* [ncase] 1: viewer/mesh_CASE.js holds the case's meshes (owned) */
} pm_cmp_viewer;

/* Write the study's viewer/ folder: three.js and its licence (copied from $PM_THREE_JS, else
 * Debian's libjs-three), viewer.js (built into packmesh from compare/viewer/viewer.js) and, per
 * case, viewer/mesh_CASE.js with the first successful run of each method (its surface triangles
 * and their measures; colour_max tops the R/l_min colour scale). Without three.js nothing is
 * written and v->note says why: the report then says the viewer is not available. PM_ERR_IO when
 * files cannot be written. */
pm_status pm_cmp_viewer_write(const pm_cmp_study *st, double colour_max, pm_cmp_viewer *v,
                              pm_error *err);
void pm_cmp_viewer_clear(pm_cmp_viewer *v);

/* The case's data file, relative to the study folder ("viewer/mesh_qi3.js"). */
void pm_cmp_viewer_case_file(const pm_cmp_study *st, int c, char *buf, size_t len);

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

/* A growing text for SB; `bad` records a failed append (out of memory), checked once when the
 * text is used. */
typedef struct sbuf {
  char *s; /* malloc'ed, NUL-terminated (NULL while empty) */
  size_t n, cap;
  int bad;
} sbuf;

#define SB(b, ...) ((b)->bad |= pm_cmp_appendf(&(b)->s, &(b)->n, &(b)->cap, __VA_ARGS__) != 0)

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
