/* Running the rows of a study: each row is a `packmesh mesh` child process (the binary running
 * the harness, /proc/self/exe) started in the study folder, in its own process group, with a
 * time limit; a second child, `packmesh quality MESH --csv`, writes the row's per-element
 * measures. Up to `jobs` children run at once.
 *
 * What a row leaves in runs/ID/: mesh.msh, stats.json, trace.csv (when the method writes one),
 * log.txt (the children's stdout and stderr), elements.csv, and status.json -- written last and
 * atomically, it is what makes the row finished: a study interrupted at any point resumes with
 * the rows that have no status.json, or whose recorded command differs from the one the suite
 * asks for now (so a changed suite reruns exactly the rows it changed).
 *
 * status.json also records the machine (and, in a Slurm task, the job) that ran the row. A Slurm
 * task (single) writes runs/ID/slurm.json when it starts the row, naming its job, so that a task
 * that dies without a status.json can be traced in Slurm's accounting (slurm.c).
 *
 * A failed child costs its row only: its status is "failed" with the child's one-line message
 * ("packmesh: ..." on stderr), "crashed (signal N, NAME)" when a library brought it down, or
 * "timed out after T s" when it was ended (the whole process group, so TetGen's helper process
 * goes too: SIGTERM first, so that `packmesh mesh` removes its temporary files, then SIGKILL
 * after END_GRACE_S). After a child that did not succeed, temporaries ("*.pmtmp-*",
 * elements.csv.part) left in its run folder are removed.
 */
#include <packmesh/packmesh.h>

#include <cjson/cJSON.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/base/atomic_file.h"
#include "common/base/clock.h"
#include "compare/src/study.h"

#define MAX_ARGS 600
/* Seconds a child has between SIGTERM and SIGKILL. */
#define END_GRACE_S 2.0

static volatile sig_atomic_t interrupted = 0;
static void on_signal(int sig) { interrupted = sig; }

typedef enum { R_WAIT = 0, R_RUNNING, R_DONE } rstate;

typedef struct job {
  int row;       /* -1: slot free */
  int stage;     /* 0: packmesh mesh, 1: packmesh quality --csv */
  pid_t pid;
  double t0;
  int timed_out;
  double term_at; /* when SIGTERM was sent (0: not yet) */
} job;

typedef struct runner {
  pm_cmp_study *st;
  const pm_cmp_run_opts *o;
  rstate *state;
  int threads;
  int ndone;
  double t_start, last_draw;
  char last[1024];
} runner;

/* ---- paths and files ----------------------------------------------------------------------- */

static void row_path(const pm_cmp_study *st, const pm_cmp_row *r, const char *file, char *buf,
                     size_t len) {
  snprintf(buf, len, "%s/runs/%s/%s", st->dir, r->id, file);
}

static int file_exists(const char *p) {
  struct stat sb;
  return stat(p, &sb) == 0 && S_ISREG(sb.st_mode);
}

/* Remove the temporaries a child that did not finish left in its run folder. */
static void sweep_row(const pm_cmp_study *st, const pm_cmp_row *r) {
  char dir[4096];
  snprintf(dir, sizeof dir, "%s/runs/%s", st->dir, r->id);
  DIR *d = opendir(dir);
  if (!d) return;
  struct dirent *de;
  while ((de = readdir(d))) {
    size_t n = strlen(de->d_name);
    if (!strstr(de->d_name, ".pmtmp-") && !(n > 5 && strcmp(de->d_name + n - 5, ".part") == 0))
      continue;
    char p[8192];
    snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
    if (unlink(p) != 0) rmdir(p);
  }
  closedir(d);
}

/* End a child's process group: SIGTERM now; SIGKILL once END_GRACE_S has passed (call again). */
static void end_child(job *j) {
  double now = pm_seconds();
  if (j->term_at == 0) {
    j->term_at = now;
    kill(-j->pid, SIGTERM);
    kill(j->pid, SIGTERM);
  } else if (now - j->term_at > END_GRACE_S) {
    kill(-j->pid, SIGKILL);
    kill(j->pid, SIGKILL);
  }
}

/* The child's message: the last "packmesh: ..." line of its log, without the prefix (the same
 * line a user sees running the command), else the last non-empty line. */
static void log_error(const char *log_path, char *out, size_t len) {
  out[0] = '\0';
  size_t n = 0;
  char *text = pm_cmp_read_file(log_path, &n);
  if (!text) return;
  char *line = text, *best = NULL, *lastline = NULL;
  while (line && *line) {
    char *nl = strchr(line, '\n');
    if (nl) *nl = '\0';
    if (strncmp(line, "packmesh: ", 10) == 0) best = line + 10;
    if (line[strspn(line, " \t\r")]) lastline = line;
    line = nl ? nl + 1 : NULL;
  }
  const char *msg = best ? best : lastline;
  if (msg) snprintf(out, len, "%s", msg);
  for (char *c = out; *c; ++c)
    if (*c == '\r') *c = ' ';
  free(text);
}

/* ---- the command of a row ------------------------------------------------------------------ */

typedef struct argvec {
  char *v[MAX_ARGS + 1];
  int n;
} argvec;

static int arg_add(argvec *a, const char *s) {
  if (a->n >= MAX_ARGS) return -1;
  a->v[a->n] = malloc(strlen(s) + 1);
  if (!a->v[a->n]) return -1;
  strcpy(a->v[a->n++], s);
  a->v[a->n] = NULL;
  return 0;
}

static void arg_free(argvec *a) {
  for (int i = 0; i < a->n; ++i) free(a->v[i]);
  a->n = 0;
}

/* argv for `packmesh mesh` and its shell form. target > 0 adds --target-nodes (or, when the
 * suite matches surfaces, --target-surface-nodes). Paths of the
 * outputs are relative to the study folder, where the child runs. */
static int build_command(const runner *R, const pm_cmp_row *r, long target, argvec *a,
                         char *cmd, size_t cmdlen) {
  const pm_cmp_suite *s = &R->st->suite;
  const pm_cmp_case *c = &s->cases[r->icase];
  const pm_cmp_method *m = &s->methods[r->imethod];
  char buf[1200];
  a->n = 0;
  int bad = 0;
  bad |= arg_add(a, "packmesh");
  bad |= arg_add(a, "mesh");
  bad |= arg_add(a, c->input);
  bad |= arg_add(a, "--method");
  bad |= arg_add(a, m->name);
  const char *size = c->size;
  if (r->isweep >= 0 && strcmp(s->sweep_key, "size") == 0) size = s->sweep_values[r->isweep];
  if (size) {
    bad |= arg_add(a, "--size");
    bad |= arg_add(a, size);
  }
  for (int k = 0; k < m->nset; ++k) {
    bad |= arg_add(a, "--set");
    bad |= arg_add(a, m->sets[k]);
  }
  if (r->isweep >= 0 && strcmp(s->sweep_key, "size") != 0) {
    snprintf(buf, sizeof buf, "%s=%s", s->sweep_key, s->sweep_values[r->isweep]);
    bad |= arg_add(a, "--set");
    bad |= arg_add(a, buf);
  }
  snprintf(buf, sizeof buf, "%ld", r->seed);
  bad |= arg_add(a, "--seed");
  bad |= arg_add(a, buf);
  snprintf(buf, sizeof buf, "%d", R->threads);
  bad |= arg_add(a, "--threads");
  bad |= arg_add(a, buf);
  if (c->volume) bad |= arg_add(a, "--volume");
  if (s->max_nodes > 0) {
    snprintf(buf, sizeof buf, "%ld", s->max_nodes);
    bad |= arg_add(a, "--max-nodes");
    bad |= arg_add(a, buf);
  }
  if (target > 0) {
    snprintf(buf, sizeof buf, "%ld", target);
    bad |= arg_add(a, s->match_surface ? "--target-surface-nodes" : "--target-nodes");
    bad |= arg_add(a, buf);
  }
  snprintf(buf, sizeof buf, "runs/%s/mesh.msh", r->id);
  bad |= arg_add(a, "-o");
  bad |= arg_add(a, buf);
  snprintf(buf, sizeof buf, "runs/%s/stats.json", r->id);
  bad |= arg_add(a, "--stats");
  bad |= arg_add(a, buf);
  /* A trace of the methods that record one; `mesh` refuses --trace for the others. */
  const pm_method *method = pm_method_find(m->name);
  if (s->trace && method && pm_method_traces(method)) {
    snprintf(buf, sizeof buf, "runs/%s/trace.csv", r->id);
    bad |= arg_add(a, "--trace");
    bad |= arg_add(a, buf);
  }
  if (bad) return -1;
  cmd[0] = '\0';
  for (int i = 0; i < a->n; ++i) {
    char q[2400];
    pm_cmp_shell_quote(a->v[i], q, sizeof q);
    if (strlen(cmd) + strlen(q) + 2 >= cmdlen) return -1;
    if (i) strcat(cmd, " ");
    strcat(cmd, q);
  }
  /* The run's phase into its log.txt every 2 s, which the updating line shows for the run in
   * flight. Left out of the recorded command: it changes no output, and a resumed study compares
   * the commands to decide what to run again. */
  return arg_add(a, "--progress") ? -1 : 0;
}

/* ---- status.json --------------------------------------------------------------------------- */

pm_status pm_cmp_record_write(const pm_cmp_study *st, const pm_cmp_row *r, pm_error *err) {
  cJSON *o = cJSON_CreateObject();
  if (!o) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  cJSON_AddStringToObject(o, "status", pm_cmp_status_name(r->status));
  cJSON_AddStringToObject(o, "error", r->error);
  cJSON_AddStringToObject(o, "command", r->command);
  cJSON_AddNumberToObject(o, "wall_s", r->wall_s);
  cJSON_AddNumberToObject(o, "nodes", (double)r->nodes);
  cJSON_AddBoolToObject(o, "elements", r->elements_ok);
  cJSON_AddStringToObject(o, "host", r->host);
  if (r->job[0]) cJSON_AddStringToObject(o, "slurm_job", r->job);
  char *text = cJSON_Print(o);
  cJSON_Delete(o);
  if (!text) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  char path[4096];
  row_path(st, r, "status.json", path, sizeof path);
  pm_status s = pm_atomic_write(path, text, strlen(text), err);
  free(text);
  return s;
}

static pm_cmp_status status_of(const char *name) {
  static const pm_cmp_status all[] = {PM_CMP_OK, PM_CMP_FAILED, PM_CMP_CRASHED, PM_CMP_TIMEOUT};
  for (size_t i = 0; i < sizeof all / sizeof all[0]; ++i)
    if (strcmp(name, pm_cmp_status_name(all[i])) == 0) return all[i];
  return PM_CMP_PENDING;
}

/* Load the stats of an OK row into r->flat; nodes from them. */
static pm_status load_stats(const runner *R, pm_cmp_row *r, pm_error *err) {
  char path[4096];
  row_path(R->st, r, "stats.json", path, sizeof path);
  char *text = pm_cmp_read_file(path, NULL);
  if (!text) return pm_error_setf(err, PM_ERR_IO, "the run wrote no stats (%s)", path);
  pm_stats_flat_clear(&r->flat);
  pm_status s = pm_stats_flatten_json(text, &r->flat, err);
  free(text);
  if (s) return s;
  const pm_stats_item *it = pm_stats_flat_find(&r->flat, "nodes");
  if (!it || it->is_text) return pm_error_setf(err, PM_ERR_PARSE, "stats without \"nodes\"");
  r->nodes = (long)it->num;
  return PM_OK;
}

/* A row finished by an earlier invocation with the same command: take its record (a failed one
 * only when !retry). */
static int try_reuse(const runner *R, pm_cmp_row *r, int retry) {
  char path[4096];
  row_path(R->st, r, "status.json", path, sizeof path);
  char *text = pm_cmp_read_file(path, NULL);
  if (!text) return 0;
  cJSON *o = cJSON_Parse(text);
  free(text);
  if (!o) return 0;
  const cJSON *status = cJSON_GetObjectItemCaseSensitive(o, "status");
  const cJSON *command = cJSON_GetObjectItemCaseSensitive(o, "command");
  const cJSON *error = cJSON_GetObjectItemCaseSensitive(o, "error");
  const cJSON *wall = cJSON_GetObjectItemCaseSensitive(o, "wall_s");
  const cJSON *elements = cJSON_GetObjectItemCaseSensitive(o, "elements");
  const cJSON *host = cJSON_GetObjectItemCaseSensitive(o, "host");
  const cJSON *job = cJSON_GetObjectItemCaseSensitive(o, "slurm_job");
  const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(o, "nodes");
  int ok = cJSON_IsString(status) && cJSON_IsString(command) &&
           strcmp(command->valuestring, r->command) == 0;
  pm_cmp_status s = ok ? status_of(status->valuestring) : PM_CMP_PENDING;
  if (s == PM_CMP_PENDING || (s != PM_CMP_OK && retry)) ok = 0;
  if (ok) {
    r->status = s;
    snprintf(r->error, sizeof r->error, "%s", cJSON_IsString(error) ? error->valuestring : "");
    r->wall_s = cJSON_IsNumber(wall) ? wall->valuedouble : 0;
    snprintf(r->host, sizeof r->host, "%s", cJSON_IsString(host) ? host->valuestring : "");
    snprintf(r->job, sizeof r->job, "%s", cJSON_IsString(job) ? job->valuestring : "");
    if (cJSON_IsNumber(nodes)) r->nodes = (long)nodes->valuedouble;
    r->elements_ok = cJSON_IsTrue(elements);
    if (s == PM_CMP_OK && load_stats(R, r, NULL) != PM_OK) ok = 0;
    if (r->elements_ok) {
      row_path(R->st, r, "elements.csv", path, sizeof path);
      r->elements_ok = file_exists(path);
    }
  }
  cJSON_Delete(o);
  if (!ok) {
    r->status = PM_CMP_PENDING;
    r->error[0] = '\0';
    r->host[0] = r->job[0] = '\0';
    r->wall_s = 0;
    r->nodes = -1;
    r->elements_ok = 0;
    pm_stats_flat_clear(&r->flat);
  }
  r->reused = ok;
  return ok;
}

/* ---- children ------------------------------------------------------------------------------ */

/* Start argv in the study folder in a new process group. stdout to out_path (truncated, or
 * appended), stderr to stdout or to err_path (appended). */
static pid_t spawn(const char *exe, char *const argv[], const char *cwd, const char *out_path,
                   int out_append, const char *err_path) {
  fflush(NULL);
  pid_t parent = getpid();
  pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    setpgid(0, 0);
    /* A study killed outright (SIGKILL: a Slurm task ended by its node, the OOM killer) takes
     * its run with it: no orphan goes on writing into the run folder that a later attempt uses. */
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(126);
    /* The study's own handlers must not run in the child. */
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    if (chdir(cwd) != 0) _exit(126);
    int fo = open(out_path, O_WRONLY | O_CREAT | (out_append ? O_APPEND : O_TRUNC), 0666);
    int fe = err_path ? open(err_path, O_WRONLY | O_CREAT | O_APPEND, 0666) : fo;
    int fi = open("/dev/null", O_RDONLY);
    if (fo < 0 || fe < 0 || fi < 0) _exit(126);
    dup2(fi, 0);
    dup2(fo, 1);
    dup2(fe, 2);
    execv(exe, argv);
    dprintf(2, "packmesh: cannot start %s: %s\n", exe, strerror(errno));
    _exit(126);
  }
  setpgid(pid, pid); /* also here: whichever runs first, the group exists before a kill */
  return pid;
}

/* ---- progress ------------------------------------------------------------------------------ */

/* The last progress line of a running mesh run's log.txt ("packmesh: METHOD: TEXT, m:ss.s"), as
 * TEXT with its time, into buf; "" when it has printed none yet. Reads the file's last 512 bytes
 * only: the log grows by a line every 2 s. */
static void run_phase(const pm_cmp_study *st, const pm_cmp_row *r, char *buf, size_t len) {
  buf[0] = '\0';
  char p[4096], tail[513];
  row_path(st, r, "log.txt", p, sizeof p);
  FILE *f = fopen(p, "rb");
  if (!f) return;
  size_t n = 0;
  if (fseek(f, 0, SEEK_END) == 0) {
    long size = ftell(f);
    if (size > 0 && fseek(f, size > 512 ? size - 512 : 0, SEEK_SET) == 0)
      n = fread(tail, 1, sizeof tail - 1, f);
  }
  fclose(f);
  tail[n] = '\0';
  /* The last complete line that the progress wrote. */
  char *line = NULL;
  for (char *q = tail; (q = strstr(q, "packmesh: ")) != NULL; q += 10)
    if (strchr(q, '\n')) line = q;
  if (!line) return;
  *strchr(line, '\n') = '\0';
  const char *text = strchr(line + 10, ':'); /* past "packmesh: METHOD" */
  snprintf(buf, len, "%s", text && text[1] == ' ' ? text + 2 : line + 10);
}

static void draw(runner *R, const job *slots, int jobs, int running, int force) {
  const pm_cmp_run_opts *o = R->o;
  if (o->progress != 2) return;
  double now = pm_seconds();
  if (!force && now - R->last_draw < 0.5) return;
  R->last_draw = now;
  int el = (int)(now - R->t_start);
  /* The run in flight longest, with its phase; else the last run finished. */
  const job *oldest = NULL;
  for (int k = 0; k < jobs; ++k)
    if (slots[k].row >= 0 && slots[k].stage == 0 && (!oldest || slots[k].t0 < oldest->t0))
      oldest = &slots[k];
  char flight[700] = "";
  if (oldest) {
    char title[320], phase[200];
    pm_cmp_row_title(R->st, &R->st->rows[oldest->row], title, sizeof title);
    run_phase(R->st, &R->st->rows[oldest->row], phase, sizeof phase);
    int t = (int)(now - oldest->t0);
    if (phase[0])
      snprintf(flight, sizeof flight, "%s: %s", title, phase);
    else
      snprintf(flight, sizeof flight, "%s: started %d:%02d ago", title, t / 60, t % 60);
  }
  const char *tail = oldest ? flight : R->last;
  char line[1200];
  snprintf(line, sizeof line, "[%d/%d] %d:%02d %d running%s%s", R->ndone, R->st->nrow, el / 60,
           el % 60, running, tail[0] ? " | " : "", tail);
  /* One screen line: a wrapped line could not be rewritten by the carriage return. */
  struct winsize ws;
  int width = ioctl(fileno(o->log), TIOCGWINSZ, &ws) == 0 && ws.ws_col > 10 ? ws.ws_col : 80;
  if ((int)strlen(line) > width - 1) line[width - 1] = '\0';
  fprintf(o->log, "\r\033[K%s", line);
  fflush(o->log);
}

static void report_row(runner *R, const pm_cmp_row *r) {
  char title[320];
  pm_cmp_row_title(R->st, r, title, sizeof title);
  char what[96];
  if (r->status == PM_CMP_OK)
    snprintf(what, sizeof what, "ok (%.1f s, %ld nodes)%s", r->wall_s, r->nodes,
             r->reused ? " [earlier run]" : "");
  else
    snprintf(what, sizeof what, "%s%s", pm_cmp_status_name(r->status),
             r->reused ? " [earlier run]" : "");
  snprintf(R->last, sizeof R->last, "%s ... %s", title, what);
  const pm_cmp_run_opts *o = R->o;
  if (o->progress == 1) {
    fprintf(o->log, "[%d/%d] %s ... %s%s%s\n", R->ndone, R->st->nrow, title, what,
            r->status == PM_CMP_OK ? "" : ": ", r->status == PM_CMP_OK ? "" : r->error);
    fflush(o->log);
  } else if (o->progress == 2 && r->status != PM_CMP_OK && !r->reused) {
    /* Failures stay on screen above the updating line. */
    fprintf(o->log, "\r\033[K[%d/%d] %s ... %s: %s\n", R->ndone, R->st->nrow, title, what,
            r->error);
    fflush(o->log);
  }
}

/* ---- the loop ------------------------------------------------------------------------------ */

static void finish_row(runner *R, pm_cmp_row *r, pm_status *io, pm_error *err) {
  R->state[r->index] = R_DONE;
  R->ndone++;
  if (!r->reused && r->status != PM_CMP_SKIPPED && r->status != PM_CMP_PENDING) {
    pm_error e = {0};
    if (pm_cmp_record_write(R->st, r, &e) && *io == PM_OK) {
      *io = e.code;
      if (err) *err = e;
    }
  }
  if (r->status != PM_CMP_PENDING) report_row(R, r);
}

/* The command of a row into r->command, and its argv into a when given: a matched row's target
 * is its reference's node count. Returns 0; 1 when the row is not run: SKIPPED (its reference
 * did not succeed) or FAILED (no command could be built); -1 when its reference has no record
 * yet (the row stays PENDING, with no command). */
static int plan_row(const runner *R, pm_cmp_row *r, argvec *a) {
  const pm_cmp_study *st = R->st;
  long target = 0;
  r->command[0] = '\0';
  if (r->ref_row >= 0) {
    const pm_cmp_row *ref = &st->rows[r->ref_row];
    if (ref->status == PM_CMP_PENDING) return -1;
    if (ref->status != PM_CMP_OK) {
      r->status = PM_CMP_SKIPPED;
      snprintf(r->error, sizeof r->error, "not run: node counts are matched to %s, whose run %s",
               st->suite.methods[ref->imethod].label,
               ref->status == PM_CMP_SKIPPED ? "was skipped" : "failed");
      return 1;
    }
    target = ref->nodes;
    if (st->suite.match_surface) {
      /* The reference's surface nodes, which every run records (surface_nodes). */
      double sn = pm_cmp_row_value(ref, "surface_nodes");
      target = isfinite(sn) ? (long)sn : 0;
      if (target < 3) {
        r->status = PM_CMP_FAILED;
        snprintf(r->error, sizeof r->error,
                 "not run: surface nodes are matched to %s, whose run %s has no surface_nodes",
                 st->suite.methods[ref->imethod].label, ref->id);
        return 1;
      }
    }
  }
  argvec tmp = {0};
  argvec *v = a ? a : &tmp;
  int bad = build_command(R, r, target, v, r->command, sizeof r->command);
  if (bad || !a) arg_free(v);
  if (bad) {
    r->command[0] = '\0';
    r->status = PM_CMP_FAILED;
    snprintf(r->error, sizeof r->error, "command too long or out of memory");
    return 1;
  }
  return 0;
}

/* runs/ID/slurm.json: the Slurm job that starts the row now (study.h). */
static pm_status write_marker(const runner *R, const pm_cmp_row *r, pm_error *err) {
  cJSON *o = cJSON_CreateObject();
  if (!o) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  cJSON_AddStringToObject(o, "job", R->o->job);
  cJSON_AddStringToObject(o, "job_id", R->o->job_id ? R->o->job_id : "");
  cJSON_AddStringToObject(o, "host", r->host);
  cJSON_AddNumberToObject(o, "started", (double)time(NULL));
  char *text = cJSON_Print(o);
  cJSON_Delete(o);
  if (!text) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  char path[4096];
  row_path(R->st, r, PM_CMP_SLURM_MARKER, path, sizeof path);
  pm_status s = pm_atomic_write(path, text, strlen(text), err);
  free(text);
  return s;
}

static void set_host(const runner *R, pm_cmp_row *r) {
  if (R->o->host && R->o->host[0]) {
    snprintf(r->host, sizeof r->host, "%s", R->o->host);
  } else if (gethostname(r->host, sizeof r->host) != 0) {
    snprintf(r->host, sizeof r->host, "unknown");
  }
  r->host[sizeof r->host - 1] = '\0';
  snprintf(r->job, sizeof r->job, "%s", R->o->job ? R->o->job : "");
}

static int start_mesh(runner *R, job *j, pm_cmp_row *r, pm_status *io, pm_error *err) {
  const pm_cmp_study *st = R->st;
  argvec a = {0};
  int planned = plan_row(R, r, &a);
  if (planned != 0) {
    finish_row(R, r, io, err);
    return 0;
  }
  if (try_reuse(R, r, R->o->retry_failed)) {
    arg_free(&a);
    finish_row(R, r, io, err);
    R->st->nreused++;
    return 0;
  }
  char dir[4096], logp[4096];
  snprintf(dir, sizeof dir, "%s/runs/%s", st->dir, r->id);
  pm_error e = {0};
  if (pm_cmp_mkdirs(dir, &e)) {
    arg_free(&a);
    if (*io == PM_OK) {
      *io = e.code;
      if (err) *err = e;
    }
    return -1;
  }
  /* Outputs of an earlier, different run of this row must not be taken for this one's (nor an
   * earlier Slurm task's marker for this run's). */
  static const char *const old[] = {"status.json", "stats.json",  "mesh.msh",
                                    "trace.csv",   "elements.csv", PM_CMP_SLURM_MARKER,
                                    NULL};
  for (int k = 0; old[k]; ++k) {
    char p[4096];
    row_path(st, r, old[k], p, sizeof p);
    unlink(p);
  }
  set_host(R, r);
  if (R->o->job && R->o->job[0] && write_marker(R, r, &e)) {
    arg_free(&a);
    if (*io == PM_OK) {
      *io = e.code;
      if (err) *err = e;
    }
    return -1;
  }
  row_path(st, r, "log.txt", logp, sizeof logp);
  j->pid = spawn(st->exe, a.v, st->dir, logp, 0, NULL);
  arg_free(&a);
  if (j->pid < 0) {
    r->status = PM_CMP_FAILED;
    snprintf(r->error, sizeof r->error, "cannot start a process: %s", strerror(errno));
    finish_row(R, r, io, err);
    return 0;
  }
  j->row = r->index;
  j->stage = 0;
  j->t0 = pm_seconds();
  j->timed_out = 0;
  j->term_at = 0;
  R->state[r->index] = R_RUNNING;
  R->st->nrun++;
  return 1;
}

static int start_quality(runner *R, job *j, pm_cmp_row *r) {
  const pm_cmp_study *st = R->st;
  char mesh[4096], part[4096], logp[4096];
  snprintf(mesh, sizeof mesh, "runs/%s/mesh.msh", r->id);
  row_path(st, r, "elements.csv.part", part, sizeof part);
  row_path(st, r, "log.txt", logp, sizeof logp);
  char *argv[] = {"packmesh", "quality", mesh, "--csv", NULL};
  j->pid = spawn(st->exe, argv, st->dir, part, 0, logp);
  if (j->pid < 0) return 0;
  j->row = r->index;
  j->stage = 1;
  j->t0 = pm_seconds();
  j->timed_out = 0;
  j->term_at = 0;
  return 1;
}

static void describe_signal(int sig, char *buf, size_t len) {
  const char *name = strsignal(sig);
  snprintf(buf, len, "crashed (signal %d, %s)", sig, name ? name : "unknown");
}

/* A child ended: set the row's status; returns 1 when the row needs its quality stage. */
static int child_done(runner *R, job *j, int ws) {
  pm_cmp_row *r = &R->st->rows[j->row];
  double dt = pm_seconds() - j->t0;
  char logp[4096];
  row_path(R->st, r, "log.txt", logp, sizeof logp);
  if (j->stage == 1) {
    char part[4096], fin[4096];
    row_path(R->st, r, "elements.csv.part", part, sizeof part);
    row_path(R->st, r, "elements.csv", fin, sizeof fin);
    struct stat sb;
    if (!j->timed_out && WIFEXITED(ws) && WEXITSTATUS(ws) == 0 && stat(part, &sb) == 0 &&
        sb.st_size > 0 && rename(part, fin) == 0) {
      r->elements_ok = 1;
    } else {
      unlink(part);
      FILE *f = fopen(logp, "a");
      if (f) {
        fprintf(f, "packmesh compare: no per-element measures (packmesh quality %s)\n",
                j->timed_out ? "timed out" : "failed");
        fclose(f);
      }
    }
    return 0;
  }
  r->wall_s = dt;
  if (j->timed_out) {
    r->status = PM_CMP_TIMEOUT;
    snprintf(r->error, sizeof r->error, "timed out after %g s", R->st->suite.timeout_s);
  } else if (WIFSIGNALED(ws)) {
    r->status = PM_CMP_CRASHED;
    describe_signal(WTERMSIG(ws), r->error, sizeof r->error);
  } else if (WIFEXITED(ws) && WEXITSTATUS(ws) != 0) {
    r->status = PM_CMP_FAILED;
    log_error(logp, r->error, sizeof r->error);
    if (!r->error[0]) snprintf(r->error, sizeof r->error, "exit code %d", WEXITSTATUS(ws));
  } else {
    pm_error e = {0};
    if (load_stats(R, r, &e)) {
      r->status = PM_CMP_FAILED;
      snprintf(r->error, sizeof r->error, "%s", e.msg);
    } else {
      r->status = PM_CMP_OK;
      return 1;
    }
  }
  return 0;
}

int pm_cmp_run_threads(const pm_cmp_suite *s, int jobs) {
  if (s->threads > 0) return s->threads;
  if (jobs <= 0) return 1;
  long cores = sysconf(_SC_NPROCESSORS_ONLN);
  return (int)(cores / jobs > 0 ? cores / jobs : 1);
}

static void reset_row(pm_cmp_row *r) {
  r->status = PM_CMP_PENDING;
  r->reused = 0;
  r->elements_ok = 0;
  r->nodes = -1;
  r->wall_s = 0;
  r->same_mesh_as = -1;
  r->error[0] = r->host[0] = r->job[0] = '\0';
  pm_stats_flat_clear(&r->flat);
}

/* A row's state from its record, running nothing (pm_cmp_records_read); a failed record is taken
 * unless retry. */
static void read_row(const runner *R, pm_cmp_row *r, int retry) {
  reset_row(r);
  if (plan_row(R, r, NULL) == 0) try_reuse(R, r, retry);
}

pm_status pm_cmp_records_read(pm_cmp_study *st, int threads, pm_error *err) {
  (void)err;
  pm_cmp_run_opts o = {0};
  o.threads = threads;
  runner R;
  memset(&R, 0, sizeof R);
  R.st = st;
  R.o = &o;
  R.threads = threads > 0 ? threads : pm_cmp_run_threads(&st->suite, 0);
  st->nreused = 0;
  /* In row order: a reference comes before the rows matched to it. */
  for (int i = 0; i < st->nrow; ++i) {
    read_row(&R, &st->rows[i], 0);
    st->nreused += st->rows[i].reused;
  }
  return PM_OK;
}

pm_status pm_cmp_run(pm_cmp_study *st, const pm_cmp_run_opts *o, pm_error *err) {
  runner R;
  memset(&R, 0, sizeof R);
  R.st = st;
  R.o = o;
  int jobs = o->single ? 1 : o->jobs > 0 ? o->jobs : 1;
  R.threads = o->threads > 0 ? o->threads : pm_cmp_run_threads(&st->suite, jobs);
  if (o->single && (o->row < 0 || o->row >= st->nrow))
    return pm_error_setf(err, PM_ERR_ARG, "run %d is not in the study (it has runs 0 to %d)",
                         o->row, st->nrow - 1);
  R.state = calloc((size_t)st->nrow + 1, sizeof *R.state);
  job *slots = calloc((size_t)jobs, sizeof *slots);
  if (!R.state || !slots) {
    free(R.state);
    free(slots);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int k = 0; k < jobs; ++k) slots[k].row = -1;
  for (int i = 0; i < st->nrow; ++i) reset_row(&st->rows[i]);
  if (o->single) {
    /* One row: the others are done as far as this invocation goes; its reference (run by another
     * task) is read from its record as it is, failed or not. */
    for (int i = 0; i < st->nrow; ++i)
      if (i != o->row) R.state[i] = R_DONE, R.ndone++;
    int ref = st->rows[o->row].ref_row;
    if (ref >= 0) read_row(&R, &st->rows[ref], 0);
  }
  char runs[4096];
  snprintf(runs, sizeof runs, "%s/runs", st->dir);
  pm_status io = pm_cmp_mkdirs(runs, err);
  if (io) {
    free(R.state);
    free(slots);
    return io;
  }

  struct sigaction sa, old_int, old_term;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  interrupted = 0;
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);

  R.t_start = pm_seconds();
  int running = 0, next = 0, nq = 0, qnext = 0;
  int *qrows = calloc((size_t)st->nrow + 1, sizeof *qrows);
  if (!qrows) io = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  while (!io && !interrupted && (R.ndone < st->nrow || running > 0)) {
    int progress = 0;
    /* Reap. */
    for (int k = 0; k < jobs; ++k) {
      job *j = &slots[k];
      if (j->row < 0) continue;
      int ws = 0;
      pid_t w = waitpid(j->pid, &ws, WNOHANG);
      if (w == 0) {
        double limit = st->suite.timeout_s;
        if (!j->timed_out && pm_seconds() - j->t0 > limit) j->timed_out = 1;
        if (j->timed_out) end_child(j);
        continue;
      }
      if (w < 0 && errno == EINTR) continue;
      /* The group may still hold a grandchild (TetGen's helper): end it with its parent. */
      kill(-j->pid, SIGKILL);
      pm_cmp_row *r = &st->rows[j->row];
      if (j->timed_out || !WIFEXITED(ws) || WEXITSTATUS(ws) != 0) sweep_row(st, r);
      if (w < 0) {
        r->status = PM_CMP_FAILED;
        snprintf(r->error, sizeof r->error, "lost the child process: %s", strerror(errno));
      } else if (child_done(&R, j, ws)) {
        qrows[nq++] = r->index;
      }
      if (!(w > 0 && j->stage == 0 && r->status == PM_CMP_OK)) finish_row(&R, r, &io, err);
      j->row = -1;
      running--;
      progress = 1;
    }
    /* Start: quality stages first (they finish rows), then new rows in order, each once its
     * reference row is done. */
    for (int k = 0; k < jobs && !io; ++k) {
      job *j = &slots[k];
      if (j->row >= 0) continue;
      if (qnext < nq) {
        pm_cmp_row *r = &st->rows[qrows[qnext++]];
        if (start_quality(&R, j, r)) {
          running++;
        } else {
          finish_row(&R, r, &io, err);
        }
        progress = 1;
        continue;
      }
      /* The next row that can start: its reference (if any) is done. */
      for (int i = next; i < st->nrow; ++i) {
        pm_cmp_row *r = &st->rows[i];
        if (R.state[i] != R_WAIT) continue;
        if (r->ref_row >= 0 && R.state[r->ref_row] != R_DONE) continue;
        if (start_mesh(&R, j, r, &io, err) > 0) running++;
        progress = 1;
        if (j->row >= 0 || io) break;
      }
      while (next < st->nrow && R.state[next] != R_WAIT) next++;
    }
    draw(&R, slots, jobs, running, progress);
    if (!progress) {
      struct timespec ts = {0, 20 * 1000 * 1000};
      nanosleep(&ts, NULL);
    }
  }
  if (interrupted || io) {
    /* SIGTERM to every running child, SIGKILL to those still there after the grace period. */
    int left = 0;
    for (int k = 0; k < jobs; ++k)
      if (slots[k].row >= 0) end_child(&slots[k]), ++left;
    while (left > 0) {
      left = 0;
      for (int k = 0; k < jobs; ++k) {
        job *j = &slots[k];
        if (j->row < 0) continue;
        pid_t w = waitpid(j->pid, NULL, WNOHANG);
        if (w == j->pid || (w < 0 && errno != EINTR)) {
          kill(-j->pid, SIGKILL);
          sweep_row(st, &st->rows[j->row]);
          j->row = -1;
          continue;
        }
        end_child(j);
        ++left;
      }
      if (left) {
        struct timespec ts = {0, 10 * 1000 * 1000};
        nanosleep(&ts, NULL);
      }
    }
  }
  if (o->progress == 2) {
    draw(&R, slots, 0, 0, 1);
    fputc('\n', o->log);
    fflush(o->log);
  }
  sigaction(SIGINT, &old_int, NULL);
  sigaction(SIGTERM, &old_term, NULL);
  free(qrows);
  free(R.state);
  free(slots);
  st->interrupted = interrupted;
  if (!io && !interrupted && !o->single) io = pm_cmp_duplicates_mark(st, err);
  if (!io && interrupted && o->single)
    io = pm_error_setf(err, PM_ERR_ARG,
                       "compare interrupted by %s before run %d (%s) finished; it has no record: "
                       "the next submission runs it",
                       interrupted == SIGINT ? "SIGINT" : "SIGTERM", o->row, st->rows[o->row].id);
  else if (!io && interrupted)
    io = pm_error_setf(err, PM_ERR_ARG,
                       "compare interrupted by %s with %d of %d runs finished; run the same "
                       "command again to resume",
                       interrupted == SIGINT ? "SIGINT" : "SIGTERM", R.ndone, st->nrow);
  return io;
}
