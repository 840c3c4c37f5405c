/* The built-in solid cases (DESIGN.md, "Built-in cases"), built in-process with gmsh's
 * OpenCASCADE kernel and loaded like a CAD file (see geom_cad.h for the shapes and counts).
 *
 * Default sizes: about 1/15 .. 1/20 of the bounding-box diagonal, rounded, and small enough to
 * resolve the smallest feature with several elements (the torus tube's circumference 2.2 with 11
 * edges, the hole's 1.57 with 12, the box's thickness 0.6 with 5).
 */
#include <gmshc.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/geom/geom_cad.h"
#include "common/geom/geom_cad_private.h"
#include "common/backends/gmsh_session.h"

static const pm_cad_case_info cad_cases[] = {
    /* diagonal 2 sqrt(3) = 3.46: size = diagonal / 17.3 */
    {"sphere", "solid unit sphere at the origin (one face with a seam and two poles)", 0.2},
    /* diagonal sqrt(2 * 2.7^2 + 0.7^2) = 3.88: diagonal / 19.4 */
    {"torus", "solid torus about the z axis, R = 1, r = 0.35 (doubly periodic face)", 0.2},
    /* diagonal sqrt(1 + 1 + 4) = 2.45: diagonal / 16.3 */
    {"cylinder", "solid cylinder of radius 0.5, z from -1 to 1 (seam, two disks)", 0.15},
    /* diagonal sqrt(4 + 1 + 0.36) = 2.32: diagonal / 18.5 */
    {"boxhole",
     "box 2 x 1 x 0.6 centred at the origin with a hole of radius 0.25 through its thickness",
     0.125},
    /* diagonal sqrt(3) = 1.73: diagonal / 17.3 */
    {"nonmanifold",
     "unit cube with an internal triangle hanging from an edge and a dangling segment (papers/003 "
     "Fig. 11 analogue)",
     0.1},
};
#define NCASES ((int)(sizeof cad_cases / sizeof cad_cases[0]))

static const char *const case_names[NCASES + 1] = {"sphere",  "torus",       "cylinder",
                                                   "boxhole", "nonmanifold", NULL};

const pm_cad_case_info *pm_cad_cases(int *n) {
  if (n) *n = NCASES;
  return cad_cases;
}

const char *const *pm_cad_case_names(void) { return case_names; }

/* Shapes, in the current gmsh model. Each returns gmsh's ierr (0 on success). */

static int make_sphere(void) {
  int ierr = 0;
  gmshModelOccAddSphere(0, 0, 0, 1, -1, -M_PI / 2, M_PI / 2, 2 * M_PI, &ierr);
  return ierr;
}

static int make_torus(void) {
  int ierr = 0;
  gmshModelOccAddTorus(0, 0, 0, 1, 0.35, -1, 2 * M_PI, &ierr);
  return ierr;
}

static int make_cylinder(void) {
  int ierr = 0;
  gmshModelOccAddCylinder(0, 0, -1, 0, 0, 2, 0.5, -1, 2 * M_PI, &ierr);
  return ierr;
}

static int make_boxhole(void) {
  int ierr = 0;
  int box = gmshModelOccAddBox(-1, -0.5, -0.3, 2, 1, 0.6, -1, &ierr);
  if (ierr) return ierr;
  /* The tool overshoots both faces so that the cut does not meet coplanar faces. */
  int cyl = gmshModelOccAddCylinder(0, 0, -0.5, 0, 0, 1, 0.25, -1, 2 * M_PI, &ierr);
  if (ierr) return ierr;
  int obj[2] = {3, box}, tool[2] = {3, cyl};
  int *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  gmshModelOccCut(obj, 2, tool, 2, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  if (out) gmshFree(out);
  for (size_t i = 0; i < nnmap; ++i) gmshFree(map[i]);
  if (map) gmshFree(map);
  if (nmap) gmshFree(nmap);
  return ierr;
}

static int make_nonmanifold(void) {
  int ierr = 0, e = 0;
  int box = gmshModelOccAddBox(0, 0, 0, 1, 1, 1, -1, &ierr);
  e |= ierr;
  int p1 = gmshModelOccAddPoint(0, 0, 0, 0, -1, &ierr);
  e |= ierr;
  int p2 = gmshModelOccAddPoint(0, 0, 1, 0, -1, &ierr);
  e |= ierr;
  int p3 = gmshModelOccAddPoint(0.5, 0.5, 0.5, 0, -1, &ierr);
  e |= ierr;
  int p4 = gmshModelOccAddPoint(0.8, 0.6, 0.5, 0, -1, &ierr);
  e |= ierr;
  int l1 = gmshModelOccAddLine(p1, p2, -1, &ierr);
  e |= ierr;
  int l2 = gmshModelOccAddLine(p2, p3, -1, &ierr);
  e |= ierr;
  int l3 = gmshModelOccAddLine(p3, p1, -1, &ierr);
  e |= ierr;
  int l4 = gmshModelOccAddLine(p3, p4, -1, &ierr);
  e |= ierr;
  if (e) return e;
  int lines[3] = {l1, l2, l3};
  int loop = gmshModelOccAddCurveLoop(lines, 3, -1, &ierr);
  if (ierr) return ierr;
  int tri = gmshModelOccAddPlaneSurface(&loop, 1, -1, &ierr);
  if (ierr) return ierr;
  /* Fragment: the triangle and the segment become part of the volume's topology, sharing the
   * cube edge x = y = 0 and the vertex (0.5, 0.5, 0.5). */
  int obj[2] = {3, box}, tool[4] = {2, tri, 1, l4};
  int *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  gmshModelOccFragment(obj, 2, tool, 4, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  if (out) gmshFree(out);
  for (size_t i = 0; i < nnmap; ++i) gmshFree(map[i]);
  if (map) gmshFree(map);
  if (nmap) gmshFree(nmap);
  return ierr;
}

pm_status pm_cad_case(const char *name, pm_model **out, pm_error *err) {
  *out = NULL;
  int which = -1;
  for (int i = 0; i < NCASES; ++i)
    if (name && strcmp(name, cad_cases[i].name) == 0) which = i;
  if (which < 0) {
    char known[256] = "";
    for (int i = 0; i < NCASES; ++i) {
      strncat(known, i ? ", " : "", sizeof known - strlen(known) - 1);
      strncat(known, cad_cases[i].name, sizeof known - strlen(known) - 1);
    }
    return pm_error_setf(err, PM_ERR_ARG, "unknown solid case '%s' (known: %s)", name ? name : "",
                         known);
  }
  pm_status s = pm_gmsh_begin(err);
  if (s) return s;
  pm_gmsh_lock();
  pm_gmsh_scope scope;
  char gname[64];
  s = cad_new_gmsh_model(gname, &scope, err);
  if (s) {
    pm_gmsh_unlock();
    return s;
  }
  int (*make[NCASES])(void) = {make_sphere, make_torus, make_cylinder, make_boxhole,
                               make_nonmanifold};
  int ierr = make[which]();
  if (!ierr) gmshModelOccSynchronize(&ierr);
  if (ierr) {
    s = pm_gmsh_error(err, PM_ERR_BACKEND, "building the shape");
    pm_gmsh_scope_leave(&scope, 1);
    pm_gmsh_unlock();
    return pm_error_prefix(err, "case %s", name);
  }
  char label[64];
  snprintf(label, sizeof label, "case:%s", name);
  pm_model *m = NULL;
  s = cad_build(gname, label, &m, err);
  pm_gmsh_scope_leave(&scope, 0);
  pm_gmsh_unlock();
  if (s) return pm_error_prefix(err, "case %s", name);
  *out = m;
  return PM_OK;
}
