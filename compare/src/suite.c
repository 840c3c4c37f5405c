/* Reading a comparison suite (compare/README.md documents the format) and expanding it into rows.
 *
 * The suite is checked strictly for its structure -- an unknown key is an error naming it, so a
 * misspelt "match_node" does not silently run an unmatched study -- but not for what only a run
 * can tell (an unknown method, a missing file, a bad size expression): those become the error of
 * their rows, reported by packmesh mesh itself, so the row's command reproduces the error too.
 */
#include <cjson/cJSON.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "compare/src/study.h"

#define MAX_ENTRIES 10000 /* cases, methods, seeds, sweep values: a cap on each list */
#define MAX_ROWS 100000

static char *dup_str(const char *s) {
  char *d = malloc(strlen(s) + 1);
  if (d) strcpy(d, s);
  return d;
}

static pm_status oom(pm_error *err) { return pm_error_setf(err, PM_ERR_NOMEM, "out of memory"); }

/* Keys allowed in an object; the first unknown one is an error naming `where`. */
static pm_status check_keys(const cJSON *obj, const char *const *allowed, const char *where,
                            pm_error *err) {
  for (const cJSON *c = obj->child; c; c = c->next) {
    int ok = 0;
    for (int i = 0; allowed[i]; ++i) ok |= strcmp(c->string, allowed[i]) == 0;
    if (!ok) {
      char list[512] = "";
      for (int i = 0; allowed[i]; ++i) {
        strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
        strncat(list, allowed[i], sizeof list - strlen(list) - 1);
      }
      return pm_error_setf(err, PM_ERR_ARG, "%s: unknown key \"%s\" (known: %s)", where,
                           c->string, list);
    }
  }
  return PM_OK;
}

/* A size or parameter value: a JSON number (written with 10 significant digits, enough for any
 * value typed in a suite) or a string taken as it is. */
static pm_status value_text(const cJSON *v, const char *where, char **out, pm_error *err) {
  char buf[64];
  if (cJSON_IsNumber(v)) {
    if (!isfinite(v->valuedouble))
      return pm_error_setf(err, PM_ERR_ARG, "%s: not a finite number", where);
    snprintf(buf, sizeof buf, "%.10g", v->valuedouble);
    *out = dup_str(buf);
  } else if (cJSON_IsString(v)) {
    if (!v->valuestring[0]) return pm_error_setf(err, PM_ERR_ARG, "%s: empty text", where);
    *out = dup_str(v->valuestring);
  } else if (cJSON_IsBool(v)) {
    *out = dup_str(cJSON_IsTrue(v) ? "1" : "0");
  } else {
    return pm_error_setf(err, PM_ERR_ARG, "%s: expected a number or a string", where);
  }
  return *out ? PM_OK : oom(err);
}

static pm_status get_bool(const cJSON *obj, const char *key, const char *where, int *out,
                          pm_error *err) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v) return PM_OK;
  if (!cJSON_IsBool(v))
    return pm_error_setf(err, PM_ERR_ARG, "%s: \"%s\" must be true or false", where, key);
  *out = cJSON_IsTrue(v);
  return PM_OK;
}

static pm_status get_number(const cJSON *obj, const char *key, const char *where, double lo,
                            double hi, double *out, pm_error *err) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v) return PM_OK;
  if (!cJSON_IsNumber(v) || !(v->valuedouble >= lo && v->valuedouble <= hi))
    return pm_error_setf(err, PM_ERR_ARG, "%s: \"%s\" must be a number in [%g, %g]", where, key,
                         lo, hi);
  *out = v->valuedouble;
  return PM_OK;
}

/* A string that must be one of two words: *out = 0 for the first, 1 for the second. */
static pm_status get_choice(const cJSON *obj, const char *key, const char *where, const char *w0,
                            const char *w1, int *out, pm_error *err) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v) return PM_OK;
  if (!cJSON_IsString(v) || (strcmp(v->valuestring, w0) != 0 && strcmp(v->valuestring, w1) != 0))
    return pm_error_setf(err, PM_ERR_ARG, "%s: \"%s\" must be \"%s\" or \"%s\"", where, key, w0,
                         w1);
  *out = strcmp(v->valuestring, w1) == 0;
  return PM_OK;
}

static const char *base_name(const char *p) {
  const char *s = strrchr(p, '/');
  return s ? s + 1 : p;
}

/* A row-id-safe short name from an input: "case:qi3" -> "qi3", "/x/screw.step" -> "screw". */
static void short_name(const char *input, char *out, size_t len) {
  const char *b = strncmp(input, "case:", 5) == 0 ? input + 5 : base_name(input);
  snprintf(out, len, "%s", b);
  if (strncmp(input, "case:", 5) != 0) {
    char *dot = strrchr(out, '.');
    if (dot && dot != out) *dot = '\0';
  }
}

static char *resolve_input(const char *input, const char *base_dir) {
  if (strncmp(input, "case:", 5) == 0 || input[0] == '/' || !base_dir || !base_dir[0])
    return dup_str(input);
  size_t n = strlen(base_dir) + strlen(input) + 2;
  char *joined = malloc(n);
  if (!joined) return NULL;
  snprintf(joined, n, "%s/%s", base_dir, input);
  char real[PATH_MAX];
  if (realpath(joined, real)) {
    free(joined);
    return dup_str(real);
  }
  return joined; /* missing: the run reports it */
}

static pm_status parse_case(const cJSON *c, int i, const char *base_dir, const cJSON *def_size,
                            int def_volume, pm_cmp_case *out, pm_error *err) {
  char where[64];
  snprintf(where, sizeof where, "cases[%d]", i);
  static const char *const keys[] = {"input", "name", "size", "volume", "reference", NULL};
  const cJSON *input = c, *size = def_size;
  out->volume = def_volume;
  const char *name = NULL;
  pm_status s;
  if (cJSON_IsObject(c)) {
    if ((s = check_keys(c, keys, where, err))) return s;
    input = cJSON_GetObjectItemCaseSensitive(c, "input");
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(c, "name");
    if (n && (!cJSON_IsString(n) || !n->valuestring[0]))
      return pm_error_setf(err, PM_ERR_ARG, "%s: \"name\" must be a non-empty string", where);
    if (n) name = n->valuestring;
    const cJSON *sz = cJSON_GetObjectItemCaseSensitive(c, "size");
    if (sz) size = sz;
    if ((s = get_bool(c, "volume", where, &out->volume, err))) return s;
    const cJSON *ref = cJSON_GetObjectItemCaseSensitive(c, "reference");
    if (ref) {
      if (!cJSON_IsObject(ref))
        return pm_error_setf(err, PM_ERR_ARG, "%s: \"reference\" must be an object", where);
      out->ref_json = cJSON_PrintUnformatted(ref);
      if (!out->ref_json) return oom(err);
    }
  }
  if (!cJSON_IsString(input) || !input->valuestring[0])
    return pm_error_setf(err, PM_ERR_ARG,
                         "%s: expected an input (\"case:NAME\" or a file) or an object with "
                         "\"input\"",
                         where);
  out->input = resolve_input(input->valuestring, base_dir);
  if (!out->input) return oom(err);
  char sn[128];
  if (name)
    snprintf(sn, sizeof sn, "%s", name);
  else
    short_name(input->valuestring, sn, sizeof sn);
  out->name = dup_str(sn);
  if (!out->name) return oom(err);
  if (size && !cJSON_IsNull(size)) {
    char w[80];
    snprintf(w, sizeof w, "%s size", where);
    if ((s = value_text(size, w, &out->size, err))) return s;
  }
  return PM_OK;
}

static pm_status parse_method(const cJSON *m, int i, pm_cmp_method *out, pm_error *err) {
  char where[64];
  snprintf(where, sizeof where, "methods[%d]", i);
  static const char *const keys[] = {"method", "label", "set", "cases", NULL};
  const cJSON *name = m;
  pm_status s;
  if (cJSON_IsObject(m)) {
    if ((s = check_keys(m, keys, where, err))) return s;
    name = cJSON_GetObjectItemCaseSensitive(m, "method");
  }
  if (!cJSON_IsString(name) || !name->valuestring[0])
    return pm_error_setf(err, PM_ERR_ARG,
                         "%s: expected a method name or an object with \"method\"", where);
  out->name = dup_str(name->valuestring);
  if (!out->name) return oom(err);
  const cJSON *label = cJSON_IsObject(m) ? cJSON_GetObjectItemCaseSensitive(m, "label") : NULL;
  if (label && (!cJSON_IsString(label) || !label->valuestring[0]))
    return pm_error_setf(err, PM_ERR_ARG, "%s: \"label\" must be a non-empty string", where);
  out->label = dup_str(label ? label->valuestring : name->valuestring);
  if (!out->label) return oom(err);
  if (!cJSON_IsObject(m)) return PM_OK;

  /* "set": {"k0": 30, "w2": 0.6} or ["k0=30", "w2=0.6"]. */
  const cJSON *set = cJSON_GetObjectItemCaseSensitive(m, "set");
  if (set) {
    int n = cJSON_GetArraySize(set);
    if (!(cJSON_IsObject(set) || cJSON_IsArray(set)) || n > MAX_ENTRIES)
      return pm_error_setf(err, PM_ERR_ARG,
                           "%s: \"set\" must be an object {\"KEY\": VALUE} or a list of "
                           "\"KEY=VALUE\"",
                           where);
    out->sets = calloc((size_t)n + 1, sizeof *out->sets);
    if (!out->sets) return oom(err);
    for (const cJSON *e = set->child; e; e = e->next) {
      char *text = NULL;
      if (cJSON_IsObject(set)) {
        char w[160];
        snprintf(w, sizeof w, "%s set.%s", where, e->string);
        if ((s = value_text(e, w, &text, err))) return s;
        size_t len = strlen(e->string) + strlen(text) + 2;
        char *pair = malloc(len);
        if (!pair) {
          free(text);
          return oom(err);
        }
        snprintf(pair, len, "%s=%s", e->string, text);
        free(text);
        text = pair;
      } else {
        if (!cJSON_IsString(e) || !strchr(e->valuestring, '='))
          return pm_error_setf(err, PM_ERR_ARG, "%s: \"set\" entries must read \"KEY=VALUE\"",
                               where);
        text = dup_str(e->valuestring);
        if (!text) return oom(err);
      }
      out->sets[out->nset++] = text;
    }
  }
  const cJSON *cases = cJSON_GetObjectItemCaseSensitive(m, "cases");
  if (cases) {
    int n = cJSON_GetArraySize(cases);
    if (!cJSON_IsArray(cases) || n == 0 || n > MAX_ENTRIES)
      return pm_error_setf(err, PM_ERR_ARG, "%s: \"cases\" must be a non-empty list of case names",
                           where);
    out->only = calloc((size_t)n, sizeof *out->only);
    if (!out->only) return oom(err);
    for (const cJSON *e = cases->child; e; e = e->next) {
      if (!cJSON_IsString(e))
        return pm_error_setf(err, PM_ERR_ARG, "%s: \"cases\" must list case names", where);
      out->only[out->nonly] = dup_str(e->valuestring);
      if (!out->only[out->nonly++]) return oom(err);
    }
  }
  return PM_OK;
}

/* "sweep": {"key": K, "values": [...]} or {"key": K, "from": a, "to": b, "count": n,
 * "scale": "linear"|"log"} or {"key": K, "from": a, "to": b, "step": h}. */
static pm_status parse_sweep(const cJSON *sw, pm_cmp_suite *s, pm_error *err) {
  static const char *const keys[] = {"key", "values", "from", "to", "count", "step", "scale", NULL};
  pm_status st;
  if (!cJSON_IsObject(sw)) return pm_error_setf(err, PM_ERR_ARG, "sweep: expected an object");
  if ((st = check_keys(sw, keys, "sweep", err))) return st;
  const cJSON *key = cJSON_GetObjectItemCaseSensitive(sw, "key");
  if (!cJSON_IsString(key) || !key->valuestring[0] || strchr(key->valuestring, '='))
    return pm_error_setf(err, PM_ERR_ARG,
                         "sweep: \"key\" must name a parameter (as for --set) or \"size\"");
  s->sweep_key = dup_str(key->valuestring);
  if (!s->sweep_key) return oom(err);
  const cJSON *values = cJSON_GetObjectItemCaseSensitive(sw, "values");
  if (values) {
    int n = cJSON_GetArraySize(values);
    if (!cJSON_IsArray(values) || n == 0 || n > MAX_ENTRIES)
      return pm_error_setf(err, PM_ERR_ARG, "sweep: \"values\" must be a non-empty list");
    s->sweep_values = calloc((size_t)n, sizeof *s->sweep_values);
    if (!s->sweep_values) return oom(err);
    for (const cJSON *e = values->child; e; e = e->next) {
      if ((st = value_text(e, "sweep values", &s->sweep_values[s->nsweep], err))) return st;
      s->nsweep++;
    }
    return PM_OK;
  }
  double from = NAN, to = NAN, count = 0, step = 0;
  if ((st = get_number(sw, "from", "sweep", -1e300, 1e300, &from, err)) ||
      (st = get_number(sw, "to", "sweep", -1e300, 1e300, &to, err)) ||
      (st = get_number(sw, "count", "sweep", 2, MAX_ENTRIES, &count, err)) ||
      (st = get_number(sw, "step", "sweep", 0, 1e300, &step, err)))
    return st;
  if (isnan(from) || isnan(to) || (count == 0) == (step == 0) || (count && count != floor(count)))
    return pm_error_setf(err, PM_ERR_ARG,
                         "sweep: give \"values\", or \"from\", \"to\" and either a whole "
                         "\"count\" >= 2 or a \"step\" > 0");
  int logscale = 0;
  const cJSON *scale = cJSON_GetObjectItemCaseSensitive(sw, "scale");
  if (scale) {
    if (!cJSON_IsString(scale) ||
        (strcmp(scale->valuestring, "linear") && strcmp(scale->valuestring, "log")))
      return pm_error_setf(err, PM_ERR_ARG, "sweep: \"scale\" is \"linear\" or \"log\"");
    logscale = strcmp(scale->valuestring, "log") == 0;
  }
  if (logscale && !(from > 0 && to > 0))
    return pm_error_setf(err, PM_ERR_ARG, "sweep: a log scale needs \"from\" and \"to\" > 0");
  int n;
  if (step > 0) {
    if (logscale) return pm_error_setf(err, PM_ERR_ARG, "sweep: \"step\" goes with a linear scale");
    /* The small slack keeps `to` when (to - from) / step is a whole number up to rounding. */
    double k = floor(fabs(to - from) / step + 1e-9);
    if (k + 1 > MAX_ENTRIES)
      return pm_error_setf(err, PM_ERR_ARG, "sweep: more than %d values", MAX_ENTRIES);
    n = (int)k + 1;
  } else {
    n = (int)count;
  }
  s->sweep_values = calloc((size_t)n, sizeof *s->sweep_values);
  if (!s->sweep_values) return oom(err);
  for (int i = 0; i < n; ++i) {
    double v;
    if (step > 0)
      v = from + (to >= from ? 1 : -1) * step * i;
    else if (logscale)
      v = exp(log(from) + (log(to) - log(from)) * i / (n - 1));
    else
      v = from + (to - from) * i / (n - 1);
    if (i == n - 1 && step == 0) v = to; /* the end point exactly as written */
    char buf[64];
    /* 6 significant digits: a range's values read as typed ("0.55", not "0.55000000000000004"). */
    snprintf(buf, sizeof buf, "%.6g", v);
    s->sweep_values[i] = dup_str(buf);
    if (!s->sweep_values[i]) return oom(err);
    s->nsweep++;
  }
  return PM_OK;
}

pm_status pm_cmp_suite_parse(const char *text, const char *base_dir, const char *path,
                             pm_cmp_suite *s, pm_error *err) {
  memset(s, 0, sizeof *s);
  s->timeout_s = 600;
  s->trace = 1;
  pm_status st = PM_OK;
  cJSON *root = cJSON_Parse(text);
  if (!root) {
    const char *at = cJSON_GetErrorPtr();
    int line = 1;
    for (const char *c = text; at && c < at && *c; ++c) line += *c == '\n';
    return pm_error_setf(err, PM_ERR_PARSE, "suite %s: not valid JSON (near line %d)",
                         path && path[0] ? path : "(built in)", line);
  }
  static const char *const keys[] = {"name",  "description", "cases",   "methods", "seeds",
                                     "repeats", "size",      "options", "sweep",   NULL};
  static const char *const okeys[] = {"match_nodes", "reference", "volume", "timeout_s",
                                      "threads",     "max_nodes", "trace",  "match",
                                      "whiskers",    NULL};
  const cJSON *cases, *methods, *opts, *seeds, *repeats, *name, *desc;
  int def_volume = 0, n;
  if (!cJSON_IsObject(root)) {
    st = pm_error_setf(err, PM_ERR_ARG, "suite: expected a JSON object");
    goto done;
  }
  if ((st = check_keys(root, keys, "suite", err))) goto done;
  s->path = dup_str(path ? path : "");
  s->text = dup_str(text);
  name = cJSON_GetObjectItemCaseSensitive(root, "name");
  desc = cJSON_GetObjectItemCaseSensitive(root, "description");
  if ((name && !cJSON_IsString(name)) || (desc && !cJSON_IsString(desc))) {
    st = pm_error_setf(err, PM_ERR_ARG, "suite: \"name\" and \"description\" must be strings");
    goto done;
  }
  if (name && name->valuestring[0]) {
    s->name = dup_str(name->valuestring);
  } else {
    char sn[128];
    short_name(path && path[0] ? path : "suite.json", sn, sizeof sn);
    s->name = dup_str(sn);
  }
  s->description = dup_str(desc ? desc->valuestring : "");
  if (!s->path || !s->text || !s->name || !s->description) {
    st = oom(err);
    goto done;
  }

  /* Options first: "volume" is the default of every case. */
  opts = cJSON_GetObjectItemCaseSensitive(root, "options");
  if (opts) {
    if (!cJSON_IsObject(opts)) {
      st = pm_error_setf(err, PM_ERR_ARG, "options: expected an object");
      goto done;
    }
    if ((st = check_keys(opts, okeys, "options", err))) goto done;
    double thr = 0, mx = 0;
    if ((st = get_bool(opts, "match_nodes", "options", &s->match_nodes, err)) ||
        (st = get_bool(opts, "volume", "options", &def_volume, err)) ||
        (st = get_bool(opts, "trace", "options", &s->trace, err)) ||
        (st = get_number(opts, "timeout_s", "options", 1e-3, 1e7, &s->timeout_s, err)) ||
        (st = get_number(opts, "threads", "options", 1, 1024, &thr, err)) ||
        (st = get_number(opts, "max_nodes", "options", 3, 2e9, &mx, err)) ||
        (st = get_choice(opts, "match", "options", "all", "surface", &s->match_surface, err)) ||
        (st = get_choice(opts, "whiskers", "options", "tukey", "minmax", &s->whiskers_minmax, err)))
      goto done;
    if (thr != floor(thr) || mx != floor(mx)) {
      st = pm_error_setf(err, PM_ERR_ARG, "options: \"threads\" and \"max_nodes\" are whole numbers");
      goto done;
    }
    s->threads = (int)thr;
    s->max_nodes = (long)mx;
  }

  cases = cJSON_GetObjectItemCaseSensitive(root, "cases");
  n = cJSON_GetArraySize(cases);
  if (!cJSON_IsArray(cases) || n == 0 || n > MAX_ENTRIES) {
    st = pm_error_setf(err, PM_ERR_ARG, "suite: \"cases\" must be a non-empty list");
    goto done;
  }
  s->cases = calloc((size_t)n, sizeof *s->cases);
  if (!s->cases) {
    st = oom(err);
    goto done;
  }
  for (const cJSON *c = cases->child; c; c = c->next) {
    st = parse_case(c, s->ncase, base_dir, cJSON_GetObjectItemCaseSensitive(root, "size"),
                    def_volume, &s->cases[s->ncase], err);
    s->ncase++;
    if (st) goto done;
  }
  /* Distinct case names: they name rows and plot groups. */
  for (int i = 0; i < s->ncase; ++i)
    for (int j = 0; j < i; ++j)
      if (strcmp(s->cases[i].name, s->cases[j].name) == 0) {
        st = pm_error_setf(err, PM_ERR_ARG,
                           "cases[%d]: the name '%s' is used twice; give one of them a \"name\"",
                           i, s->cases[i].name);
        goto done;
      }

  methods = cJSON_GetObjectItemCaseSensitive(root, "methods");
  n = cJSON_GetArraySize(methods);
  if (!cJSON_IsArray(methods) || n == 0 || n > MAX_ENTRIES) {
    st = pm_error_setf(err, PM_ERR_ARG, "suite: \"methods\" must be a non-empty list");
    goto done;
  }
  s->methods = calloc((size_t)n, sizeof *s->methods);
  if (!s->methods) {
    st = oom(err);
    goto done;
  }
  for (const cJSON *m = methods->child; m; m = m->next) {
    st = parse_method(m, s->nmethod, &s->methods[s->nmethod], err);
    s->nmethod++;
    if (st) goto done;
  }
  for (int i = 0; i < s->nmethod; ++i) {
    for (int j = 0; j < i; ++j)
      if (strcmp(s->methods[i].label, s->methods[j].label) == 0) {
        st = pm_error_setf(err, PM_ERR_ARG,
                           "methods[%d]: the label '%s' is used twice; give each entry its own "
                           "\"label\"",
                           i, s->methods[i].label);
        goto done;
      }
    for (int k = 0; k < s->methods[i].nonly; ++k) {
      int found = 0;
      for (int c = 0; c < s->ncase; ++c) found |= strcmp(s->cases[c].name, s->methods[i].only[k]) == 0;
      if (!found) {
        st = pm_error_setf(err, PM_ERR_ARG, "methods[%d]: \"cases\" names '%s', which is no case "
                           "of the suite", i, s->methods[i].only[k]);
        goto done;
      }
    }
  }
  if (opts) {
    const cJSON *ref = cJSON_GetObjectItemCaseSensitive(opts, "reference");
    if (ref) {
      s->reference = -1;
      for (int i = 0; cJSON_IsString(ref) && i < s->nmethod; ++i)
        if (strcmp(s->methods[i].label, ref->valuestring) == 0) s->reference = i;
      if (s->reference < 0) {
        st = pm_error_setf(err, PM_ERR_ARG,
                           "options: \"reference\" must be the label of one of the methods");
        goto done;
      }
    }
  }

  seeds = cJSON_GetObjectItemCaseSensitive(root, "seeds");
  repeats = cJSON_GetObjectItemCaseSensitive(root, "repeats");
  if (seeds && repeats) {
    st = pm_error_setf(err, PM_ERR_ARG, "suite: give \"seeds\" or \"repeats\", not both");
    goto done;
  }
  if (seeds) {
    n = cJSON_GetArraySize(seeds);
    if (!cJSON_IsArray(seeds) || n == 0 || n > MAX_ENTRIES) {
      st = pm_error_setf(err, PM_ERR_ARG, "suite: \"seeds\" must be a non-empty list of whole numbers");
      goto done;
    }
    s->seeds = calloc((size_t)n, sizeof *s->seeds);
    if (!s->seeds) {
      st = oom(err);
      goto done;
    }
    for (const cJSON *e = seeds->child; e; e = e->next) {
      if (!cJSON_IsNumber(e) || e->valuedouble < 0 || e->valuedouble > 9e15 ||
          e->valuedouble != floor(e->valuedouble)) {
        st = pm_error_setf(err, PM_ERR_ARG, "suite: \"seeds\" must be whole numbers >= 0");
        goto done;
      }
      s->seeds[s->nseed++] = (long)e->valuedouble;
    }
  } else {
    double r = 1;
    if ((st = get_number(root, "repeats", "suite", 1, MAX_ENTRIES, &r, err))) goto done;
    if (r != floor(r)) {
      st = pm_error_setf(err, PM_ERR_ARG, "suite: \"repeats\" must be a whole number >= 1");
      goto done;
    }
    s->seeds = calloc((size_t)r, sizeof *s->seeds);
    if (!s->seeds) {
      st = oom(err);
      goto done;
    }
    for (int i = 0; i < (int)r; ++i) s->seeds[s->nseed++] = i + 1;
  }

  if (cJSON_GetObjectItemCaseSensitive(root, "sweep") &&
      (st = parse_sweep(cJSON_GetObjectItemCaseSensitive(root, "sweep"), s, err)))
    goto done;
  if ((double)s->ncase * s->nmethod * s->nseed * (s->nsweep ? s->nsweep : 1) > MAX_ROWS)
    st = pm_error_setf(err, PM_ERR_LIMIT, "suite: more than %d runs", MAX_ROWS);
done:
  cJSON_Delete(root);
  if (st) pm_cmp_suite_clear(s);
  return st;
}

pm_status pm_cmp_suite_load(const char *path, pm_cmp_suite *s, pm_error *err) {
  memset(s, 0, sizeof *s);
  size_t len = 0;
  char *text = pm_cmp_read_file(path, &len);
  if (!text) return pm_error_setf(err, PM_ERR_IO, "cannot read suite '%s'", path);
  if (strlen(text) != len) {
    free(text);
    return pm_error_setf(err, PM_ERR_PARSE, "suite %s: not a text file", path);
  }
  /* Relative inputs are relative to the suite's folder. */
  char dir[PATH_MAX];
  char real[PATH_MAX];
  if (realpath(path, real)) {
    snprintf(dir, sizeof dir, "%s", real);
    char *slash = strrchr(dir, '/');
    if (slash) *(slash == dir ? slash + 1 : slash) = '\0';
  } else {
    snprintf(dir, sizeof dir, ".");
  }
  pm_status st = pm_cmp_suite_parse(text, dir, path, s, err);
  free(text);
  return st;
}

void pm_cmp_suite_clear(pm_cmp_suite *s) {
  if (!s) return;
  for (int i = 0; i < s->ncase; ++i) {
    free(s->cases[i].name);
    free(s->cases[i].input);
    free(s->cases[i].size);
    free(s->cases[i].ref_json);
  }
  free(s->cases);
  for (int i = 0; i < s->nmethod; ++i) {
    free(s->methods[i].label);
    free(s->methods[i].name);
    for (int k = 0; k < s->methods[i].nset; ++k) free(s->methods[i].sets[k]);
    free(s->methods[i].sets);
    for (int k = 0; k < s->methods[i].nonly; ++k) free(s->methods[i].only[k]);
    free(s->methods[i].only);
  }
  free(s->methods);
  free(s->seeds);
  for (int i = 0; i < s->nsweep; ++i) free(s->sweep_values[i]);
  free(s->sweep_values);
  free(s->sweep_key);
  free(s->path);
  free(s->text);
  free(s->name);
  free(s->description);
  memset(s, 0, sizeof *s);
}

/* ---- rows ---------------------------------------------------------------------------------- */

const char *pm_cmp_status_name(pm_cmp_status s) {
  switch (s) {
    case PM_CMP_PENDING: return "pending";
    case PM_CMP_OK: return "ok";
    case PM_CMP_FAILED: return "failed";
    case PM_CMP_CRASHED: return "crashed";
    case PM_CMP_TIMEOUT: return "timeout";
    case PM_CMP_SKIPPED: return "skipped";
  }
  return "?";
}

/* Letters, digits and ._=- stay; anything else becomes '_' (row ids are folder names). */
static void sanitize(char *s) {
  for (; *s; ++s)
    if (!((*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z') || (*s >= '0' && *s <= '9') ||
          strchr("._=-", *s)))
      *s = '_';
}

static int runs_on(const pm_cmp_method *m, const pm_cmp_case *c) {
  if (m->nonly == 0) return 1;
  for (int k = 0; k < m->nonly; ++k)
    if (strcmp(m->only[k], c->name) == 0) return 1;
  return 0;
}

pm_status pm_cmp_study_init(pm_cmp_study *st, pm_cmp_suite *s, const char *dir, pm_error *err) {
  memset(st, 0, sizeof *st);
  pm_status rc = pm_cmp_mkdirs(dir, err);
  if (rc) return rc;
  char real[PATH_MAX];
  if (!realpath(dir, real)) return pm_error_setf(err, PM_ERR_IO, "cannot resolve folder '%s'", dir);
  st->dir = dup_str(real);
  char exe[PATH_MAX];
  ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) {
    free(st->dir);
    st->dir = NULL;
    return pm_error_setf(err, PM_ERR_IO, "cannot find the packmesh binary (/proc/self/exe)");
  }
  exe[n] = '\0';
  st->exe = dup_str(exe);
  st->suite = *s;
  memset(s, 0, sizeof *s);
  const pm_cmp_suite *su = &st->suite;

  int nsw = su->nsweep ? su->nsweep : 1;
  size_t cap = (size_t)su->ncase * su->nmethod * su->nseed * nsw;
  st->rows = calloc(cap ? cap : 1, sizeof *st->rows);
  if (!st->rows || !st->exe) return oom(err);
  /* Method order within a group: the reference first, so its node count is known early. */
  int *order = malloc((size_t)su->nmethod * sizeof *order);
  if (!order) return oom(err);
  int k = 0;
  if (su->match_nodes) order[k++] = su->reference;
  for (int m = 0; m < su->nmethod; ++m)
    if (!(su->match_nodes && m == su->reference)) order[k++] = m;
  for (int c = 0; c < su->ncase; ++c)
    for (int sd = 0; sd < su->nseed; ++sd)
      for (int w = 0; w < nsw; ++w) {
        int ref = -1;
        for (int j = 0; j < su->nmethod; ++j) {
          int m = order[j];
          if (!runs_on(&su->methods[m], &su->cases[c])) continue;
          pm_cmp_row *r = &st->rows[st->nrow];
          r->index = st->nrow;
          r->icase = c;
          r->imethod = m;
          r->seed = su->seeds[sd];
          r->isweep = su->nsweep ? w : -1;
          r->nodes = -1;
          r->ref_row = -1;
          r->same_mesh_as = -1;
          if (su->match_nodes) {
            if (m == su->reference)
              ref = st->nrow;
            else
              r->ref_row = ref;
          }
          char id[sizeof r->id];
          if (r->isweep >= 0)
            snprintf(id, sizeof id, "%s__%s__s%ld__%s=%s", su->cases[c].name,
                     su->methods[m].label, r->seed, su->sweep_key, su->sweep_values[w]);
          else
            snprintf(id, sizeof id, "%s__%s__s%ld", su->cases[c].name, su->methods[m].label,
                     r->seed);
          sanitize(id);
          /* Sanitizing may merge two ids ("a b" and "a_b"): number the later one. */
          int dup = 0;
          for (int q = 0; q < st->nrow && !dup; ++q) dup = strcmp(st->rows[q].id, id) == 0;
          if (dup)
            snprintf(r->id, sizeof r->id, "%.170s__%d", id, st->nrow);
          else
            snprintf(r->id, sizeof r->id, "%s", id);
          st->nrow++;
        }
      }
  free(order);
  return PM_OK;
}

void pm_cmp_study_clear(pm_cmp_study *st) {
  if (!st) return;
  for (int i = 0; i < st->nrow; ++i) pm_stats_flat_clear(&st->rows[i].flat);
  free(st->rows);
  pm_cmp_suite_clear(&st->suite);
  free(st->dir);
  free(st->exe);
  memset(st, 0, sizeof *st);
}

const char *pm_cmp_row_sweep(const pm_cmp_study *st, const pm_cmp_row *r) {
  return r->isweep >= 0 ? st->suite.sweep_values[r->isweep] : "";
}

void pm_cmp_row_title(const pm_cmp_study *st, const pm_cmp_row *r, char *buf, size_t len) {
  const pm_cmp_suite *s = &st->suite;
  if (r->isweep >= 0)
    snprintf(buf, len, "%s %s seed %ld %s=%s", s->cases[r->icase].name,
             s->methods[r->imethod].label, r->seed, s->sweep_key, s->sweep_values[r->isweep]);
  else
    snprintf(buf, len, "%s %s seed %ld", s->cases[r->icase].name, s->methods[r->imethod].label,
             r->seed);
}
