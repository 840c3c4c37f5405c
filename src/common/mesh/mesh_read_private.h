/* The mesh readers' shared machinery (mesh_read.c), used by one parser per format
 * (mesh_read_msh.c, mesh_read_vtk.c, mesh_read_vtu.c, mesh_read_stl.c, mesh_read_medit.c,
 * mesh_read_obj.c).
 *
 * A parser never trusts the file: it reads from a buffer holding the whole file (with a '\0'
 * after its last byte), every count the file declares is checked against the bytes left before
 * anything is sized from it (rd_room), every number is parsed whole and range-checked (rd_int,
 * rd_double), every coordinate must be finite and within PM_COORD_MAX, and node references are
 * resolved against the nodes the file defines (rd_finish). Memory therefore grows with what the
 * file holds, never with what it claims: at most a small multiple of the file's size.
 *
 * Messages name the file and the place ("x.msh line 145: ..." for text, "x.msh byte 2048: ..."
 * for binary data), and what is wrong, on one line.
 */
#ifndef PM_MESH_READ_PRIVATE_H
#define PM_MESH_READ_PRIVATE_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdint.h>

#include "common/mesh/mesh.h"

/* A node as a file gives it: its tag (the file's number for it), coordinates, and its
 * classification when the file has one (dim -1 otherwise). */
typedef struct rd_node {
  uint64_t tag;
  double xyz[3], par[2];
  int32_t cell;
  int8_t dim;
} rd_node;

/* A line (kind 1), triangle (2), tet (3) or, for classification only, a point element (0):
 * its tag, its corner nodes' tags and its cell (-1 untagged). seq is the order in the file. */
typedef struct rd_elem {
  uint64_t tag, seq;
  uint64_t node[4];
  int32_t cell;
  int8_t kind;
} rd_elem;

typedef struct pm_rd {
  /* In */
  const char *name;              /* the file, for messages (borrowed) */
  const char *base, *end;        /* the bytes [base, end); *end == '\0' */
  const char *p;                 /* the cursor */
  pm_error *err;
  /* How rd_finish reads what was collected; set by the parser. */
  int classify_by_elements;      /* MSH 2: a node lies on the entity of the lowest-dimensional
                                    element that uses it (gmsh's rule for that format) */
  int unique_elem_tags;          /* element tags must not repeat (MSH: one numbering) */
  const char *node_word;         /* "node", "point", "vertex": what the format calls a node */
  /* Collected */
  rd_node *node;
  size_t nnode, cap_node;
  rd_elem *el;
  size_t nel, cap_el;
  uint64_t *ho;                  /* tags of higher-order (non-corner) nodes of elements */
  size_t nho, cap_ho;
} pm_rd;

/* A gmsh element type (MSH files): its family and node count. */
typedef struct rd_elem_type {
  int type;          /* gmsh's number */
  int kind;          /* 0 point, 1 line, 2 triangle, 3 tet; -1 a type packmesh does not read */
  int nnode;         /* nodes per element, corners first */
  const char *family;/* "Triangle", "Quadrilateral", ... (gmsh's name is family + nnode) */
} rd_elem_type;

/* The type `type` of gmsh's table, or NULL when gmsh defines no such type. */
const rd_elem_type *pm_rd_elem_type(int type);

/* ---- errors ---- */

/* Fill the error with "<file> line L: <message>" (or "byte B" when `binary`) for the place `at`;
 * returns PM_ERR_PARSE. */
pm_status pm_rd_fail(pm_rd *r, const char *at, int binary, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* Copy up to 24 bytes of a token for a message, replacing what is not printable. */
void pm_rd_quote(const char *tok, size_t len, char out[40]);

/* ---- text ---- */

/* Skip spaces, tabs and line breaks. */
void pm_rd_skip_space(pm_rd *r);
/* Skip to just after the next line break (or to the end). */
void pm_rd_skip_line(pm_rd *r);
/* The next whitespace-delimited token; 0 at the end of the buffer. */
int pm_rd_token(pm_rd *r, const char **tok, size_t *len);
/* 1 when the next token equals word (case-sensitive unless nocase); consumed only then. */
int pm_rd_peek_word(pm_rd *r, const char *word, int nocase);
/* The next token must be `word`: PM_ERR_PARSE naming `what` otherwise. */
pm_status pm_rd_expect(pm_rd *r, const char *word, int nocase, const char *what);
/* The next token as a whole number in [lo, hi], an unsigned one >= lo, or a number (any value
 * strtod reads; finiteness is the caller's check). `what` (printf-style, formatted only when
 * the token is wrong) names the value in the message. */
pm_status pm_rd_int(pm_rd *r, int64_t lo, int64_t hi, int64_t *out, const char *what, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;
pm_status pm_rd_uint(pm_rd *r, uint64_t lo, uint64_t *out, const char *what, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
pm_status pm_rd_double(pm_rd *r, double *out, const char *what, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---- binary ---- */

/* Take n bytes at the cursor: PM_ERR_PARSE naming `what` when fewer are left. */
pm_status pm_rd_bytes(pm_rd *r, size_t n, const char *what, const unsigned char **out);
/* Decode little- or big-endian values (swap: the file's byte order differs from the host's). */
int32_t pm_rd_i32(const unsigned char *b, int swap);
uint32_t pm_rd_u32(const unsigned char *b, int swap);
uint64_t pm_rd_u64(const unsigned char *b, int swap);
double pm_rd_f64(const unsigned char *b, int swap);
float pm_rd_f32(const unsigned char *b, int swap);
/* 1 when the host is big-endian. */
int pm_rd_host_big(void);

/* ---- bounds ---- */

/* `count` items of at least `min_bytes` each must fit in the bytes left after the cursor:
 * PM_ERR_PARSE naming `what`, the count and the room otherwise. */
pm_status pm_rd_room(pm_rd *r, uint64_t count, uint64_t min_bytes, int binary, const char *what);

/* ---- what was read ---- */

/* Add a node; coordinates must be finite and within PM_COORD_MAX (the message names the node
 * and the place `at`). par may be NULL. */
pm_status pm_rd_node(pm_rd *r, const char *at, int binary, uint64_t tag, const double xyz[3],
                     int dim, int32_t cell, const double *par);
/* Add an element of `kind` with kind + 1 corner tags (a point element: kind 0, one tag). */
pm_status pm_rd_elem(pm_rd *r, int kind, uint64_t tag, const uint64_t *corners, int32_t cell);
/* Record the tag of a higher-order node (dropped unless some element has it as a corner). */
pm_status pm_rd_ho(pm_rd *r, uint64_t tag);

/* Resolve, check and build the mesh (*out on success). Elements come in order of kind
 * (lines, triangles, tets), each kind by increasing tag; nodes by increasing tag. */
pm_status pm_rd_finish(pm_rd *r, pm_mesh **out);

/* The cell an entity tag names: tag - 1, or -1 for PM_MSH_UNTAGGED and tags <= 0. */
int32_t pm_rd_cell_of_tag(int64_t tag);

/* One VTK cell (.vtk and .vtu) of VTK type `type` with points pts[0..n) (0-based indices):
 * checked against the type's point count and the npoint points, then added (a poly-line as
 * segments, quadratic cells reduced to their corners, vertices ignored); a type packmesh does not
 * read is PM_ERR_ARG naming it. Element tags follow the order of addition. */
pm_status pm_rd_vtk_cell(pm_rd *r, const char *at, int binary, int type, uint64_t index,
                         const uint64_t *pts, uint64_t n, uint64_t npoint, int32_t cell);

/* Parsers: each reads r->base..r->end into r and returns PM_OK or a filled error. */
pm_status pm_rd_parse_msh(pm_rd *r);
pm_status pm_rd_parse_vtk(pm_rd *r);
pm_status pm_rd_parse_vtu(pm_rd *r);
pm_status pm_rd_parse_stl(pm_rd *r);
pm_status pm_rd_parse_medit(pm_rd *r);
pm_status pm_rd_parse_obj(pm_rd *r);

#endif /* PM_MESH_READ_PRIVATE_H */
