/* The meshers the library knows, and their parameter sets (packmesh.h, "methods and their
 * parameters"). */
#include <packmesh/packmesh.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api/api.h"
#include "bubble/bubble.h"
#include "peers/peers.h"
#include "psys/psys.h"

/* In the order `packmesh mesh --help` lists them: ours first, then the classic peers. `traces`:
 * the method reports its iterations to the observer (method.h: trace rows, frames); the peers run
 * to completion inside their libraries and report none, so --trace and --frames are refused for
 * them rather than written empty. */
static const struct {
  const pm_method *method;
  int traces;
} methods[] = {
    {&bub_method, 1},
    {&psys_method, 1},
    {&peer_gmsh_frontal, 0},
    {&peer_gmsh_delaunay, 0},
    {&peer_gmsh_meshadapt, 0},
    {&peer_cgal, 0},
};

static int count(void) { return (int)(sizeof methods / sizeof methods[0]); }

int pm_method_count(void) { return count(); }

const pm_method *pm_method_at(int i) { return i >= 0 && i < count() ? methods[i].method : NULL; }

int pm_method_traces(const pm_method *m) {
  for (int i = 0; i < count(); ++i)
    if (methods[i].method == m) return methods[i].traces;
  return 0;
}

const pm_method *pm_method_find(const char *name) {
  for (int i = 0; name && i < count(); ++i)
    if (strcmp(methods[i].method->name, name) == 0) return methods[i].method;
  return NULL;
}

void pm_method_names(char *buf, size_t len) {
  buf[0] = '\0';
  for (int i = 0; i < count(); ++i) {
    strncat(buf, i ? ", " : "", len - strlen(buf) - 1);
    strncat(buf, methods[i].method->name, len - strlen(buf) - 1);
  }
}

void pm_method_help(const pm_method *m, FILE *f) {
  if (m && m->params)
    pm_params_help(m->params, f);
  else
    fprintf(f, "(no parameters)\n");
}

const char *pm_method_name(const pm_method *m) { return m ? m->name : NULL; }
const char *pm_method_description(const pm_method *m) { return m ? m->description : NULL; }
int pm_method_planar_only(const pm_method *m) { return m ? m->planar_only : 0; }

/* ---- parameters --------------------------------------------------------------------------- */

int pm_method_param_count(const pm_method *m) { return m && m->params ? m->params->n : 0; }

pm_status pm_method_param_info(const pm_method *m, int i, pm_param_info *out, pm_error *err) {
  if (!m || !out) return pm_error_setf(err, PM_ERR_ARG, "pm_method_param_info: no method");
  if (i < 0 || i >= pm_method_param_count(m))
    return pm_error_setf(err, PM_ERR_ARG, "method %s has %d parameters, no parameter %d", m->name,
                         pm_method_param_count(m), i);
  const pm_param_desc *d = &m->params->desc[i];
  memset(out, 0, sizeof *out);
  out->key = d->name;
  out->unit = d->unit;
  out->doc = d->doc;
  out->source = d->source;
  /* The default as text, through the same formatter as --help: from a struct at its defaults. */
  void *def = calloc(1, m->params_size ? m->params_size : 1);
  if (!def) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  m->params_init(def);
  pm_params_format(d, def, out->default_value, sizeof out->default_value);
  free(def);
  pm_params_format_range(d, out->range, sizeof out->range);
  return PM_OK;
}

struct pm_method_params {
  const pm_method *method;
  void *values; /* the method's parameter struct, params_size bytes */
};

pm_status pm_method_params_create(const pm_method *m, pm_method_params **out, pm_error *err) {
  *out = NULL;
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_method_params_create: no method");
  pm_method_params *p = calloc(1, sizeof *p);
  if (p) p->values = calloc(1, m->params_size ? m->params_size : 1);
  if (!p || !p->values) {
    pm_method_params_destroy(p);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  p->method = m;
  if (m->params_init) m->params_init(p->values);
  *out = p;
  return PM_OK;
}

pm_status pm_method_params_set(pm_method_params *p, const char *key, const char *value,
                               pm_error *err) {
  if (!p || !key || !value) return pm_error_setf(err, PM_ERR_ARG, "pm_method_params_set: no %s",
                                                 !p ? "parameter set" : !key ? "key" : "value");
  if (!p->method->params)
    return pm_error_setf(err, PM_ERR_ARG, "method %s has no parameters (got '%s')",
                         p->method->name, key);
  return pm_params_set(p->method->params, p->values, key, value, err);
}

pm_status pm_method_params_check(const pm_method_params *p, pm_error *err) {
  if (!p) return pm_error_setf(err, PM_ERR_ARG, "pm_method_params_check: no parameter set");
  return p->method->params ? pm_params_check(p->method->params, p->values, err) : PM_OK;
}

pm_status pm_method_params_set_pair(pm_method_params *p, const char *pair, pm_error *err) {
  if (!p || !pair) return pm_error_setf(err, PM_ERR_ARG, "pm_method_params_set_pair: no %s",
                                        p ? "KEY=VALUE" : "parameter set");
  if (!p->method->params)
    return pm_error_setf(err, PM_ERR_ARG, "method %s has no parameters (got --set %s)",
                         p->method->name, pair);
  return pm_params_set_pair(p->method->params, p->values, pair, err);
}

pm_status pm_method_params_get(const pm_method_params *p, const char *key, char *buf, size_t len,
                               pm_error *err) {
  if (!p || !key || !buf || len == 0)
    return pm_error_setf(err, PM_ERR_ARG, "pm_method_params_get: bad argument");
  const pm_param_desc *d = p->method->params ? pm_params_find(p->method->params, key) : NULL;
  if (!d)
    return pm_error_setf(err, PM_ERR_ARG, "method %s has no parameter '%s'", p->method->name,
                         key);
  pm_params_format(d, p->values, buf, len);
  return PM_OK;
}

void pm_method_params_destroy(pm_method_params *p) {
  if (!p) return;
  free(p->values);
  free(p);
}

const pm_method *pm_method_params_method(const pm_method_params *p) {
  return p ? p->method : NULL;
}

const void *pm_method_params_values(const pm_method_params *p) { return p ? p->values : NULL; }
