/* The Slurm engine of a study (compare.h, "the Slurm engine"): the rows become the tasks of job
 * arrays, each task `packmesh compare SUITE -o DIR --slurm-task ROW` running one row exactly as
 * the local engine does (run.c, with single); a last job, `packmesh compare SUITE -o DIR
 * --collect`, writes the tables, figures and report from the folder.
 *
 * Nothing but the study folder and Slurm's own queue carries state:
 *   - a row is finished when its runs/ID/status.json records its command (as for the local
 *     engine, so that a study can move between the engines);
 *   - a row is pending or running when a task of one of the study's jobs holds it in squeue: the
 *     jobs are named after the study (a hash of its folder) and the first row of their array
 *     ("pm.NAME.HASH.0"; task i of that array is row 0 + i), so `squeue --name` tells which rows
 *     are in flight, and a second submission submits only the others;
 *   - a task that starts its row writes runs/ID/slurm.json (its job), so that a task that died
 *     without a status.json (node failure, out of memory, Slurm's time limit, kill -9) can be
 *     looked up in Slurm's accounting (sacct; sacct -c with job completion only; scontrol while
 *     the controller still knows the job) and recorded as crashed or timeout with Slurm's state.
 * Matched node counts: a row matched to a reference whose run is still to come goes into a
 * second array that starts after the first (afterany): its --target-nodes is read from the
 * reference's record when its task starts. The task index is the row, within windows of 1000
 * rows (Slurm's default MaxArraySize is 1001), so that the arrays of a large study stay valid.
 */
#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/base/atomic_file.h"
#include "compare/src/study.h"

/* Rows per array: task ids stay below Slurm's default MaxArraySize (1001). */
#define WINDOW 1000
/* Seconds an sbatch, squeue, sacct or scontrol may take. */
#define SLURM_CMD_TIMEOUT_S 60
/* Seconds between two looks at the queue while waiting. */
#define WAIT_POLL_S 3
/* Minutes the report job may take (plots of large studies take a while). */
#define REPORT_MINUTES 60

/* What the queue says of a row. */
typedef enum { Q_NONE = 0, Q_PENDING, Q_RUNNING } qstate;

typedef struct queue {
  qstate *row;          /* [nrow] */
  char (*job)[32];      /* [nrow] the task holding the row ("12_3") */
  char (*array)[24];    /* [nrow] its array job ("12") */
  char report[32];      /* a report job of the study in the queue, "" none */
  char **ids;           /* the study's array and report jobs in the queue (unique) */
  int nid;
  int answered;         /* squeue ran */
} queue;

/* ---- names and paths ----------------------------------------------------------------------- */

/* "pm.NAME.HASH": NAME the suite's (folder-safe, at most 24 characters), HASH 8 hex digits of
 * the study folder's path (FNV-1a), so that two studies never share a name. */
static void study_key(const pm_cmp_study *st, char *out, size_t len) {
  uint32_t h = 2166136261u;
  for (const char *c = st->dir; *c; ++c) h = (h ^ (unsigned char)*c) * 16777619u;
  char name[25];
  snprintf(name, sizeof name, "%s", st->suite.name);
  for (char *c = name; *c; ++c)
    if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
          *c == '-' || *c == '_'))
      *c = '_';
  snprintf(out, len, "pm.%s.%08x", name, (unsigned)h);
}

static void job_name(const pm_cmp_study *st, int base, char *out, size_t len) {
  char key[64];
  study_key(st, key, sizeof key);
  if (base < 0)
    snprintf(out, len, "%s.report", key);
  else
    snprintf(out, len, "%s.%d", key, base);
}

/* Every name the study's jobs can have, comma-separated (squeue --name). */
static void all_names(const pm_cmp_study *st, char *out, size_t len) {
  out[0] = '\0';
  char n[96];
  for (int base = 0; base < st->nrow; base += WINDOW) {
    job_name(st, base, n, sizeof n);
    snprintf(out + strlen(out), len - strlen(out), "%s,", n);
  }
  job_name(st, -1, n, sizeof n);
  snprintf(out + strlen(out), len - strlen(out), "%s", n);
}

static void slurm_path(const pm_cmp_study *st, const char *file, char *out, size_t len) {
  snprintf(out, len, "%s/slurm/%s", st->dir, file);
}

/* ---- running Slurm's commands -------------------------------------------------------------- */

/* Run a Slurm command; its stdout into *out (malloc'ed). PM_ERR_IO with its stderr's first line
 * when it cannot run or fails. */
static pm_status slurm_cmd(char *const argv[], char **out, pm_error *err) {
  char *o = NULL, *e = NULL;
  int ws = 0, to = 0;
  /* Job arrays' task ids in full: squeue cuts them at 64 characters otherwise ("1-3,5-7,..."). */
  static char bitstr[] = "SLURM_BITSTR_LEN=0";
  char *env[] = {bitstr, NULL};
  if (pm_cmp_capture(argv, env, SLURM_CMD_TIMEOUT_S, &o, &e, &ws, &to) != 0)
    return pm_error_setf(err, PM_ERR_IO,
                         "cannot run %s: the Slurm engine needs Slurm's commands (sbatch, "
                         "squeue, sacct; Debian's slurm-client) on PATH",
                         argv[0]);
  pm_status s = PM_OK;
  if (to) {
    s = pm_error_setf(err, PM_ERR_IO, "%s did not answer within %d s", argv[0],
                      SLURM_CMD_TIMEOUT_S);
  } else if (!WIFEXITED(ws) || WEXITSTATUS(ws) != 0) {
    char *line = e;
    while (*line == '\n') ++line;
    line[strcspn(line, "\n")] = '\0';
    s = pm_error_setf(err, PM_ERR_IO, "%s failed: %s", argv[0],
                      line[0] ? line : "no message (exit code not 0)");
  }
  free(e);
  if (s || !out)
    free(o);
  else
    *out = o;
  return s;
}

/* The next line of text (modified in place), NULL at the end. */
static char *next_line(char **cursor) {
  char *line = *cursor;
  if (!line || !*line) return NULL;
  char *nl = strchr(line, '\n');
  if (nl) {
    *nl = '\0';
    *cursor = nl + 1;
  } else {
    *cursor = line + strlen(line);
  }
  return line;
}

/* Split line on '|' into at most n fields; returns how many. */
static int split(char *line, char **f, int n) {
  int k = 0;
  while (k < n) {
    f[k++] = line;
    char *bar = strchr(line, '|');
    if (!bar) break;
    *bar = '\0';
    line = bar + 1;
  }
  return k;
}

/* ---- the queue ----------------------------------------------------------------------------- */

static void queue_free(queue *q) {
  free(q->row);
  free(q->job);
  free(q->array);
  for (int i = 0; i < q->nid; ++i) free(q->ids[i]);
  free(q->ids);
  memset(q, 0, sizeof *q);
}

static int queue_add_id(queue *q, const char *id) {
  for (int i = 0; i < q->nid; ++i)
    if (strcmp(q->ids[i], id) == 0) return 0;
  char **ids = realloc(q->ids, (size_t)(q->nid + 1) * sizeof *ids);
  if (!ids) return -1;
  q->ids = ids;
  if (!(ids[q->nid] = malloc(strlen(id) + 1))) return -1;
  strcpy(ids[q->nid++], id);
  return 0;
}

/* The study's jobs in Slurm's queue (pending, running, completing): which rows they hold. With
 * need == 0 a squeue that cannot run leaves the queue empty and unanswered instead of failing. */
static pm_status queue_read(const pm_cmp_study *st, queue *q, int need, pm_error *err) {
  memset(q, 0, sizeof *q);
  q->row = calloc((size_t)st->nrow + 1, sizeof *q->row);
  q->job = calloc((size_t)st->nrow + 1, sizeof *q->job);
  q->array = calloc((size_t)st->nrow + 1, sizeof *q->array);
  if (!q->row || !q->job || !q->array) {
    queue_free(q);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  char names[4096], arg[4200];
  all_names(st, names, sizeof names);
  snprintf(arg, sizeof arg, "--name=%s", names);
  /* Job, array job, task ids, state, name. Not -r (a line per task): Slurm 22.05's squeue -r
   * leaves out the last task of a pending array given as a list ("0,4,8" lists 0 and 4); the
   * pending rest of an array is one line whose task ids are a spec ("0-44:4%2"). */
  char *argv[] = {"squeue", "-h", arg, "-o", "%i|%F|%K|%T|%j", NULL};
  char *out = NULL;
  pm_error e = {0};
  if (slurm_cmd(argv, &out, &e)) {
    if (!need) return PM_OK;
    queue_free(q);
    if (err) *err = e;
    return e.code;
  }
  q->answered = 1;
  char key[64], report[96];
  study_key(st, key, sizeof key);
  job_name(st, -1, report, sizeof report);
  size_t klen = strlen(key);
  char *cur = out, *line;
  pm_status s = PM_OK;
  while (!s && (line = next_line(&cur))) {
    char *f[5];
    if (split(line, f, 5) != 5) continue;
    const char *state = f[3], *name = f[4];
    qstate qs = strcmp(state, "PENDING") == 0 || strcmp(state, "REQUEUED") == 0 ? Q_PENDING
                                                                                : Q_RUNNING;
    if (strcmp(name, report) == 0) {
      snprintf(q->report, sizeof q->report, "%s", f[0]);
      if (queue_add_id(q, f[0])) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      continue;
    }
    if (strncmp(name, key, klen) != 0 || name[klen] != '.') continue;
    char *end;
    long base = strtol(name + klen + 1, &end, 10);
    if (*end || base < 0) continue;
    /* The task ids: "3", or "0,4,8-11,20-40:4" with an optional "%N" (the throttle). */
    char *spec = f[2];
    spec[strcspn(spec, "%")] = '\0';
    for (char *item = strtok(spec, ","); item; item = strtok(NULL, ",")) {
      long a = -1, b = -1, step = 1;
      char *p = item;
      a = strtol(p, &end, 10);
      if (end == p) break; /* "N/A": not an array */
      b = a;
      if (*end == '-') b = strtol(end + 1, &end, 10);
      if (*end == ':') step = strtol(end + 1, &end, 10);
      if (step < 1) step = 1;
      for (long t = a; t <= b; t += step) {
        long row = base + t;
        if (row < 0 || row >= st->nrow) continue;
        q->row[row] = qs;
        snprintf(q->job[row], sizeof q->job[row], "%s_%ld", f[1], t);
        snprintf(q->array[row], sizeof q->array[row], "%s", f[1]);
      }
    }
    if (queue_add_id(q, f[1])) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  free(out);
  if (s) queue_free(q);
  return s;
}

/* ---- submitting ---------------------------------------------------------------------------- */

/* Task ids of rows [from, to) that are marked, relative to base, as an array spec ("0,4,8-11"). */
static int array_spec(const unsigned char *mark, int from, int to, int base, char **spec,
                      int *ntask) {
  size_t len = 0, cap = 0;
  *spec = NULL;
  *ntask = 0;
  for (int i = from; i < to;) {
    if (!mark[i]) {
      ++i;
      continue;
    }
    int j = i;
    while (j + 1 < to && mark[j + 1]) ++j;
    int bad = j > i ? pm_cmp_appendf(spec, &len, &cap, "%s%d-%d", len ? "," : "", i - base,
                                     j - base)
                    : pm_cmp_appendf(spec, &len, &cap, "%s%d", len ? "," : "", i - base);
    if (bad) return -1;
    *ntask += j - i + 1;
    i = j + 1;
  }
  return 0;
}

typedef struct submitter {
  pm_cmp_study *st;
  const pm_cmp_slurm_opts *o;
  pm_cmp_slurm_submission *sub;
  char exe[PATH_MAX], suite[PATH_MAX];
  int threads;
} submitter;

/* The packmesh command a job runs, for sbatch --wrap (a POSIX shell line). */
static int job_command(const submitter *S, const char *what, char *out, size_t len) {
  char qe[PATH_MAX + 64], qs[PATH_MAX + 64], qd[PATH_MAX + 64];
  pm_cmp_shell_quote(S->exe, qe, sizeof qe);
  pm_cmp_shell_quote(S->suite, qs, sizeof qs);
  pm_cmp_shell_quote(S->st->dir, qd, sizeof qd);
  int n = snprintf(out, len, "exec %s compare %s -o %s %s", qe, qs, qd, what);
  if (S->o->timeout_s > 0) n += snprintf(out + n, len - (size_t)n, " --timeout %.17g",
                                         S->o->timeout_s);
  return n < 0 || (size_t)n >= len ? -1 : 0;
}

/* sbatch one job; its id into id. array NULL: a single job. */
static pm_status sbatch(submitter *S, const char *name, const char *array, int minutes, int cpus,
                        const char *after, const char *wrap, const char *log, char *id,
                        size_t idlen, pm_error *err) {
  char a_name[160], a_chdir[PATH_MAX + 16], a_out[PATH_MAX + 32], a_time[32], a_cpus[32];
  char a_dep[1200];
  char *a_array = NULL, *a_wrap = NULL;
  size_t n1 = 0, c1 = 0, n2 = 0, c2 = 0;
  snprintf(a_name, sizeof a_name, "--job-name=%s", name);
  snprintf(a_chdir, sizeof a_chdir, "--chdir=%s", S->st->dir);
  snprintf(a_out, sizeof a_out, "--output=%s", log);
  snprintf(a_time, sizeof a_time, "--time=%d", minutes);
  snprintf(a_cpus, sizeof a_cpus, "--cpus-per-task=%d", cpus);
  snprintf(a_dep, sizeof a_dep, "--dependency=%s", after);
  if ((array && pm_cmp_appendf(&a_array, &n1, &c1, "--array=%s", array)) ||
      pm_cmp_appendf(&a_wrap, &n2, &c2, "--wrap=%s", wrap)) {
    free(a_array);
    free(a_wrap);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  char **argv = calloc((size_t)S->o->nsbatch_arg + 16, sizeof *argv);
  if (!argv) {
    free(a_array);
    free(a_wrap);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  int k = 0;
  argv[k++] = "sbatch";
  argv[k++] = "--parsable";
  argv[k++] = a_name;
  argv[k++] = a_chdir;
  argv[k++] = a_out;
  argv[k++] = a_time;
  argv[k++] = a_cpus;
  if (array) argv[k++] = a_array;
  if (after[0]) argv[k++] = a_dep;
  /* After ours, so that the user's --time, --cpus-per-task or --output win. */
  for (int i = 0; i < S->o->nsbatch_arg; ++i) argv[k++] = S->o->sbatch_args[i];
  argv[k++] = a_wrap;
  argv[k] = NULL;
  char *out = NULL;
  pm_status s = slurm_cmd(argv, &out, err);
  free(argv);
  free(a_array);
  free(a_wrap);
  if (s) return s;
  /* --parsable: "ID" or "ID;CLUSTER". */
  out[strcspn(out, ";\n")] = '\0';
  if (!out[0] || strspn(out, "0123456789") != strlen(out))
    s = pm_error_setf(err, PM_ERR_IO, "sbatch answered '%s', not a job id", out);
  else
    snprintf(id, idlen, "%s", out);
  free(out);
  return s;
}

/* "afterany:A:B" of ids (at most 1000 characters); "" without any. */
static int dependency(char **ids, int n, char *out, size_t len) {
  out[0] = '\0';
  if (n == 0) return 0;
  size_t k = (size_t)snprintf(out, len, "afterany");
  for (int i = 0; i < n; ++i) {
    int w = snprintf(out + k, len - k, ":%s", ids[i]);
    if (w < 0 || (size_t)w >= len - k) return -1;
    k += (size_t)w;
  }
  return 0;
}

static pm_status add_job(submitter *S, pm_cmp_job_kind kind, const char *id, int ntask,
                         const char *array, const char *after, pm_error *err) {
  pm_cmp_slurm_submission *sub = S->sub;
  if (sub->njob >= PM_CMP_SLURM_MAX_JOBS)
    return pm_error_setf(err, PM_ERR_ARG, "the study needs more than %d Slurm jobs",
                         PM_CMP_SLURM_MAX_JOBS);
  pm_cmp_slurm_job *j = &sub->job[sub->njob++];
  memset(j, 0, sizeof *j);
  snprintf(j->id, sizeof j->id, "%s", id);
  j->kind = kind;
  j->ntask = ntask;
  if (array && strlen(array) >= sizeof j->array)
    snprintf(j->array, sizeof j->array, "%.*s...", (int)sizeof j->array - 4, array);
  else
    snprintf(j->array, sizeof j->array, "%s", array ? array : "");
  if (strlen(after) >= sizeof j->after)
    snprintf(j->after, sizeof j->after, "%.*s...", (int)sizeof j->after - 4, after);
  else
    snprintf(j->after, sizeof j->after, "%s", after);
  return PM_OK;
}

/* The arrays of the rows marked in mark, one per window of rows, each after `after`. */
static pm_status submit_arrays(submitter *S, const unsigned char *mark, pm_cmp_job_kind kind,
                               const char *after, char ***ids, int *nid, pm_error *err) {
  const pm_cmp_study *st = S->st;
  double timeout = S->o->timeout_s > 0 ? S->o->timeout_s : st->suite.timeout_s;
  /* The run and its quality measures have timeout_s each; a minute for the rest. */
  int minutes = (int)ceil((2 * timeout + 60) / 60);
  for (int base = 0; base < st->nrow; base += WINDOW) {
    int to = base + WINDOW < st->nrow ? base + WINDOW : st->nrow;
    char *spec = NULL;
    int ntask = 0;
    if (array_spec(mark, base, to, base, &spec, &ntask))
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    if (!ntask) {
      free(spec);
      continue;
    }
    char what[160], wrap[4 * PATH_MAX], name[96], log[PATH_MAX + 32], id[32];
    if (base == 0)
      snprintf(what, sizeof what, "--slurm-task \"$SLURM_ARRAY_TASK_ID\"%s",
               S->o->retry_failed ? " --retry-failed" : "");
    else
      snprintf(what, sizeof what, "--slurm-task $((%d + SLURM_ARRAY_TASK_ID))%s", base,
               S->o->retry_failed ? " --retry-failed" : "");
    job_name(st, base, name, sizeof name);
    snprintf(log, sizeof log, "%s/slurm/log/%%A_%%a.txt", st->dir);
    pm_status s = job_command(S, what, wrap, sizeof wrap)
                      ? pm_error_setf(err, PM_ERR_ARG, "the job's command is too long")
                      : sbatch(S, name, spec, minutes, S->threads, after, wrap, log, id,
                               sizeof id, err);
    if (!s) s = add_job(S, kind, id, ntask, spec, after, err);
    free(spec);
    if (s) return s;
    char **more = realloc(*ids, (size_t)(*nid + 1) * sizeof *more);
    if (!more || !(more[*nid] = malloc(strlen(id) + 1))) {
      if (more) *ids = more;
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    strcpy(more[*nid], id);
    *ids = more;
    ++*nid;
  }
  return PM_OK;
}

static pm_status write_submission(const submitter *S, char **ids, int nid, pm_error *err) {
  cJSON *o = cJSON_CreateObject();
  cJSON *jobs = cJSON_CreateArray();
  if (!o || !jobs) {
    cJSON_Delete(o);
    cJSON_Delete(jobs);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int i = 0; i < nid; ++i) cJSON_AddItemToArray(jobs, cJSON_CreateString(ids[i]));
  cJSON_AddStringToObject(o, "invocation", S->o->invocation ? S->o->invocation : "");
  cJSON_AddNumberToObject(o, "submitted", S->sub->submitted);
  cJSON_AddItemToObject(o, "jobs", jobs);
  cJSON_AddStringToObject(o, "report_job", S->sub->report_job);
  char *text = cJSON_Print(o);
  cJSON_Delete(o);
  if (!text) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  char path[PATH_MAX + 32];
  slurm_path(S->st, "submit.json", path, sizeof path);
  pm_status s = pm_atomic_write(path, text, strlen(text), err);
  free(text);
  return s;
}

static void free_ids(char **ids, int n) {
  for (int i = 0; i < n; ++i) free(ids[i]);
  free(ids);
}

pm_status pm_cmp_slurm_submit(pm_cmp_study *st, const pm_cmp_slurm_opts *o,
                              pm_cmp_slurm_submission *sub, pm_error *err) {
  memset(sub, 0, sizeof *sub);
  submitter S;
  memset(&S, 0, sizeof S);
  S.st = st;
  S.o = o;
  S.sub = sub;
  S.threads = pm_cmp_run_threads(&st->suite, 0);
  if (!o->suite_path || !realpath(o->suite_path, S.suite))
    return pm_error_setf(err, PM_ERR_IO, "cannot resolve the suite's path '%s'",
                         o->suite_path ? o->suite_path : "");
  snprintf(S.exe, sizeof S.exe, "%s", st->exe);
  all_names(st, sub->names, sizeof sub->names);
  char logdir[PATH_MAX + 32];
  slurm_path(st, "log", logdir, sizeof logdir);
  pm_status s = pm_cmp_mkdirs(logdir, err);
  if (!s) s = pm_cmp_records_read(st, S.threads, err);
  if (s) return s;
  queue q;
  if ((s = queue_read(st, &q, 1, err))) return s;

  /* Each row's fate, in row order (a reference before the rows matched to it). */
  enum { F_DONE = 0, F_QUEUED, F_NOW, F_AFTER };
  unsigned char *fate = calloc((size_t)st->nrow + 1, 1);
  unsigned char *now = calloc((size_t)st->nrow + 1, 1);
  unsigned char *after = calloc((size_t)st->nrow + 1, 1);
  char **wait_for = NULL, **ids = NULL; /* queued jobs the second array needs; new jobs */
  int nwait = 0, nid = 0;
  if (!fate || !now || !after) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int i = 0; i < st->nrow && !s; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    int ref = r->ref_row, f;
    /* Whether the row's reference is still to run (queued, or submitted now). */
    int ref_later = ref >= 0 && fate[ref] != F_DONE;
    if (q.row[i] != Q_NONE)
      f = F_QUEUED;
    else if (r->status == PM_CMP_OK)
      f = F_DONE;
    else if (r->status == PM_CMP_SKIPPED) /* its reference failed: runs when that reruns */
      f = ref_later ? F_AFTER : F_DONE;
    else if (r->status != PM_CMP_PENDING)
      f = !o->retry_failed ? F_DONE : ref_later ? F_AFTER : F_NOW;
    else
      f = ref_later ? F_AFTER : F_NOW; /* no reference, or its reference has its record */
    if (f == F_AFTER && fate[ref] == F_QUEUED) {
      /* The second array waits for the queued job that holds the reference too. */
      const char *id = q.array[ref];
      int have = 0;
      for (int k = 0; k < nwait && !have; ++k) have = strcmp(wait_for[k], id) == 0;
      if (!have) {
        char **w = realloc(wait_for, (size_t)(nwait + 1) * sizeof *w);
        if (!w) {
          s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
          break;
        }
        wait_for = w;
        wait_for[nwait++] = (char *)id;
      }
    }
    fate[i] = (unsigned char)f;
    now[i] = f == F_NOW;
    after[i] = f == F_AFTER;
    sub->nfinished += f == F_DONE;
    sub->nqueued += f == F_QUEUED;
    sub->nsubmitted += f == F_NOW || f == F_AFTER;
  }
  sub->submitted = (double)time(NULL);
  /* The rows that can run now; then those matched to references still to run. */
  if (!s) s = submit_arrays(&S, now, PM_CMP_JOB_RUNS, "", &ids, &nid, err);
  if (!s && sub->nsubmitted > 0) {
    int nfirst = nid;
    char **deps = calloc((size_t)(nfirst + nwait) + 1, sizeof *deps);
    char dep[1100];
    if (!deps) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    int nd = 0;
    for (int k = 0; !s && k < nfirst; ++k) deps[nd++] = ids[k];
    for (int k = 0; !s && k < nwait; ++k) deps[nd++] = wait_for[k];
    if (!s && dependency(deps, nd, dep, sizeof dep))
      s = pm_error_setf(err, PM_ERR_ARG, "too many jobs to wait for");
    if (!s) s = submit_arrays(&S, after, PM_CMP_JOB_MATCHED, dep, &ids, &nid, err);
    free(deps);
  }
  /* The report: after every job of the study, new or queued; the one queued already when
   * nothing new was submitted. */
  if (!s && nid == 0 && q.report[0]) {
    snprintf(sub->report_job, sizeof sub->report_job, "%s", q.report);
  } else if (!s) {
    char **deps = calloc((size_t)(nid + q.nid) + 1, sizeof *deps);
    char dep[1100], wrap[4 * PATH_MAX], name[96], log[PATH_MAX + 32];
    int nd = 0;
    if (!deps) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int k = 0; !s && k < nid; ++k) deps[nd++] = ids[k];
    for (int k = 0; !s && k < q.nid; ++k) deps[nd++] = q.ids[k];
    if (!s && dependency(deps, nd, dep, sizeof dep))
      s = pm_error_setf(err, PM_ERR_ARG, "too many jobs to wait for");
    free(deps);
    job_name(st, -1, name, sizeof name);
    snprintf(log, sizeof log, "%s/slurm/log/report-%%j.txt", st->dir);
    if (!s && job_command(&S, "--collect", wrap, sizeof wrap))
      s = pm_error_setf(err, PM_ERR_ARG, "the job's command is too long");
    if (!s)
      s = sbatch(&S, name, NULL, REPORT_MINUTES, 1, dep, wrap, log, sub->report_job,
                 sizeof sub->report_job, err);
    if (!s) s = add_job(&S, PM_CMP_JOB_REPORT, sub->report_job, 0, NULL, dep, err);
    if (!s) s = write_submission(&S, ids, nid, err);
  }
  free(fate);
  free(now);
  free(after);
  free(wait_for);
  free_ids(ids, nid);
  queue_free(&q);
  return s;
}

/* ---- waiting ------------------------------------------------------------------------------- */

pm_status pm_cmp_slurm_wait(pm_cmp_study *st, const pm_cmp_slurm_submission *sub, int progress,
                            FILE *log, pm_error *err) {
  int threads = pm_cmp_run_threads(&st->suite, 0);
  char last[256] = "";
  double t0 = (double)time(NULL), last_print = 0;
  int unanswered = 0;
  for (;;) {
    queue q;
    pm_error qe = {0};
    pm_status s = queue_read(st, &q, 1, &qe);
    if (s) {
      /* A controller that restarts does not answer for a while: give it a minute. */
      if (++unanswered * WAIT_POLL_S > 60) {
        if (err) *err = qe;
        return s;
      }
      sleep(WAIT_POLL_S);
      continue;
    }
    unanswered = 0;
    if ((s = pm_cmp_records_read(st, threads, err))) {
      queue_free(&q);
      return s;
    }
    int pend = 0, run = 0, done = 0, failed = 0, other = 0;
    /* The queue first: a row submitted again (--retry-failed) still has its old record. */
    for (int i = 0; i < st->nrow; ++i) {
      pm_cmp_status rs = st->rows[i].status;
      if (q.row[i] == Q_PENDING)
        ++pend;
      else if (q.row[i] == Q_RUNNING)
        ++run;
      else if (rs == PM_CMP_OK)
        ++done;
      else if (rs != PM_CMP_PENDING)
        ++failed;
      else
        ++other;
    }
    int report_queued = 0;
    for (int k = 0; k < q.nid; ++k) report_queued |= strcmp(q.ids[k], sub->report_job) == 0;
    queue_free(&q);
    char line[256];
    int n = snprintf(line, sizeof line, "%d pending, %d running, %d done, %d failed", pend, run,
                     done, failed);
    if (other) snprintf(line + n, sizeof line - (size_t)n, ", %d not in the queue", other);
    double now = (double)time(NULL);
    int el = (int)(now - t0);
    if (progress == 2) {
      fprintf(log, "\r\033[K[%d:%02d] %s%s", el / 60, el % 60, line,
              report_queued && !pend && !run ? "; writing the report" : "");
      fflush(log);
    } else if (progress == 1 && (strcmp(line, last) != 0 || now - last_print >= 300)) {
      fprintf(log, "[%d:%02d] %s\n", el / 60, el % 60, line);
      fflush(log);
      last_print = now;
    }
    snprintf(last, sizeof last, "%s", line);
    if (!report_queued) break;
    sleep(WAIT_POLL_S);
  }
  if (progress == 2) {
    fputc('\n', log);
    fflush(log);
  }
  char report[PATH_MAX + 16];
  snprintf(report, sizeof report, "%s/report.md", st->dir);
  struct stat sb;
  if (stat(report, &sb) != 0 || (double)sb.st_mtime + 1 < sub->submitted)
    return pm_error_setf(err, PM_ERR_IO,
                         "the report job %s ended without writing the report; its log is "
                         "%s/slurm/log/report-%s.txt",
                         sub->report_job, st->dir, sub->report_job);
  return PM_OK;
}

/* ---- a task -------------------------------------------------------------------------------- */

pm_status pm_cmp_slurm_task(pm_cmp_study *st, int row, int retry_failed, int progress, FILE *log,
                            pm_error *err) {
  /* The rows are the submission's only while the suite is: a task must not run another row. */
  char path[PATH_MAX + 16];
  snprintf(path, sizeof path, "%s/suite.json", st->dir);
  char *saved = pm_cmp_read_file(path, NULL);
  int same = saved && strcmp(saved, st->suite.text) == 0;
  free(saved);
  if (!same)
    return pm_error_setf(err, PM_ERR_ARG,
                         "the suite is not the one submitted into %s (suite.json): it changed "
                         "after the submission; submit the study again",
                         st->dir);
  const char *aj = getenv("SLURM_ARRAY_JOB_ID"), *at = getenv("SLURM_ARRAY_TASK_ID");
  const char *jid = getenv("SLURM_JOB_ID"), *node = getenv("SLURMD_NODENAME");
  char job[64] = "";
  if (aj && at && *aj && *at)
    snprintf(job, sizeof job, "%s_%s", aj, at);
  else if (jid && *jid)
    snprintf(job, sizeof job, "%s", jid);
  pm_cmp_run_opts ro = {0};
  ro.jobs = 1;
  ro.single = 1;
  ro.row = row;
  ro.retry_failed = retry_failed;
  ro.progress = progress;
  ro.log = log;
  ro.threads = pm_cmp_run_threads(&st->suite, 0);
  ro.job = job[0] ? job : NULL;
  ro.job_id = jid && *jid ? jid : NULL;
  ro.host = node && *node ? node : NULL;
  return pm_cmp_run(st, &ro, err);
}

/* ---- collecting ---------------------------------------------------------------------------- */

typedef struct jobstate {
  char id[32];        /* the job's own id (JobIDRaw) */
  char state[64];     /* COMPLETED, FAILED, TIMEOUT, CANCELLED, NODE_FAIL, OUT_OF_MEMORY, ... */
  char exit[32];      /* "0:9": exit code and signal */
  char node[256];
  double elapsed;     /* seconds */
  int known;
} jobstate;

/* "[D-]HH:MM:SS" or "MM:SS" into seconds. */
static double elapsed_of(const char *t) {
  int d = 0, h = 0, m = 0, sec = 0;
  if (sscanf(t, "%d-%d:%d:%d", &d, &h, &m, &sec) == 4) return ((d * 24.0 + h) * 60 + m) * 60 + sec;
  if (sscanf(t, "%d:%d:%d", &h, &m, &sec) == 3) return (h * 60.0 + m) * 60 + sec;
  if (sscanf(t, "%d:%d", &m, &sec) == 2) return m * 60.0 + sec;
  return 0;
}

static jobstate *find_state(jobstate *js, int n, const char *id) {
  for (int i = 0; i < n; ++i)
    if (strcmp(js[i].id, id) == 0) return &js[i];
  return NULL;
}

/* sacct's answer (-X: the jobs, not their steps) for the jobs in js, in groups of 100; with
 * completion 1 from the job completion log (sacct -c), where there is no accounting database. */
static int sacct_states(jobstate *js, int n, int completion) {
  int answered = 0;
  for (int from = 0; from < n; from += 100) {
    char *ids = NULL;
    size_t len = 0, cap = 0;
    for (int i = from; i < n && i < from + 100; ++i)
      if (pm_cmp_appendf(&ids, &len, &cap, "%s%s", len ? "," : "", js[i].id)) {
        free(ids);
        return answered;
      }
    char *argv[] = {"sacct", completion ? "-c" : "-X", "-n", "-P", "-j", ids,
                    "-o", "JobIDRaw,State,ExitCode,NodeList,Elapsed", NULL};
    char *out = NULL;
    if (slurm_cmd(argv, &out, NULL) == PM_OK) {
      answered = 1;
      char *cur = out, *line;
      while ((line = next_line(&cur))) {
        char *f[5];
        if (split(line, f, 5) != 5) continue;
        jobstate *j = find_state(js, n, f[0]);
        if (!j) continue;
        /* A job listed twice (requeued) is taken at its last record. */
        snprintf(j->state, sizeof j->state, "%s", f[1]);
        j->state[strcspn(j->state, " ")] = '\0';
        snprintf(j->exit, sizeof j->exit, "%s", f[2]);
        snprintf(j->node, sizeof j->node, "%s", f[3]);
        j->elapsed = elapsed_of(f[4]);
        j->known = 1;
      }
      free(out);
    }
    free(ids);
  }
  return answered;
}

/* The value of KEY= in scontrol's one-line record. */
static void scontrol_field(const char *rec, const char *key, char *out, size_t len) {
  out[0] = '\0';
  size_t k = strlen(key);
  for (const char *p = rec; (p = strstr(p, key)) != NULL; p += k) {
    if ((p == rec || p[-1] == ' ') && p[k] == '=') {
      const char *v = p + k + 1;
      snprintf(out, len, "%.*s", (int)strcspn(v, " \n"), v);
      return;
    }
  }
}

/* What the controller still knows of a job (for MinJobAge after its end). */
static void scontrol_state(jobstate *j) {
  char *argv[] = {"scontrol", "show", "job", "-o", j->id, NULL};
  char *out = NULL;
  if (slurm_cmd(argv, &out, NULL)) return;
  char run[64];
  scontrol_field(out, "JobState", j->state, sizeof j->state);
  scontrol_field(out, "ExitCode", j->exit, sizeof j->exit);
  scontrol_field(out, "NodeList", j->node, sizeof j->node);
  scontrol_field(out, "RunTime", run, sizeof run);
  j->elapsed = elapsed_of(run);
  j->known = j->state[0] != '\0';
  free(out);
}

/* A row's marker (runs/ID/slurm.json): the job and its own id; 0 when there is none. */
static int read_marker(const pm_cmp_study *st, const pm_cmp_row *r, char *job, size_t jlen,
                       char *id, size_t idlen) {
  char path[PATH_MAX + 256];
  snprintf(path, sizeof path, "%s/runs/%s/status.json", st->dir, r->id);
  struct stat sb;
  /* A record of another command: the marker, if any, is of that earlier run. */
  if (stat(path, &sb) == 0) return 0;
  snprintf(path, sizeof path, "%s/runs/%s/%s", st->dir, r->id, PM_CMP_SLURM_MARKER);
  char *text = pm_cmp_read_file(path, NULL);
  if (!text) return 0;
  cJSON *o = cJSON_Parse(text);
  free(text);
  const cJSON *j = cJSON_GetObjectItemCaseSensitive(o, "job");
  const cJSON *i = cJSON_GetObjectItemCaseSensitive(o, "job_id");
  int ok = cJSON_IsString(j) && cJSON_IsString(i) && i->valuestring[0];
  if (ok) {
    snprintf(job, jlen, "%s", j->valuestring);
    snprintf(id, idlen, "%s", i->valuestring);
  }
  cJSON_Delete(o);
  return ok;
}

/* The last submission (DIR/slurm/submit.json): its invocation and time, whether job `array` (an
 * array job id) is one of its jobs. */
typedef struct submission_rec {
  char *invocation;
  double submitted;
  char **jobs;
  int njob;
} submission_rec;

static void submission_read(const pm_cmp_study *st, submission_rec *rec) {
  memset(rec, 0, sizeof *rec);
  char path[PATH_MAX + 32];
  slurm_path(st, "submit.json", path, sizeof path);
  char *text = pm_cmp_read_file(path, NULL);
  if (!text) return;
  cJSON *o = cJSON_Parse(text);
  free(text);
  const cJSON *inv = cJSON_GetObjectItemCaseSensitive(o, "invocation");
  const cJSON *when = cJSON_GetObjectItemCaseSensitive(o, "submitted");
  const cJSON *jobs = cJSON_GetObjectItemCaseSensitive(o, "jobs");
  if (cJSON_IsString(inv) && (rec->invocation = malloc(strlen(inv->valuestring) + 1)))
    strcpy(rec->invocation, inv->valuestring);
  rec->submitted = cJSON_IsNumber(when) ? when->valuedouble : 0;
  int n = cJSON_IsArray(jobs) ? cJSON_GetArraySize(jobs) : 0;
  rec->jobs = n ? calloc((size_t)n, sizeof *rec->jobs) : NULL;
  for (int i = 0; i < n && rec->jobs; ++i) {
    const cJSON *j = cJSON_GetArrayItem(jobs, i);
    if (cJSON_IsString(j) && (rec->jobs[rec->njob] = malloc(strlen(j->valuestring) + 1)))
      strcpy(rec->jobs[rec->njob++], j->valuestring);
  }
  cJSON_Delete(o);
}

static void submission_free(submission_rec *rec) {
  free(rec->invocation);
  for (int i = 0; i < rec->njob; ++i) free(rec->jobs[i]);
  free(rec->jobs);
}

/* Whether a row's record was made by a job of the submission ("12_3": array job 12). */
static int made_by(const submission_rec *rec, const pm_cmp_row *r) {
  if (!r->job[0]) return 0;
  size_t n = strcspn(r->job, "_");
  for (int i = 0; i < rec->njob; ++i)
    if (strlen(rec->jobs[i]) == n && strncmp(rec->jobs[i], r->job, n) == 0) return 1;
  return 0;
}

/* A dead task's row, from Slurm's state: recorded as timeout or crashed (1), or left unfinished
 * when the task was cancelled (0), with the state in r->error either way. */
static int judge(pm_cmp_row *r, const char *job, const jobstate *j) {
  if (!j || !j->known) {
    r->status = PM_CMP_CRASHED;
    snprintf(r->error, sizeof r->error,
             "Slurm job %s ended without a record of the run; Slurm no longer knows its state "
             "(no accounting, and the controller has forgotten it)",
             job);
    return 1;
  }
  const char *s = j->state;
  if (strncmp(s, "CANCELLED", 9) == 0 || strcmp(s, "PREEMPTED") == 0 ||
      strcmp(s, "REQUEUED") == 0 || strcmp(s, "PENDING") == 0 || strcmp(s, "RUNNING") == 0 ||
      strcmp(s, "SUSPENDED") == 0 || strcmp(s, "COMPLETING") == 0) {
    snprintf(r->error, sizeof r->error,
             "Slurm job %s: %s before the run ended; submitting the study again runs it", job,
             s);
    return 0;
  }
  r->status = strcmp(s, "TIMEOUT") == 0 || strcmp(s, "DEADLINE") == 0 ? PM_CMP_TIMEOUT
                                                                        : PM_CMP_CRASHED;
  snprintf(r->error, sizeof r->error, "Slurm job %s ended %s (exit code %s) on %s without a "
           "record of the run",
           job, s, j->exit[0] ? j->exit : "?", j->node[0] ? j->node : "an unknown node");
  snprintf(r->host, sizeof r->host, "%s", j->node);
  r->wall_s = j->elapsed;
  return 1;
}

pm_status pm_cmp_collect(pm_cmp_study *st, char *invocation, size_t len, pm_error *err) {
  int threads = pm_cmp_run_threads(&st->suite, 0);
  pm_status s = pm_cmp_records_read(st, threads, err);
  /* Repeats with byte-identical meshes, as the local engine marks them after its runs. */
  if (!s) s = pm_cmp_duplicates_mark(st, err);
  if (s) return s;
  queue q;
  if ((s = queue_read(st, &q, 0, err))) return s;
  /* The rows whose task started and is no longer in the queue, without a record: Slurm's state
   * of their jobs, asked all at once. */
  int n = 0;
  char (*job)[64] = calloc((size_t)st->nrow + 1, sizeof *job);
  char (*jid)[32] = calloc((size_t)st->nrow + 1, sizeof *jid);
  char (*why)[sizeof st->rows[0].error] = calloc((size_t)st->nrow + 1, sizeof *why);
  jobstate *js = calloc((size_t)st->nrow + 1, sizeof *js);
  if (!job || !jid || !why || !js) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int i = 0; i < st->nrow && !s && q.answered; ++i) {
    pm_cmp_row *r = &st->rows[i];
    if (r->status != PM_CMP_PENDING || q.row[i] != Q_NONE || !r->command[0] ||
        !read_marker(st, r, job[i], sizeof job[i], jid[i], sizeof jid[i]))
      continue;
    if (!find_state(js, n, jid[i])) {
      snprintf(js[n].id, sizeof js[n].id, "%s", jid[i]);
      n++;
    }
  }
  if (!s && n) {
    if (!sacct_states(js, n, 0)) sacct_states(js, n, 1);
    for (int k = 0; k < n; ++k)
      if (!js[k].known) scontrol_state(&js[k]);
  }
  int recorded = 0;
  for (int i = 0; i < st->nrow && !s; ++i) {
    pm_cmp_row *r = &st->rows[i];
    if (!jid[i][0]) continue;
    if (judge(r, job[i], find_state(js, n, jid[i]))) {
      snprintf(r->job, sizeof r->job, "%s", job[i]);
      s = pm_cmp_record_write(st, r, err);
      recorded = 1;
    } else {
      snprintf(why[i], sizeof why[i], "%s", r->error);
    }
  }
  /* The rows matched to a reference recorded now are skipped: read the records again. */
  if (!s && recorded) s = pm_cmp_records_read(st, threads, err);
  for (int i = 0; i < st->nrow && !s; ++i) {
    pm_cmp_row *r = &st->rows[i];
    if (r->status != PM_CMP_PENDING) continue;
    if (q.row[i] != Q_NONE)
      snprintf(r->error, sizeof r->error, "%s in Slurm (job %s)",
               q.row[i] == Q_PENDING ? "pending" : "running", q.job[i]);
    else if (why[i][0])
      snprintf(r->error, sizeof r->error, "%s", why[i]);
    else if (!r->command[0])
      snprintf(r->error, sizeof r->error, "waits for its reference run %s",
               st->rows[r->ref_row].id);
    else
      snprintf(r->error, sizeof r->error, "not run%s",
               q.answered ? ": not in Slurm's queue" : " (Slurm does not answer)");
  }
  free(job);
  free(jid);
  free(why);
  free(js);
  queue_free(&q);
  if (s) return s;

  submission_rec rec;
  submission_read(st, &rec);
  st->nrun = st->nreused = 0;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (r->status == PM_CMP_PENDING || r->status == PM_CMP_SKIPPED) continue;
    if (made_by(&rec, r))
      st->nrun++;
    else
      st->nreused++;
  }
  st->wall_s = rec.submitted > 0 ? (double)time(NULL) - rec.submitted : 0;
  if (rec.invocation && rec.invocation[0]) snprintf(invocation, len, "%s", rec.invocation);
  submission_free(&rec);
  return PM_OK;
}
