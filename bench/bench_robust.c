/* Robustness corpus run: every CAD file of the given folders (by default ../shared/cad/robust,
 * gmsh's own benchmark files, and ../shared/cad) meshed by each method at its default size with
 * one thread, as `packmesh mesh FILE --method M --threads 1 --stats ...` in a child process, so
 * that a crash or a hang of one run is a row of the table and not the end of the study.
 *
 *   bench_robust [--methods bubble,psys,gmsh-frontal] [--timeout SECONDS] [--only TEXT]
 *                [--csv FILE] [--packmesh PATH] [--old-cli] [--set METHOD:KEY=VALUE ...] [DIR ...]
 *
 * --packmesh runs another build of the command (the previous code path, for a before/after table
 * from the same benchmark; default: the command built beside this benchmark); --old-cli for a
 * build without `mesh --time-limit`. Each run gets `--time-limit SECONDS`: the command stops a
 * run that lasts longer with its own one-line error, which is the row's status. --set
 * METHOD:KEY=VALUE adds `--set KEY=VALUE` to METHOD's runs (a bad key or value is each run's
 * one-line error).
 *
 * Per file and method: the status (ok, the one-line error, timeout, crash), the checker's
 * verdict, nodes, the time of each stage from --stats (load: reading and healing the file; setup:
 * building the cell complex; mesh: the method without its connection; connect; check; distance),
 * the run's total, the measuring (check + quality + distance) beside the meshing (mesh + connect)
 * of the same run, the smallest angle, and the needles below 10 degrees, forced and unforced
 * (needles.h); the CSV adds the distance's mean and max (model units), and the figures that do
 * not depend on the machine's load: the run's iterations, median and p75 R / l_min. Then per method: files
 * loaded, valid, with no unforced needle; bubble's total time over gmsh-frontal's per file (the
 * largest ratio and where), and the runs that spent longer measuring than meshing, with the
 * largest ratio of the two and where; then every stage of a run that took longer than the run's
 * meshing (load, setup, check and distance against mesh + connect, connect against mesh), each
 * named with its file, method and ratio.
 *
 * Prints figures only; never a test (tests/cad_robust_long runs the validity assertions).
 */
#include <cjson/cJSON.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/base/clock.h"

#define MAX_METHODS 8
#define MAX_FILES 4096

typedef struct row {
  char file[256], method[32];
  char status[200]; /* "ok", "timeout", "crash (signal N)", or the error line */
  int ran, valid;
  long nodes;
  double t_load, t_setup, t_mesh, t_connect, t_check, t_quality, t_distance, t_total;
  double min_angle;
  double iterations, median_ar, p75_ar; /* the run's iterations, median and p75 R / l_min */
  double dist_mean, dist_max;
  long forced, unforced;
  int healed;
} row;

static int cad_ext(const char *name) {
  const char *d = strrchr(name, '.');
  if (!d) return 0;
  return !strcasecmp(d, ".step") || !strcasecmp(d, ".stp") || !strcasecmp(d, ".iges") ||
         !strcasecmp(d, ".igs") || !strcasecmp(d, ".brep");
}

static int cmp_str(const void *a, const void *b) {
  return strcmp(*(const char *const *)a, *(const char *const *)b);
}

static double num(const cJSON *o, const char *path) {
  char buf[128];
  snprintf(buf, sizeof buf, "%s", path);
  const cJSON *c = o;
  for (char *tok = strtok(buf, "."); tok && c; tok = strtok(NULL, "."))
    c = cJSON_GetObjectItemCaseSensitive(c, tok);
  return c && cJSON_IsNumber(c) ? c->valuedouble : 0;
}

/* Read a file whole (NUL-terminated); NULL when missing. */
static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *s = malloc((size_t)(n > 0 ? n : 0) + 1);
  if (s && n > 0 && fread(s, 1, (size_t)n, f) != (size_t)n) n = 0;
  if (s) s[n > 0 ? n : 0] = '\0';
  fclose(f);
  return s;
}

/* Run one file with one method into row r; `tmp` is a scratch folder. The command stops its
 * own run at the timeout (--time-limit: one line saying where the run stood, as a user sees it)
 * unless old_cli (a build without that option); the child is killed KILL_GRACE later (the
 * limit does not count loading, measuring or writing) or, with old_cli, at the timeout. */
#define KILL_GRACE(timeout) ((timeout) / 4 > 60 ? (timeout) / 4 : 60)
/* --set METHOD:KEY=VALUE: a parameter given to METHOD's runs (e.g. bubble:hold_rings=2), so
 * that a corpus run can compare a parameter's settings with --packmesh's before/after. */
#define MAX_SETS 16
static const char *sets[MAX_SETS];
static int nsets;

static void run_one(const char *cli, const char *path, const char *method, double timeout,
                    int old_cli, const char *tmp, row *r) {
  char msh[1024], json[1024], errf[1024];
  snprintf(msh, sizeof msh, "%s/mesh.msh", tmp);
  snprintf(json, sizeof json, "%s/stats.json", tmp);
  snprintf(errf, sizeof errf, "%s/stderr.txt", tmp);
  unlink(msh), unlink(json), unlink(errf);
  double t0 = pm_seconds();
  pid_t pid = fork();
  if (pid == 0) {
    int fd = open("/dev/null", O_WRONLY);
    int fe = open(errf, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) dup2(fd, 1);
    if (fe >= 0) dup2(fe, 2);
    setpgid(0, 0);
    char limit[64];
    snprintf(limit, sizeof limit, "%g", timeout);
    const char *args[16 + 2 * MAX_SETS];
    int na = 0;
    const char *fixed[] = {cli, "mesh", path, "--method", method, "--threads", "1", "-o", msh, "--stats", json};
    for (size_t k = 0; k < sizeof fixed / sizeof fixed[0]; ++k) args[na++] = fixed[k];
    if (!old_cli) args[na++] = "--time-limit", args[na++] = limit;
    const size_t ml = strlen(method);
    for (int k = 0; k < nsets; ++k)
      if (!strncmp(sets[k], method, ml) && sets[k][ml] == ':') args[na++] = "--set", args[na++] = sets[k] + ml + 1;
    args[na] = NULL;
    execv(cli, (char *const *)args);
    _exit(127);
  }
  const double kill_at = old_cli ? timeout : timeout + KILL_GRACE(timeout);
  int status = 0, done = 0;
  while (!done) {
    pid_t w = waitpid(pid, &status, WNOHANG);
    if (w == pid) {
      done = 1;
      break;
    }
    if (pm_seconds() - t0 > kill_at) {
      kill(-pid, SIGKILL);
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      snprintf(r->status, sizeof r->status, "timeout (killed at %g s)", kill_at);
      r->t_total = pm_seconds() - t0;
      return;
    }
    struct timespec ts = {0, 20 * 1000 * 1000};
    nanosleep(&ts, NULL);
  }
  r->t_total = pm_seconds() - t0;
  if (WIFSIGNALED(status)) {
    snprintf(r->status, sizeof r->status, "crash (signal %d)", WTERMSIG(status));
    return;
  }
  char *err = slurp(errf);
  char *line = NULL;
  /* The error is the last line; a healing report is an earlier "healed:" line. */
  if (err) {
    r->healed = strstr(err, ": healed: ") != NULL;
    for (char *s = strtok(err, "\n"); s; s = strtok(NULL, "\n"))
      if (!strstr(s, ": healed: ")) line = s;
  }
  if (WEXITSTATUS(status) != 0) {
    if (line)
      snprintf(r->status, sizeof r->status, "%s", line);
    else /* 127: the program could not be started */
      snprintf(r->status, sizeof r->status, "failed without a message (exit status %d)",
               WEXITSTATUS(status));
    free(err);
    return;
  }
  free(err);
  char *text = slurp(json);
  cJSON *o = text ? cJSON_Parse(text) : NULL;
  free(text);
  if (!o) {
    snprintf(r->status, sizeof r->status, "no stats written");
    return;
  }
  r->ran = 1;
  snprintf(r->status, sizeof r->status, "ok");
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, "valid");
  r->valid = cJSON_IsTrue(v);
  r->nodes = (long)num(o, "nodes");
  r->t_total = num(o, "time_s.total");
  r->t_load = num(o, "time_s.load");
  r->t_setup = num(o, "time_s.setup");
  r->t_connect = num(o, "time_s.connect");
  r->t_check = num(o, "time_s.check");
  r->t_quality = num(o, "time_s.quality");
  r->t_distance = num(o, "time_s.distance");
  r->t_mesh = r->t_total - r->t_load - r->t_setup - r->t_connect;
  r->min_angle = num(o, "tri.min_angle_deg.min");
  r->iterations = num(o, "iterations");
  r->median_ar = num(o, "tri.aspect_ratio.median");
  r->p75_ar = num(o, "tri.aspect_ratio.p75");
  r->dist_mean = num(o, "distance.mean");
  r->dist_max = num(o, "distance.max");
  r->forced = (long)num(o, "tri.needles.forced");
  r->unforced = (long)num(o, "tri.needles.unforced");
  cJSON_Delete(o);
}

static void csv_text(FILE *f, const char *s) {
  fputc('"', f);
  for (; *s; ++s) {
    if (*s == '"') fputc('"', f);
    fputc(*s, f);
  }
  fputc('"', f);
}

int main(int argc, char **argv) {
  const char *methods_arg = "bubble,psys,gmsh-frontal", *only = NULL, *csv = NULL, *cli = PM_CLI;
  double timeout = 600;
  int old_cli = 0;
  const char *dirs[16];
  int ndir = 0;
  for (int i = 1; i < argc; ++i) {
    if (!strcmp(argv[i], "--methods") && i + 1 < argc) methods_arg = argv[++i];
    else if (!strcmp(argv[i], "--timeout") && i + 1 < argc) timeout = atof(argv[++i]);
    else if (!strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
    else if (!strcmp(argv[i], "--csv") && i + 1 < argc) csv = argv[++i];
    else if (!strcmp(argv[i], "--packmesh") && i + 1 < argc) cli = argv[++i];
    else if (!strcmp(argv[i], "--old-cli")) old_cli = 1;
    else if (!strcmp(argv[i], "--set") && i + 1 < argc) {
      const char *v = argv[++i], *colon = strchr(v, ':');
      if (!colon || colon == v || !strchr(colon, '=') || nsets == MAX_SETS) {
        fprintf(stderr, "bench_robust: --set takes METHOD:KEY=VALUE (at most %d), got '%s'\n", MAX_SETS, v);
        return 2;
      }
      sets[nsets++] = v;
    }
    else if (argv[i][0] == '-') {
      fprintf(stderr, "bench_robust: unknown option '%s'\n", argv[i]);
      return 2;
    } else if (ndir < 16) dirs[ndir++] = argv[i];
  }
  if (!(timeout > 0)) {
    fprintf(stderr, "bench_robust: --timeout takes a positive number of seconds\n");
    return 2;
  }
  if (ndir == 0) dirs[ndir++] = PM_CAD_DIR "/robust", dirs[ndir++] = PM_CAD_DIR;
  char mbuf[256], *methods[MAX_METHODS];
  int nm = 0;
  snprintf(mbuf, sizeof mbuf, "%s", methods_arg);
  for (char *t = strtok(mbuf, ","); t && nm < MAX_METHODS; t = strtok(NULL, ",")) methods[nm++] = t;

  char *files[MAX_FILES];
  int nf = 0;
  for (int d = 0; d < ndir; ++d) {
    DIR *dh = opendir(dirs[d]);
    if (!dh) {
      fprintf(stderr, "bench_robust: cannot open %s: %s\n", dirs[d], strerror(errno));
      continue;
    }
    char *names[MAX_FILES];
    int nn = 0;
    struct dirent *de;
    while ((de = readdir(dh)) && nn < MAX_FILES)
      if (cad_ext(de->d_name) && (!only || strstr(de->d_name, only))) names[nn++] = strdup(de->d_name);
    closedir(dh);
    qsort(names, (size_t)nn, sizeof(char *), cmp_str);
    for (int k = 0; k < nn && nf < MAX_FILES; ++k) {
      char p[2048];
      snprintf(p, sizeof p, "%s/%s", dirs[d], names[k]);
      files[nf++] = strdup(p);
      free(names[k]);
    }
  }
  char tmp[] = "/tmp/bench_robust.XXXXXX";
  if (!mkdtemp(tmp)) {
    fprintf(stderr, "bench_robust: cannot make a scratch folder: %s\n", strerror(errno));
    return 1;
  }
  printf("command:");
  for (int i = 0; i < argc; ++i) printf(" %s", argv[i]);
  printf("\npackmesh: %s; one thread per run; timeout %g s per run\n\n", cli, timeout);
  /* "measure" is check + quality + distance, "meshing" mesh + connect, both from one run's
   * --stats; a '>' after the measuring marks a run that measured longer than it meshed. */
  printf("%-44s %-12s %-5s %7s %7s %7s %8s %7s %8s %7s %8s %9s %8s %7s %6s %6s  %s\n", "file",
         "method", "valid", "nodes", "load", "setup", "mesh", "connect", "meshing", "check",
         "distance", "measure", "total", "minang", "forced", "unforc", "status");
  row *rows = calloc((size_t)nf * (size_t)nm + 1, sizeof(row));
  if (!rows) return 1;
  for (int i = 0; i < nf; ++i)
    for (int j = 0; j < nm; ++j) {
      row *r = &rows[i * nm + j];
      const char *base = strrchr(files[i], '/');
      snprintf(r->file, sizeof r->file, "%s", base ? base + 1 : files[i]);
      snprintf(r->method, sizeof r->method, "%s", methods[j]);
      run_one(cli, files[i], methods[j], timeout, old_cli, tmp, r);
      if (r->ran) {
        double meshing = r->t_mesh + r->t_connect;
        double measure = r->t_check + r->t_quality + r->t_distance;
        printf("%-44s %-12s %-5s %7ld %7.2f %7.2f %8.2f %7.2f %8.2f %7.2f %8.2f %8.2f%c %8.2f "
               "%7.2f %6ld %6ld  %s%s\n",
               r->file, r->method, r->valid ? "yes" : "NO", r->nodes, r->t_load, r->t_setup,
               r->t_mesh, r->t_connect, meshing, r->t_check, r->t_distance, measure,
               measure > meshing ? '>' : ' ', r->t_total, r->min_angle, r->forced, r->unforced,
               r->status, r->healed ? " (healed)" : "");
      } else {
        printf("%-44s %-12s %-5s %7s %7s %7s %8s %7s %8s %7s %8s %9s %8.2f %7s %6s %6s  %s\n",
               r->file, r->method, "-", "-", "-", "-", "-", "-", "-", "-", "-", "-", r->t_total,
               "-", "-", "-", r->status);
      }
      fflush(stdout);
    }
  printf("\n%-14s %6s %6s %6s %9s %12s %13s  %s\n", "method", "runs", "loaded", "valid",
         "no-unforc", "measure>mesh", "largest ratio", "where");
  for (int j = 0; j < nm; ++j) {
    int runs = 0, loaded = 0, valid = 0, clean = 0, slow = 0;
    double worst = 0;
    const char *where = "-";
    for (int i = 0; i < nf; ++i) {
      const row *r = &rows[i * nm + j];
      ++runs;
      loaded += r->ran;
      valid += r->ran && r->valid;
      clean += r->ran && r->valid && r->unforced == 0;
      if (!r->ran) continue;
      double measure = r->t_check + r->t_quality + r->t_distance;
      double meshing = r->t_mesh + r->t_connect;
      slow += measure > meshing;
      double ratio = meshing > 0 ? measure / meshing : 0;
      if (ratio > worst) worst = ratio, where = r->file;
    }
    printf("%-14s %6d %6d %6d %9d %12d %13.2f  %s\n", methods[j], runs, loaded, valid, clean, slow,
           worst, where);
  }
  /* Every stage beside the meshing of the same run: loading, set-up, the checker and the
   * distance against mesh + connect, and the connection against the method's own part (mesh). */
  printf("\nstages that took longer than the meshing of their run (connect: than mesh):\n");
  int any_stage = 0;
  for (int j = 0; j < nm; ++j)
    for (int i = 0; i < nf; ++i) {
      const row *r = &rows[i * nm + j];
      if (!r->ran) continue;
      const double meshing = r->t_mesh + r->t_connect;
      const struct {
        const char *name;
        double t, against;
      } st[] = {{"load", r->t_load, meshing},
                {"setup", r->t_setup, meshing},
                {"connect", r->t_connect, r->t_mesh},
                {"check", r->t_check, meshing},
                {"distance", r->t_distance, meshing}};
      for (size_t k = 0; k < sizeof st / sizeof st[0]; ++k)
        if (st[k].t > st[k].against) {
          printf("  %-44s %-12s %-8s %8.4f s against %8.4f s (%.2f times)\n", r->file,
                 r->method, st[k].name, st[k].t, st[k].against,
                 st[k].against > 0 ? st[k].t / st[k].against : INFINITY);
          any_stage = 1;
        }
    }
  if (!any_stage) printf("  none\n");
  /* bubble over gmsh-frontal, per file. */
  int jb = -1, jg = -1;
  for (int j = 0; j < nm; ++j) {
    if (!strcmp(methods[j], "bubble")) jb = j;
    if (!strcmp(methods[j], "gmsh-frontal")) jg = j;
  }
  if (jb >= 0 && jg >= 0) {
    double worst = 0;
    const char *where = "";
    int over10 = 0;
    for (int i = 0; i < nf; ++i) {
      const row *b = &rows[i * nm + jb], *g = &rows[i * nm + jg];
      if (!b->ran || !g->ran || !(g->t_total > 0)) continue;
      double ratio = b->t_total / g->t_total;
      over10 += ratio > 10;
      if (ratio > worst) worst = ratio, where = b->file;
    }
    printf("\nbubble / gmsh-frontal total time: largest %.1f (%s); files above 10: %d\n", worst,
           where, over10);
  }
  if (csv) {
    FILE *f = fopen(csv, "w");
    if (!f) {
      fprintf(stderr, "bench_robust: cannot write %s: %s\n", csv, strerror(errno));
    } else {
      fprintf(f, "file,method,status,valid,nodes,load_s,setup_s,mesh_s,connect_s,check_s,"
                 "quality_s,distance_s,total_s,min_angle_deg,needles_forced,needles_unforced,"
                 "healed,distance_mean,distance_max,iterations,median_aspect,p75_aspect\n");
      for (int i = 0; i < nf * nm; ++i) {
        const row *r = &rows[i];
        csv_text(f, r->file);
        fprintf(f, ",%s,", r->method);
        csv_text(f, r->status);
        if (r->ran)
          fprintf(f,
                  ",%s,%ld,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%ld,%ld,%d,%.17g,%.17g,%.0f,"
                  "%.6f,%.6f\n",
                  r->valid ? "true" : "false", r->nodes, r->t_load, r->t_setup, r->t_mesh,
                  r->t_connect, r->t_check, r->t_quality, r->t_distance, r->t_total,
                  r->min_angle, r->forced, r->unforced, r->healed, r->dist_mean, r->dist_max,
                  r->iterations, r->median_ar, r->p75_ar);
        else
          fprintf(f, ",,,,,,,,,,%.4f,,,,,,,,,\n", r->t_total);
      }
      fclose(f);
      printf("table written to %s\n", csv);
    }
  }
  char p[1100];
  snprintf(p, sizeof p, "%s/mesh.msh", tmp), unlink(p);
  snprintf(p, sizeof p, "%s/stats.json", tmp), unlink(p);
  snprintf(p, sizeof p, "%s/stderr.txt", tmp), unlink(p);
  rmdir(tmp);
  for (int i = 0; i < nf; ++i) free(files[i]);
  free(rows);
  return 0;
}
