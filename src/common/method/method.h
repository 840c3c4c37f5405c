/* The interface every mesher implements -- ours (bubble, psys) and the classic peers (gmsh's
 * algorithms, CGAL's Mesh_2) -- so that `packmesh mesh`, the comparison harness and the tests run
 * them the same way, on the same model with the same size field, and measure the result with the
 * same quality module.
 *
 * A method is a pm_method descriptor: its name, its parameter table (params.h: defaults, --set,
 * --help, range checks, all from one table) and its run function. The command line (src/cli)
 * holds the table of methods; methods never include each other.
 */
#ifndef PM_METHOD_H
#define PM_METHOD_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdint.h>

#include "common/report/frames.h"
#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/base/params.h"
#include "common/sizing/sizing.h"
#include "common/report/stats.h"
#include "common/report/trace.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_run_input {
  const pm_model *model;   /* borrowed */
  const pm_sizing *size;   /* borrowed; the desired edge length. NULL: the method's own default
                              (bubble: its default rule; psys: its inferred field) */
  uint64_t seed;           /* fixes every random choice of the run */
  int threads;             /* >= 1: OpenMP threads the method may use; the result must not
                              depend on it */
  int volume;              /* 1: also mesh the model's volumes with tets */
  int64_t max_nodes;       /* cap on the node count, > 0; exceeding it is PM_ERR_LIMIT */
  pm_trace *trace;         /* borrowed, may be NULL: one row per iteration (the method sets the
                              columns) */
  pm_frames *frames;       /* borrowed, may be NULL: snapshots of the particles */
} pm_run_input;

typedef struct pm_run_output {
  pm_mesh *mesh;           /* out: created by the method, freed by the caller */
  int64_t iterations;      /* out: steps / iterations the method ran (0 for direct meshers) */
  char stop_reason[128];   /* out: what ended the run ("converged: ...", "max steps", ...) */
  pm_stats *stats;         /* in, may be NULL: the method adds its phase times ("place",
                              "connect", ...) and extra keys; the caller fills the rest */
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
