/* The built-in cases (DESIGN.md, "Built-in cases"): named models with a default size field,
 * needing no file. Planar domains come from geom_analytic (papers/004 section 3, papers/003
 * eq. 17); solids and surfaces are built in-process with gmsh's OpenCASCADE kernel (geom_cad).
 */
#ifndef PM_CASES_H
#define PM_CASES_H

#include "common/geom/geom.h"
#include "common/sizing/sizing.h"

typedef struct pm_case_info {
  const char *name;        /* what `case:NAME` names */
  int dim;                 /* 2: planar domain; 3: a solid or surface model */
  const char *description; /* one line */
  const char *size;        /* default edge length: a NUMBER or an EXPR in x, y, z, r */
  const char *source;      /* where the case comes from */
} pm_case_info;

/* The table of cases; *n receives its length. Static storage. */
const pm_case_info *pm_cases(int *n);

/* The case named `name` (without the "case:" prefix), or NULL. */
const pm_case_info *pm_case_find(const char *name);

/* Build the case's model and, when size is not NULL, its default size field. An unknown name is
 * PM_ERR_ARG listing the known ones. */
pm_status pm_case_open(const char *name, pm_model **model, pm_sizing **size, pm_error *err);

#endif /* PM_CASES_H */
