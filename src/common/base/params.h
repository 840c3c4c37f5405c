/* Parameter tables: one description per method parameter drives its default, `--set KEY=VALUE`,
 * `--help` and the range check, so none of them is written twice.
 *
 * A method keeps its parameters in a plain struct (bub_params, psys_params) and describes each
 * field once in a static pm_param_desc array: name, type, offset in the struct, default,
 * allowed range, unit, meaning and the paper/equation it comes from.
 */
#ifndef PM_PARAMS_H
#define PM_PARAMS_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdio.h>

typedef enum pm_param_type {
  PM_PARAM_DOUBLE, /* field is a double */
  PM_PARAM_INT,    /* field is an int; the value must be a whole number */
  PM_PARAM_BOOL,   /* field is an int 0/1; accepts 0/1/true/false/on/off/yes/no */
  PM_PARAM_CHOICE  /* field is an int index into `choices`; accepts the choice's name */
} pm_param_type;

/* Range flags: which ends of [lo, hi] are excluded. */
enum { PM_RANGE_CLOSED = 0, PM_RANGE_LO_OPEN = 1, PM_RANGE_HI_OPEN = 2 };

typedef struct pm_param_desc {
  const char *name;     /* the --set key, e.g. "k0" */
  pm_param_type type;
  size_t offset;        /* offsetof(struct, field) */
  double def;           /* default (choices: index) */
  double lo, hi;        /* allowed range (ignored for BOOL and CHOICE) */
  int range_flags;      /* PM_RANGE_* */
  const char *unit;     /* "" when dimensionless */
  const char *doc;      /* one line: meaning */
  const char *source;   /* paper and equation, e.g. "003 eq. 13, 000 sec. 6.4" */
  const char *const *choices; /* NULL-terminated names for PM_PARAM_CHOICE, else NULL */
} pm_param_desc;

typedef struct pm_param_table {
  const char *owner;          /* "bubble", "psys", ... (used in messages) */
  const pm_param_desc *desc;  /* borrowed, static */
  int n;
} pm_param_table;

/* Write every default into params. */
void pm_params_defaults(const pm_param_table *t, void *params);

/* Parse one "value" for key into params. Unknown key, malformed value and out-of-range value
 * are PM_ERR_ARG with a message naming the key and the allowed range. */
pm_status pm_params_set(const pm_param_table *t, void *params, const char *key,
                        const char *value, pm_error *err);

/* Parse "KEY=VALUE". */
pm_status pm_params_set_pair(const pm_param_table *t, void *params, const char *pair,
                             pm_error *err);

/* Check every field against its range. */
pm_status pm_params_check(const pm_param_table *t, const void *params, pm_error *err);

/* Find a description by name; NULL when unknown. */
const pm_param_desc *pm_params_find(const pm_param_table *t, const char *key);

/* Read a field as a double (int/bool/choice converted). */
double pm_params_get(const pm_param_desc *d, const void *params);

/* Format the field's current value ("30", "0.7", "on", "rk4") into buf. */
void pm_params_format(const pm_param_desc *d, const void *params, char *buf, size_t len);

/* Format the values the parameter takes ("[0.5, 2]", "(0, 1]", "on|off", "eigen|lloyd") into
 * buf. */
void pm_params_format_range(const pm_param_desc *d, char *buf, size_t len);

/* Write the help table (name, default, range, unit, meaning, source) to out. */
void pm_params_help(const pm_param_table *t, FILE *out);

#endif /* PM_PARAMS_H */
