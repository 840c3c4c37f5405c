/* packmesh: the public C API.
 *
 * Mesh a CAD part, a planar domain or a built-in case with one of packmesh's meshers (Shimada's
 * bubble mesh, Bronson, Levine & Whitaker's particle system, gmsh's algorithms, CGAL's Mesh_2),
 * measure the result with the quality module every method shares, check it, and write it in any
 * of the formats the packmesh command writes. A program needs this header only:
 *
 *     cc prog.c $(pkg-config --cflags --libs packmesh)
 *
 *     pm_model *model; pm_sizing *size; pm_mesh *mesh; pm_error err;
 *     if (pm_model_open("part.step", &model, NULL, &err) ||
 *         pm_sizing_constant(2.5, &size, &err) ||
 *         pm_generate(model, size, pm_method_find("bubble"), NULL, NULL, &mesh, NULL, &err))
 *       fprintf(stderr, "%s\n", err.msg);
 *
 * Conventions (every function):
 *   - errors: a fallible function returns a pm_status, PM_OK (0) on success; its last argument
 *     is a pm_error * that may be NULL, filled on failure with the code and a one-line message
 *     naming the problem. The library never prints and never calls exit().
 *   - ownership: an argument marked "in" is read and not kept past the call unless it says
 *     "borrowed: must outlive X"; "out" receives a new object the caller releases with the
 *     matching _destroy function (each accepts NULL); on failure an out pointer is set to NULL.
 *     Pointers returned by accessors ("view") stay valid while their owner lives, unchanged.
 *   - threads: models, size fields and meshes are immutable once made and may be read from
 *     several threads at once; pm_generate uses the threads it is given (OpenMP) and its result
 *     never depends on their number. Models opened from CAD files go through gmsh, a process-wide
 *     singleton that packmesh serializes internally.
 *   - reproducibility: a seed fixes every random choice.
 *
 * Element and node arrays are 0-based; coordinates are x, y, z triples (z = 0 for planar
 * domains).
 */
#ifndef PACKMESH_PACKMESH_H
#define PACKMESH_PACKMESH_H

#include <stddef.h>
#include <stdint.h>

/* Symbols of the public API: exported from libpackmesh.so, everything else stays inside. */
#if defined(__GNUC__)
#define PM_API __attribute__((visibility("default")))
#else
#define PM_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ==== status codes and errors ================================================================ */

typedef enum pm_status {
  PM_OK = 0,
  PM_ERR_ARG,      /* a bad argument or parameter value (out of range, unknown key) */
  PM_ERR_IO,       /* a file could not be read or written */
  PM_ERR_PARSE,    /* a file or expression is malformed */
  PM_ERR_GEOM,     /* the geometry cannot be handled (empty model, failed evaluation) */
  PM_ERR_BACKEND,  /* a third-party library (gmsh, CGAL, TetGen, Embree) failed */
  PM_ERR_LIMIT,    /* a cap (nodes, iterations, memory budget) would be exceeded */
  PM_ERR_NOMEM,    /* an allocation failed */
  PM_ERR_INTERNAL, /* a broken invariant detected at run time */
  PM_ERR_CANCELLED /* the caller's progress callback asked the run to stop */
} pm_status;

/* The error record. Plain data; lives on the caller's stack. */
typedef struct pm_error {
  pm_status code;   /* PM_OK when nothing went wrong */
  char msg[512];    /* one line, no trailing newline */
} pm_error;

/* Fill err (when not NULL) with code and a printf-style message; returns code so that call
 * sites read `return pm_error_setf(err, PM_ERR_ARG, "size must be > 0, got %g", d);`. */
PM_API pm_status pm_error_setf(pm_error *err, pm_status code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Prefix an existing message with context ("reading x.step: <old message>"); keeps the code.
 * Returns err->code (PM_OK if err is NULL). */
PM_API pm_status pm_error_prefix(pm_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Reset to PM_OK with an empty message. Accepts NULL. */
PM_API void pm_error_clear(pm_error *err);

/* A short name for a status code ("bad argument", "i/o error", ...). */
PM_API const char *pm_status_name(pm_status s);

/* The library version, "MAJOR.MINOR.PATCH". */
PM_API const char *pm_version(void);

/* Release the process-wide state of the backends (gmsh's, when a CAD model or a gmsh method was
 * used). Optional; call it once, at the end of the program, after every object is destroyed: no
 * packmesh call may follow. */
PM_API void pm_finalize(void);

/* ==== models ================================================================================= */

/* A geometric model: a cell complex of vertices, curves, faces and volumes (papers/003's
 * non-manifold B-rep), loaded from a CAD file (.step/.stp, .iges/.igs, .brep through gmsh and
 * OpenCASCADE), a case file (.json, DESIGN.md "Case files") or a built-in case ("case:NAME"). */
typedef struct pm_model pm_model;

/* A size field: the desired edge length d(x, y, z) everywhere (Shimada's node spacing). */
typedef struct pm_sizing pm_sizing;

/* A mesh: nodes, segments on curves, triangles on faces and tets in volumes, each classified on
 * the cell of the model it lies on. */
typedef struct pm_mesh pm_mesh;

/* Open `spec` (in): a file path or "case:NAME" (pm_case_count lists the names). *model (out)
 * receives the model; *default_size (out, may be NULL: not wanted) the input's own size field
 * when it has one (a case's, a case file's), else NULL. PM_ERR_IO for a missing file,
 * PM_ERR_PARSE / PM_ERR_GEOM for a file that cannot be made into a model (the message names the
 * face or curve), PM_ERR_ARG for an unknown case. Loading may repair a file (sew unsewn faces,
 * drop slivers): pm_model_healed says what. */
PM_API pm_status pm_model_open(const char *spec, pm_model **model, pm_sizing **default_size,
                               pm_error *err);
PM_API void pm_model_destroy(pm_model *m);

/* Views of a model. The name is the spec it was opened from ("case:qi3", the file's path). */
PM_API const char *pm_model_name(const pm_model *m);
/* 2 for a planar domain (z = 0), 3 otherwise. */
PM_API int pm_model_dimension(const pm_model *m);
/* The number of cells of dimension dim (0 vertices, 1 curves, 2 faces, 3 volumes). */
PM_API int32_t pm_model_cell_count(const pm_model *m, int dim);
/* The bounding box (xmin, ymin, zmin, xmax, ymax, zmax) and its diagonal. */
PM_API void pm_model_box(const pm_model *m, double box[6]);
PM_API double pm_model_diagonal(const pm_model *m);
/* What loading repaired in the file, one line; "" when nothing. */
PM_API const char *pm_model_healed(const pm_model *m);

/* The built-in cases: their number, and of the i-th its name, dimension (2 planar, 3 solid),
 * description, default size (a number or an expression, as pm_sizing_parse takes it) and
 * source (the paper it comes from, or how it is built). Static storage; NULL (0) out of
 * range. */
PM_API int pm_case_count(void);
PM_API const char *pm_case_name(int i);
PM_API int pm_case_dimension(int i);
PM_API const char *pm_case_description(int i);
PM_API const char *pm_case_default_size(int i);
PM_API const char *pm_case_source(int i);

/* ==== size fields ============================================================================ */

/* d(x) = d, finite and > 0. */
PM_API pm_status pm_sizing_constant(double d, pm_sizing **out, pm_error *err);

/* d(x) = an expression in x, y, z and r = sqrt(x^2 + y^2 + z^2), parsed by muparser (sqrt, abs,
 * sin, min, max, ..., _pi). Unparsable text is PM_ERR_PARSE with muparser's reason and position;
 * an expression usable nowhere ("-0.1", "1/0") PM_ERR_ARG. */
PM_API pm_status pm_sizing_expression(const char *expr, pm_sizing **out, pm_error *err);

/* d(x) = fn(xyz, user). fn must be thread-safe and return a finite value > 0 on the model;
 * user is borrowed (must outlive the field); description (in, may be NULL) names the field in
 * reports. */
typedef double (*pm_sizing_fn)(const double xyz[3], void *user);
PM_API pm_status pm_sizing_callback(pm_sizing_fn fn, void *user, const char *description,
                                    pm_sizing **out, pm_error *err);

/* A field sampled at the nodes of `samples` (in; values[pm_mesh_node_count(samples)], in, each
 * finite and > 0), interpolated linearly on its triangles or tets (nearest nodes off them). Both
 * are copied. */
PM_API pm_status pm_sizing_sampled(const pm_mesh *samples, const double *values,
                                   pm_sizing **out, pm_error *err);

/* The field psys infers from the model's curvature, gap size and a Lipschitz bound
 * (papers/001 section 3.1), as a sampled field any method can use: what `--size inferred` means.
 * Runs psys's first two phases: seconds on small parts, minutes on large ones. */
PM_API pm_status pm_sizing_inferred(const pm_model *model, uint64_t seed, int threads,
                                    pm_sizing **out, pm_error *err);

/* A NUMBER ("0.1") or an EXPR ("0.2*abs(r-2)+0.15"), as --size takes it. */
PM_API pm_status pm_sizing_parse(const char *text, pm_sizing **out, pm_error *err);

/* The value at xyz (not checked), and a short text saying what the field is (a view). */
PM_API double pm_sizing_eval(const pm_sizing *s, const double xyz[3]);
PM_API const char *pm_sizing_describe(const pm_sizing *s);
PM_API void pm_sizing_destroy(pm_sizing *s);

/* ==== methods and their parameters =========================================================== */

/* A mesher: "bubble", "psys", "gmsh-frontal", "gmsh-delaunay", "gmsh-meshadapt", "cgal".
 * Static storage: never released. */
typedef struct pm_method pm_method;

PM_API int pm_method_count(void);
PM_API const pm_method *pm_method_at(int i);          /* NULL out of range */
PM_API const pm_method *pm_method_find(const char *name); /* NULL when unknown */
PM_API const char *pm_method_name(const pm_method *m);
PM_API const char *pm_method_description(const pm_method *m);
/* 1 when the method relaxes particles and reports every iteration (the progress callback then
 * sees rows, and a cancel is honoured between iterations); the peers run inside their libraries
 * and report only the stages. */
PM_API int pm_method_traces(const pm_method *m);
/* 1 when the method meshes planar domains only (cgal). */
PM_API int pm_method_planar_only(const pm_method *m);

/* One parameter of a method, from the table `packmesh mesh --method M --help` prints. Views. */
typedef struct pm_param_info {
  const char *key;         /* what pm_method_params_set and --set take, e.g. "k0" */
  const char *unit;        /* "" when dimensionless */
  const char *doc;         /* one line */
  const char *source;      /* the paper and equation, e.g. "003 eq. 13" */
  char default_value[64];  /* the default, as pm_method_params_set takes it */
  char range[96];          /* the values allowed, e.g. "[0.5, 2]", "on|off", "eigen|lloyd" */
} pm_param_info;

/* The method's parameters: their number, and the i-th (PM_ERR_ARG out of range). */
PM_API int pm_method_param_count(const pm_method *m);
PM_API pm_status pm_method_param_info(const pm_method *m, int i, pm_param_info *out,
                                      pm_error *err);

/* A set of parameter values for one method, starting at its defaults. */
typedef struct pm_method_params pm_method_params;
PM_API pm_status pm_method_params_create(const pm_method *m, pm_method_params **out,
                                         pm_error *err);
/* Set `key` to `value` (text, as --set KEY=VALUE takes it). An unknown key, a value that does
 * not parse or lies outside the parameter's range is PM_ERR_ARG naming the key and the range;
 * the set is then unchanged. */
PM_API pm_status pm_method_params_set(pm_method_params *p, const char *key, const char *value,
                                      pm_error *err);
/* Every value within its range (a set only made through pm_method_params_set always is):
 * PM_ERR_ARG naming the first that is not. The rules that tie parameters to each other (psys:
 * lambda_min <= lambda_init <= lambda_max, ...) are the method's, checked when pm_generate runs
 * it. */
PM_API pm_status pm_method_params_check(const pm_method_params *p, pm_error *err);
/* The current value of `key` as text, into buf (out, len bytes). */
PM_API pm_status pm_method_params_get(const pm_method_params *p, const char *key, char *buf,
                                      size_t len, pm_error *err);
PM_API void pm_method_params_destroy(pm_method_params *p);

/* ==== generating a mesh ====================================================================== */

/* What the progress callback sees. Views, valid during the call. */
typedef struct pm_progress {
  const char *method;        /* the method's name */
  const char *stage;         /* "meshing", "iteration", "done" */
  int run;                   /* 1, 2, ...: the runs of a target-node search */
  int64_t iteration;         /* the iteration of the row (stage "iteration"), else -1 */
  int ncol;                  /* the row: the method's trace columns and values (0 otherwise) */
  const char *const *columns;
  const double *values;
} pm_progress;

/* Called from the thread that called pm_generate. Return 0 to go on, anything else to cancel:
 * pm_generate then returns PM_ERR_CANCELLED and no mesh (at the next iteration for a method
 * that traces, else at the next stage). */
typedef int (*pm_progress_fn)(void *user, const pm_progress *p);

typedef struct pm_generate_options {
  uint64_t seed;           /* in: fixes every random choice; default 1 */
  int threads;             /* in: OpenMP threads, >= 1; default 1; the mesh never depends on it */
  int volume;              /* in: 1 also meshes the model's volumes with tets; default 0 */
  int64_t max_nodes;       /* in: the node cap, > 0 (PM_ERR_LIMIT beyond); default 20000000 */
  int64_t target_nodes;    /* in: > 0 scales the size field (or the method's default field) and
                              runs again until the node count is within target_tolerance of it,
                              at most target_runs times; default 0: one run at the given size */
  double target_tolerance; /* in: default 0.03 */
  int target_runs;         /* in: default 8 */
  pm_progress_fn progress; /* in, may be NULL */
  void *progress_user;     /* borrowed: passed to progress */
  int target_surface;      /* in: 1: target_nodes counts the surface nodes (the nodes of the
                              triangles; a volume mesh's interior nodes are left out), so that
                              volume meshes are matched on their surfaces; default 0: all nodes */
} pm_generate_options;

/* Fill o with the defaults above. */
PM_API void pm_generate_options_init(pm_generate_options *o);

/* What a run did (out). */
typedef struct pm_generate_result {
  int64_t iterations;      /* steps / iterations of the last run (0 for direct meshers) */
  char stop_reason[128];   /* what ended it ("converged: ...", "max steps", ...) */
  int runs;                /* runs made (1 without target_nodes) */
  double size_scale;       /* the factor the size field was scaled by (1 without target_nodes) */
  int target_met;          /* 1 when the node count is within the tolerance (or no target) */
  double seconds;          /* wall time of all the runs */
  int64_t target_count;    /* with target_nodes: the count compared with it (all nodes, or the
                              surface nodes with target_surface) in the last run; else 0 */
} pm_generate_result;

/* Mesh `model` (in) with `method` (in), its parameters `params` (in, may be NULL: the
 * defaults) and the size field `size` (in, may be NULL: the method's own default -- bubble's
 * rule from the model's features, psys's inferred field, the peers' field of the model's
 * features).
 * opts (in, may be NULL: the defaults of pm_generate_options_init). *out (out) receives the
 * mesh; result (out, may be NULL) what the run did. Errors: PM_ERR_ARG for a size field that is
 * not finite and > 0 on the model, a planar-only method on a solid, volume on a model without
 * volumes, bad parameters; PM_ERR_LIMIT past max_nodes; PM_ERR_CANCELLED from the progress
 * callback; PM_ERR_GEOM / PM_ERR_BACKEND from the method. */
PM_API pm_status pm_generate(const pm_model *model, const pm_sizing *size,
                             const pm_method *method, const pm_method_params *params,
                             const pm_generate_options *opts, pm_mesh **out,
                             pm_generate_result *result, pm_error *err);

/* ==== meshes ================================================================================= */

/* Views of a mesh's arrays. Nodes: xyz[3n]; each node's cell dimension (0..3, -1 unknown) and
 * cell index. Elements by dimension (1 segments, 2 triangles, 3 tets): dim + 1 node indices
 * each, and each element's cell index (-1 unknown). */
PM_API int32_t pm_mesh_node_count(const pm_mesh *m);
PM_API const double *pm_mesh_nodes(const pm_mesh *m);
PM_API const int8_t *pm_mesh_node_dims(const pm_mesh *m);
PM_API const int32_t *pm_mesh_node_cells(const pm_mesh *m);
PM_API int32_t pm_mesh_element_count(const pm_mesh *m, int dim);
PM_API const int32_t *pm_mesh_elements(const pm_mesh *m, int dim);
PM_API const int32_t *pm_mesh_element_cells(const pm_mesh *m, int dim);

/* Read a mesh (.msh, .vtk, .vtu, .stl, .mesh, .obj), made by packmesh or another tool. */
PM_API pm_status pm_mesh_read(const char *path, pm_mesh **out, pm_error *err);

/* Put the nodes that carry no cell (node dimension -1: a mesh read from .stl, .mesh, .obj, or
 * another tool's .msh, .vtk or .vtu) on the cells of `model` (in) they lie on -- a vertex or curve
 * within 1e-5 of the diagonal (and 1/20 of the node's shortest edge), else the nearest face, or
 * the volume of their tets -- with their parameters, and give their elements the cell of the
 * model (a file's own tags name no model cell). Then the measures that depend on where a node
 * lies (eps_t's interior nodes, the split of triangles by site, the checker's face patches) are
 * those of the same mesh written by packmesh with its tags. m (in-out); nodes with a cell are
 * kept. *classified and *unmatched (out, may be NULL): nodes classified, and nodes of triangles
 * or segments farther than 1e-3 of the diagonal from every cell (left at -1). */
PM_API pm_status pm_mesh_classify(pm_mesh *m, const pm_model *model, int32_t *classified,
                                  int32_t *unmatched, pm_error *err);

/* Write a mesh; the format follows the extension (.msh, .vtk, .vtu, .stl, .obj, .mesh), as
 * `packmesh mesh -o` writes it (per-element quality included in .msh and .vtu). The file is
 * written under a temporary name and renamed: on failure nothing is left at path. */
PM_API pm_status pm_mesh_write(const pm_mesh *m, const char *path, pm_error *err);
PM_API void pm_mesh_destroy(pm_mesh *m);

/* ==== quality and validity =================================================================== */

/* A five-number summary and the mean of n values (n = 0: every field 0). Percentiles
 * interpolate linearly between order statistics (Hyndman & Fan's type 7, as R and NumPy). */
typedef struct pm_summary {
  int64_t n;
  double min, p25, median, p75, max, mean;
} pm_summary;

/* The measures of one element (DESIGN.md "Quality measures"). */
typedef enum pm_measure {
  PM_MEASURE_RADIUS_RATIO = 0, /* 2 r_in / R (triangles), 3 r_in / R (tets): 1 is best */
  PM_MEASURE_ASPECT_RATIO,     /* R / l_min: 0.577 for an equilateral triangle */
  PM_MEASURE_MIN_ANGLE,        /* degrees; a tet's smallest dihedral angle */
  PM_MEASURE_MAX_ANGLE,        /* degrees; a tet's largest dihedral angle */
  PM_MEASURE_COUNT
} pm_measure;

/* The measures of every triangle and tet of a mesh, with the summaries of papers/003 section
 * 2.5 (eps_t, eps_g) and, with a size field, the size conformity (edge length over d). */
typedef struct pm_quality pm_quality;

/* Measure m (in) against size (in, may be NULL: no size conformity). */
PM_API pm_status pm_quality_measure(const pm_mesh *m, const pm_sizing *size, pm_quality **out,
                                    pm_error *err);
/* The summary of one measure over the elements of dimension dim (2 or 3). */
PM_API pm_status pm_quality_summary(const pm_quality *q, int dim, pm_measure what,
                                    pm_summary *out, pm_error *err);
/* The per-element values, in element order (a view; *n receives their number). */
PM_API const double *pm_quality_values(const pm_quality *q, int dim, pm_measure what,
                                       int32_t *n);
/* papers/003 eq. 8 and eq. 9 for dimension dim; and the summary of edge length / d (n = 0
 * without a size field). */
PM_API double pm_quality_eps_t(const pm_quality *q, int dim);
PM_API double pm_quality_eps_g(const pm_quality *q, int dim);
PM_API pm_summary pm_quality_size_ratio(const pm_quality *q, int dim);
PM_API void pm_quality_destroy(pm_quality *q);

/* The checker's verdict on a mesh, against its model when given: duplicate nodes or elements,
 * inverted or flat elements, non-manifold edges, holes, nodes off their cells, self-intersecting
 * surfaces, tets that do not tile their volume. */
typedef struct pm_check_result {
  int valid;               /* 1 when no problem was found */
  int nproblem;            /* lines in problem[] */
  char problem[24][320];   /* one line per kind of problem found: its count and first case */
} pm_check_result;

/* Check m (in) against model (in, may be NULL). PM_OK when the check ran, whatever the
 * verdict. */
PM_API pm_status pm_mesh_validate(const pm_mesh *m, const pm_model *model, pm_check_result *out,
                                  pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PACKMESH_PACKMESH_H */
