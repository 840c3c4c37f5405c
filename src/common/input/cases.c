/* The built-in cases (see cases.h): one table, the planar domains of the papers and the solids
 * built in-process with gmsh's OpenCASCADE kernel, with the builder of each.
 *
 * Solid default sizes: about 1/15 .. 1/20 of the bounding-box diagonal, rounded, and small enough
 * to resolve the smallest feature with several elements (the torus tube's circumference 2.2 with
 * 11 edges, the hole's 1.57 with 12, the box's thickness 0.6 with 5).
 */
#include "common/input/cases.h"

#include <gmshc.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"

#define OCC_SOURCE "built in-process with gmsh's OpenCASCADE kernel"

static const pm_case_info table[] = {
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
    /* diagonal 2 sqrt(3) = 3.46: size = diagonal / 17.3 */
    {"sphere", 3, "solid unit sphere at the origin (one face with a seam and two poles)", "0.2",
     OCC_SOURCE},
    /* diagonal sqrt(2 * 2.7^2 + 0.7^2) = 3.88: diagonal / 19.4 */
    {"torus", 3, "solid torus about the z axis, R = 1, r = 0.35 (doubly periodic face)", "0.2",
     OCC_SOURCE},
    /* diagonal sqrt(1 + 1 + 4) = 2.45: diagonal / 16.3 */
    {"cylinder", 3, "solid cylinder of radius 0.5, z from -1 to 1 (seam, two disks)", "0.15",
     OCC_SOURCE},
    /* diagonal sqrt(4 + 1 + 0.36) = 2.32: diagonal / 18.5 */
    {"boxhole", 3,
     "box 2 x 1 x 0.6 centred at the origin with a hole of radius 0.25 through its thickness",
     "0.125", OCC_SOURCE},
    /* diagonal sqrt(3) = 1.73: diagonal / 17.3 */
    {"nonmanifold", 3,
     "unit cube with an internal triangle hanging from an edge and a dangling segment (papers/003 "
     "Fig. 11 analogue)",
     "0.1", OCC_SOURCE},
};
#define NCASES ((int)(sizeof table / sizeof table[0]))

const pm_case_info *pm_cases(int *n) {
  if (n) *n = NCASES;
  return table;
}

const pm_case_info *pm_case_find(const char *name) {
  for (int i = 0; i < NCASES; ++i)
    if (name && strcmp(table[i].name, name) == 0) return &table[i];
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
  return pm_cad_occ_cut_volumes(box, cyl);
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

/* The solids' shape makers, by name. */
static int (*solid_maker(const char *name))(void) {
  static const struct {
    const char *name;
    int (*make)(void);
  } makers[] = {{"sphere", make_sphere},   {"torus", make_torus},
                {"cylinder", make_cylinder}, {"boxhole", make_boxhole},
                {"nonmanifold", make_nonmanifold}};
  for (size_t i = 0; i < sizeof makers / sizeof makers[0]; ++i)
    if (strcmp(makers[i].name, name) == 0) return makers[i].make;
  return NULL;
}

static pm_status build_solid(const char *name, pm_model **out, pm_error *err) {
  int (*make)(void) = solid_maker(name);
  if (!make) return pm_error_setf(err, PM_ERR_INTERNAL, "no builder for solid case '%s'", name);
  char label[64];
  snprintf(label, sizeof label, "case:%s", name);
  pm_status s = pm_cad_build_shapes(label, make, out, err);
  return s ? pm_error_prefix(err, "case %s", name) : PM_OK;
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
  pm_status s = ci->dim == 2 ? build_planar(ci->name, model, err) : build_solid(ci->name, model, err);
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
