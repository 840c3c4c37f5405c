/* The geometry interface: a B-rep cell complex in Shimada's sense (papers/003 section 2.1).
 *
 * A model is a set of cells of dimension 0 (vertices), 1 (curves C(t)), 2 (faces S(u,v), possibly
 * trimmed) and 3 (volumes). Every cell knows the cells on its boundary (`bound`, one dimension
 * lower) and the cells it bounds (`up`, one dimension higher). Non-manifold models are allowed:
 * a face may bound no volume or two, a curve may dangle, a face may lie inside a volume.
 *
 * Every method sees geometry only through this header. Backends (geom_analytic.c for built-in
 * planar domains, geom_cad.c for STEP/IGES/BREP through gmsh) fill the structs below and provide
 * a pm_cell_class of evaluation functions; the generic parts (curvatures from derivatives, the
 * parameter displacement of a particle, the rule for a step leaving the trimmed region, the
 * trimming polylines and their inside test, projection by Newton iteration) live in geom.c and
 * trim.c and are shared.
 *
 * Parameters of a cell ("par"): a vertex has none, a curve has t, a face has (u, v), a volume has
 * (x, y, z) (a volume is parametrized by space itself). pm_cell_npar() says how many.
 *
 * Cells are indexed per dimension from 0: (dim, index) names a cell. `tag` is the backend's own
 * id (the gmsh entity tag for CAD models), kept for output files and messages.
 *
 * Thread safety: evaluation, projection, inside tests and moves are safe to call concurrently on
 * a loaded model (backends that call non-thread-safe libraries serialize internally).
 */
#ifndef PM_GEOM_H
#define PM_GEOM_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

enum { PM_VERTEX = 0, PM_CURVE = 1, PM_FACE = 2, PM_VOLUME = 3 };

/* The resolution of a model: CAD features (curves, strips, wedges) below this fraction of its
 * bounding-box diagonal are taken as below what a mesh must show. The feature size field does
 * not refine below it (sizing_features.h) and a needle it forces is reported as forced
 * (needles.h). */
#define PM_FEATURE_FLOOR 3e-5

typedef struct pm_cell pm_cell;
typedef struct pm_model pm_model;

/* One use of a cell in the boundary of another.
 * - In a curve's `bound`: its two end vertices, sense -1 for the start (t = lo), +1 for the end.
 * - In a face loop: a boundary curve, sense +1 when the loop runs along increasing t.
 *   `side` tells the two uses of a seam curve apart (which of its two pcurves, 0 or 1); 0 for
 *   every other curve.
 * - In a volume's `bound`: a face, sense +1 when the face's natural normal Su x Sv points out of
 *   the volume, -1 when it points in. */
/* A reference to a cell of any dimension. */
typedef struct pm_cellref {
  int32_t dim;
  int32_t index;
} pm_cellref;

typedef struct pm_use {
  int32_t cell;  /* index of the used cell in its dimension */
  int8_t sense;  /* +1 / -1 as above */
  int8_t side;   /* seam pcurve selector (faces only), else 0 */
} pm_use;

/* A trimming loop of a face: a closed chain of boundary-curve uses, and its parameter-space
 * polyline (the pcurves sampled by trim.c, consecutive uses joined end to start; the polyline is
 * closed implicitly: the last point connects to the first). The outer loop runs
 * counter-clockwise in (u, v), holes clockwise (trim.c normalizes whatever the backend gave). */
typedef struct pm_loop {
  int32_t nuse;
  pm_use *use;        /* [nuse], owned */
  int outer;          /* 1 for an outer loop, 0 for a hole; a backend that does not know sets
                         -1 and pm_model_finish classifies by signed area and nesting */
  int32_t npts;
  double *uv;         /* [2*npts] polyline, owned */
  int32_t *pt_use;    /* [npts] index in `use` of the curve each polyline point lies on, owned */
  double *pt_t;       /* [npts] that curve's parameter at the point, owned */
  double box[4];      /* umin, vmin, umax, vmax of the polyline */
} pm_loop;

/* Evaluation results. Derivatives are with respect to the cell's own parameters. */
typedef struct pm_curve_point {
  double p[3];   /* C(t) */
  double d1[3];  /* C'(t)  (order >= 1) */
  double d2[3];  /* C''(t) (order >= 2) */
} pm_curve_point;

typedef struct pm_face_point {
  double p[3];                 /* S(u, v) */
  double su[3], sv[3];         /* first derivatives  (order >= 1) */
  double suu[3], suv[3], svv[3]; /* second derivatives (order >= 2) */
} pm_face_point;

/* What a backend provides per cell. Functions that may be NULL say so; geom.c supplies the
 * generic fallback. `self` is the cell being evaluated; backend data is in self->impl. */
typedef struct pm_cell_class {
  const char *name; /* surface/curve type: "plane", "cylinder", "bspline", "segment", "arc", ... */

  /* Curves: evaluate C and derivatives up to `order` (0..2) at t (any real t: periodic curves
   * wrap, others extrapolate or clamp). */
  void (*curve_eval)(const pm_cell *self, double t, int order, pm_curve_point *out);

  /* Faces: evaluate S and derivatives up to `order` at (u, v) on the untrimmed surface. */
  void (*face_eval)(const pm_cell *self, const double uv[2], int order, pm_face_point *out);

  /* Faces, may be NULL: evaluate n points at once (backends with per-call overhead batch). */
  void (*face_eval_many)(const pm_cell *self, int32_t n, const double *uv, int order,
                         pm_face_point *out);

  /* Faces: (u, v) of the point of boundary curve `use.cell` at parameter t, using the pcurve
   * selected by use.side for seams. */
  void (*face_curve_uv)(const pm_cell *self, const pm_use *use, double t, double uv[2]);

  /* May be NULL: closest point on the untrimmed surface / the curve's range, from an optional
   * guess (NULL: none). Writes par; returns 0 on success. The generic Newton iteration of geom.c
   * is used when NULL or when this fails. */
  int (*project)(const pm_cell *self, const double xyz[3], const double *guess, double *par);

  /* May be NULL: release self->impl. */
  void (*destroy)(pm_cell *self);
} pm_cell_class;

struct pm_cell {
  int dim;            /* PM_VERTEX .. PM_VOLUME */
  int32_t index;      /* index within its dimension */
  const pm_model *model; /* the model the cell belongs to (set by pm_model_alloc) */
  int tag;            /* backend id (gmsh tag), for files and messages */

  /* Parameter box: curves use lo[0], hi[0]; faces lo[0..1], hi[0..1] (the box of the trimmed
   * face, which may be smaller than the surface's domain); volumes the xyz bounding box. */
  double lo[3], hi[3];
  int periodic[2];    /* per parameter: 1 when the cell closes on itself along it */
  double period[2];   /* the period where periodic (2 pi for a cylinder's u), else 0 */

  int32_t nbound;
  pm_use *bound;      /* [nbound] owned; vertices: none; curves: end vertices (start first);
                         faces: every boundary curve once per use, loop by loop (filled by
                         pm_model_finish from the loops; a backend leaves it empty);
                         volumes: bounding faces with orientation sense */
  int32_t nup;
  int32_t *up;        /* [nup] owned: indices of the cells of dimension dim+1 this one bounds
                         (filled by pm_model_finish from the `bound` lists) */

  /* Cells of lower dimension that lie inside this one without being on its boundary: an
   * internal (crack or dangling) face or a dangling curve inside a volume, a curve or a point
   * embedded in a face. They are meshed conformally: tets on both sides of an internal face,
   * its triangles shared. */
  int32_t nembed;
  pm_cellref *embed;  /* [nembed] owned */
  int32_t nhost;
  pm_cellref *host;   /* [nhost] owned: the cells this one is embedded in (filled by
                         pm_model_finish from the `embed` lists) */

  double xyz[3];      /* vertices: the point */
  int stray;          /* vertices: a leftover point of the file (a construction point) that
                         bounds nothing, lies in nothing, and sits on another vertex or on a curve
                         (within 1000 x the model tolerance): it gets no mesh node, which would
                         duplicate the other vertex's or a curve node that lands on it (the
                         control points on a straight edge of synth_bspline_patch.brep) (set by
                         pm_model_finish) */
  int degenerate;     /* curves: zero length (a sphere pole, a cone apex) */

  int32_t nloop;
  pm_loop *loop;      /* faces: [nloop] owned, outer loop(s) first */
  double box[6];      /* 3D bounding box (xmin, ymin, zmin, xmax, ymax, zmax) */

  const pm_cell_class *cls; /* borrowed (static) */
  void *impl;               /* backend data, released by cls->destroy */
  void *trim;               /* faces: trim.c's inside-test accelerator, owned by geom.c */
};

struct pm_model {
  char name[256];       /* file name or "case:NAME" */
  int dim;              /* highest dimension present */
  int32_t count[4];     /* cells per dimension */
  pm_cell *cells[4];    /* [count[d]] owned */
  double box[6];        /* 3D bounding box */
  double diagonal;      /* |box max - box min| */
  double tol;           /* geometric tolerance, relative to the diagonal (backend's choice) */
  char heal[512];       /* what loading repaired in the file, one line ("" when nothing: see
                           geom_cad_heal.c) */
  double time_build;    /* seconds spent building the cell complex once the file was read
                           (loops, trimming polylines and inside tests, projection grids); 0 for
                           a backend that does not measure it */
  double time_open;     /* seconds pm_input_open took, time_build included (0 for a model made
                           otherwise) */
  void *impl;           /* backend data */
  void (*destroy_impl)(pm_model *m);
};

/* ---- model ------------------------------------------------------------------------------- */

/* Allocate an empty model with room for the given number of cells per dimension; cells are
 * zeroed with dim and index set. The backend fills them, then calls pm_model_finish(). */
pm_status pm_model_alloc(const int32_t count[4], pm_model **out, pm_error *err);

/* Derive what the backend need not fill: `up` lists from `bound`, 3D boxes of cells and model,
 * the diagonal, the tolerance when zero, and the trimming polylines and inside accelerators of
 * every face (trim.c). Checks consistency (indices in range, loops closed). */
pm_status pm_model_finish(pm_model *m, pm_error *err);

/* Release the model and everything it owns. Accepts NULL. */
void pm_model_destroy(pm_model *m);

static inline int32_t pm_model_count(const pm_model *m, int dim) { return m->count[dim]; }
static inline const pm_cell *pm_model_cell(const pm_model *m, int dim, int32_t i) {
  return &m->cells[dim][i];
}

/* ---- evaluation -------------------------------------------------------------------------- */

/* Number of parameters of a cell: 0, 1, 2 or 3 for dimensions 0..3. */
static inline int pm_cell_npar(const pm_cell *c) { return c->dim; }

void pm_curve_eval(const pm_cell *c, double t, int order, pm_curve_point *out);
void pm_face_eval(const pm_cell *f, const double uv[2], int order, pm_face_point *out);
void pm_face_eval_many(const pm_cell *f, int32_t n, const double *uv, int order,
                       pm_face_point *out);

/* The unit normal Su x Sv / |Su x Sv| of an evaluated face point (order >= 1) into n; 0 with n
 * zero where the point is singular: |Su x Sv| <= min_sin |Su| |Sv|, Su and Sv closer to
 * parallel than the angle whose sine is min_sin (a pole, an apex, a collapsed corner). */
int pm_face_point_normal(const pm_face_point *fp, double min_sin, double n[3]);

/* The 3D point of a cell at par (vertex: its point; volume: par itself). */
void pm_cell_point(const pm_cell *c, const double *par, double xyz[3]);

/* Arc length of curve c between parameters t1 and t2 (|t2 - t1| when c is a volume's axis is
 * meaningless: curves only): Gauss-Legendre, 5 points on each of 4 pieces. */
double pm_curve_length(const pm_cell *c, double t1, double t2);

/* Curvature |C' x C''| / |C'|^3 of a curve (0 on a degenerate curve). */
double pm_curve_curvature(const pm_cell *c, double t);

/* Principal curvatures of a face at (u, v), from the first and second fundamental forms:
 * kmax is the one of larger magnitude. Signs are relative to the natural normal Su x Sv
 * (positive: the surface bends towards the normal). normal may be NULL; when given it receives
 * the unit natural normal (zero vector where Su x Sv vanishes). At a singular point (a pole) the
 * curvatures are the limits from nearby regular points. */
void pm_face_curvatures(const pm_cell *f, const double uv[2], double *kmax, double *kmin,
                        double normal[3]);

/* The principal curvatures (as pm_face_curvatures) of a face point evaluated to order 2; 0, with
 * the normal zeroed, where the point is singular (pm_face_curvatures then takes the limit). */
int pm_face_point_curvatures(const pm_face_point *fp, double *kmax, double *kmin, double normal[3]);

/* (u, v) of a boundary-curve point on face f, for the use `use` of that curve. */
void pm_face_curve_uv(const pm_cell *f, const pm_use *use, double t, double uv[2]);

/* The orientation of a face's triangles in a mesh (mesh.h): +1 when they follow the natural
 * normal Su x Sv, -1 when they are reversed. A face that bounds a volume has its triangles point
 * out of the first volume listed in its `up` list (so a solid's surface mesh is outward); a face
 * bounding no volume follows its natural normal. */
int pm_face_mesh_sign(const pm_model *m, int32_t face);

/* ---- trimmed region ---------------------------------------------------------------------- */

/* Wrap periodic parameters into the cell's base range [lo, lo + period). */
void pm_cell_wrap(const pm_cell *c, double *par);

/* 1 if (u, v) lies in the trimmed region of face f, else 0. Periodic parameters are wrapped
 * first. Robust: the orientation tests against the loop polylines are exact (predicates.h), so
 * the answer is consistent for points on or next to the polyline. */
int pm_face_inside(const pm_cell *f, const double uv[2]);

/* ---- moving a particle that lives on a cell ---------------------------------------------- */

/* The one routine that turns a 3D displacement dx of a particle at par into a parameter
 * displacement dpar (papers/001 eq. 7-9; curves papers/003 eq. 15):
 *   faces:  dpar = M^-1 J dx, M = [[Su.Su, Su.Sv], [Su.Sv, Sv.Sv]], J = [Su; Sv];
 *   curves: dt = dx . C' / |C'|^2;   vertices: nothing;   volumes: dpar = dx.
 * `d` may hold the cell's first derivatives at par when the caller has them (curves: C' in d[0..2];
 * faces: Su in d[0..2], Sv in d[3..5]); NULL evaluates them. Where M is singular (a pole), the
 * component along the degenerate direction is dropped (pseudo-inverse), never divided by ~0. */
void pm_cell_param_delta(const pm_cell *c, const double *par, const double *d, const double dx[3],
                         double *dpar);

enum {
  PM_MOVE_FREE = 0,    /* the step was taken whole */
  PM_MOVE_CLIPPED = 1  /* the step would leave the cell; it was cut short inside the boundary */
};

/* The one rule for a step par -> par + dpar on a cell (both methods use it, never their own):
 * - periodic parameters wrap (the same 3D point, not a jump);
 * - curves: a step past an end of a non-periodic curve stops just inside that end;
 * - faces: a step whose end leaves the trimmed region stops just inside the first crossing of
 *   the loop polylines along the segment (clip to the boundary and stop);
 * - a particle that starts outside the trimmed region (allowed for Shimada's overlap-only
 *   bubbles) takes the whole step;
 * - "just inside" is the crossing pulled back by PM_CLIP_BACKOFF of the step, halved until the
 *   inside test accepts it, or the start point.
 * Writes the new parameters to par_out (may alias par) and returns PM_MOVE_FREE or
 * PM_MOVE_CLIPPED. */
int pm_cell_move(const pm_cell *c, const double *par, const double *dpar, double *par_out);
#define PM_CLIP_BACKOFF 1e-3

/* pm_cell_param_delta followed by pm_cell_move. */
int pm_cell_displace(const pm_cell *c, const double *par, const double dx[3], double *par_out);

/* ---- projection -------------------------------------------------------------------------- */

/* Closest point of cell c to xyz: on a curve within [lo, hi]; on a face within its trimmed
 * region (a foot point outside the trim is replaced by the closest point of the boundary curves,
 * expressed in the face's (u, v)). `guess` (may be NULL) is a starting parameter. Writes par
 * and, when not NULL, the closest point and its distance. */
pm_status pm_cell_project(const pm_cell *c, const double xyz[3], const double *guess, double *par,
                          double closest[3], double *dist, pm_error *err);

/* The closest point of the untrimmed surface of face f to xyz by Newton iteration from `start`
 * (a local search: the minimum nearest to start, within the parameter box where a parameter is
 * not periodic). Writes uv (periodic parameters wrapped into the base range) and returns the
 * squared distance. */
double pm_face_project_from(const pm_cell *f, const double xyz[3], const double start[2],
                            double uv[2]);

#ifdef __cplusplus
}
#endif

#endif /* PM_GEOM_H */
