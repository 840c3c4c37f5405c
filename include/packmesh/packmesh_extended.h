/* packmesh: the extended C API.
 *
 * packmesh.h is enough to mesh, measure and write. This header adds what the packmesh command
 * itself is built from, for a program that wants to do exactly what `packmesh mesh` and
 * `packmesh quality` do:
 *   - the run's record (pm_report): the --stats JSON of docs/DESIGN.md, the per-iteration trace
 *     (--trace) and the particle snapshots (--frames), filled by pm_generate_report and by the
 *     same measuring (checker, quality, needles, two-sided distance) the command runs;
 *   - the fit checks of a run made before any file is written, and the method tables as text;
 *   - file formats by extension, and output sets that appear together or not at all.
 * The packmesh command uses packmesh.h and this header and nothing else of the library.
 *
 * The conventions of packmesh.h hold here too (errors, ownership, threads).
 */
#ifndef PACKMESH_PACKMESH_EXTENDED_H
#define PACKMESH_PACKMESH_EXTENDED_H

#include <packmesh/packmesh.h>

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ==== methods ================================================================================ */

/* "bubble, psys, gmsh-frontal, ..." (every method, in pm_method_at order) into buf (out, len
 * bytes, truncated to fit). */
PM_API void pm_method_names(char *buf, size_t len);

/* Set a parameter from "KEY=VALUE", as `packmesh mesh --set` takes it. */
PM_API pm_status pm_method_params_set_pair(pm_method_params *p, const char *pair, pm_error *err);

/* The table of m's parameters (name, default, range, unit, source, meaning) as
 * `packmesh mesh --method M --help` prints it, to f; "(no parameters)" for a method without. */
PM_API void pm_method_help(const pm_method *m, FILE *f);

/* ==== the fit of a run ======================================================================= */

/* Which choice of a run does not fit the model and method. */
typedef enum pm_generate_misfit {
  PM_MISFIT_NONE = 0,
  PM_MISFIT_PLANAR_ONLY, /* a planar-only method on a model that is not planar */
  PM_MISFIT_VOLUME,      /* volume meshing asked for, on a model without volumes */
  PM_MISFIT_TARGET       /* a node target without a size field, for a method with no default */
} pm_generate_misfit;

/* PM_ERR_ARG when the choices of a run (all in; size and opts may be NULL) do not fit the model
 * and method, *misfit (out, may be NULL) saying which; pm_generate makes the same check. */
PM_API pm_status pm_generate_check(const pm_model *model, const pm_sizing *size,
                                   const pm_method *method, const pm_generate_options *opts,
                                   pm_generate_misfit *misfit, pm_error *err);

/* ==== the record of a run ==================================================================== */

/* A run's record: its stats (the JSON keys of docs/DESIGN.md), and when asked its trace and
 * frames. Not thread-safe: one report per run. */
typedef struct pm_report pm_report;

/* A new, empty record for `method` and `input` (in: the names the stats carry, e.g. "bubble"
 * and "case:qi3"; "external" for a mesh measured from a file). */
PM_API pm_status pm_report_create(const char *method, const char *input, pm_report **out,
                                  pm_error *err);
PM_API void pm_report_destroy(pm_report *r);

/* Keep the trace of the method's iterations (one row per iteration; the particle methods only,
 * pm_method_traces). Call before the run. */
PM_API pm_status pm_report_record_trace(pm_report *r, pm_error *err);

/* Write snapshots of the particles into the folder dir (in; created if missing) as the run goes,
 * for model (borrowed: must outlive r). Call before the run; pm_report_finish_frames completes
 * the folder's index. */
PM_API pm_status pm_report_record_frames(pm_report *r, const char *dir, const pm_model *model,
                                         pm_error *err);

/* pm_generate, with the method's phase times, numbers, texts, trace rows and frames kept in r
 * (in-out, may be NULL). Over the runs of a node-target search r describes the last run only.
 * *final_size (out, may be NULL) receives the field of the last run when it is not `size` (a
 * scaled field, or the method's default made for a node target), else NULL. */
PM_API pm_status pm_generate_report(const pm_model *model, const pm_sizing *size,
                                    const pm_method *method, const pm_method_params *params,
                                    const pm_generate_options *opts, pm_report *r,
                                    pm_sizing **final_size, pm_mesh **out,
                                    pm_generate_result *result, pm_error *err);

/* What pm_report_measure measures (or'ed). */
enum {
  PM_REPORT_CHECK = 1,    /* the checker's verdict, problems and shells (against the model) */
  PM_REPORT_QUALITY = 2,  /* counts, quality summaries (size ratio with a field), needles */
  PM_REPORT_DISTANCE = 4, /* the two-sided mesh-to-model distance (needs the model; skipped for
                              a mesh without segments or triangles) */
  PM_REPORT_TIMES = 8,    /* record time_s.check, .quality, .distance, and the model's loading
                              as time_s.load and time_s.setup */
  PM_REPORT_ALL = 15
};

/* Measure m (in) against model (in, may be NULL) and the size field (in, may be NULL) into r.
 * The measures are kept whole for pm_report_write_table and pm_report_write_elements_csv. Each
 * measure is taken once per report: asking for one again is PM_ERR_ARG and changes nothing.
 * Separate calls may take different ones (PM_REPORT_DISTANCE after the others, to tell its
 * failure apart). */
PM_API pm_status pm_report_measure(pm_report *r, const pm_mesh *m, const pm_model *model,
                                   const pm_sizing *size, unsigned what, pm_error *err);

/* The run's settings and outcome, as `packmesh mesh --stats` records them: iterations,
 * stop_reason, seed, threads, heal (the model's), size (final_size's description, or "method
 * default"), the node-target keys when opts asked for a target, and params.KEY for every
 * parameter of params (in, may be NULL: the method's defaults). */
PM_API pm_status pm_report_record_run(pm_report *r, const pm_model *model,
                                      const pm_method *method, const pm_method_params *params,
                                      const pm_generate_options *opts,
                                      const pm_generate_result *result,
                                      const pm_sizing *final_size, pm_error *err);

/* A phase time in seconds ("total", or a phase name; dots nest: "bubble.force"), and extra keys
 * (dots nest; a standard key, or one added before, is PM_ERR_ARG). */
PM_API pm_status pm_report_set_time(pm_report *r, const char *phase, double seconds,
                                    pm_error *err);
PM_API pm_status pm_report_add_number(pm_report *r, const char *key, double value, pm_error *err);
PM_API pm_status pm_report_add_text(pm_report *r, const char *key, const char *text,
                                    pm_error *err);

/* The stats JSON (indented, ending with a newline); *json (out) is malloc'ed: free() it. */
PM_API pm_status pm_report_stats_json(const pm_report *r, char **json, pm_error *err);
/* The stats JSON, the trace CSV (PM_ERR_ARG when no trace was recorded), written to path. */
PM_API pm_status pm_report_write_stats(const pm_report *r, const char *path, pm_error *err);
PM_API pm_status pm_report_write_trace(const pm_report *r, const char *path, pm_error *err);
/* Complete the frames' folder (its index); PM_OK when no frames were recorded. */
PM_API pm_status pm_report_finish_frames(pm_report *r, pm_error *err);

/* The measures of the last pm_report_measure as the readable table of `packmesh quality`, to f;
 * `geometry` (in, may be NULL) names the model it was measured against. */
PM_API pm_status pm_report_write_table(const pm_report *r, const char *geometry, FILE *f,
                                       pm_error *err);
/* One CSV row per triangle and tet of m (in: the mesh of the last pm_report_measure, with
 * PM_REPORT_QUALITY), as `packmesh quality --csv` prints it:
 *   kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg */
PM_API pm_status pm_report_write_elements_csv(const pm_report *r, const pm_mesh *m, FILE *f,
                                              pm_error *err);

/* ==== files ================================================================================== */

typedef enum pm_mesh_format {
  PM_MESH_MSH = 0,
  PM_MESH_VTK,
  PM_MESH_VTU,
  PM_MESH_STL,
  PM_MESH_OBJ,
  PM_MESH_MEDIT,
  PM_MESH_FORMAT_COUNT
} pm_mesh_format;

/* The format of a path from its extension; PM_ERR_ARG naming the extension when unknown. */
PM_API pm_status pm_mesh_format_of(const char *path, pm_mesh_format *fmt, pm_error *err);

/* 1 when files of format fmt hold elements of dimension dim (1 segments, 2 triangles, 3 tets):
 * .stl holds triangles only, .obj segments and triangles, the others all three. A writer leaves
 * out what its format cannot hold. */
PM_API int pm_mesh_format_holds(pm_mesh_format fmt, int dim);

/* The extension of a format, without the dot ("msh"). */
PM_API const char *pm_mesh_format_ext(pm_mesh_format fmt);

/* What a writer may add beyond the default (zero-initialize, then set). */
typedef struct pm_mesh_write_opts {
  int msh_parametric; /* 1: .msh nodes on curves and faces carry their parameters */
} pm_mesh_write_opts;

/* pm_mesh_write with options; opts (in) may be NULL (the defaults, as pm_mesh_write). */
PM_API pm_status pm_mesh_write_with(const pm_mesh *m, const char *path,
                                    const pm_mesh_write_opts *opts, pm_error *err);

/* ---- a set of outputs: written together or not at all ---- */

/* The files and folders one command writes: each is reserved before the work starts (a
 * temporary beside it; an unwritable destination is reported then, not after the work), written
 * under its temporary name, and all are renamed into place only once every one is complete. On
 * any failure none of them exists. */
typedef struct pm_outputs pm_outputs;

/* An empty set; NULL when out of memory. */
PM_API pm_outputs *pm_outputs_create(void);

/* Reserve `path` (a file, or a folder when `folder` is set) and return in *tmp (owned by the
 * set, valid until it is destroyed) the name to write it under: an empty temporary file with
 * the same extension in the same folder, or an empty temporary folder beside the destination
 * (whose missing parent folders are made, and removed again if the set is not committed).
 * PM_ERR_ARG when path names an output of the set already (pm_path_same); PM_ERR_IO naming path
 * when it cannot be written (a missing or read-only folder, a file where a folder is asked for
 * or the reverse). */
PM_API pm_status pm_outputs_add(pm_outputs *s, const char *path, int folder, const char **tmp,
                                pm_error *err);

/* Rename every temporary onto its destination, in the order added. A folder replaces a missing
 * or empty destination folder; into an existing folder its files are moved one by one. On
 * failure nothing of the set is left. */
PM_API pm_status pm_outputs_commit(pm_outputs *s, pm_error *err);

/* Remove what was not committed, and release the set. Accepts NULL. */
PM_API void pm_outputs_destroy(pm_outputs *s);

/* 1 when a and b name the same file: the same name in the same folder (folders compared by
 * device and inode when they exist, so that "x.msh" and "./x.msh" or a path through a link are
 * one file). Trailing slashes are ignored. */
PM_API int pm_path_same(const char *a, const char *b);

/* Remove every temporary file and folder the library has made and not yet renamed or removed,
 * the latest first: for a SIGINT / SIGTERM handler. Async-signal-safe. */
PM_API void pm_tmp_remove_all(void);

#ifdef __cplusplus
}
#endif

#endif /* PACKMESH_PACKMESH_EXTENDED_H */
