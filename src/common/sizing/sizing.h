/* Node-spacing fields d(x, y, z): the desired edge length everywhere (Shimada's node spacing,
 * the bubble diameter). Every public interface of packmesh speaks of size in this sense; each
 * method converts internally (a bubble's radius is d/2, a psys particle's sigma is calibrated
 * against d).
 *
 * Kinds: a constant; an expression in x, y, z parsed by muparser (functions sqrt, abs, sin,
 * min, max, ... and the constant _pi); a C callback; a field sampled at mesh nodes and
 * interpolated (how one method's inferred field is handed to the other); and a scaled copy of
 * any of these (how a comparison matches node counts).
 *
 * A field is immutable once made and safe to evaluate from several threads at once.
 */
#ifndef PM_SIZING_H
#define PM_SIZING_H

#include <packmesh/packmesh.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_sizing pm_sizing;

/* d(x) = d. d must be finite and > 0. */
pm_status pm_sizing_constant(double d, pm_sizing **out, pm_error *err);

/* d(x) = the expression, in the variables x, y, z (and r = sqrt(x^2 + y^2 + z^2) for
 * convenience), parsed by muparser (sizing_expr.c lists its functions and operators).
 * Unparsable text, unknown variables or several comma-separated values are PM_ERR_PARSE with
 * muparser's reason and position ("size expression '0.1*(x': Missing parenthesis at position
 * 7"). An expression that is not finite and > 0 at any of a set of probe points (around the unit
 * cube, the origin left out) is PM_ERR_ARG: it is usable nowhere ("-0.1", "0*x", "1/0"). One that
 * is bad only in places is accepted here, since a field may be non-positive outside the model;
 * pm_sizing_check judges it against the model. */
pm_status pm_sizing_expression(const char *expr, pm_sizing **out, pm_error *err);

/* d(x) = fn(xyz, user). The callback must be thread-safe; user is borrowed. */
typedef double (*pm_sizing_fn)(const double xyz[3], void *user);
pm_status pm_sizing_callback(pm_sizing_fn fn, void *user, const char *description,
                             pm_sizing **out, pm_error *err);

/* A field sampled at the nodes of `samples` (values [samples->nnode], each finite and > 0):
 * evaluation interpolates linearly on the sample mesh's triangles (or tets) at the closest point
 * of the nearest element when that is within 0.1 x the element's longest edge of the query
 * point, else by inverse-distance weighting (1/d^2) of the 8 nearest nodes. The value always lies
 * within [min, max] of the samples. Elements are located through a pm_grid, so an evaluation
 * costs O(1), not a scan (far from a thin sample set the nearest-node fallback slows down: sample
 * a field meant for a volume on tets). Both inputs are copied; degenerate elements are
 * ignored. */
pm_status pm_sizing_sampled(const pm_mesh *samples, const double *values, pm_sizing **out,
                            pm_error *err);

/* factor * d(x) of an existing field (factor finite and > 0). The base field is shared by
 * reference count: destroying either is safe. A scale of a scaled field multiplies the factors;
 * a scaled constant is a constant. */
pm_status pm_sizing_scaled(const pm_sizing *base, double factor, pm_sizing **out, pm_error *err);

/* A NUMBER ("0.1") or an EXPR ("0.2*abs(r-2)+0.15"), as --size takes it. */
pm_status pm_sizing_parse(const char *text, pm_sizing **out, pm_error *err);

/* The field's value at xyz. Does not check the value (see pm_sizing_check). Safe to call from
 * several threads at once for every kind (a callback must be thread-safe itself). An expression
 * returns NaN only when no parser could be made for the calling thread (out of memory). */
double pm_sizing_eval(const pm_sizing *s, const double xyz[3]);

/* Evaluate the field at the vertices and at sample points of every curve (33 per curve) and face
 * (a 17 x 17 grid over its parameter box, points inside the trimming loops) of model m and
 * reject it (PM_ERR_ARG naming the cell and the point) when a value is not finite, not > 0 or
 * beyond PM_COORD_MAX (mesh.h).
 * Volume interiors are not sampled. */
pm_status pm_sizing_check(const pm_sizing *s, const pm_model *m, pm_error *err);

/* A short text that says what the field is: for a constant, an expression and a scaled one of
 * either, text that pm_sizing_parse (--size) takes back to the same field ("0.1",
 * "0.2*abs(r-2)+0.15", "1.07*(0.2*abs(r-2)+0.15)"); for the others a description
 * ("sampled (712 nodes)", the callback's description, "1.07 x (sampled (712 nodes))").
 * Borrowed, valid while s lives. */
const char *pm_sizing_describe(const pm_sizing *s);

/* Release. Accepts NULL. */
void pm_sizing_destroy(pm_sizing *s);

#ifdef __cplusplus
}
#endif

#endif /* PM_SIZING_H */
