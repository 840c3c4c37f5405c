/* The built-in cases (see cases.h). */
#include "common/input/cases.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"

/* The planar cases; the solids come from geom_cad's table and are appended to form the one
 * registry (pm_cases). */
static const pm_case_info planar_table[] = {
    {"qi1", 2, "rectangle [-1,1] x [-2,2], uniform size", "0.1", "papers/004 section 3.1"},
    {"qi2", 2, "square [-1,1]^2 minus the disk of radius 0.2 at the origin, size growing with r",
     "r/8", "papers/004 section 3.2 (hole radius chosen: the paper does not give it)"},
    {"qi3", 2, "square [-3,3]^2, size smallest on the circle r = 2", "0.2*abs(r-2)+0.15",
     "papers/004 section 3.3 (712 nodes in the paper)"},
    {"qi4", 2, "unit disk minus the disk of radius 0.5 centred at (-0.4, 0)",
     "min(0.25-0.15*(r-1), min(0.05+0.08*(sqrt((x+0.4)^2+y^2)-0.5), "
     "((sqrt((x+0.4)^2+y^2)-0.5)-(r-1))/2))",
     "papers/004 section 3.4"},
    {"shimada", 2, "unit square [0,1]^2 with a sinusoidal size field", "0.04/(1.5+sin(3+4*x*y))",
     "papers/003 eq. 17 (about 1000 nodes)"},
};

#define NPLANAR ((int)(sizeof planar_table / sizeof planar_table[0]))
#define MAX_CASES 32

static pm_case_info all_cases[MAX_CASES];
static char solid_sizes[MAX_CASES][32];
static int ncases;
static pthread_once_t cases_once = PTHREAD_ONCE_INIT;

static void build_registry(void) {
  for (int i = 0; i < NPLANAR; ++i) all_cases[ncases++] = planar_table[i];
  int nsolid = 0;
  const pm_cad_case_info *solid = pm_cad_cases(&nsolid);
  for (int i = 0; i < nsolid && ncases < MAX_CASES; ++i, ++ncases) {
    snprintf(solid_sizes[ncases], sizeof solid_sizes[ncases], "%.6g", solid[i].size);
    all_cases[ncases] = (pm_case_info){solid[i].name, 3, solid[i].description,
                                       solid_sizes[ncases],
                                       "built in-process with gmsh's OpenCASCADE kernel"};
  }
}

const pm_case_info *pm_cases(int *n) {
  pthread_once(&cases_once, build_registry);
  *n = ncases;
  return all_cases;
}

const pm_case_info *pm_case_find(const char *name) {
  int n;
  const pm_case_info *t = pm_cases(&n);
  for (int i = 0; i < n; ++i)
    if (strcmp(t[i].name, name) == 0) return &t[i];
  return NULL;
}

/* Planar domains. */

static pm_status rectangle(const char *name, double x0, double y0, double x1, double y1,
                           const pm_planar_loop *holes, int nholes, pm_model **out, pm_error *err) {
  const pm_planar_piece outer[4] = {
      {PM_PIECE_LINE, {x0, y0}, {0, 0}, 0},
      {PM_PIECE_LINE, {x1, y0}, {0, 0}, 0},
      {PM_PIECE_LINE, {x1, y1}, {0, 0}, 0},
      {PM_PIECE_LINE, {x0, y1}, {0, 0}, 0},
  };
  pm_planar_loop loops[4] = {{4, outer}};
  for (int k = 0; k < nholes; ++k) loops[1 + k] = holes[k];
  return pm_planar_model(name, 1 + nholes, loops, out, err);
}

static pm_status circle_hole(const char *name, double cx, double cy, double R, double hx,
                             double hy, double hr, pm_model **out, pm_error *err) {
  const pm_planar_piece outer[1] = {{PM_PIECE_ARC, {cx + R, cy}, {cx, cy}, 1}};
  const pm_planar_piece hole[1] = {{PM_PIECE_ARC, {hx + hr, hy}, {hx, hy}, 0}};
  const pm_planar_loop loops[2] = {{1, outer}, {1, hole}};
  return pm_planar_model(name, 2, loops, out, err);
}

static pm_status build_planar(const char *name, pm_model **out, pm_error *err) {
  char full[64];
  snprintf(full, sizeof full, "case:%s", name);
  if (strcmp(name, "qi1") == 0) return rectangle(full, -1, -2, 1, 2, NULL, 0, out, err);
  if (strcmp(name, "qi2") == 0) {
    const pm_planar_piece hole[1] = {{PM_PIECE_ARC, {0.2, 0}, {0, 0}, 0}};
    const pm_planar_loop h = {1, hole};
    return rectangle(full, -1, -1, 1, 1, &h, 1, out, err);
  }
  if (strcmp(name, "qi3") == 0) return rectangle(full, -3, -3, 3, 3, NULL, 0, out, err);
  if (strcmp(name, "qi4") == 0) return circle_hole(full, 0, 0, 1, -0.4, 0, 0.5, out, err);
  if (strcmp(name, "shimada") == 0) return rectangle(full, 0, 0, 1, 1, NULL, 0, out, err);
  return pm_error_setf(err, PM_ERR_INTERNAL, "no builder for planar case '%s'", name);
}

pm_status pm_case_open(const char *name, pm_model **model, pm_sizing **size, pm_error *err) {
  *model = NULL;
  if (size) *size = NULL;
  const pm_case_info *ci = pm_case_find(name);
  if (!ci) {
    char known[512] = "";
    int n;
    const pm_case_info *t = pm_cases(&n);
    for (int i = 0; i < n; ++i) {
      strncat(known, i ? ", " : "", sizeof known - strlen(known) - 1);
      strncat(known, t[i].name, sizeof known - strlen(known) - 1);
    }
    return pm_error_setf(err, PM_ERR_ARG, "unknown case '%s' (known: %s)", name, known);
  }
  pm_status s = ci->dim == 2 ? build_planar(ci->name, model, err) : pm_cad_case(ci->name, model, err);
  if (s) return s;
  if (size) {
    s = pm_sizing_parse(ci->size, size, err);
    if (s) {
      pm_model_destroy(*model);
      *model = NULL;
      return pm_error_prefix(err, "case %s default size", name);
    }
  }
  return PM_OK;
}
