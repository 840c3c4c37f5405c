/* Parameter tables (see params.h). */
#include "common/base/params.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static void *field(void *params, const pm_param_desc *d) { return (char *)params + d->offset; }
static const void *cfield(const void *params, const pm_param_desc *d) {
  return (const char *)params + d->offset;
}

const pm_param_desc *pm_params_find(const pm_param_table *t, const char *key) {
  for (int i = 0; i < t->n; ++i)
    if (strcmp(t->desc[i].name, key) == 0) return &t->desc[i];
  return NULL;
}

void pm_params_defaults(const pm_param_table *t, void *params) {
  for (int i = 0; i < t->n; ++i) {
    const pm_param_desc *d = &t->desc[i];
    if (d->type == PM_PARAM_DOUBLE)
      *(double *)field(params, d) = d->def;
    else
      *(int *)field(params, d) = (int)d->def;
  }
}

double pm_params_get(const pm_param_desc *d, const void *params) {
  if (d->type == PM_PARAM_DOUBLE) return *(const double *)cfield(params, d);
  return (double)*(const int *)cfield(params, d);
}

void pm_params_format_range(const pm_param_desc *d, char *buf, size_t len) {
  if (d->type == PM_PARAM_BOOL) {
    snprintf(buf, len, "on|off");
    return;
  }
  if (d->type == PM_PARAM_CHOICE) {
    size_t used = 0;
    buf[0] = '\0';
    for (int k = 0; d->choices[k]; ++k)
      used += (size_t)snprintf(buf + used, used < len ? len - used : 0, "%s%s", k ? "|" : "",
                               d->choices[k]);
    return;
  }
  snprintf(buf, len, "%c%g, %g%c", (d->range_flags & PM_RANGE_LO_OPEN) ? '(' : '[', d->lo, d->hi,
           (d->range_flags & PM_RANGE_HI_OPEN) ? ')' : ']');
}

static int in_range(const pm_param_desc *d, double v) {
  if (d->type == PM_PARAM_BOOL) return v == 0 || v == 1;
  if (d->type == PM_PARAM_CHOICE) {
    int n = 0;
    while (d->choices[n]) ++n;
    return v >= 0 && v < n;
  }
  if (!isfinite(v) && !(isinf(v) && ((v > 0 && isinf(d->hi)) || (v < 0 && isinf(d->lo)))))
    return 0;
  if (v < d->lo || v > d->hi) return 0;
  if ((d->range_flags & PM_RANGE_LO_OPEN) && v == d->lo) return 0;
  if ((d->range_flags & PM_RANGE_HI_OPEN) && v == d->hi) return 0;
  return 1;
}

static pm_status range_error(const pm_param_table *t, const pm_param_desc *d, const char *value,
                             pm_error *err) {
  char r[160];
  pm_params_format_range(d, r, sizeof r);
  return pm_error_setf(err, PM_ERR_ARG, "%s parameter %s=%s is outside its allowed range %s",
                       t->owner, d->name, value, r);
}

pm_status pm_params_set(const pm_param_table *t, void *params, const char *key,
                        const char *value, pm_error *err) {
  const pm_param_desc *d = pm_params_find(t, key);
  if (!d)
    return pm_error_setf(err, PM_ERR_ARG, "unknown %s parameter '%s'",
                         t->owner, key);
  double v = 0;
  if (d->type == PM_PARAM_BOOL) {
    static const char *yes[] = {"1", "true", "on", "yes"}, *no[] = {"0", "false", "off", "no"};
    int found = 0;
    for (int k = 0; k < 4 && !found; ++k) {
      if (strcasecmp(value, yes[k]) == 0) v = 1, found = 1;
      else if (strcasecmp(value, no[k]) == 0) v = 0, found = 1;
    }
    if (!found)
      return pm_error_setf(err, PM_ERR_ARG, "%s parameter %s takes on/off, got '%s'", t->owner,
                           key, value);
  } else if (d->type == PM_PARAM_CHOICE) {
    int k = 0;
    while (d->choices[k] && strcasecmp(d->choices[k], value) != 0) ++k;
    if (!d->choices[k]) return range_error(t, d, value, err);
    v = k;
  } else {
    char *end = NULL;
    errno = 0;
    v = strtod(value, &end);
    if (end == value || *end != '\0' || errno == ERANGE || isnan(v))
      return pm_error_setf(err, PM_ERR_ARG, "%s parameter %s takes a number, got '%s'", t->owner,
                           key, value);
    if (d->type == PM_PARAM_INT && (v != floor(v) || fabs(v) > 2e9))
      return pm_error_setf(err, PM_ERR_ARG, "%s parameter %s takes a whole number, got '%s'",
                           t->owner, key, value);
    if (!in_range(d, v)) return range_error(t, d, value, err);
  }
  if (d->type == PM_PARAM_DOUBLE)
    *(double *)field(params, d) = v;
  else
    *(int *)field(params, d) = (int)v;
  return PM_OK;
}

pm_status pm_params_set_pair(const pm_param_table *t, void *params, const char *pair,
                             pm_error *err) {
  const char *eq = strchr(pair, '=');
  if (!eq || eq == pair || !eq[1])
    return pm_error_setf(err, PM_ERR_ARG, "--set takes KEY=VALUE, got '%s'", pair);
  char key[128];
  size_t n = (size_t)(eq - pair);
  if (n >= sizeof key) return pm_error_setf(err, PM_ERR_ARG, "parameter name too long: '%s'", pair);
  memcpy(key, pair, n);
  key[n] = '\0';
  return pm_params_set(t, params, key, eq + 1, err);
}

pm_status pm_params_check(const pm_param_table *t, const void *params, pm_error *err) {
  for (int i = 0; i < t->n; ++i) {
    const pm_param_desc *d = &t->desc[i];
    double v = pm_params_get(d, params);
    if (!in_range(d, v)) {
      char buf[64];
      pm_params_format(d, params, buf, sizeof buf);
      return range_error(t, d, buf, err);
    }
  }
  return PM_OK;
}

void pm_params_format(const pm_param_desc *d, const void *params, char *buf, size_t len) {
  double v = pm_params_get(d, params);
  if (d->type == PM_PARAM_BOOL)
    snprintf(buf, len, "%s", v != 0 ? "on" : "off");
  else if (d->type == PM_PARAM_CHOICE) {
    int n = 0;
    while (d->choices[n]) ++n;
    int k = (int)v;
    snprintf(buf, len, "%s", (k >= 0 && k < n) ? d->choices[k] : "?");
  } else
    snprintf(buf, len, "%.10g", v);
}

void pm_params_help(const pm_param_table *t, FILE *out) {
  fprintf(out, "%s parameters (--set KEY=VALUE):\n", t->owner);
  fprintf(out, "  %-18s %-10s %-22s %-8s %s\n", "KEY", "DEFAULT", "RANGE", "UNIT",
          "MEANING [SOURCE]");
  for (int i = 0; i < t->n; ++i) {
    const pm_param_desc *d = &t->desc[i];
    char def[64], range[160];
    if (d->type == PM_PARAM_BOOL)
      snprintf(def, sizeof def, "%s", d->def != 0 ? "on" : "off");
    else if (d->type == PM_PARAM_CHOICE)
      snprintf(def, sizeof def, "%s", d->choices[(int)d->def]);
    else
      snprintf(def, sizeof def, "%g", d->def);
    pm_params_format_range(d, range, sizeof range);
    fprintf(out, "  %-18s %-10s %-22s %-8s %s [%s]\n", d->name, def, range,
            d->unit && d->unit[0] ? d->unit : "-", d->doc, d->source ? d->source : "");
  }
}
