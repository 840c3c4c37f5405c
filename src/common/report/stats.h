/* The run record every mesher fills and the command writes with --stats, its JSON form (the keys
 * of DESIGN.md, "--stats writes JSON with at least these keys"), its flattened form for tidy CSV
 * tables ("tri.radius_ratio.mean" = value), and the per-element CSV used for box plots.
 *
 * JSON layout (keys in this order; a key whose data was not computed is left out):
 *   method, input                      text
 *   nodes, segments, triangles, tets   counts
 *   valid, problems                    the checker's verdict and problem lines (mesh_check.h)
 *   shells                             per shell: volume, euler, components, closed, genus
 *   iterations                         number (0 when the method has none)
 *   time_s                             {"total": s, then each phase set, in order}
 *   tri   (when the mesh has triangles)
 *     radius_ratio, aspect_ratio, min_angle_deg, max_angle_deg   summaries (below)
 *     eps_t (when there are interior nodes), eps_g, size_ratio {mean, std, min, p25, median,
 *     p75, max} (when a size field was given), count, degenerate, eps_t_nodes,
 *     min_angle_bins {"0_10", "10_20", "20_30", "30_40", "40_50", "50_60"},
 *     max_angle_over {"90", "120", "150"}
 *   tet   (when the mesh has tets)
 *     radius_ratio, aspect_ratio, min_dihedral_deg, max_dihedral_deg, eps_t, eps_g,
 *     size_ratio, count, degenerate, eps_t_nodes
 *   distance {mean, max, bbox_diagonal}  (when computed)
 *   extra keys added by a method; "a.b" nests as {"a": {"b": ...}}
 * A summary is {"min", "p25", "median", "p75", "max", "mean"} (quality.h for the convention).
 *
 * Flattening: nested objects join their keys with dots; an array of numbers or strings becomes
 * one text value joined by " | " (so "problems" stays one column); an array of objects is
 * flattened by index ("shells.0.euler"); true / false become the text "true" / "false", null an
 * empty text.
 */
#ifndef PM_STATS_H
#define PM_STATS_H

#include <packmesh/packmesh.h>

#include <stdint.h>
#include <stdio.h>

#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/needles.h"
#include "common/measure/quality.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A named number or text (extras, timings, flattened values). */
typedef struct pm_stats_item {
  char *key;   /* owned */
  int is_text;
  int is_bool; /* a number written as true (num != 0) or false */
  double num;  /* when !is_text */
  char *text;  /* owned, when is_text */
} pm_stats_item;

typedef struct pm_stats {
  char method[64];      /* "bubble", "psys", "gmsh-frontal", "external", ... */
  char input[1024];     /* "case:qi3", a file name, ... */
  int64_t nodes, segments, triangles, tets;

  int has_check;        /* valid / problems / shells are written only when set */
  int valid;
  int32_t nproblem;
  char **problems;      /* [nproblem] owned */
  int32_t nshell;
  pm_check_shell *shells; /* [nshell] owned */

  int64_t iterations;

  double time_total;    /* seconds */
  int32_t ntime;
  pm_stats_item *time;  /* [ntime] owned: phases ("place", "connect", ...) in order */

  int has_quality;
  pm_quality quality;   /* summaries only: the per-element arrays are never kept here */

  int has_distance;
  double dist_mean, dist_max, bbox_diagonal;

  int32_t nextra;
  pm_stats_item *extra; /* [nextra] owned */
} pm_stats;

/* Zero s (method "", no check, no quality, no distance). */
void pm_stats_init(pm_stats *s);

/* Release everything s owns and re-initialize it. */
void pm_stats_clear(pm_stats *s);

/* Method and input names (copied, truncated to the field sizes). */
void pm_stats_set_run(pm_stats *s, const char *method, const char *input);

/* Node and element counts of m. */
void pm_stats_set_mesh(pm_stats *s, const pm_mesh *m);

/* The checker's verdict, problems and shells (copied). */
pm_status pm_stats_set_check(pm_stats *s, const pm_check_report *r, pm_error *err);

/* The quality summaries of q (copied; q keeps its arrays). */
void pm_stats_set_quality(pm_stats *s, const pm_quality *q);

/* The needles (needles.h) under "tri.needles": count, forced (= corner + feature), unforced,
 * corner, feature, and the limit in degrees. */
pm_status pm_stats_set_needles(pm_stats *s, const pm_needles *n, double limit, pm_error *err);

/* A phase time in seconds ("total" sets time_total; another name is added, or replaced when it
 * was set before). Dots nest: "bubble.force" is time_s.bubble.force, {"bubble": {"force": ..}}
 * in JSON; a name that is a dotted prefix of another ("a" and "a.b") is PM_ERR_ARG. */
pm_status pm_stats_set_time(pm_stats *s, const char *phase, double seconds, pm_error *err);

/* The two-sided mesh-to-model distance and the model's bounding-box diagonal. */
void pm_stats_set_distance(pm_stats *s, double mean, double max, double bbox_diagonal);

/* An extra key (dots nest). Extras may add keys inside the standard objects tri, tet and
 * distance ("distance.rel_mean"), but not replace their standard keys; a key whose first part is
 * another standard key (method, input, nodes, ..., time_s: use pm_stats_set_time), or one that
 * was added before, is PM_ERR_ARG. */
pm_status pm_stats_add_number(pm_stats *s, const char *key, double value, pm_error *err);
pm_status pm_stats_add_text(pm_stats *s, const char *key, const char *text, pm_error *err);
pm_status pm_stats_add_bool(pm_stats *s, const char *key, int value, pm_error *err);

/* The JSON text (indented, ending with a newline); *out is malloc'ed, free() it. Non-finite
 * numbers are written as null. */
pm_status pm_stats_to_json(const pm_stats *s, char **out, pm_error *err);

/* Write the JSON to path atomically (temporary file in the same folder, then rename). */
pm_status pm_stats_write_json(const pm_stats *s, const char *path, pm_error *err);

/* ---- flattening ------------------------------------------------------------------------- */

typedef struct pm_stats_flat {
  int32_t n;
  pm_stats_item *item; /* [n] owned, in document order */
} pm_stats_flat;

/* Flatten the record (as its JSON would be) or any JSON object text. */
pm_status pm_stats_flatten(const pm_stats *s, pm_stats_flat *out, pm_error *err);
pm_status pm_stats_flatten_json(const char *json, pm_stats_flat *out, pm_error *err);
void pm_stats_flat_clear(pm_stats_flat *f);

/* The item named key, or NULL. */
const pm_stats_item *pm_stats_flat_find(const pm_stats_flat *f, const char *key);

/* ---- CSV ---------------------------------------------------------------------------------- */

/* One CSV field (RFC 4180: quoted when it holds a comma, a quote or a line break). */
void pm_csv_field(FILE *f, const char *text);

/* A number as the shortest text that reads back to the same double (%.15g, else %.17g);
 * non-finite values as an empty field. */
void pm_csv_number(FILE *f, double x);

/* A header row of the flattened keys, and a row of their values. */
void pm_stats_flat_csv_header(FILE *f, const pm_stats_flat *flat);
void pm_stats_flat_csv_row(FILE *f, const pm_stats_flat *flat);

/* Per-element measures, one row per element, for box plots:
 *   kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg
 * kind is "tri" or "tet" (for tets the angles are dihedral angles); index is the element's index
 * in the mesh, cell its tag. q must come from pm_quality_compute_fn on m. PM_ERR_IO when the
 * stream fails. */
pm_status pm_stats_write_elements_csv(FILE *f, const pm_mesh *m, const pm_quality *q,
                                      pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_STATS_H */
