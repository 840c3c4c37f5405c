/* The interface every mesher implements -- ours (bubble, psys) and the classic peers (gmsh's
 * algorithms, CGAL's Mesh_2) -- so that `packmesh mesh`, the comparison harness and the tests run
 * them the same way, on the same model with the same size field, and measure the result with the
 * same quality module.
 *
 * A method is a pm_method descriptor: its name, its parameter table (params.h: defaults, --set,
 * --help, range checks, all from one table) and its run function. The command line (src/cli)
 * holds the table of methods; methods never include each other.
 *
 * A method reports while it runs through an observer (pm_run_observer): its phase times and
 * counters, one trace row per iteration, snapshots of its particles. It does not know where they
 * go: report/run_report.h sends them to the stats, the trace and the frames of `packmesh mesh`,
 * the public API to a progress callback that may cancel the run.
 */
#ifndef PM_METHOD_H
#define PM_METHOD_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdint.h>

#include "common/base/params.h"
#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/sizing/sizing.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A snapshot of a running method's particles (the observer's frame callback), for --frames: the
 * arrays are borrowed for the call, [n] each unless said otherwise. */
typedef struct pm_run_frame {
  int64_t step;            /* the step or iteration it follows (the trace's step column) */
  int phase;               /* the method's phase (the trace's phase column) */
  const char *phase_name;  /* what the phase does ("surface", "faces", ...) */
  int32_t n;
  const double *xyz;       /* [3n] */
  const double *radius;    /* the particle's size: a bubble's radius, a psys particle's sigma */
  double draw_scale;       /* pictures draw particle i as a circle of draw_scale * radius[i] */
  const int8_t *dim;       /* the dimension of its cell */
  const int32_t *cell;     /* its cell's index in its dimension; NULL: no triangulation drawn */
  const double *par;       /* [2n] its parameters on the cell (t, or (u, v)); with cell */
  const double *energy;    /* may be NULL: the particle's energy, which pictures colour by */
} pm_run_frame;

/* Where a running method reports. Every callback may be NULL (the report is not wanted); ctx is
 * passed back to each. A callback that returns a status other than PM_OK stops the run, which
 * returns that status (PM_ERR_CANCELLED when the caller asked to stop). */
typedef struct pm_run_observer {
  void *ctx;
  /* The names of the trace columns, once, before the first row. */
  pm_status (*trace_columns)(void *ctx, int ncol, const char *const *names, pm_error *err);
  /* One row per iteration, ncol values in the order of the names. */
  pm_status (*trace_row)(void *ctx, const double *row, pm_error *err);
  /* A snapshot of the particles. The caller closes the series after the run. */
  pm_status (*frame)(void *ctx, const pm_run_frame *frame, pm_error *err);
  /* The seconds a phase took ("place", "connect", ...), and the method's own numbers and texts
   * ("bubble.steps", "psys.particles", ...), under the keys of DESIGN.md's stats. */
  pm_status (*time)(void *ctx, const char *phase, double seconds, pm_error *err);
  pm_status (*number)(void *ctx, const char *key, double value, pm_error *err);
  pm_status (*text)(void *ctx, const char *key, const char *text, pm_error *err);
} pm_run_observer;

/* The calls a method makes: each is PM_OK when o or its callback is NULL. */
static inline int pm_observe_wants_trace(const pm_run_observer *o) { return o && o->trace_row; }
static inline int pm_observe_wants_frames(const pm_run_observer *o) { return o && o->frame; }
static inline pm_status pm_observe_trace_columns(const pm_run_observer *o, int ncol,
                                                 const char *const *names, pm_error *err) {
  return o && o->trace_columns ? o->trace_columns(o->ctx, ncol, names, err) : PM_OK;
}
static inline pm_status pm_observe_trace_row(const pm_run_observer *o, const double *row,
                                             pm_error *err) {
  return o && o->trace_row ? o->trace_row(o->ctx, row, err) : PM_OK;
}
static inline pm_status pm_observe_frame(const pm_run_observer *o, const pm_run_frame *frame,
                                         pm_error *err) {
  return o && o->frame ? o->frame(o->ctx, frame, err) : PM_OK;
}
static inline pm_status pm_observe_time(const pm_run_observer *o, const char *phase,
                                        double seconds, pm_error *err) {
  return o && o->time ? o->time(o->ctx, phase, seconds, err) : PM_OK;
}
static inline pm_status pm_observe_number(const pm_run_observer *o, const char *key,
                                          double value, pm_error *err) {
  return o && o->number ? o->number(o->ctx, key, value, err) : PM_OK;
}
static inline pm_status pm_observe_text(const pm_run_observer *o, const char *key,
                                        const char *text, pm_error *err) {
  return o && o->text ? o->text(o->ctx, key, text, err) : PM_OK;
}

typedef struct pm_run_input {
  const pm_model *model;   /* borrowed */
  const pm_sizing *size;   /* borrowed; the desired edge length. NULL: the method's own default
                              (bubble: its default rule; psys: its inferred field) */
  uint64_t seed;           /* fixes every random choice of the run */
  int threads;             /* >= 1: OpenMP threads the method may use; the result must not
                              depend on it */
  int volume;              /* 1: also mesh the model's volumes with tets */
  int64_t max_nodes;       /* cap on the node count, > 0; exceeding it is PM_ERR_LIMIT */
  const pm_run_observer *observer; /* borrowed, may be NULL: nothing is reported */
} pm_run_input;

typedef struct pm_run_output {
  pm_mesh *mesh;           /* out: created by the method, freed by the caller */
  int64_t iterations;      /* out: steps / iterations the method ran (0 for direct meshers) */
  char stop_reason[128];   /* out: what ended the run ("converged: ...", "max steps", ...) */
} pm_run_output;

typedef struct pm_method {
  const char *name;        /* what --method names */
  const char *description; /* one line */
  const pm_param_table *params; /* may be NULL (no parameters) */
  size_t params_size;      /* sizeof the parameter struct (0 when none) */
  void (*params_init)(void *params); /* defaults; may be NULL when params is NULL */
  /* Run. `params` points to a checked parameter struct of params_size bytes. On failure
   * out->mesh is NULL. */
  pm_status (*run)(const pm_run_input *in, const void *params, pm_run_output *out,
                   pm_error *err);
  int planar_only;         /* 1 when the method meshes planar domains only (CGAL Mesh_2) */
  int needs_size;          /* 1 when the method has no default size of its own */
  /* May be NULL: the size field the method uses when it is given none (in->size == NULL), as a
   * pm_sizing the caller owns -- so that a caller can scale it (--target-nodes, matched node
   * counts in comparisons). */
  pm_status (*default_size)(const pm_model *model, const void *params, uint64_t seed,
                            int threads, pm_sizing **out, pm_error *err);
} pm_method;

/* Default node cap of a run (the CLI's --max-nodes default). */
#define PM_DEFAULT_MAX_NODES 20000000

#ifdef __cplusplus
}
#endif

#endif /* PM_METHOD_H */
