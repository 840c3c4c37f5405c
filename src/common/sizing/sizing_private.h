/* Internals shared by the sizing files: the field record and the per-kind entry points.
 * sizing.c holds the generic parts (constant, callback, scaled, parse, describe, check),
 * sizing_expr.c the muparser expressions, sizing_sampled.c the fields sampled on a mesh,
 * sizing_features.c the fields a model's features ask for. */
#ifndef PM_SIZING_PRIVATE_H
#define PM_SIZING_PRIVATE_H

#include <stdatomic.h>

#include "common/sizing/sizing.h"

typedef enum sz_kind { SZ_CONSTANT, SZ_EXPR, SZ_CALLBACK, SZ_SAMPLED, SZ_SCALED, SZ_FEATURES } sz_kind;

typedef struct sz_expr sz_expr;       /* sizing_expr.c */
typedef struct sz_sampled sz_sampled; /* sizing_sampled.c */

struct pm_sizing {
  sz_kind kind;
  atomic_int refs;        /* 1 + the scaled fields that share this one */
  char *desc;             /* owned: what pm_sizing_describe returns */
  double value;           /* SZ_CONSTANT: d; SZ_SCALED: the factor */
  pm_sizing_fn fn;        /* SZ_CALLBACK */
  void *user;             /* SZ_CALLBACK, borrowed */
  pm_sizing *base;        /* SZ_SCALED, SZ_FEATURES: the shared field (one reference held;
                             may be NULL for SZ_FEATURES) */
  struct pm_feature_size *features; /* SZ_FEATURES, owned (sizing_features.c) */
  sz_expr *expr;          /* SZ_EXPR, owned */
  sz_sampled *sampled;    /* SZ_SAMPLED, owned */
};

/* A zeroed record of the given kind with one reference; NULL when out of memory. */
pm_sizing *pm_sizing_alloc(sz_kind kind);

/* Parse and probe `text`; *out receives the expression data and *desc its canonical text
 * (trimmed, owned by the caller). */
pm_status sz_expr_create(const char *text, sz_expr **out, char **desc, pm_error *err);
double sz_expr_eval(sz_expr *e, const double xyz[3]);
void sz_expr_destroy(sz_expr *e);

pm_status sz_sampled_create(const pm_mesh *samples, const double *values, sz_sampled **out,
                            pm_error *err);
double sz_sampled_eval(const sz_sampled *s, const double xyz[3]);
void sz_sampled_destroy(sz_sampled *s);

/* min(base, the features) of an SZ_FEATURES field (sizing_features.c). */
double sz_features_eval(const pm_sizing *s, const double xyz[3]);

/* The shortest "%.Ng" text (N = 15..17) that reads back as exactly v. buf >= 32 chars. */
void sz_format_double(double v, char *buf, size_t len);

#endif /* PM_SIZING_PRIVATE_H */
