/* Internals of the geom_cad backend shared by geom_cad*.c (not part of any interface):
 * the per-cell data, the closed forms of the fast paths, and the guard that makes a CAD model's
 * gmsh model current for the duration of a gmsh call.
 */
#ifndef PM_GEOM_CAD_PRIVATE_H
#define PM_GEOM_CAD_PRIVATE_H

#include <stdatomic.h>

#include "common/geom/geom.h"
#include "common/backends/gmsh_session.h"

/* Closed forms, in OpenCASCADE's parametrizations (gp_Pln, gp_Cylinder, gp_Cone, gp_Sphere,
 * gp_Torus, gp_Lin, gp_Circ, gp_Elips); e(u) = cos u X + sin u Y:
 *   plane     S = O + u X + v Y
 *   cylinder  S = O + r e(u) + v Z
 *   cone      S = O + (r + v sin a) e(u) + v cos a Z        (a: the semi-angle)
 *   sphere    S = O + r cos v e(u) + r sin v Z
 *   torus     S = O + (r + r2 cos v) e(u) + r2 sin v Z
 *   line      C = O + t X
 *   circle    C = O + r e(t)
 *   ellipse   C = O + r cos t X + r2 sin t Y
 *   point     C = O (a degenerate curve: a pole or an apex) */
typedef enum cad_kind {
  CAD_GMSH = 0, /* no closed form: gmsh evaluates */
  CAD_PLANE,
  CAD_CYLINDER,
  CAD_CONE,
  CAD_SPHERE,
  CAD_TORUS,
  CAD_LINE,
  CAD_CIRCLE,
  CAD_ELLIPSE,
  CAD_POINT
} cad_kind;

typedef struct cad_form {
  cad_kind kind;
  double o[3], x[3], y[3], z[3]; /* origin and axes (X, Y, Z need not be right-handed) */
  double r, r2;                  /* radii as in the table above */
  double sa, ca;                 /* cone: sin and cos of the semi-angle */
} cad_form;

typedef struct cad_model cad_model;

typedef struct cad_cell {
  cad_model *cm;      /* borrowed: the model's backend data */
  cad_form form;      /* the closed form, or kind CAD_GMSH */
  double fallback[3]; /* the point a failed evaluation returns */
  /* A degenerate curve added where the file has none (geom_cad_build.c, synth): no gmsh
   * entity; its only pcurve, on face synth_face, runs from synth_uv[0..1] at t = 0 to
   * synth_uv[2..3] at t = 1. */
  int synthetic;
  int32_t synth_face;
  double synth_uv[4];
  /* gmsh-evaluated cells: the cell's points at a regular grid of its parameter box
   * (gn[0] x gn[1] for faces, u fastest; gn[0] for curves), owned: projection starts from the
   * nearest of them instead of calling gmshModelGetParametrization (see cad_build_grids). */
  double *grid;
  int32_t gn[2];
  /* Faces: the boundary-curve uses whose pcurve strays from the curve (cad_check_pcurves), as
   * keys 2 x curve index + side, owned; their (u, v) are the curve's points projected onto the
   * surface from the pcurve's. */
  int32_t *reproj;
  int32_t nreproj;
} cad_cell;

struct cad_model {
  char gname[64];       /* the gmsh model that holds the shapes */
  cad_cell *cells[4];   /* [count[d]] owned, parallel to the pm_model's cells */
  atomic_long failures; /* gmsh evaluations replaced by the fallback output */
  int32_t reprojected;  /* boundary-curve uses marked by cad_check_pcurves */
  double reproj_worst;  /* the largest distance of their pcurves from their curves */
};

/* Lock gmsh and make cm's gmsh model current, remembering the previous current model. Returns 0,
 * or -1 when cm's gmsh model no longer exists (then no gmsh call may be made). cad_leave()
 * restores the previous model and unlocks, in both cases. */
typedef struct cad_guard {
  char previous[256];
  int switched;
} cad_guard;
int cad_enter(const cad_model *cm, cad_guard *g);
void cad_leave(cad_guard *g);

/* Evaluation classes: one per type name; the functions dispatch on the cell's form. */
const pm_cell_class *cad_class(int dim, const char *name);

/* gmsh evaluation of n parameters of a curve (t[n]) or a face (uv[2n]), with cm's model made
 * current by the caller (inside cad_enter/cad_leave). Return 0 on success, -1 when gmsh failed or
 * gave a non-finite value (the outputs are then unspecified). A curve's second derivative is a
 * central difference of first derivatives with a step relative to `span` (its parameter range). */
int cad_gmsh_curve(int tag, int32_t n, const double *t, int order, double span,
                   pm_curve_point *out);
int cad_gmsh_face(int tag, int32_t n, const double *uv, int order, pm_face_point *out);

/* Closed forms (geom_cad_fast.c). */
void cad_form_curve(const cad_form *f, double t, int order, pm_curve_point *out);
void cad_form_face(const cad_form *f, const double uv[2], int order, pm_face_point *out);
/* Closest point parameter on the untrimmed surface / the curve; periodic angles are taken
 * nearest to `ref` (a guess, or the centre of the cell's parameter box). Returns 0 on success,
 * -1 when the form has no closed-form projection. */
int cad_form_project(const cad_form *f, const double xyz[3], const double *ref, double *par);

/* Fit a closed form to cell c (its lo/hi set; cm's gmsh model current) whose gmsh type is
 * `gtype`, and check it against gmsh at 20 random parameters in the box with positions and first
 * derivatives within 1e-9 x diag. Returns 1 and fills *out when a form passed, else 0. */
int cad_fit(const pm_cell *c, const char *gtype, double diag, cad_form *out);

/* The name of a closed form's type, for the evaluation class ("cylinder", ...). */
const char *cad_form_name(cad_kind k);

/* Build the pm_model from the gmsh model `gname` (current and synchronized; gmsh locked by the
 * caller); `label` names the model (a file name or "case:NAME"). The model owns the gmsh model
 * from the start: on failure it has been released and the gmsh model removed. */
pm_status cad_build(const char *gname, const char *label, pm_model **out, pm_error *err);

/* Give model m (allocated, cells not yet filled) its backend data: the gmsh model name, the
 * per-cell cad_cell array (cell->impl) and the release function that removes the gmsh model. */
pm_status cad_attach(pm_model *m, const char *gname, pm_error *err);

/* Sample the projection grids of the gmsh-evaluated faces and curves of m. */
pm_status cad_build_grids(pm_model *m, pm_error *err);

/* Mark the boundary-curve uses of m's faces whose pcurve strays from the curve by more than tol
 * in 3D where the curve itself lies on the surface (see geom_cad_eval.c); counts them in the
 * cad_model. Runs before the trimming polylines are made (pm_model_finish). */
pm_status cad_check_pcurves(pm_model *m, double tol, pm_error *err);

/* Create a fresh uniquely named gmsh model ("pm_cad_<n>") and make it current inside `scope`
 * (gmsh locked by the caller). */
pm_status cad_new_gmsh_model(char name[64], pm_gmsh_scope *scope, pm_error *err);

#endif /* PM_GEOM_CAD_PRIVATE_H */
