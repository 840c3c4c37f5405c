/* The mesh validity checker: an expensive, thorough verdict on a mesh, run after every mesher
 * test (the role p4est_is_valid() plays for p4est).
 *
 * Without a model (generic checks):
 *   - element node indices in range, no element repeating a node;
 *   - no duplicate elements (same node set), no duplicate nodes (closer than
 *     PM_CHECK_DUP_NODE_REL times the mesh's bounding-box diagonal);
 *   - no zero-area triangles and no zero-volume tets (relative to the element's longest edge
 *     squared / cubed, the PM_DEGENERATE_REL of quality.h), no inverted tets (exact orient3d);
 *   - orientation: two triangles with the same cell tag that share an edge, and are the only
 *     ones of that tag there, run along it in opposite directions;
 *   - tets: a face is shared by at most two tets, which lie on opposite sides of it.
 * With a model (the cells the element tags name):
 *   - tags and node classifications name existing cells; a node lies on its element's cell or
 *     on a cell of that cell's closure (boundary curves and vertices, embedded cells);
 *   - every curve has segments when the mesh has segments, every face triangles when it has
 *     triangles, every volume tets when it has tets;
 *   - conformity: each segment of curve c is an edge of triangles of every face that c bounds
 *     or is embedded in; an edge of a face's triangle patch that has one triangle of that face
 *     carries a segment of one of the face's boundary curves; no edge has more than two
 *     triangles of one face;
 *   - orientation (mesh.h, geom.h pm_face_mesh_sign): a face's triangles point out of the first
 *     volume the face bounds, and follow its natural normal Su x Sv when it bounds none. So the
 *     triangles of face f, seen from volume v, point out of v when multiplied by
 *     pm_face_mesh_sign(f) x sense(f in v) (pm_use.sense: +1 when Su x Sv points out of v);
 *   - closed shells: for each volume, the triangles of its bounding faces use every edge exactly
 *     twice, or, along a curve, as many times as the shell's faces use that curve (non-manifold
 *     edges counted per shell); with the signs above, neighbouring triangles are consistently
 *     oriented and the shell encloses a positive volume; each shell's Euler characteristic
 *     V - E + F is reported (pm_check_shell);
 *   - triangles follow their face's orientation: a triangle is judged at its nodes classified on
 *     the face (whose parameters evaluate back to the node, within 1e-6 of the diagonal, so that
 *     files without parameters are not misjudged; not where Su x Sv vanishes; not for faces
 *     without an evaluator) by the sign of pm_face_mesh_sign(f) ((b - a) x (c - a)) . (Su x Sv).
 *     A face is reported when most of its judged triangle area disagrees (a reversed face), a
 *     triangle when it disagrees at every one of its face nodes, two at least (a fold). One node
 *     is not enough to judge a triangle: near an apex or a pole the surface normal turns by more
 *     than 90 degrees across one good, coarse triangle;
 *   - tets of a volume: their boundary faces are exactly the triangles of the volume's shell,
 *     oriented outward, and the triangles of faces embedded in the volume have tets of that
 *     volume on both sides; segments of curves embedded in a volume are tet edges.
 *
 * Cost: linear in the mesh size (edge and face tables of mesh_topo.h, a hash grid for duplicate
 * nodes); no pairwise comparison of elements.
 */
#ifndef PM_MESH_CHECK_H
#define PM_MESH_CHECK_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PM_CHECK_DUP_NODE_REL 1e-10 /* duplicate-node distance, relative to the bbox diagonal */
#define PM_CHECK_MAX_PROBLEMS 32    /* problem strings kept in a report */

/* Kinds of problem, counted separately (count[] of the report). */
typedef enum pm_check_kind {
  PM_CHECK_INDEX = 0,        /* node index out of range, or an element repeating a node */
  PM_CHECK_CELL_TAG,         /* element tag or node classification naming no cell of the model */
  PM_CHECK_DUP_NODE,         /* nodes closer than the duplicate tolerance */
  PM_CHECK_DUP_ELEMENT,      /* two elements with the same node set */
  PM_CHECK_ZERO_AREA,        /* degenerate triangle */
  PM_CHECK_ZERO_VOLUME,      /* degenerate tet */
  PM_CHECK_INVERTED,         /* tet with negative orientation */
  PM_CHECK_ORIENTATION,      /* neighbouring triangles of one face disagree */
  PM_CHECK_CLASSIFICATION,   /* node classified on a cell outside its element's cell closure */
  PM_CHECK_MISSING,          /* a model cell with no elements */
  PM_CHECK_SEG_CONFORM,      /* segment not an edge of the triangles of a face its curve bounds */
  PM_CHECK_PATCH_BOUNDARY,   /* face patch boundary edge without a boundary-curve segment */
  PM_CHECK_FACE_NONMANIFOLD, /* more than two triangles of one face along an edge */
  PM_CHECK_SHELL_OPEN,       /* volume shell edge used a wrong number of times */
  PM_CHECK_SHELL_ORIENTATION,/* neighbouring shell triangles disagree */
  PM_CHECK_SHELL_INWARD,     /* a closed shell whose triangles point inwards */
  PM_CHECK_TET_FACE,         /* face of more than two tets, or two tets on one side of it */
  PM_CHECK_TET_BOUNDARY,     /* tet boundary faces differ from the shell triangles */
  PM_CHECK_FACE_NORMAL,      /* reversed face or folded triangle (pm_face_mesh_sign) */
  PM_CHECK_NKIND
} pm_check_kind;

/* A short description of a kind ("zero-area triangles"). */
const char *pm_check_kind_name(pm_check_kind k);

/* The triangles of one volume's shell (model given), or of the whole mesh (no model: volume -1,
 * every triangle with sense +1). */
typedef struct pm_check_shell {
  int32_t volume;      /* volume index, -1 for the whole mesh */
  int64_t nodes, edges, triangles; /* V, E, F */
  int64_t euler;       /* V - E + F */
  int32_t components;  /* connected components (triangles joined through shared nodes) */
  int64_t open_edges;  /* edges not used twice (shell: not as expected) */
  int closed;          /* open_edges == 0 and triangles > 0 */
  int32_t genus;       /* (2 components - euler) / 2 when closed, every edge has two triangles
                          and the result is a whole number >= 0; else -1 */
  double enclosed;     /* signed volume enclosed by the oriented triangles */
} pm_check_shell;

typedef struct pm_check_report {
  int valid;                  /* 1 when no problem was found */
  int64_t count[PM_CHECK_NKIND]; /* offending items per kind */
  int32_t nproblem;           /* strings in problem[] */
  char problem[PM_CHECK_MAX_PROBLEMS][320]; /* one line per kind found: count and first case */
  int32_t nshell;
  pm_check_shell *shell;      /* [nshell], owned; freed by pm_check_report_clear */
} pm_check_report;

/* Check m, against model when it is not NULL (element tags are then cell indices). out is
 * overwritten (release a previous report with pm_check_report_clear first). Returns PM_OK when
 * the check ran, whatever the verdict; an error only for a NULL argument or an allocation
 * failure (out is then cleared). */
pm_status pm_mesh_check(const pm_mesh *m, const pm_model *model, pm_check_report *out,
                        pm_error *err);

/* Release the shells and zero the report. Accepts a zeroed report. */
void pm_check_report_clear(pm_check_report *r);

#ifdef __cplusplus
}
#endif

#endif /* PM_MESH_CHECK_H */
