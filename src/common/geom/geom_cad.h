/* CAD models (STEP, IGES, OCCT BREP) and the built-in solid cases, through gmsh's C API with
 * its OpenCASCADE kernel: the `geom_cad` backend of the geometry interface (geom.h).
 *
 * A loaded model is the cell complex of the file's B-rep (papers/003 section 2.1): gmsh's points,
 * curves, surfaces and volumes become cells of dimension 0..3, indexed per dimension in order of
 * increasing gmsh tag (cell->tag is the gmsh tag). What gmsh 4.8.4 gets wrong or does not give
 * is rebuilt here (see /work/shared/cad/GMSH_API.md):
 *   - trimming loops: rebuilt from the curves' pcurve end points in (u, v), not from
 *     gmshModelGetBoundary's flat list; loops that touch at a vertex are split there; the two
 *     uses of a seam get the pcurve (`side`) that joins its neighbours;
 *   - periodicity: from seam curves (a curve used twice in one face, whose two pcurves differ by
 *     the period), checked by evaluation along the seam, S(lo + P, v) = S(lo, v);
 *   - volume orientation: the sense of each bounding face from gmshModelGetNormal (outward on a
 *     solid) for faces of one volume, and from the edge directions of the neighbouring faces for
 *     faces shared by two volumes (gmsh's oriented boundary signs are all +1 there);
 *   - embedded cells (internal faces, dangling curves and points) from gmshModelMeshGetEmbedded;
 *   - poles the file does not model: where a loop returns to one vertex at two (u, v) along a
 *     singular side of the surface (IGES sewing drops degenerate edges: bearing.iges), a
 *     degenerate curve is added whose only pcurve is that segment. Such curves follow gmsh's in
 *     the curve list, with tags above gmsh's largest curve tag, and no gmsh entity behind them.
 *
 * Evaluation. Faces of type plane, cylinder, cone, sphere and torus and curves of type line,
 * circle and ellipse (and degenerate curves: a point) are evaluated in closed form: their
 * OpenCASCADE parametrization (origin, axes, radii) is fitted from a few gmsh evaluations and
 * then checked against gmsh at 20 random parameters (positions and first derivatives within
 * 1e-9 of the model diagonal); a cell that fails the check stays on gmsh. Cells of other types
 * (B-splines, surfaces of revolution, gmsh's "Unknown") are tried against every form, so that a
 * revolved line or a bilinear planar patch gets the fast path too. The rest is evaluated by
 * gmsh, batched in pm_face_eval_many; a gmsh curve's C'' is a central difference of gmsh's exact
 * C' (gmsh's own is a one-sided difference with error ~5e-4 of the scale). A failed
 * gmsh evaluation (gmsh's ierr, or a non-finite value) never aborts: it returns the cell's
 * fallback point (the image of the centre of its parameter box) with zero derivatives, and is
 * counted (pm_cad_eval_failures).
 *
 * Projection (pm_cell_class.project, refined by geom.c's Newton iteration): closed forms project
 * in closed form (atan2 for the angles); gmsh-evaluated cells start from the nearest point of a
 * grid of 25 x 25 (faces) or 65 (curves) samples taken at load, or from the caller's guess when
 * its point is nearer. gmshModelGetParametrization (180-240 us per point on the shared B-spline
 * faces) is the fallback only; gmshModelGetClosestPoint is never used (its (u, v) is always
 * (0, 0) in gmsh 4.8.4).
 *
 * gmsh state. Each pm_model owns one uniquely named gmsh model ("pm_cad_<n>"), created through a
 * gmsh_session scope and removed by pm_model_destroy(). The model does not need to stay gmsh's
 * current model: every gmsh call of this backend runs under pm_gmsh_lock(), makes its own model
 * current if another one is, and restores the previous current model afterwards. Other gmsh users
 * (writers, peers) must likewise go through gmsh_session scopes and hold pm_gmsh_lock() while a
 * scope is open, so that they never act on a CAD model by accident.
 *
 * Thread safety: evaluation, projection and the inside test may be called concurrently; closed
 * forms need no lock, gmsh calls are serialized. Loading is serialized too.
 */
#ifndef PM_GEOM_CAD_H
#define PM_GEOM_CAD_H

#include "common/geom/geom.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Load a CAD file as a model.
 * [in]  path  a .step/.stp, .iges/.igs or .brep file (the extension decides the format,
 *             case-insensitively). A file whose faces are unsewn or whose solids touch
 *             without sharing faces is healed (geom_cad_heal.c); m->heal says what was done.
 * [out] out   the model (free with pm_model_destroy), NULL on failure.
 * Errors, each a one-line message naming the file:
 *   PM_ERR_ARG    an unknown extension;
 *   PM_ERR_IO     a missing or unreadable file (or not a regular file);
 *   PM_ERR_PARSE  a file gmsh cannot read (corrupt, truncated, not of its format);
 *   PM_ERR_GEOM   a file that imports to an empty model, or whose B-rep cannot be made into a
 *                 consistent cell complex (a trimming loop that does not close, ...);
 *   PM_ERR_BACKEND gmsh failed otherwise. */
pm_status pm_cad_load(const char *path, pm_model **out, pm_error *err);

/* Build a model from shapes made in-process with gmsh's OpenCASCADE kernel: `make` runs in a
 * fresh gmsh model (under the gmsh lock) and returns gmsh's ierr; its shapes are synchronized and
 * loaded like a CAD file's, under the name `label`. The built-in solid cases (cases.h) are made
 * this way. A failing `make` is PM_ERR_BACKEND with gmsh's message. */
pm_status pm_cad_build_shapes(const char *label, int (*make)(void), pm_model **out,
                              pm_error *err);

/* For a `make` of pm_cad_build_shapes: cut volume `tool` from volume `object` (both removed,
 * the result kept under new tags) in the current gmsh model. Returns gmsh's ierr. */
int pm_cad_occ_cut_volumes(int object, int tool);

/* Number of gmsh evaluations of model m that failed and were replaced by the fallback output
 * (see above); -1 when m is not a geom_cad model. */
long pm_cad_eval_failures(const pm_model *m);

/* 1 when cell c of a geom_cad model is evaluated in closed form (fitted and checked against
 * gmsh), 0 when by gmsh, -1 when c does not belong to a geom_cad model. For tests and the
 * benchmark. */
int pm_cad_cell_is_fast(const pm_cell *c);

/* The gmsh model name holding m's shapes (for tests that compare with gmsh directly under a
 * gmsh_session scope), or NULL when m is not a geom_cad model. */
const char *pm_cad_gmsh_model(const pm_model *m);

#ifdef __cplusplus
}
#endif

#endif /* PM_GEOM_CAD_H */
