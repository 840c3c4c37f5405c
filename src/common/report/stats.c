/* The run record, its JSON and flattened forms, and the per-element CSV (see stats.h). JSON goes
 * through cJSON, which writes numbers with the shortest of %.15g / %.17g that reads back exactly
 * and writes non-finite numbers as null. */
#include "common/report/stats.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/atomic_file.h"

/* Standard keys that extras may not use as their first part. */
static const char *const reserved[] = {"method", "input",      "nodes",  "segments", "triangles",
                                       "tets",   "valid",      "problems", "shells",  "iterations",
                                       "time_s", NULL};
/* Standard objects that extras may add keys to, and the keys those objects already have. */
static const char *const tri_keys[] = {"radius_ratio", "aspect_ratio", "min_angle_deg",
                                       "max_angle_deg", "eps_t", "eps_g", "size_ratio", "count",
                                       "degenerate", "eps_t_nodes", "min_angle_bins",
                                       "max_angle_over", "by_site", NULL};
static const char *const tet_keys[] = {"radius_ratio", "aspect_ratio", "min_dihedral_deg",
                                       "max_dihedral_deg", "eps_t", "eps_g", "size_ratio",
                                       "count", "degenerate", "eps_t_nodes", NULL};
static const char *const distance_keys[] = {"mean", "max", "bbox_diagonal", NULL};
static const struct {
  const char *name;
  const char *const *keys;
} extendable[] = {{"tri", tri_keys}, {"tet", tet_keys}, {"distance", distance_keys}};

void pm_stats_init(pm_stats *s) { memset(s, 0, sizeof *s); }

static void item_free(pm_stats_item *it) {
  free(it->key);
  free(it->text);
}

void pm_stats_clear(pm_stats *s) {
  if (!s) return;
  for (int32_t i = 0; i < s->nproblem; ++i) free(s->problems[i]);
  free(s->problems);
  free(s->shells);
  for (int32_t i = 0; i < s->ntime; ++i) item_free(&s->time[i]);
  free(s->time);
  for (int32_t i = 0; i < s->nextra; ++i) item_free(&s->extra[i]);
  free(s->extra);
  pm_stats_init(s);
}

void pm_stats_set_run(pm_stats *s, const char *method, const char *input) {
  snprintf(s->method, sizeof s->method, "%s", method ? method : "");
  snprintf(s->input, sizeof s->input, "%s", input ? input : "");
}

void pm_stats_set_mesh(pm_stats *s, const pm_mesh *m) {
  s->nodes = m->nnode;
  s->segments = m->nseg;
  s->triangles = m->ntri;
  s->tets = m->ntet;
}

pm_status pm_stats_set_check(pm_stats *s, const pm_check_report *r, pm_error *err) {
  for (int32_t i = 0; i < s->nproblem; ++i) free(s->problems[i]);
  free(s->problems);
  free(s->shells);
  s->problems = NULL;
  s->shells = NULL;
  s->nproblem = s->nshell = 0;
  s->has_check = 1;
  s->valid = r->valid;
  if (r->nproblem > 0) {
    s->problems = calloc((size_t)r->nproblem, sizeof *s->problems);
    if (!s->problems) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats)");
    for (int32_t i = 0; i < r->nproblem; ++i) {
      s->problems[i] = strdup(r->problem[i]);
      if (!s->problems[i]) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats)");
      s->nproblem = i + 1;
    }
  }
  if (r->nshell > 0) {
    s->shells = malloc((size_t)r->nshell * sizeof *s->shells);
    if (!s->shells) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats)");
    memcpy(s->shells, r->shell, (size_t)r->nshell * sizeof *s->shells);
    s->nshell = r->nshell;
  }
  return PM_OK;
}

static void strip_arrays(pm_kind_quality *k) {
  k->radius_ratio = k->aspect_ratio = k->min_angle = k->max_angle = NULL;
}

void pm_stats_set_quality(pm_stats *s, const pm_quality *q) {
  s->quality = *q;
  strip_arrays(&s->quality.tri);
  strip_arrays(&s->quality.tet);
  s->has_quality = 1;
}

static pm_status push_item(pm_stats_item **arr, int32_t *n, const char *key, int is_text,
                           double num, const char *text, pm_error *err) {
  pm_stats_item *p = realloc(*arr, ((size_t)*n + 1) * sizeof *p);
  if (!p) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats)");
  *arr = p;
  pm_stats_item *it = &p[*n];
  memset(it, 0, sizeof *it);
  it->key = strdup(key);
  it->is_text = is_text;
  it->num = num;
  if (is_text) it->text = strdup(text ? text : "");
  if (!it->key || (is_text && !it->text)) {
    item_free(it);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats)");
  }
  ++*n;
  return PM_OK;
}

pm_status pm_stats_set_needles(pm_stats *s, const pm_needles *n, double limit, pm_error *err) {
  const struct {
    const char *key;
    double v;
  } f[] = {{"tri.needles.limit_deg", limit},
           {"tri.needles.count", (double)n->count},
           {"tri.needles.forced", (double)(n->corner + n->feature)},
           {"tri.needles.unforced", (double)n->unforced},
           {"tri.needles.corner", (double)n->corner},
           {"tri.needles.feature", (double)n->feature}};
  for (size_t i = 0; i < sizeof f / sizeof f[0]; ++i) {
    pm_status st = pm_stats_add_number(s, f[i].key, f[i].v, err);
    if (st) return st;
  }
  return PM_OK;
}

pm_status pm_stats_set_time(pm_stats *s, const char *phase, double seconds, pm_error *err) {
  if (!phase || !phase[0] || phase[0] == '.' || phase[strlen(phase) - 1] == '.' ||
      strstr(phase, "..") || strncmp(phase, "total.", 6) == 0)
    return pm_error_setf(err, PM_ERR_ARG, "bad timing name '%s'", phase ? phase : "");
  if (strcmp(phase, "total") == 0) {
    s->time_total = seconds;
    return PM_OK;
  }
  size_t lk = strlen(phase);
  for (int32_t i = 0; i < s->ntime; ++i) {
    const char *o = s->time[i].key;
    size_t lo = strlen(o);
    if (strcmp(o, phase) == 0) {
      s->time[i].num = seconds;
      return PM_OK;
    }
    /* A phase and its sub-phases cannot both be numbers ("a" and "a.b"). */
    if ((lo < lk && strncmp(o, phase, lo) == 0 && phase[lo] == '.') ||
        (lk < lo && strncmp(o, phase, lk) == 0 && o[lk] == '.'))
      return pm_error_setf(err, PM_ERR_ARG, "timing name '%s' clashes with '%s'", phase, o);
  }
  return push_item(&s->time, &s->ntime, phase, 0, seconds, NULL, err);
}

void pm_stats_set_distance(pm_stats *s, double mean, double max, double bbox_diagonal) {
  s->has_distance = 1;
  s->dist_mean = mean;
  s->dist_max = max;
  s->bbox_diagonal = bbox_diagonal;
}

static pm_status check_extra_key(const pm_stats *s, const char *key, pm_error *err) {
  if (!key || !key[0] || key[0] == '.' || key[strlen(key) - 1] == '.' || strstr(key, ".."))
    return pm_error_setf(err, PM_ERR_ARG, "bad stats key '%s'", key ? key : "");
  size_t head = strcspn(key, ".");
  for (int i = 0; reserved[i]; ++i)
    if (strlen(reserved[i]) == head && strncmp(key, reserved[i], head) == 0)
      return pm_error_setf(err, PM_ERR_ARG, "stats key '%s' clashes with the standard key '%s'",
                           key, reserved[i]);
  for (size_t i = 0; i < sizeof extendable / sizeof extendable[0]; ++i) {
    const char *name = extendable[i].name;
    if (strlen(name) != head || strncmp(key, name, head) != 0) continue;
    if (!key[head])
      return pm_error_setf(err, PM_ERR_ARG, "stats key '%s' is a standard object", key);
    const char *sub = key + head + 1;
    size_t sl = strcspn(sub, ".");
    for (int k = 0; extendable[i].keys[k]; ++k)
      if (strlen(extendable[i].keys[k]) == sl && strncmp(sub, extendable[i].keys[k], sl) == 0)
        return pm_error_setf(err, PM_ERR_ARG, "stats key '%s' clashes with the standard key '%s.%s'",
                             key, name, extendable[i].keys[k]);
  }
  for (int32_t i = 0; i < s->nextra; ++i) {
    const char *o = s->extra[i].key;
    size_t lo = strlen(o), lk = strlen(key);
    /* Equal keys, or one a dotted prefix of the other ("a" and "a.b"), cannot both exist. */
    if (strcmp(o, key) == 0 || (lo < lk && strncmp(o, key, lo) == 0 && key[lo] == '.') ||
        (lk < lo && strncmp(o, key, lk) == 0 && o[lk] == '.'))
      return pm_error_setf(err, PM_ERR_ARG, "stats key '%s' clashes with '%s'", key, o);
  }
  return PM_OK;
}

pm_status pm_stats_add_number(pm_stats *s, const char *key, double value, pm_error *err) {
  pm_status st = check_extra_key(s, key, err);
  if (st) return st;
  return push_item(&s->extra, &s->nextra, key, 0, value, NULL, err);
}

pm_status pm_stats_add_text(pm_stats *s, const char *key, const char *text, pm_error *err) {
  pm_status st = check_extra_key(s, key, err);
  if (st) return st;
  return push_item(&s->extra, &s->nextra, key, 1, 0, text, err);
}

pm_status pm_stats_add_bool(pm_stats *s, const char *key, int value, pm_error *err) {
  pm_status st = check_extra_key(s, key, err);
  if (!st) st = push_item(&s->extra, &s->nextra, key, 0, value != 0, NULL, err);
  if (!st) s->extra[s->nextra - 1].is_bool = 1;
  return st;
}

/* ---- JSON --------------------------------------------------------------------------------- */

/* cJSON reports allocation failures by returning NULL; every add below is checked through this
 * flag rather than one by one. */
typedef struct jb {
  int fail;
} jb;

static cJSON *add_obj(jb *b, cJSON *parent, const char *key) {
  cJSON *o = cJSON_AddObjectToObject(parent, key);
  if (!o) b->fail = 1;
  return o;
}
/* The shortest of %.15g / %.17g that reads back to x. */
static void shortest(double x, char *buf, size_t len) {
  snprintf(buf, len, "%.15g", x);
  if (strtod(buf, NULL) != x) snprintf(buf, len, "%.17g", x);
}

/* Numbers are added as raw text in their shortest exact form: cJSON 1.7.15's own printer
 * accepts a %.15g form that is only within an epsilon of the value, and a figure written with
 * --stats should read back bit for bit. Non-finite values become null. */
static void add_num(jb *b, cJSON *parent, const char *key, double v) {
  if (!parent) return;
  char buf[64];
  if (isfinite(v))
    shortest(v, buf, sizeof buf);
  else
    snprintf(buf, sizeof buf, "null");
  if (!cJSON_AddRawToObject(parent, key, buf)) b->fail = 1;
}
static void add_str(jb *b, cJSON *parent, const char *key, const char *v) {
  if (!parent) return;
  if (!cJSON_AddStringToObject(parent, key, v)) b->fail = 1;
}
static void add_bool(jb *b, cJSON *parent, const char *key, int v) {
  if (!parent) return;
  if (!cJSON_AddBoolToObject(parent, key, v)) b->fail = 1;
}

static void add_summary(jb *b, cJSON *parent, const char *key, const pm_summary *s) {
  if (!parent) return;
  cJSON *o = add_obj(b, parent, key);
  add_num(b, o, "min", s->min);
  add_num(b, o, "p25", s->p25);
  add_num(b, o, "median", s->median);
  add_num(b, o, "p75", s->p75);
  add_num(b, o, "max", s->max);
  add_num(b, o, "mean", s->mean);
}

static void add_size(jb *b, cJSON *parent, const pm_kind_quality *k) {
  if (!k->has_size || !parent) return;
  cJSON *o = add_obj(b, parent, "size_ratio");
  add_num(b, o, "mean", k->size_ratio.mean);
  add_num(b, o, "std", k->size_ratio_std);
  add_num(b, o, "min", k->size_ratio.min);
  add_num(b, o, "p25", k->size_ratio.p25);
  add_num(b, o, "median", k->size_ratio.median);
  add_num(b, o, "p75", k->size_ratio.p75);
  add_num(b, o, "max", k->size_ratio.max);
}

/* The keys one element kind has (DESIGN.md, stats): summaries, errors, size ratio, counts;
 * min_key / max_key name its angle (triangles) or dihedral angle (tets) summaries. */
static cJSON *add_kind(jb *b, cJSON *root, const char *name, const pm_kind_quality *k,
                       const char *min_key, const char *max_key) {
  cJSON *t = add_obj(b, root, name);
  add_summary(b, t, "radius_ratio", &k->s_radius_ratio);
  add_summary(b, t, "aspect_ratio", &k->s_aspect_ratio);
  add_summary(b, t, min_key, &k->s_min_angle);
  add_summary(b, t, max_key, &k->s_max_angle);
  if (k->eps_t_nodes > 0) add_num(b, t, "eps_t", k->eps_t);
  add_num(b, t, "eps_g", k->eps_g);
  add_size(b, t, k);
  add_num(b, t, "count", k->n);
  add_num(b, t, "degenerate", k->degenerate);
  add_num(b, t, "eps_t_nodes", k->eps_t_nodes);
  return t;
}

static void add_quality(jb *b, cJSON *root, const pm_quality *q) {
  static const char *const bins[6] = {"0_10", "10_20", "20_30", "30_40", "40_50", "50_60"};
  static const char *const over[3] = {"90", "120", "150"};
  if (q->tri.n > 0) {
    cJSON *t = add_kind(b, root, "tri", &q->tri, "min_angle_deg", "max_angle_deg");
    cJSON *h = t ? add_obj(b, t, "min_angle_bins") : NULL;
    for (int i = 0; i < 6; ++i) add_num(b, h, bins[i], (double)q->tri_min_angle_bins[i]);
    cJSON *o = t ? add_obj(b, t, "max_angle_over") : NULL;
    for (int i = 0; i < 3; ++i) add_num(b, o, over[i], (double)q->tri_max_angle_over[i]);
    cJSON *by = t ? add_obj(b, t, "by_site") : NULL;
    for (int w = 0; w < PM_TRI_SITES; ++w) {
      const pm_summary *a = &q->tri_site_aspect[w];
      cJSON *o2 = by ? add_obj(b, by, pm_tri_site_name((pm_tri_site)w)) : NULL;
      add_num(b, o2, "count", (double)a->n);
      if (a->n > 0) add_summary(b, o2, "aspect_ratio", a);
    }
  }
  if (q->tet.n > 0) add_kind(b, root, "tet", &q->tet, "min_dihedral_deg", "max_dihedral_deg");
}

/* Put an item at its dotted path below root, creating the intermediate objects. */
static void add_extra(jb *b, cJSON *root, const pm_stats_item *it) {
  char path[512];
  snprintf(path, sizeof path, "%s", it->key);
  cJSON *at = root;
  char *part = path;
  for (char *dot; (dot = strchr(part, '.')); part = dot + 1) {
    *dot = '\0';
    cJSON *next = cJSON_GetObjectItemCaseSensitive(at, part);
    if (!next) next = add_obj(b, at, part);
    if (!next || !cJSON_IsObject(next)) {
      b->fail = 1;
      return;
    }
    at = next;
  }
  if (cJSON_GetObjectItemCaseSensitive(at, part)) return; /* never clobber a standard key */
  if (it->is_text)
    add_str(b, at, part, it->text);
  else if (it->is_bool)
    add_bool(b, at, part, it->num != 0);
  else
    add_num(b, at, part, it->num);
}

static cJSON *stats_json(const pm_stats *s) {
  jb b = {0};
  cJSON *root = cJSON_CreateObject();
  if (!root) return NULL;
  add_str(&b, root, "method", s->method);
  add_str(&b, root, "input", s->input);
  add_num(&b, root, "nodes", (double)s->nodes);
  add_num(&b, root, "segments", (double)s->segments);
  add_num(&b, root, "triangles", (double)s->triangles);
  add_num(&b, root, "tets", (double)s->tets);
  if (s->has_check) {
    add_bool(&b, root, "valid", s->valid);
    cJSON *p = cJSON_AddArrayToObject(root, "problems");
    if (!p) b.fail = 1;
    for (int32_t i = 0; p && i < s->nproblem; ++i) {
      cJSON *str = cJSON_CreateString(s->problems[i]);
      if (!str || !cJSON_AddItemToArray(p, str)) b.fail = 1;
    }
    cJSON *sh = cJSON_AddArrayToObject(root, "shells");
    if (!sh) b.fail = 1;
    for (int32_t i = 0; sh && i < s->nshell; ++i) {
      cJSON *o = cJSON_CreateObject();
      if (!o || !cJSON_AddItemToArray(sh, o)) {
        b.fail = 1;
        cJSON_Delete(o);
        break;
      }
      const pm_check_shell *c = &s->shells[i];
      add_num(&b, o, "volume", c->volume);
      add_num(&b, o, "euler", (double)c->euler);
      add_num(&b, o, "components", c->components);
      add_bool(&b, o, "closed", c->closed);
      add_num(&b, o, "genus", c->genus);
    }
  }
  add_num(&b, root, "iterations", (double)s->iterations);
  cJSON *t = add_obj(&b, root, "time_s");
  add_num(&b, t, "total", s->time_total);
  for (int32_t i = 0; i < s->ntime; ++i) add_extra(&b, t, &s->time[i]); /* "a.b" nests */
  if (s->has_quality) add_quality(&b, root, &s->quality);
  if (s->has_distance) {
    cJSON *d = add_obj(&b, root, "distance");
    add_num(&b, d, "mean", s->dist_mean);
    add_num(&b, d, "max", s->dist_max);
    add_num(&b, d, "bbox_diagonal", s->bbox_diagonal);
  }
  for (int32_t i = 0; i < s->nextra; ++i) add_extra(&b, root, &s->extra[i]);
  if (b.fail) {
    cJSON_Delete(root);
    return NULL;
  }
  return root;
}

pm_status pm_stats_to_json(const pm_stats *s, char **out, pm_error *err) {
  *out = NULL;
  cJSON *root = stats_json(s);
  if (!root) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats JSON)");
  char *text = cJSON_Print(root);
  cJSON_Delete(root);
  if (!text) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats JSON)");
  /* cJSON's buffer is released with cJSON_free; hand the caller a malloc'ed copy + newline. */
  size_t n = strlen(text);
  char *copy = malloc(n + 2);
  if (copy) {
    memcpy(copy, text, n);
    copy[n] = '\n';
    copy[n + 1] = '\0';
  }
  cJSON_free(text);
  if (!copy) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats JSON)");
  *out = copy;
  return PM_OK;
}

pm_status pm_stats_write_json(const pm_stats *s, const char *path, pm_error *err) {
  char *text = NULL;
  pm_status st = pm_stats_to_json(s, &text, err);
  if (st) return st;
  st = pm_atomic_write(path, text, strlen(text), err);
  free(text);
  return st;
}

/* ---- flattening --------------------------------------------------------------------------- */

typedef struct flat_buf {
  pm_stats_flat *out;
  int fail;
} flat_buf;

static void flat_push(flat_buf *fb, const char *key, int is_text, double num, const char *text) {
  if (fb->fail) return;
  pm_error e;
  if (push_item(&fb->out->item, &fb->out->n, key, is_text, num, text, &e)) fb->fail = 1;
}

/* Append a scalar's text form to a growing string. */
static int append(char **s, size_t *len, const char *add) {
  size_t n = strlen(add);
  char *p = realloc(*s, *len + n + 1);
  if (!p) return 0;
  memcpy(p + *len, add, n + 1);
  *s = p;
  *len += n;
  return 1;
}

static void scalar_text(const cJSON *v, char *buf, size_t len) {
  if (cJSON_IsString(v) || cJSON_IsRaw(v))
    snprintf(buf, len, "%s", v->valuestring);
  else if (cJSON_IsNumber(v))
    shortest(v->valuedouble, buf, len);
  else if (cJSON_IsTrue(v))
    snprintf(buf, len, "true");
  else if (cJSON_IsFalse(v))
    snprintf(buf, len, "false");
  else
    buf[0] = '\0';
}

static void flatten_node(flat_buf *fb, const cJSON *v, const char *prefix) {
  if (cJSON_IsObject(v)) {
    for (const cJSON *c = v->child; c; c = c->next) {
      char key[512];
      if (prefix[0])
        snprintf(key, sizeof key, "%s.%s", prefix, c->string ? c->string : "");
      else
        snprintf(key, sizeof key, "%s", c->string ? c->string : "");
      flatten_node(fb, c, key);
    }
  } else if (cJSON_IsArray(v)) {
    int objects = 0;
    for (const cJSON *c = v->child; c; c = c->next) objects |= cJSON_IsObject(c) || cJSON_IsArray(c);
    if (objects) {
      int i = 0;
      for (const cJSON *c = v->child; c; c = c->next, ++i) {
        char key[512];
        snprintf(key, sizeof key, "%s.%d", prefix, i);
        flatten_node(fb, c, key);
      }
    } else {
      char *joined = NULL;
      size_t len = 0;
      if (!append(&joined, &len, "")) {
        fb->fail = 1;
        return;
      }
      for (const cJSON *c = v->child; c; c = c->next) {
        char buf[1024];
        scalar_text(c, buf, sizeof buf);
        if ((c != v->child && !append(&joined, &len, " | ")) || !append(&joined, &len, buf)) {
          fb->fail = 1;
          break;
        }
      }
      flat_push(fb, prefix, 1, 0, joined);
      free(joined);
    }
  } else if (cJSON_IsNumber(v)) {
    flat_push(fb, prefix, 0, v->valuedouble, NULL);
  } else if (cJSON_IsRaw(v)) {
    /* our own numbers (add_num): a number, or null */
    if (strcmp(v->valuestring, "null") == 0)
      flat_push(fb, prefix, 1, 0, "");
    else
      flat_push(fb, prefix, 0, strtod(v->valuestring, NULL), NULL);
  } else {
    char buf[1024];
    scalar_text(v, buf, sizeof buf);
    flat_push(fb, prefix, 1, 0, cJSON_IsString(v) ? v->valuestring : buf);
  }
}

static pm_status flatten_root(const cJSON *root, pm_stats_flat *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  if (!cJSON_IsObject(root)) return pm_error_setf(err, PM_ERR_PARSE, "stats JSON is no object");
  flat_buf fb = {out, 0};
  flatten_node(&fb, root, "");
  if (fb.fail) {
    pm_stats_flat_clear(out);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (flattening stats)");
  }
  return PM_OK;
}

pm_status pm_stats_flatten(const pm_stats *s, pm_stats_flat *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  cJSON *root = stats_json(s);
  if (!root) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (stats JSON)");
  pm_status st = flatten_root(root, out, err);
  cJSON_Delete(root);
  return st;
}

pm_status pm_stats_flatten_json(const char *json, pm_stats_flat *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  if (!json) return pm_error_setf(err, PM_ERR_ARG, "no JSON text");
  cJSON *root = cJSON_Parse(json);
  if (!root) return pm_error_setf(err, PM_ERR_PARSE, "malformed stats JSON");
  pm_status st = flatten_root(root, out, err);
  cJSON_Delete(root);
  return st;
}

void pm_stats_flat_clear(pm_stats_flat *f) {
  if (!f) return;
  for (int32_t i = 0; i < f->n; ++i) item_free(&f->item[i]);
  free(f->item);
  memset(f, 0, sizeof *f);
}

const pm_stats_item *pm_stats_flat_find(const pm_stats_flat *f, const char *key) {
  for (int32_t i = 0; i < f->n; ++i)
    if (strcmp(f->item[i].key, key) == 0) return &f->item[i];
  return NULL;
}

/* ---- CSV ---------------------------------------------------------------------------------- */

void pm_csv_field(FILE *f, const char *text) {
  if (!text) text = "";
  if (!strpbrk(text, ",\"\r\n")) {
    fputs(text, f);
    return;
  }
  fputc('"', f);
  for (const char *c = text; *c; ++c) {
    if (*c == '"') fputc('"', f);
    fputc(*c, f);
  }
  fputc('"', f);
}

void pm_csv_number(FILE *f, double x) {
  if (!isfinite(x)) return;
  char buf[64];
  shortest(x, buf, sizeof buf);
  fputs(buf, f);
}

void pm_stats_flat_csv_header(FILE *f, const pm_stats_flat *flat) {
  for (int32_t i = 0; i < flat->n; ++i) {
    if (i) fputc(',', f);
    pm_csv_field(f, flat->item[i].key);
  }
  fputc('\n', f);
}

void pm_stats_flat_csv_row(FILE *f, const pm_stats_flat *flat) {
  for (int32_t i = 0; i < flat->n; ++i) {
    if (i) fputc(',', f);
    if (flat->item[i].is_text)
      pm_csv_field(f, flat->item[i].text);
    else
      pm_csv_number(f, flat->item[i].num);
  }
  fputc('\n', f);
}

pm_status pm_stats_write_elements_csv(FILE *f, const pm_mesh *m, const pm_quality *q,
                                      pm_error *err) {
  if (q->tri.n != m->ntri || q->tet.n != m->ntet)
    return pm_error_setf(err, PM_ERR_ARG, "quality measures do not belong to this mesh");
  fputs("kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg\n", f);
  const pm_kind_quality *k[2] = {&q->tri, &q->tet};
  const int32_t *cells[2] = {m->tri_cell, m->tet_cell};
  static const char *const kind[2] = {"tri", "tet"};
  for (int j = 0; j < 2; ++j)
    for (int32_t i = 0; i < k[j]->n; ++i) {
      fprintf(f, "%s,%ld,%ld,", kind[j], (long)i, (long)cells[j][i]);
      pm_csv_number(f, k[j]->radius_ratio[i]);
      fputc(',', f);
      pm_csv_number(f, k[j]->aspect_ratio[i]);
      fputc(',', f);
      pm_csv_number(f, k[j]->min_angle[i]);
      fputc(',', f);
      pm_csv_number(f, k[j]->max_angle[i]);
      fputc('\n', f);
    }
  if (ferror(f)) return pm_error_setf(err, PM_ERR_IO, "writing element CSV: %s", strerror(errno));
  return PM_OK;
}
