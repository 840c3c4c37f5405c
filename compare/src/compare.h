/* packmesh_compare, the comparison engine behind `packmesh compare` and `packmesh demo`: what its
 * callers (the packmesh command, src/cli) use. A suite (compare/README.md documents its JSON) is
 * read and expanded into a study of rows, one per case x method x seed x sweep value; the rows
 * are run as `packmesh mesh` child processes, here (pm_cmp_run) or as the tasks of Slurm job
 * arrays (pm_cmp_slurm_submit); the results, figures and report are written into the study
 * folder. The engine's own declarations are in study.h, which callers do not include.
 *
 * The engine prints nothing but the progress of pm_cmp_run and pm_cmp_slurm_wait (to the
 * stream its caller gives) and never exits; its errors come back as pm_status with a pm_error. Dependencies run one way,
 * cli -> compare -> libpackmesh: the command uses the engine, the engine uses libpackmesh (its
 * public header and headers of src/common), never the command. compare/README.md ("Code") names
 * the files.
 */
#ifndef PM_COMPARE_H
#define PM_COMPARE_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdio.h>

#include "common/report/stats.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- the suite ----------------------------------------------------------------------------- */

typedef struct pm_cmp_case {
  char *name;        /* short name used in tables, plots and row ids (owned) */
  char *input;       /* the INPUT of packmesh mesh: "case:NAME" or an absolute path (owned) */
  char *size;        /* --size text, or NULL: the input's own field / the method's default */
  int volume;        /* 1: --volume */
  char *ref_json;    /* the case's "reference" object (published figures) as JSON, or NULL */
} pm_cmp_case;

typedef struct pm_cmp_method {
  char *label;       /* what tables and plots call it (owned; defaults to the method name) */
  char *name;        /* --method (owned) */
  char **sets;       /* [nset] "KEY=VALUE" for --set (owned) */
  int nset;
  char **only;       /* [nonly] case names this method runs on; nonly == 0: every case */
  int nonly;
} pm_cmp_method;

typedef struct pm_cmp_suite {
  char *path;        /* the suite file as given, or "" for a built-in suite (owned) */
  char *text;        /* the suite's JSON text, verbatim (owned) */
  char *name, *description; /* owned; description may be "" */
  pm_cmp_case *cases;
  int ncase;
  pm_cmp_method *methods;
  int nmethod;
  long *seeds;
  int nseed;
  int match_nodes;   /* scale every other method's size until its node count matches the
                        reference's (packmesh mesh --target-nodes: within 3%) */
  int match_surface; /* 1 ("match": "surface"): match the surface nodes (the nodes of the
                        triangles; --target-surface-nodes), so that volume meshes are compared
                        on like surfaces; 0 ("all", the default): all nodes (--target-nodes) */
  int whiskers_minmax; /* 1 ("whiskers": "minmax"): box-plot whiskers at the min and max, as
                          papers/001 Fig. 11; 0 ("tukey", the default): Tukey's 1.5 IQR, with
                          the elements beyond as points */
  int reference;     /* index into methods of the reference method */
  double timeout_s;  /* time limit of one run */
  int threads;       /* --threads of each run; 0: cores / jobs */
  long max_nodes;    /* --max-nodes of each run; 0: packmesh mesh's default */
  int trace;         /* 1: --trace for every run (convergence curves) */
  char *sweep_key;   /* parameter swept (--set KEY=VALUE, or "size" for --size), or NULL */
  char **sweep_values; /* [nsweep] texts of the values (owned) */
  int nsweep;
} pm_cmp_suite;

/* Read the suite file at path (relative inputs are resolved against its folder). A malformed
 * suite (not JSON, a missing or mistyped key, an unknown key, an empty list) is PM_ERR_PARSE or
 * PM_ERR_ARG naming the key. Unknown methods, missing input files and bad sizes are not checked
 * here: each becomes the error of its own rows. */
pm_status pm_cmp_suite_load(const char *path, pm_cmp_suite *s, pm_error *err);

/* The same from JSON text; base_dir resolves relative file inputs; path is recorded as given
 * (may be ""). */
pm_status pm_cmp_suite_parse(const char *text, const char *base_dir, const char *path,
                             pm_cmp_suite *s, pm_error *err);

void pm_cmp_suite_clear(pm_cmp_suite *s);

/* ---- rows ---------------------------------------------------------------------------------- */

typedef enum pm_cmp_status {
  PM_CMP_PENDING = 0, /* not run yet */
  PM_CMP_OK,          /* the run succeeded and its stats were read */
  PM_CMP_FAILED,      /* packmesh mesh ended with an error (its message in error) */
  PM_CMP_CRASHED,     /* killed by a signal */
  PM_CMP_TIMEOUT,     /* over the time limit, killed */
  PM_CMP_SKIPPED      /* not run: the reference run of its group failed (match_nodes) */
} pm_cmp_status;

typedef struct pm_cmp_row {
  int index;
  char id[192];        /* folder name under runs/, unique in the study */
  int icase, imethod, isweep; /* isweep = -1 without a sweep */
  long seed;
  int ref_row;         /* row whose node count this row matches (-1: none) */

  /* Filled by the runner (or read back from runs/ID/status.json when resuming). */
  pm_cmp_status status;
  char error[1024];
  char command[8192];  /* shell form of the packmesh mesh command, run in the study folder */
  double wall_s;       /* wall-clock seconds of the child process */
  char host[256];      /* the machine that ran it (gethostname; Slurm's node), "" when not run */
  char job[64];        /* the Slurm job that ran it ("12_3": array job 12, task 3), "" locally */
  long nodes;          /* node count (from stats.json), -1 when unknown */
  int elements_ok;     /* runs/ID/elements.csv holds the per-element measures */
  int reused;          /* finished in an earlier invocation and not run again */
  int same_mesh_as;    /* the earlier row whose mesh.msh this row's repeats byte for byte (one
                          result, counted once), -1 when none; set once the runs are done */
  pm_stats_flat flat;  /* the flattened stats.json (empty unless status is OK) */
} pm_cmp_row;

typedef struct pm_cmp_study {
  pm_cmp_suite suite;  /* owned */
  char *dir;           /* output folder (absolute, owned) */
  char *exe;           /* the packmesh binary (owned) */
  pm_cmp_row *rows;
  int nrow;
  double wall_s;       /* duration of the whole invocation */
  int nrun, nreused;   /* rows run now / taken from an earlier invocation */
  int interrupted;     /* the signal that stopped pm_cmp_run (SIGINT, SIGTERM), else 0 */
} pm_cmp_study;

/* Expand the suite into rows (case-major, then seed, sweep value and method, the reference
 * method first in each group) and set their ids. s is moved into the study. dir is created
 * when missing. */
pm_status pm_cmp_study_init(pm_cmp_study *st, pm_cmp_suite *s, const char *dir, pm_error *err);
void pm_cmp_study_clear(pm_cmp_study *st);

/* ---- running ------------------------------------------------------------------------------- */

typedef struct pm_cmp_run_opts {
  int jobs;            /* parallel runs, >= 1 */
  int retry_failed;    /* rerun rows that failed in an earlier invocation */
  int progress;        /* 0 quiet, 1 lines, 2 one updating line (a terminal) */
  FILE *log;           /* progress stream (stderr) */
  int threads;         /* > 0: --threads of every run; 0: pm_cmp_run_threads(suite, jobs) */
  int single;          /* 1: run row `row` alone (a Slurm task): the other rows are read from
                          their records, never run, and failed records of its reference are kept */
  int row;             /* the row, with single */
  const char *job;     /* the Slurm job running it ("12_3"), recorded with the row; NULL: none */
  const char *job_id;  /* that job's own id (SLURM_JOB_ID), for the marker; NULL: none */
  const char *host;    /* the machine recorded for the runs; NULL: gethostname */
} pm_cmp_run_opts;

/* Run every row that is not finished yet (with single, the one row: it stays PENDING, unrun,
 * when its reference has no record yet). A row is finished when runs/ID/status.json records a
 * status for the same command (a changed suite reruns exactly the rows whose command changed).
 * Returns PM_OK when every row has a status (failed rows included); PM_ERR_IO when the study
 * folder cannot be written; PM_ERR_ARG when interrupted by SIGINT / SIGTERM, with the signal in
 * st->interrupted (running children are ended -- SIGTERM, which makes `packmesh mesh` remove its
 * temporaries, then SIGKILL after a grace period -- and whatever temporaries they left in their
 * run folders are removed; the next invocation resumes). */
pm_status pm_cmp_run(pm_cmp_study *st, const pm_cmp_run_opts *o, pm_error *err);

/* ---- the Slurm engine ---------------------------------------------------------------------- */

/* A study on a Slurm cluster (slurm.c): the same rows, commands, run folders and records as the
 * local engine, each row run by one task of a job array, `packmesh compare SUITE -o DIR
 * --slurm-task ROW`, and the tables, figures and report written by a last job, `packmesh compare
 * SUITE -o DIR --collect`. The study folder is the only shared state: it must be on a file system
 * every node sees, like the suite (and the files it names) and the packmesh binary. A task writes
 * only into its own runs/ID/. Every run's --threads and CPUs are the suite's threads, else 1. */

typedef struct pm_cmp_slurm_opts {
  const char *suite_path;  /* the suite file, which the jobs load again (borrowed) */
  int retry_failed;        /* resubmit the runs whose record is failed, crashed or timeout */
  double timeout_s;        /* > 0: --timeout, passed on to the jobs; 0: the suite's */
  char **sbatch_args;      /* [nsbatch_arg] words added to every sbatch command (borrowed) */
  int nsbatch_arg;
  const char *invocation;  /* the command line, which the report will show (borrowed) */
} pm_cmp_slurm_opts;

#define PM_CMP_SLURM_MAX_JOBS 64

typedef enum { PM_CMP_JOB_RUNS = 0, PM_CMP_JOB_MATCHED, PM_CMP_JOB_REPORT } pm_cmp_job_kind;

typedef struct pm_cmp_slurm_job {
  char id[32];             /* the job id sbatch gave */
  pm_cmp_job_kind kind;    /* runs (no reference, or theirs is done), runs matched to
                              references still to run, the report */
  int ntask;               /* tasks of the array (0: the report) */
  char array[128];         /* the array's task ids (= rows; cut with "..." when longer) */
  char after[128];         /* "afterany:ID:ID" or "" */
} pm_cmp_slurm_job;

typedef struct pm_cmp_slurm_submission {
  int nfinished;           /* rows with a record that stands (or skipped) */
  int nqueued;             /* rows pending or running in Slurm already: not submitted again */
  int nsubmitted;          /* rows submitted now */
  pm_cmp_slurm_job job[PM_CMP_SLURM_MAX_JOBS]; /* the jobs submitted now, in order */
  int njob;
  char report_job[32];     /* the job that will write the report (submitted now or queued) */
  char names[1024];        /* the study's job names, for squeue --name */
  double submitted;        /* when (seconds since the epoch) */
} pm_cmp_slurm_submission;

/* Submit the rows of the study that are neither finished (a record for their command; a failed
 * one too unless retry_failed) nor pending or running in Slurm already (squeue --name: the job
 * names carry a hash of the study folder): one job array of the rows that can run now, one of
 * the rows matched to references that are still to run (--dependency=afterany on theirs), and
 * a report job after all of them (or the report job already queued when nothing was submitted).
 * Each task's --time is 2 x timeout_s + 1 minute (the run and its quality measures each have
 * timeout_s), its --cpus-per-task the suite's threads (else 1). Writes DIR/slurm/submit.json
 * (the invocation, the time, the job ids, for the report) and the tasks' logs go to
 * DIR/slurm/log/. PM_ERR_IO naming sbatch's message when a submission fails. */
pm_status pm_cmp_slurm_submit(pm_cmp_study *st, const pm_cmp_slurm_opts *o,
                              pm_cmp_slurm_submission *sub, pm_error *err);

/* Follow a submission until its report job has left the queue: every few seconds, the numbers
 * of runs pending and running in Slurm and done and failed in the folder, to log (progress 1: a
 * line when they change; 2: one updating line). PM_ERR_IO when the report job ended without a
 * report (its log is named). */
pm_status pm_cmp_slurm_wait(pm_cmp_study *st, const pm_cmp_slurm_submission *sub, int progress,
                            FILE *log, pm_error *err);

/* One task of an array: run row `row` alone (pm_cmp_run with single), recording the job
 * (SLURM_ARRAY_JOB_ID, SLURM_ARRAY_TASK_ID, SLURM_JOB_ID) and node (SLURMD_NODENAME) from the
 * environment. PM_ERR_ARG when the suite is not the one submitted (DIR/suite.json). */
pm_status pm_cmp_slurm_task(pm_cmp_study *st, int row, int retry_failed, int progress, FILE *log,
                            pm_error *err);

/* The study as the folder holds it, for the tables and the report, running nothing: every row's
 * record; a row whose Slurm task started (runs/ID/slurm.json) and ended without a record is
 * recorded now (status.json) as timeout (Slurm's TIMEOUT) or crashed (FAILED, NODE_FAIL,
 * OUT_OF_MEMORY, ...), with Slurm's state (sacct, else scontrol) in its error; a task cancelled
 * (scancel) leaves its row unfinished, to be submitted again. The other unfinished rows stay
 * PENDING with their state in error (pending or running in Slurm, waiting for its reference,
 * not submitted). Sets st->nrun (rows made by the last submission's jobs), st->nreused and
 * st->wall_s (since that submission) and copies its invocation into `invocation` (left as it is
 * when there was none). Where Slurm does not answer nothing is recorded. */
pm_status pm_cmp_collect(pm_cmp_study *st, char *invocation, size_t len, pm_error *err);

/* ---- results ------------------------------------------------------------------------------- */

/* The suite's text as suite.json in the study folder (atomically): the study can be rerun from
 * its own folder. */
pm_status pm_cmp_suite_save(const pm_cmp_study *st, pm_error *err);

/* results.csv and elements.csv in the study folder (atomically). */
pm_status pm_cmp_results_write(const pm_cmp_study *st, pm_error *err);

/* ---- figures and report -------------------------------------------------------------------- */

typedef struct pm_cmp_figure {
  char name[128];      /* file stem under plots/ */
  char title[256];
  char caption[1024];
  int drawn;           /* gnuplot made the SVG, PNG and PDF */
  char error[512];     /* why not, when !drawn */
} pm_cmp_figure;

/* A picture of one run's mesh (plot_mesh.c): plots/NAME.png and plots/NAME.svg. */
typedef struct pm_cmp_picture {
  char name[160];      /* file stem under plots/: mesh_CASE_LABEL, or ..._worst for the zoom */
  char caption[512];
  int icase, imethod, row; /* the case, the method and the row pictured */
  int worst;           /* 1: the zoom on the mesh's worst element */
  double worst_value;  /* R/l_min of that element (worst pictures) */
  int drawn;           /* both files were written */
  char error[512];     /* why not, when !drawn */
} pm_cmp_picture;

typedef struct pm_cmp_figures {
  pm_cmp_figure *fig;
  int n;
  int have_gnuplot;
  char gnuplot_version[128];
  pm_cmp_picture *pic; /* the mesh pictures, per case and method, each followed by its zoom */
  int npic;
  double colour_max;   /* the top of the pictures' shared R/l_min colour scale */
  double picture_s;    /* seconds spent drawing them (wall clock) */
  double picture_cpu_s; /* and the processor time they took (clock(): a busy machine stretches
                           the wall time, not this) */
} pm_cmp_figures;

/* Write the data and the gnuplot script of every figure under plots/ and run gnuplot on each
 * (time-limited), then draw the mesh pictures (pm_cmp_mesh_pictures). A missing gnuplot or a
 * failed figure is recorded, not an error; PM_ERR_IO when files cannot be written. */
pm_status pm_cmp_plots(const pm_cmp_study *st, pm_cmp_figures *figs, pm_error *err);
void pm_cmp_figures_clear(pm_cmp_figures *figs);

/* The pictures of the meshes into figs->pic: for each case and method the first successful
 * run's mesh (planar cases flat, surfaces and volumes shaded from one camera per case), its
 * triangles coloured by R/l_min on one colour scale shared by the whole study, and a zoom on
 * its worst element (a tet's for volume meshes). A mesh that cannot be read is recorded in its
 * picture, not an error; PM_ERR_IO when files cannot be written. */
pm_status pm_cmp_mesh_pictures(const pm_cmp_study *st, pm_cmp_figures *figs, pm_error *err);

/* report.md and report.html. `invocation` is the command line that ran the study. */
pm_status pm_cmp_report(const pm_cmp_study *st, const pm_cmp_figures *figs,
                        const char *invocation, pm_error *err);

/* ---- helpers for callers ------------------------------------------------------------------- */

/* Shell-quote one word ("abc" stays, "a b" -> 'a b'). */
void pm_cmp_shell_quote(const char *word, char *out, size_t len);

/* ---- the papers ---------------------------------------------------------------------------- */

/* The papers packmesh implements, by the keys its help and reports cite them with: "papers/003"
 * (reports, descriptions) or "003" in a parameter's [SOURCE] (`packmesh mesh --method M --help`).
 * `packmesh references` prints them in full; a comparison report lists the ones it cites. */
typedef struct pm_cmp_reference {
  const char *key;      /* "003": cited as papers/003 */
  const char *citation; /* authors, title, where and when it appeared */
  const char *used_for; /* what packmesh takes from it */
} pm_cmp_reference;

/* The number of papers and the i-th, in key order (NULL outside 0 .. count - 1). */
int pm_cmp_reference_count(void);
const pm_cmp_reference *pm_cmp_reference_at(int i);

/* ---- helper processes and signals ---------------------------------------------------------- */

/* End (SIGKILL) the process group of every helper the engine is running now (gnuplot,
 * dpkg-query). Async-signal-safe: the caller's SIGINT / SIGTERM handler calls it before the
 * process exits, so that no helper outlives an interrupted study. The `packmesh mesh` children
 * of pm_cmp_run are not among them: pm_cmp_run ends those itself (see above). */
void pm_cmp_children_kill_all(void);

/* ---- animations ---------------------------------------------------------------------------- */

/* The frames of a run (`packmesh mesh --frames DIR` on a planar input: frame_NNNNNN.svg and
 * .dat) as OUT.gif, drawn by gnuplot's gif terminal with delay_ms per frame, and OUT.html, a
 * player of the SVG pictures that needs no other file (animate.c). Both are written together or
 * not at all. *nframes (may be NULL) receives the frame count. PM_ERR_ARG when dir holds no
 * frames, PM_ERR_IO when a frame cannot be read, an output cannot be written or gnuplot fails. */
pm_status pm_cmp_animate(const char *frames_dir, const char *out, int delay_ms, int *nframes,
                         pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_COMPARE_H */
