/* The tidy tables of a study:
 *   results.csv   one row per run: case, method, seed, sweep_key, sweep_value, status, error,
 *                 command (DESIGN.md's leading columns, in that order), then row (the folder
 *                 under runs/), label (the method entry's label), input, wall_s (seconds of the
 *                 child process, start to exit), host (the machine or Slurm node that ran it;
 *                 empty when it did not run), same_mesh_as (the row whose mesh.msh this run's
 *                 repeats byte for byte, spread.c; empty when none), then every key of the run's
 *                 --stats JSON
 *                 flattened with dots (stats.h), except method, input and seed, which are the
 *                 leading columns already. The key columns are the union over the runs, merged
 *                 so that each run's keys keep their document order (a 3D run's tet.* columns
 *                 sit after the tri.* ones, not at the end); a run without a key leaves it empty.
 *   elements.csv  one row per element of every successful run: the run's row, case, method,
 *                 label, seed, sweep_key, sweep_value, then the columns of
 *                 `packmesh quality MESH --csv` (kind, index, cell, radius_ratio, aspect_ratio,
 *                 min_angle_deg, max_angle_deg).
 */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/atomic_file.h"
#include "common/mesh/mesh_io.h"
#include "compare/src/study.h"

static const char *const lead[] = {"case",   "method", "seed",  "sweep_key", "sweep_value",
                                   "status", "error",  "command", "row",     "label",
                                   "input",  "wall_s", "host",  "same_mesh_as", NULL};

/* Flattened keys that repeat a leading column. */
static int is_lead_key(const char *k) {
  return strcmp(k, "method") == 0 || strcmp(k, "input") == 0 || strcmp(k, "seed") == 0;
}

typedef struct keyset {
  char **k;
  int n, cap;
} keyset;

static int keyset_find(const keyset *ks, const char *key) {
  for (int i = 0; i < ks->n; ++i)
    if (strcmp(ks->k[i], key) == 0) return i;
  return -1;
}

static int keyset_insert(keyset *ks, int at, const char *key) {
  if (ks->n == ks->cap) {
    int c = ks->cap ? 2 * ks->cap : 64;
    char **k = realloc(ks->k, (size_t)c * sizeof *k);
    if (!k) return -1;
    ks->k = k;
    ks->cap = c;
  }
  memmove(ks->k + at + 1, ks->k + at, (size_t)(ks->n - at) * sizeof *ks->k);
  ks->k[at] = malloc(strlen(key) + 1);
  if (!ks->k[at]) return -1;
  strcpy(ks->k[at], key);
  ks->n++;
  return 0;
}

static void keyset_free(keyset *ks) {
  for (int i = 0; i < ks->n; ++i) free(ks->k[i]);
  free(ks->k);
}

double pm_cmp_row_value(const pm_cmp_row *r, const char *key) {
  if (r->status != PM_CMP_OK) return NAN;
  const pm_stats_item *it = pm_stats_flat_find(&r->flat, key);
  if (!it || it->is_text) return NAN;
  return it->num;
}

pm_status pm_cmp_results_load(pm_cmp_study *st, pm_error *err) {
  for (int i = 0; i < st->nrow; ++i) {
    pm_cmp_row *r = &st->rows[i];
    if (r->status != PM_CMP_OK || r->flat.n > 0) continue;
    char path[4096];
    snprintf(path, sizeof path, "%s/runs/%s/stats.json", st->dir, r->id);
    char *text = pm_cmp_read_file(path, NULL);
    if (!text) return pm_error_setf(err, PM_ERR_IO, "cannot read %s", path);
    pm_status s = pm_stats_flatten_json(text, &r->flat, err);
    free(text);
    if (s) return s;
  }
  return PM_OK;
}

static void write_item(FILE *f, const pm_stats_item *it) {
  if (!it) return;
  if (it->is_text)
    pm_csv_field(f, it->text);
  else
    pm_csv_number(f, it->num);
}

static pm_status write_results(const pm_cmp_study *st, pm_error *err) {
  keyset ks = {0};
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    int prev = -1;
    for (int k = 0; k < r->flat.n; ++k) {
      const char *key = r->flat.item[k].key;
      if (is_lead_key(key)) continue;
      int at = keyset_find(&ks, key);
      if (at < 0) {
        at = prev + 1;
        if (keyset_insert(&ks, at, key)) {
          keyset_free(&ks);
          return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        }
      }
      prev = at;
    }
  }
  char path[4096];
  snprintf(path, sizeof path, "%s/results.csv", st->dir);
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) {
    keyset_free(&ks);
    return s;
  }
  FILE *f = a.f;
  for (int i = 0; lead[i]; ++i) fprintf(f, "%s%s", i ? "," : "", lead[i]);
  for (int k = 0; k < ks.n; ++k) {
    fputc(',', f);
    pm_csv_field(f, ks.k[k]);
  }
  fputc('\n', f);
  const pm_cmp_suite *su = &st->suite;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    pm_csv_field(f, su->cases[r->icase].name);
    fputc(',', f);
    pm_csv_field(f, su->methods[r->imethod].name);
    fprintf(f, ",%ld,", r->seed);
    pm_csv_field(f, r->isweep >= 0 ? su->sweep_key : "");
    fputc(',', f);
    pm_csv_field(f, pm_cmp_row_sweep(st, r));
    fputc(',', f);
    pm_csv_field(f, pm_cmp_status_name(r->status));
    fputc(',', f);
    pm_csv_field(f, r->error);
    fputc(',', f);
    pm_csv_field(f, r->command);
    fputc(',', f);
    pm_csv_field(f, r->id);
    fputc(',', f);
    pm_csv_field(f, su->methods[r->imethod].label);
    fputc(',', f);
    pm_csv_field(f, su->cases[r->icase].input);
    fputc(',', f);
    /* Milliseconds are all a wall time measured by polling every 20 ms can tell. */
    if (r->status != PM_CMP_SKIPPED && r->status != PM_CMP_PENDING)
      pm_csv_number(f, round(r->wall_s * 1000) / 1000);
    fputc(',', f);
    pm_csv_field(f, r->host);
    fputc(',', f);
    if (r->same_mesh_as >= 0) pm_csv_field(f, st->rows[r->same_mesh_as].id);
    for (int k = 0; k < ks.n; ++k) {
      fputc(',', f);
      if (r->status == PM_CMP_OK) write_item(f, pm_stats_flat_find(&r->flat, ks.k[k]));
    }
    fputc('\n', f);
  }
  keyset_free(&ks);
  return pm_atomic_commit(&a, err);
}

static pm_status write_elements(const pm_cmp_study *st, pm_error *err) {
  char path[4096];
  snprintf(path, sizeof path, "%s/elements.csv", st->dir);
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  FILE *f = a.f;
  fputs("row,case,method,label,seed,sweep_key,sweep_value,kind,index,cell,radius_ratio,"
        "aspect_ratio,min_angle_deg,max_angle_deg\n",
        f);
  const pm_cmp_suite *su = &st->suite;
  char *line = NULL;
  size_t cap = 0;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (r->status != PM_CMP_OK || !r->elements_ok) continue;
    char p[4096];
    snprintf(p, sizeof p, "%s/runs/%s/elements.csv", st->dir, r->id);
    FILE *in = fopen(p, "r");
    if (!in) continue;
    /* The prefix of every line of this run. */
    char *pre = NULL;
    size_t plen = 0, pcap = 0;
    char q[1024];
    const char *fields[] = {r->id, su->cases[r->icase].name, su->methods[r->imethod].name,
                            su->methods[r->imethod].label};
    for (int k = 0; k < 4; ++k) {
      /* CSV quoting by hand into the prefix: ids and names are plain; labels may not be. */
      const char *t = fields[k];
      if (strpbrk(t, ",\"\r\n")) {
        size_t n = 0;
        q[n++] = '"';
        for (; *t && n + 3 < sizeof q; ++t) {
          if (*t == '"') q[n++] = '"';
          q[n++] = *t;
        }
        q[n++] = '"';
        q[n] = '\0';
        pm_cmp_strcat(&pre, &plen, &pcap, q);
      } else {
        pm_cmp_strcat(&pre, &plen, &pcap, t);
      }
      pm_cmp_strcat(&pre, &plen, &pcap, ",");
    }
    pm_cmp_appendf(&pre, &plen, &pcap, "%ld,%s,%s,", r->seed, r->isweep >= 0 ? su->sweep_key : "",
                   pm_cmp_row_sweep(st, r));
    if (!pre) {
      fclose(in);
      free(line);
      pm_atomic_abort(&a);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    int first = 1;
    while (getline(&line, &cap, in) > 0) {
      if (first) { /* header of the run's file */
        first = 0;
        continue;
      }
      fputs(pre, f);
      fputs(line, f);
    }
    free(pre);
    fclose(in);
  }
  free(line);
  return pm_atomic_commit(&a, err);
}

pm_status pm_cmp_suite_save(const pm_cmp_study *st, pm_error *err) {
  char path[PATH_MAX];
  if (snprintf(path, sizeof path, "%s/suite.json", st->dir) >= (int)sizeof path)
    return pm_error_setf(err, PM_ERR_IO, "study folder name too long: %s", st->dir);
  return pm_atomic_write(path, st->suite.text, strlen(st->suite.text), err);
}

pm_status pm_cmp_results_write(const pm_cmp_study *st, pm_error *err) {
  pm_status s = write_results(st, err);
  if (!s) s = write_elements(st, err);
  return s;
}

pm_status pm_cmp_row_elements(const pm_cmp_study *st, const pm_cmp_row *r, const char *kind,
                              const char *column, double **v, size_t *n, size_t *cap,
                              pm_error *err) {
  if (r->status != PM_CMP_OK || !r->elements_ok) return PM_OK;
  char p[4096];
  snprintf(p, sizeof p, "%s/runs/%s/elements.csv", st->dir, r->id);
  FILE *in = fopen(p, "r");
  if (!in) return pm_error_setf(err, PM_ERR_IO, "cannot read %s", p);
  char *line = NULL;
  size_t lcap = 0;
  int col = -1, kcol = -1;
  pm_status s = PM_OK;
  if (getline(&line, &lcap, in) > 0) {
    int c = 0;
    for (char *tok = strtok(line, ",\r\n"); tok; tok = strtok(NULL, ",\r\n"), ++c) {
      if (strcmp(tok, column) == 0) col = c;
      if (strcmp(tok, "kind") == 0) kcol = c;
    }
  }
  if (col < 0 || kcol < 0) {
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: no column '%s'", p, column);
  } else {
    size_t klen = strlen(kind);
    while (getline(&line, &lcap, in) > 0) {
      /* Fields are plain numbers and kind names: split on commas. */
      char *f = line;
      const char *kv = NULL, *cv = NULL;
      for (int c = 0; f; ++c) {
        if (c == kcol) kv = f;
        if (c == col) cv = f;
        f = strchr(f, ',');
        if (f) *f++ = '\0';
      }
      if (!kv || !cv || strncmp(kv, kind, klen) != 0 || kv[klen] != '\0') continue;
      char *end;
      double x = strtod(cv, &end);
      if (end == cv || !isfinite(x)) continue;
      if (*n == *cap) {
        size_t nc = *cap ? 2 * *cap : 4096;
        double *nv = realloc(*v, nc * sizeof *nv);
        if (!nv) {
          s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
          break;
        }
        *v = nv;
        *cap = nc;
      }
      (*v)[(*n)++] = x;
    }
  }
  free(line);
  fclose(in);
  return s;
}

int pm_cmp_first_ok_row(const pm_cmp_study *st, int c, int m) {
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (r->icase == c && r->imethod == m && r->status == PM_CMP_OK) return i;
  }
  return -1;
}

pm_status pm_cmp_row_mesh(const pm_cmp_study *st, const pm_cmp_row *r, pm_mesh **mesh,
                          pm_element_values *values, pm_error *err) {
  *mesh = NULL;
  memset(values, 0, sizeof *values);
  char path[4400];
  snprintf(path, sizeof path, "%s/runs/%s/mesh.msh", st->dir, r->id);
  pm_status s = pm_mesh_read(path, mesh, err);
  if (!s) s = pm_element_values_compute(*mesh, values, err);
  if (s) {
    pm_mesh_destroy(*mesh);
    *mesh = NULL;
  }
  return s;
}
