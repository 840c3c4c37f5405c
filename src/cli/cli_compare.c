/* packmesh compare SUITE.json -o DIR: run a comparison suite (compare/README.md) and write its
 * results, figures and report into DIR through the comparison engine (compare/src/compare.h).
 *
 *   packmesh compare SUITE.json -o DIR [--jobs N] [--timeout SECONDS] [--retry-failed] [--quiet]
 *   packmesh compare SUITE.json -o DIR --engine slurm [--slurm-opt OPTIONS ...] [--wait] ...
 *   packmesh compare SUITE.json -o DIR --collect
 *
 * Running it again with the same DIR resumes: finished runs are kept, runs whose command changed
 * (an edited suite) are run again, failed runs are kept unless --retry-failed. With --engine
 * slurm the runs are submitted as Slurm job arrays instead; each task runs `--slurm-task ROW`,
 * and a last job `--collect`.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/cli_compare.h"

#include "cli/cli.h"
#include "cli/cli_signal.h"
#include "cli/cli_util.h"

static const char *const usage_text =
    "usage: packmesh compare SUITE.json -o DIR [--jobs N] [--timeout SECONDS] [--retry-failed]\n"
    "                        [--quiet]\n"
    "       packmesh compare SUITE.json -o DIR --engine slurm [--slurm-opt OPTIONS ...] [--wait]\n"
    "                        [--timeout SECONDS] [--retry-failed] [--quiet]\n"
    "       packmesh compare SUITE.json -o DIR --collect\n"
    "\n"
    "Runs every case x method x seed x sweep value of the suite as its own `packmesh mesh`\n"
    "process and writes into DIR: results.csv (one row per run: case, method, seed, sweep_key,\n"
    "sweep_value, status, error, command, then every --stats key), elements.csv (per-element\n"
    "measures), runs/ID/ (mesh, stats, trace, log of each run), plots/ (gnuplot scripts, data,\n"
    "SVG, PNG, PDF; pictures of the meshes, mesh_CASE_METHOD.png and .svg, with a zoom on each\n"
    "one's worst element), viewer/ (the 3D viewer of report.html: three.js and its licence,\n"
    "copied from $PM_THREE_JS or Debian's libjs-three, and the meshes as JS data) and\n"
    "report.md + report.html.\n"
    "  -o, --output DIR  the study's folder (made when missing; an earlier study in it resumes)\n"
    "  --jobs N          runs at once (default: the number of cores; local engine only)\n"
    "  --timeout S       time limit of each run in seconds (default: the suite's, else 600)\n"
    "  --retry-failed    rerun the runs that failed in an earlier invocation into DIR (with\n"
    "                    --engine slurm: submit them again, crashed and timed-out tasks too)\n"
    "  --engine local|slurm  local (the default): run on this machine; slurm: submit the runs\n"
    "                    to a Slurm cluster as job arrays, print the job ids and return\n"
    "  --slurm-opt OPTIONS  more sbatch options for every job, split at spaces, e.g.\n"
    "                    \"--partition=long --account=lab\" (may be given again)\n"
    "  --wait            with --engine slurm: follow the jobs until the report is written,\n"
    "                    showing how many runs are pending, running, done and failed\n"
    "  --collect         run nothing: write results.csv, elements.csv, plots/ and the report\n"
    "                    from the runs DIR holds, and list the runs not finished (the Slurm\n"
    "                    engine's last job runs it)\n"
    "  --slurm-task ROW  run row ROW (0, 1, ...) of the study alone: what each task of the\n"
    "                    Slurm engine's job arrays runs\n"
    "  --quiet           no progress on stderr (otherwise, on a terminal, one updating line\n"
    "                    with the run in flight and its phase; else a line per finished run)\n"
    "  --help            this text\n"
    "Running again into the same DIR resumes: finished runs are not redone; a run whose\n"
    "command changed (an edited suite) is. A failed run (error, crash, time limit) is recorded\n"
    "in its row and the study goes on; the exit code is 0 once the report is written.\n"
    "SIGINT / SIGTERM end the running runs and exit 130 / 143; the next run resumes.\n"
    "\n"
    "With --engine slurm, DIR, the suite (and the files it names) and the packmesh binary must\n"
    "be on a file system every node sees, at the same paths. Each run is one array task (its\n"
    "--time twice the suite's timeout_s plus a minute, its CPUs the suite's threads, else 1);\n"
    "runs matched to a reference still to run are a second array that starts after the first\n"
    "(afterany); a last job writes the report (--collect). The jobs are named after the study\n"
    "(squeue --name, printed). Submitting again submits only the runs that are neither\n"
    "finished nor pending or running in Slurm: it resumes a study whose tasks were cancelled.\n"
    "A task that ended without its run's record (Slurm's time limit, a node failure, out of\n"
    "memory) is recorded as timeout or crashed with Slurm's state; --retry-failed submits it\n"
    "again. The suite format is described in compare/README.md.\n";

void pm_cli_compare_usage(FILE *f) { fputs(usage_text, f); }

/* The tables, figures and report of a study whose rows have their states; prints where they
 * are. t0: when the invocation started. */
static int write_study(pm_cmp_study *st, const char *invocation, double t0, int set_wall) {
  pm_error e = {0};
  pm_cmp_figures figs = {0};
  int code = PM_EXIT_OK;
  if (pm_cmp_results_write(st, &e) || pm_cmp_plots(st, &figs, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  if (set_wall) st->wall_s = pm_cli_now() - t0;
  if (pm_cmp_report(st, &figs, invocation, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  int nok = 0, npend = 0;
  for (int i = 0; i < st->nrow; ++i) {
    nok += st->rows[i].status == PM_CMP_OK;
    npend += st->rows[i].status == PM_CMP_PENDING;
  }
  int drawn = 0;
  for (int i = 0; i < figs.n; ++i) drawn += figs.fig[i].drawn;
  char pend[64] = "";
  if (npend) snprintf(pend, sizeof pend, ", %d not finished", npend);
  printf("%d runs: %d succeeded, %d did not%s; %d of %d figures drawn%s; %.1f s\n", st->nrow,
         nok, st->nrow - nok - npend, pend, drawn, figs.n,
         figs.have_gnuplot ? "" : " (gnuplot is not installed)", pm_cli_now() - t0);
  for (int i = 0; i < st->nrow; ++i)
    if (st->rows[i].status == PM_CMP_PENDING)
      printf("not finished: %s: %s\n", st->rows[i].id, st->rows[i].error);
  printf("results: %s/results.csv\n", st->dir);
  printf("report: %s/report.html (and report.md)\n", st->dir);
done:
  pm_cmp_figures_clear(&figs);
  return code;
}

/* --slurm-task ROW: one row, as a task of a job array. */
static int run_task(pm_cmp_study *st, const pm_cli_compare_options *o) {
  pm_error e = {0};
  if (pm_cmp_slurm_task(st, o->task_row, o->retry_failed, o->quiet ? 0 : 1, stderr, &e)) {
    int code = pm_cli_error(&e);
    return st->interrupted ? 128 + st->interrupted : code;
  }
  const pm_cmp_row *r = &st->rows[o->task_row];
  if (r->reused)
    fprintf(stderr, "packmesh compare: run %d (%s) is finished already: not run again\n",
            o->task_row, r->id);
  else if (r->status == PM_CMP_PENDING)
    fprintf(stderr,
            "packmesh compare: run %d (%s) not run: its reference run %s has no record (its "
            "task was cancelled or died); submitting the study again runs both\n",
            o->task_row, r->id, st->rows[r->ref_row].id);
  return PM_EXIT_OK;
}

static const char *const kind_text[] = {
    "the runs that can start now",
    "the runs matched to references still to run",
    "the report",
};

/* --engine slurm: submit, print the jobs, follow them with --wait. */
static int submit(pm_cmp_study *st, const pm_cli_compare_options *o, const char *invocation) {
  pm_error e = {0};
  pm_cmp_slurm_opts so = {0};
  so.suite_path = o->suite_path;
  so.retry_failed = o->retry_failed;
  so.timeout_s = o->timeout_s;
  so.sbatch_args = o->sbatch_args;
  so.nsbatch_arg = o->nsbatch_arg;
  so.invocation = invocation;
  pm_cmp_slurm_submission sub;
  pm_cli_signals_detail("; the jobs submitted so far stay queued (squeue lists them)");
  if (pm_cmp_slurm_submit(st, &so, &sub, &e)) return pm_cli_error(&e);
  printf("%s, %d runs: %d finished, %d pending or running in Slurm already, %d submitted\n",
         st->suite.name, st->nrow, sub.nfinished, sub.nqueued, sub.nsubmitted);
  for (int k = 0; k < sub.njob; ++k) {
    const pm_cmp_slurm_job *j = &sub.job[k];
    if (j->kind == PM_CMP_JOB_REPORT)
      printf("job %s: %s%s%s\n", j->id, kind_text[j->kind], j->after[0] ? ", " : "", j->after);
    else
      printf("job %s: %d run%s, array %s%s%s: %s\n", j->id, j->ntask, j->ntask == 1 ? "" : "s",
             j->array, j->after[0] ? ", " : "", j->after, kind_text[j->kind]);
  }
  if (sub.njob == 0) printf("job %s: the report, queued already\n", sub.report_job);
  printf("follow: squeue --name=%s\n", sub.names);
  printf("report: %s/report.html once job %s has run\n", st->dir, sub.report_job);
  fflush(stdout);
  if (!o->wait) return PM_EXIT_OK;
  char detail[160];
  snprintf(detail, sizeof detail, "; the jobs go on (the same command with --wait follows them "
                                  "again)");
  pm_cli_signals_detail(detail);
  if (pm_cmp_slurm_wait(st, &sub, o->quiet ? 0 : (isatty(2) ? 2 : 1), stderr, &e))
    return pm_cli_error(&e);
  printf("results: %s/results.csv\n", st->dir);
  printf("report: %s/report.html (and report.md)\n", st->dir);
  return PM_EXIT_OK;
}

int pm_cli_compare_execute(pm_cmp_suite *s, const char *dir, const pm_cli_compare_options *o,
                           const char *invocation) {
  double t0 = pm_cli_now();
  pm_error e = {0};
  pm_cli_signals_detail("; the finished runs are kept (run the same command again to resume)");
  if (o->timeout_s > 0) s->timeout_s = o->timeout_s;
  pm_cmp_study st;
  if (pm_cmp_study_init(&st, s, dir, &e)) {
    pm_cmp_suite_clear(s);
    pm_cmp_study_clear(&st);
    return pm_cli_error(&e);
  }
  int code = PM_EXIT_OK;
  if (o->task) {
    code = run_task(&st, o);
    goto done;
  }
  if (o->collect) {
    char inv[8192];
    snprintf(inv, sizeof inv, "%s", invocation);
    if (pm_cmp_collect(&st, inv, sizeof inv, &e))
      code = pm_cli_error(&e);
    else
      code = write_study(&st, inv, t0, 0);
    goto done;
  }
  if (pm_cmp_suite_save(&st, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  if (o->slurm) {
    code = submit(&st, o, invocation);
    goto done;
  }
  long cores = sysconf(_SC_NPROCESSORS_ONLN);
  pm_cmp_run_opts ro = {0};
  ro.jobs = o->jobs > 0 ? o->jobs : (int)(cores > 0 ? cores : 1);
  ro.retry_failed = o->retry_failed;
  ro.progress = o->quiet ? 0 : (isatty(2) ? 2 : 1);
  ro.log = stderr;
  if (!o->quiet)
    fprintf(stderr, "packmesh compare: %s, %d runs, %d at a time, into %s\n", st.suite.name,
            st.nrow, ro.jobs, st.dir);
  if (pm_cmp_run(&st, &ro, &e) || pm_cmp_results_write(&st, &e)) {
    code = pm_cli_error(&e);
    /* Interrupted: the exit code a shell gives a process ended by the signal. */
    if (st.interrupted) code = 128 + st.interrupted;
    goto done;
  }
  code = write_study(&st, invocation, t0, 1);
done:
  pm_cmp_study_clear(&st);
  return code;
}

/* The command line as typed, quoted for a shell, for the report. */
static void invocation_text(int argc, char **argv, const char *prefix, char *out, size_t len) {
  snprintf(out, len, "%s", prefix);
  for (int i = 1; i < argc; ++i) {
    char q[2048];
    pm_cmp_shell_quote(argv[i], q, sizeof q);
    if (strlen(out) + strlen(q) + 2 >= len) break;
    strcat(out, " ");
    strcat(out, q);
  }
}

int pm_cli_compare_option(const char *command, int argc, char **argv, int *i, const char **dir,
                          pm_cli_compare_options *o, int *code) {
  const char *a = argv[*i], *v = NULL;
  int r;
  *code = 0;
  if (strcmp(a, "-o") == 0) {
    if (*i + 1 >= argc) return *code = pm_cli_usage(command, "-o needs a folder"), 1;
    *dir = argv[*i + 1];
    *i += 2;
    return 1;
  }
  if ((r = pm_cli_option(argc, argv, i, "output", &v)) != 0) {
    if (r < 0) return *code = pm_cli_usage(command, "--output needs a folder"), 1;
    *dir = v;
    return 1;
  }
  if ((r = pm_cli_option(argc, argv, i, "jobs", &v)) != 0) {
    long n;
    if (r < 0 || !pm_cli_parse_long(v, 1, 1024, &n))
      return *code = pm_cli_usage(command, "--jobs takes a whole number from 1 to 1024"), 1;
    o->jobs = (int)n;
    return 1;
  }
  if (pm_cli_flag(a, "quiet")) {
    o->quiet = 1;
    ++*i;
    return 1;
  }
  return 0;
}

/* --slurm-opt's text split into words at spaces and tabs; '...' and "..." keep spaces. Appended
 * to o->sbatch_args; -1 on a missing closing quote or out of memory. */
static int add_words(pm_cli_compare_options *o, const char *text) {
  const char *c = text;
  for (;;) {
    while (*c == ' ' || *c == '\t') ++c;
    if (!*c) return 0;
    char *w = malloc(strlen(c) + 1);
    char **more = realloc(o->sbatch_args, (size_t)(o->nsbatch_arg + 1) * sizeof *more);
    if (more) o->sbatch_args = more;
    if (!w || !more) {
      free(w);
      return -1;
    }
    size_t n = 0;
    char quote = 0;
    for (; *c && (quote || (*c != ' ' && *c != '\t')); ++c) {
      if (quote && *c == quote)
        quote = 0;
      else if (!quote && (*c == '\'' || *c == '"'))
        quote = *c;
      else
        w[n++] = *c;
    }
    w[n] = '\0';
    o->sbatch_args[o->nsbatch_arg++] = w;
    if (quote) return -1;
  }
}

static void free_words(pm_cli_compare_options *o) {
  for (int i = 0; i < o->nsbatch_arg; ++i) free(o->sbatch_args[i]);
  free(o->sbatch_args);
  o->sbatch_args = NULL;
  o->nsbatch_arg = 0;
}

static int compare_main(int argc, char **argv, pm_cli_compare_options *o) {
  const char *suite = NULL, *dir = NULL, *engine = NULL;
  int jobs_given = 0;
  for (int i = 1; i < argc;) {
    const char *a = argv[i], *v = NULL;
    int r;
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      fputs(usage_text, stdout);
      return PM_EXIT_OK;
    }
    int code = 0;
    jobs_given |= strcmp(a, "--jobs") == 0 || strncmp(a, "--jobs=", 7) == 0;
    if (pm_cli_compare_option("compare", argc, argv, &i, &dir, o, &code)) {
      if (code) return code;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "engine", &v)) != 0) {
      if (r < 0 || (strcmp(v, "local") != 0 && strcmp(v, "slurm") != 0))
        return pm_cli_usage("compare", "--engine takes local or slurm");
      engine = v;
      o->slurm = strcmp(v, "slurm") == 0;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "slurm-opt", &v)) != 0) {
      if (r < 0) return pm_cli_usage("compare", "--slurm-opt needs sbatch options");
      if (add_words(o, v))
        return pm_cli_usage("compare", "--slurm-opt '%s': a quote is not closed", v);
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "slurm-task", &v)) != 0) {
      long row;
      if (r < 0 || !pm_cli_parse_long(v, 0, 1000000000, &row))
        return pm_cli_usage("compare", "--slurm-task takes a run's row, a whole number >= 0");
      o->task = 1;
      o->task_row = (int)row;
      continue;
    }
    if (pm_cli_flag(a, "wait")) {
      o->wait = 1;
      ++i;
      continue;
    }
    if (pm_cli_flag(a, "collect")) {
      o->collect = 1;
      ++i;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "timeout", &v)) != 0) {
      double t;
      if (r < 0 || !pm_cli_parse_double(v, &t) || !(t > 0))
        return pm_cli_usage("compare", "--timeout takes a number of seconds > 0");
      o->timeout_s = t;
      continue;
    }
    if (pm_cli_flag(a, "retry-failed")) {
      o->retry_failed = 1;
      ++i;
      continue;
    }
    if (a[0] == '-' && a[1]) return pm_cli_usage("compare", "unknown option '%s'", a);
    if (suite) return pm_cli_usage("compare", "one suite expected, got '%s' too", a);
    suite = a;
    ++i;
  }
  if (!suite) return pm_cli_usage("compare", "no suite given");
  if (!dir) return pm_cli_usage("compare", "no output folder given (-o DIR)");
  if ((o->wait || o->nsbatch_arg) && !o->slurm)
    return pm_cli_usage("compare", "%s needs --engine slurm",
                        o->wait ? "--wait" : "--slurm-opt");
  if (jobs_given && o->slurm)
    return pm_cli_usage("compare", "--jobs is for --engine local (Slurm runs the tasks)");
  if (o->collect && (engine || o->task || o->retry_failed || jobs_given))
    return pm_cli_usage("compare", "--collect runs nothing: it takes no %s",
                        engine ? "--engine" : o->task ? "--slurm-task"
                                          : o->retry_failed ? "--retry-failed" : "--jobs");
  if (o->task && (engine || jobs_given))
    return pm_cli_usage("compare", "--slurm-task runs one row: it takes no %s",
                        engine ? "--engine" : "--jobs");
  o->suite_path = suite;
  pm_error e = {0};
  pm_cmp_suite s;
  if (pm_cmp_suite_load(suite, &s, &e)) return pm_cli_error(&e);
  char inv[8192];
  invocation_text(argc, argv, "packmesh compare", inv, sizeof inv);
  return pm_cli_compare_execute(&s, dir, o, inv);
}

int pm_cli_compare(int argc, char **argv) {
  pm_cli_compare_options o = {0};
  int code = compare_main(argc, argv, &o);
  free_words(&o);
  return code;
}
