/* packmesh compare SUITE.json -o DIR: run a comparison suite (compare/README.md) and write its
 * results, figures and report into DIR through the comparison engine (compare/src/compare.h).
 *
 *   packmesh compare SUITE.json -o DIR [--jobs N] [--timeout SECONDS] [--retry-failed] [--quiet]
 *
 * Running it again with the same DIR resumes: finished runs are kept, runs whose command changed
 * (an edited suite) are run again, failed runs are kept unless --retry-failed.
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
    "  --jobs N          runs at once (default: the number of cores)\n"
    "  --timeout S       time limit of each run in seconds (default: the suite's, else 600)\n"
    "  --retry-failed    rerun the runs that failed in an earlier invocation into DIR\n"
    "  --quiet           no progress on stderr (otherwise, on a terminal, one updating line\n"
    "                    with the run in flight and its phase; else a line per finished run)\n"
    "  --help            this text\n"
    "Running again into the same DIR resumes: finished runs are not redone; a run whose\n"
    "command changed (an edited suite) is. A failed run (error, crash, time limit) is recorded\n"
    "in its row and the study goes on; the exit code is 0 once the report is written.\n"
    "SIGINT / SIGTERM end the running runs and exit 130 / 143; the next run resumes.\n"
    "The suite format is described in compare/README.md.\n";

void pm_cli_compare_usage(FILE *f) { fputs(usage_text, f); }

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
  pm_cmp_figures figs = {0};
  if (pm_cmp_suite_save(&st, &e)) {
    code = pm_cli_error(&e);
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
  if (pm_cmp_plots(&st, &figs, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  st.wall_s = pm_cli_now() - t0;
  if (pm_cmp_report(&st, &figs, invocation, &e)) {
    code = pm_cli_error(&e);
    goto done;
  }
  int nok = 0;
  for (int i = 0; i < st.nrow; ++i) nok += st.rows[i].status == PM_CMP_OK;
  int drawn = 0;
  for (int i = 0; i < figs.n; ++i) drawn += figs.fig[i].drawn;
  printf("%d runs: %d succeeded, %d did not; %d of %d figures drawn%s; %.1f s\n", st.nrow, nok,
         st.nrow - nok, drawn, figs.n, figs.have_gnuplot ? "" : " (gnuplot is not installed)",
         pm_cli_now() - t0);
  printf("results: %s/results.csv\n", st.dir);
  printf("report: %s/report.html (and report.md)\n", st.dir);
done:
  pm_cmp_figures_clear(&figs);
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

int pm_cli_compare(int argc, char **argv) {
  const char *suite = NULL, *dir = NULL;
  pm_cli_compare_options o = {0};
  for (int i = 1; i < argc;) {
    const char *a = argv[i], *v = NULL;
    int r;
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      fputs(usage_text, stdout);
      return PM_EXIT_OK;
    }
    int code = 0;
    if (pm_cli_compare_option("compare", argc, argv, &i, &dir, &o, &code)) {
      if (code) return code;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "timeout", &v)) != 0) {
      double t;
      if (r < 0 || !pm_cli_parse_double(v, &t) || !(t > 0))
        return pm_cli_usage("compare", "--timeout takes a number of seconds > 0");
      o.timeout_s = t;
      continue;
    }
    if (pm_cli_flag(a, "retry-failed")) {
      o.retry_failed = 1;
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
  pm_error e = {0};
  pm_cmp_suite s;
  if (pm_cmp_suite_load(suite, &s, &e)) return pm_cli_error(&e);
  char inv[8192];
  invocation_text(argc, argv, "packmesh compare", inv, sizeof inv);
  return pm_cli_compare_execute(&s, dir, &o, inv);
}
