/* Connecting nodes on cells into a conforming mesh (see connect.h). */
#include "common/connect/connect.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/cdt_cgal.h"
#include "common/connect/face_smooth.h"
#include "common/base/clock.h"
#include "common/mesh/mesh_topo.h"
#include "common/base/hash.h"
#include "common/backends/predicates.h"
#include "common/mesh/element_measure.h"
#include "common/mesh/mesh_check.h"
#include "common/base/vec3.h"

void pm_connect_params_init(pm_connect_params *p) {
  memset(p, 0, sizeof *p);
  p->affine = 1;
  p->metric_flips = 1;
  p->drop_crossed = 1;
  p->flips = PM_FLIP_DIAMETRIC;
  p->max_flips_per_tri = 20;
  p->volume = PM_VOLUME_NONE;
  p->radius_edge = 1.5;
  p->max_volume = 0;
  p->max_nodes = 0;
  p->check_surface = 1;
  p->recovery_points = 1;
  p->smooth = 0;
}

/* ---- nodes grouped by cell --------------------------------------------------------------- */

/* For one dimension: the nodes of cell c are ids[off[c] .. off[c+1]). */
typedef struct buckets {
  int32_t *off, *ids;
} buckets;

static void buckets_free(buckets *b) {
  free(b->off), free(b->ids);
  b->off = b->ids = NULL;
}

static pm_status buckets_build(const pm_mesh *mesh, int dim, int32_t ncell, buckets *b,
                               pm_error *err) {
  b->off = calloc((size_t)ncell + 1, sizeof(int32_t));
  int32_t n = 0;
  for (int32_t i = 0; i < mesh->nnode; ++i) n += mesh->node_dim[i] == dim;
  b->ids = malloc(sizeof(int32_t) * (size_t)(n ? n : 1));
  if (!b->off || !b->ids) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == dim) b->off[mesh->node_cell[i] + 1]++;
  for (int32_t c = 0; c < ncell; ++c) b->off[c + 1] += b->off[c];
  int32_t *fill = malloc(sizeof(int32_t) * ((size_t)ncell + 1));
  if (!fill) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  memcpy(fill, b->off, sizeof(int32_t) * ((size_t)ncell + 1));
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == dim) b->ids[fill[mesh->node_cell[i]]++] = i;
  free(fill);
  return PM_OK;
}

/* ---- step 0: validate, drop trimmed-away face nodes, add what is missing ------------------- */

static pm_status validate_nodes(const pm_model *m, const pm_mesh *mesh, pm_error *err) {
  for (int32_t i = 0; i < mesh->nnode; ++i) {
    int d = mesh->node_dim[i];
    int32_t c = mesh->node_cell[i];
    if (d < 0 || d > 3 || c < 0 || c >= m->count[d])
      return pm_error_setf(err, PM_ERR_ARG,
                           "node %d is not classified on a cell of the model (dim %d, cell %d)",
                           (int)i, d, (int)c);
    const double *x = &mesh->xyz[3 * i];
    if (!isfinite(x[0]) || !isfinite(x[1]) || !isfinite(x[2]))
      return pm_error_setf(err, PM_ERR_ARG, "node %d has non-finite coordinates", (int)i);
  }
  return PM_OK;
}

/* Remove the nodes flagged in `drop` (order of the others kept). */
static void compact_nodes(pm_mesh *mesh, const uint8_t *drop) {
  int32_t n = 0;
  for (int32_t i = 0; i < mesh->nnode; ++i) {
    if (drop[i]) continue;
    if (n != i) {
      memcpy(&mesh->xyz[3 * n], &mesh->xyz[3 * i], 3 * sizeof(double));
      memcpy(&mesh->node_par[2 * n], &mesh->node_par[2 * i], 2 * sizeof(double));
      mesh->node_dim[n] = mesh->node_dim[i];
      mesh->node_cell[n] = mesh->node_cell[i];
    }
    ++n;
  }
  mesh->nnode = n;
}

static pm_status prepare_nodes(const pm_model *m, pm_mesh *mesh, pm_connect_report *rep,
                               pm_error *err) {
  pm_status s = validate_nodes(m, mesh, err);
  if (s) return s;
  /* Face nodes outside their face's trimmed region cannot be mesh nodes. */
  uint8_t *drop = calloc((size_t)mesh->nnode + 1, 1);
  if (!drop) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t ndrop = 0;
  for (int32_t i = 0; i < mesh->nnode; ++i) {
    if (mesh->node_dim[i] != PM_FACE) continue;
    const pm_cell *f = &m->cells[PM_FACE][mesh->node_cell[i]];
    double *uv = &mesh->node_par[2 * i];
    pm_cell_wrap(f, uv);
    if (!pm_face_inside(f, uv)) drop[i] = 1, ++ndrop;
  }
  if (ndrop) compact_nodes(mesh, drop);
  free(drop);
  rep->dropped_nodes = ndrop;

  /* Stray CAD points (geom.h) get no node: it would duplicate another vertex's. */
  int32_t nv = m->count[PM_VERTEX];
  drop = calloc((size_t)mesh->nnode + 1, 1);
  if (!drop) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  ndrop = 0;
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == PM_VERTEX && m->cells[PM_VERTEX][mesh->node_cell[i]].stray)
      drop[i] = 1, ++ndrop;
  if (ndrop) compact_nodes(mesh, drop);
  free(drop);
  rep->dropped_nodes += ndrop;

  /* One node per vertex: add the missing ones, reject doubles. */
  int32_t *has = calloc((size_t)nv + 1, sizeof(int32_t));
  if (!has) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == PM_VERTEX && has[mesh->node_cell[i]]++) {
      int tag = m->cells[PM_VERTEX][mesh->node_cell[i]].tag;
      free(has);
      return pm_error_setf(err, PM_ERR_ARG, "vertex %d carries more than one node", tag);
    }
  for (int32_t v = 0; v < nv && !s; ++v)
    if (!has[v] && !m->cells[PM_VERTEX][v].stray) {
      s = pm_mesh_add_node(mesh, m->cells[PM_VERTEX][v].xyz, PM_VERTEX, v, NULL, NULL, err);
      rep->added_nodes++;
    }
  free(has);
  if (s) return s;

  /* A closed curve (one end vertex) is a polygon only with at least two interior nodes: with
   * none, add nodes at a third and two thirds of its range; with one, add one half a range away. */
  for (int32_t c = 0; c < m->count[PM_CURVE] && !s; ++c) {
    const pm_cell *cv = &m->cells[PM_CURVE][c];
    if (cv->degenerate || cv->nbound != 2 || cv->bound[0].cell != cv->bound[1].cell) continue;
    int32_t n = 0, one = -1;
    for (int32_t i = 0; i < mesh->nnode; ++i)
      if (mesh->node_dim[i] == PM_CURVE && mesh->node_cell[i] == c) ++n, one = i;
    if (n >= 2) continue;
    double range = cv->hi[0] - cv->lo[0], ts[2];
    int nadd = 2 - n;
    if (n == 0) {
      ts[0] = cv->lo[0] + range / 3, ts[1] = cv->lo[0] + 2 * range / 3;
    } else {
      ts[0] = mesh->node_par[2 * one] + range / 2;
      if (ts[0] > cv->hi[0]) ts[0] -= range;
    }
    for (int k = 0; k < nadd && !s; ++k) {
      double x[3];
      pm_cell_point(cv, &ts[k], x);
      s = pm_mesh_add_node(mesh, x, PM_CURVE, c, &ts[k], NULL, err);
      rep->added_nodes++;
    }
  }
  return s;
}

/* ---- step 1: curve chains ------------------------------------------------------------------- */

/* The chain of a curve: its start-vertex node, its own nodes by increasing t, its end-vertex
 * node; node[off[c] .. off[c+1]) with parameters t[...]. A degenerate curve's chain is its two
 * end-vertex nodes (often the same node). */
typedef struct chains {
  int32_t *off, *node;
  double *t;
} chains;

static void chains_free(chains *ch) {
  free(ch->off), free(ch->node), free(ch->t);
  memset(ch, 0, sizeof *ch);
}

/* A node id with a sort key: a curve parameter (chains) or a coordinate (step 1a's sweep). */
typedef struct tnode {
  double t;
  int32_t id;
} tnode;

static int tnode_cmp(const void *a, const void *b) {
  const tnode *x = a, *y = b;
  if (x->t < y->t) return -1;
  if (x->t > y->t) return 1;
  return (x->id > y->id) - (x->id < y->id);
}

static pm_status chains_build(const pm_model *m, const pm_mesh *mesh, const buckets *cb,
                              const int32_t *vnode, chains *ch, pm_error *err) {
  int32_t nc = m->count[PM_CURVE];
  ch->off = malloc(sizeof(int32_t) * ((size_t)nc + 1));
  int32_t total = 0;
  for (int32_t c = 0; c < nc; ++c) total += cb->off[c + 1] - cb->off[c] + 2;
  ch->node = malloc(sizeof(int32_t) * (size_t)(total ? total : 1));
  ch->t = malloc(sizeof(double) * (size_t)(total ? total : 1));
  if (!ch->off || !ch->node || !ch->t) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t pos = 0;
  for (int32_t c = 0; c < nc; ++c) {
    const pm_cell *cv = &m->cells[PM_CURVE][c];
    ch->off[c] = pos;
    if (cv->nbound != 2)
      return pm_error_setf(err, PM_ERR_GEOM, "curve %d does not have two end vertices", cv->tag);
    int32_t n = cb->off[c + 1] - cb->off[c];
    if (cv->degenerate && n > 0)
      return pm_error_setf(err, PM_ERR_ARG, "degenerate curve %d (a pole) carries %d nodes",
                           cv->tag, (int)n);
    tnode *tn = malloc(sizeof(tnode) * (size_t)(n ? n : 1));
    if (!tn) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t k = 0; k < n; ++k) {
      int32_t id = cb->ids[cb->off[c] + k];
      double t = mesh->node_par[2 * id];
      if (cv->periodic[0]) pm_cell_wrap(cv, &t);
      tn[k] = (tnode){t, id};
    }
    qsort(tn, (size_t)n, sizeof(tnode), tnode_cmp);
    ch->node[pos] = vnode[cv->bound[0].cell], ch->t[pos++] = cv->lo[0];
    for (int32_t k = 0; k < n; ++k) ch->node[pos] = tn[k].id, ch->t[pos++] = tn[k].t;
    ch->node[pos] = vnode[cv->bound[1].cell], ch->t[pos++] = cv->hi[0];
    free(tn);
  }
  ch->off[nc] = pos;
  return PM_OK;
}

static pm_status emit_segments(const pm_model *m, pm_mesh *mesh, const chains *ch, pm_error *err) {
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    if (m->cells[PM_CURVE][c].degenerate) continue;
    for (int32_t k = ch->off[c]; k + 1 < ch->off[c + 1]; ++k) {
      pm_status s = pm_mesh_add_seg(mesh, ch->node[k], ch->node[k + 1], c, err);
      if (s) return s;
    }
  }
  return PM_OK;
}

/* ---- step 1b: face nodes that a disagreeing pcurve puts on the wrong side of a curve -------- */

/* A face's boundary is each curve's node chain seen twice: in (u, v) through the face's pcurve
 * of the curve, which is where the parameter-space triangulation puts it, and in 3D through the
 * curve nodes' own positions on the 3D curve, which is where the triangles end up. A CAD face
 * built to a loose tolerance has a pcurve whose image S(pcurve(t)) lies off the 3D curve C(t);
 * when the gap is a fair part of the node spacing (fusee.stp's face 85 along curve 418), a face
 * node can lie on the inner side of a boundary segment in (u, v) yet on its outer side in 3D.
 * The triangle the segment makes with that node is then folded over in 3D, and no flip can
 * undo it, as the segment is a constraint. Such a node is dropped before the face is
 * triangulated: the segment's triangle then reaches the next node inwards.
 * A node is dropped when its orientation to the segment in (u, v) differs from its orientation in
 * 3D about the surface normal Su x Sv at the node (the two agree wherever S is a regular map and
 * the pcurve matches the curve), or when its (u, v) offset from the segment, mapped to 3D
 * lengths through the Jacobian, is no larger than the segment's gap: its side is then below the
 * trace's own error (on fusee.stp's face 85 the bubble mesh put face nodes right on the trace,
 * offset 0 to 0.03 against gaps of 0.03-0.08). The test is made only along segments whose ends'
 * gap |S(pcurve(t)) - C(t)| exceeds CROSSED_GAP of the segment's 3D length, and only for nodes
 * beside the segment within one segment length of it in (u, v), so a face whose pcurves follow
 * their curves keeps every node. 0.05: a gap that changes a node's side is of the order of its
 * distance to the boundary, about half a spacing; the pcurves of fusee.stp's face 85 that do
 * follow their curves are off by 1.5e-7 where the spacing is 1.8-2.4.
 * The same holds for a segment too coarse for its curve: the chord cuts inside the arc by its
 * sag, and a face node nearer the arc than that lies beyond the chord in 3D while inside it in
 * (u, v) (a quarter circle of radius 0.0032 with no node inside it against face nodes 0.0004
 * apart: robust/occ_large__simple_plane.brep with psys, face 3, four folded triangles in the
 * cap's plane). Such a node's triangle with the segment stands nearly upright on the surface (at
 * a right angle as the node reaches the arc, then folded over where the surface leans towards
 * the chord, as a cone's does): along a segment whose sag exceeds CROSSED_GAP of its length, a
 * node is dropped when that triangle's normal is more than 80 degrees off the surface normal at
 * the node (STEEP_COS = cos 80). */
#define CROSSED_GAP 0.05
#define STEEP_COS 0.17364817766693041

typedef struct cross_seg {
  double qa[2], qb[2]; /* the segment's ends in (u, v) */
  double gap;          /* the larger of its ends' gaps |S(pcurve(t)) - C(t)| */
  int sagging;         /* its chord cuts inside the curve by more than CROSSED_GAP of its length */
  const double *xa, *xb; /* ... and in 3D (the nodes' positions) */
} cross_seg;

/* Append the segments of chain c (as traced by `use` on face f) whose pcurve and 3D curve
 * disagree; returns -1 when out of memory. */
static int crossed_segments(const pm_model *m, const pm_cell *f, const pm_use *use,
                            const pm_mesh *mesh, const chains *ch, cross_seg **seg, int32_t *nseg,
                            int32_t *cap) {
  const pm_cell *curve = &m->cells[PM_CURVE][use->cell];
  int32_t a = ch->off[use->cell], b = ch->off[use->cell + 1];
  double prev_uv[2] = {0, 0}, prev_gap = 0;
  for (int32_t i = a; i < b; ++i) {
    double uv[2];
    pm_face_curve_uv(f, use, ch->t[i], uv);
    const double *x = &mesh->xyz[3 * (size_t)ch->node[i]];
    double s[3];
    pm_cell_point(f, uv, s);
    double gap = sqrt(pm_v3_dist2(s, x));
    if (i > a) {
      const double *xp = &mesh->xyz[3 * (size_t)ch->node[i - 1]];
      double len = sqrt(pm_v3_dist2(xp, x));
      /* The chord's sag: the curve at the middle parameter against the chord's middle. */
      pm_curve_point mid;
      pm_curve_eval(curve, 0.5 * (ch->t[i - 1] + ch->t[i]), 0, &mid);
      double chord_mid[3] = {0.5 * (xp[0] + x[0]), 0.5 * (xp[1] + x[1]), 0.5 * (xp[2] + x[2])};
      double sag = sqrt(pm_v3_dist2(mid.p, chord_mid));
      if (fmax(fmax(gap, prev_gap), sag) > CROSSED_GAP * len) {
        if (*nseg == *cap) {
          int32_t nc = *cap ? 2 * *cap : 16;
          cross_seg *g = realloc(*seg, sizeof(cross_seg) * (size_t)nc);
          if (!g) return -1;
          *seg = g, *cap = nc;
        }
        cross_seg *cs = &(*seg)[(*nseg)++];
        memcpy(cs->qa, prev_uv, sizeof prev_uv), memcpy(cs->qb, uv, sizeof uv);
        cs->xa = xp, cs->xb = x, cs->gap = fmax(gap, prev_gap);
        cs->sagging = sag > CROSSED_GAP * len;
      }
    }
    memcpy(prev_uv, uv, sizeof uv), prev_gap = gap;
  }
  return 0;
}

/* Flag in `drop` the face nodes of face f on opposite sides of a disagreeing segment in (u, v)
 * and in 3D; returns how many, or -1 when out of memory. */
static int32_t flag_crossed_nodes(const pm_model *m, const pm_cell *f, const pm_mesh *mesh,
                                  const chains *ch, const buckets *fb, uint8_t *drop) {
  cross_seg *seg = NULL;
  int32_t nseg = 0, cap = 0;
  for (int32_t l = 0; l < f->nloop; ++l)
    for (int32_t k = 0; k < f->loop[l].nuse; ++k) {
      const pm_use *use = &f->loop[l].use[k];
      if (m->cells[PM_CURVE][use->cell].degenerate) continue;
      if (crossed_segments(m, f, use, mesh, ch, &seg, &nseg, &cap)) goto oom;
    }
  for (int32_t e = 0; e < f->nembed; ++e)
    if (f->embed[e].dim == PM_CURVE) {
      pm_use use = {f->embed[e].index, 1, 0};
      if (crossed_segments(m, f, &use, mesh, ch, &seg, &nseg, &cap)) goto oom;
    }
  int32_t n = 0;
  for (int32_t k = fb->off[f->index]; k < fb->off[f->index + 1] && nseg; ++k) {
    int32_t id = fb->ids[k];
    const double *p = &mesh->node_par[2 * (size_t)id], *P = &mesh->xyz[3 * (size_t)id];
    int have_normal = 0;
    double nrm[3];
    pm_face_point fp;
    for (int32_t j = 0; j < nseg; ++j) {
      const cross_seg *cs = &seg[j];
      double d[2] = {cs->qb[0] - cs->qa[0], cs->qb[1] - cs->qa[1]};
      double r[2] = {p[0] - cs->qa[0], p[1] - cs->qa[1]};
      double len2 = d[0] * d[0] + d[1] * d[1];
      if (!(len2 > 0)) continue;
      double along = (r[0] * d[0] + r[1] * d[1]) / len2, side_uv = d[0] * r[1] - d[1] * r[0];
      /* beside the segment, within one segment length of it */
      if (along < 0 || along > 1 || side_uv * side_uv > len2 * len2) continue;
      if (!have_normal) {
        pm_face_eval(f, p, 1, &fp);
        pm_v3_cross(nrm, fp.su, fp.sv);
        have_normal = 1;
      }
      double e3[3], r3[3], c3[3];
      pm_v3_sub(e3, cs->xb, cs->xa), pm_v3_sub(r3, P, cs->xa);
      pm_v3_cross(c3, e3, r3);
      double side_3d = pm_v3_dot(c3, nrm);
      /* the node's offset from the segment in (u, v), in 3D lengths through the Jacobian */
      double o[2] = {r[0] - along * d[0], r[1] - along * d[1]}, o3[3];
      for (int c = 0; c < 3; ++c) o3[c] = fp.su[c] * o[0] + fp.sv[c] * o[1];
      /* Beyond a sagging chord, the triangle the node makes with the segment stands on the
       * surface instead of lying in it: steeper than STEEP_COS allows. */
      double steep = STEEP_COS * pm_v3_norm(c3) * pm_v3_norm(nrm);
      if ((side_uv > 0 && side_3d <= 0) || (side_uv < 0 && side_3d >= 0) ||
          pm_v3_dot(o3, o3) <= cs->gap * cs->gap ||
          (cs->sagging && fabs(side_3d) <= steep)) {
        drop[id] = 1, ++n;
        break;
      }
    }
  }
  free(seg);
  return n;
oom:
  free(seg);
  return -1;
}

/* ---- a small set of node pairs (open addressing), for duplicate-edge checks ------------------ */

typedef struct pairset {
  uint64_t *key; /* 0 = empty, 1 = removed */
  int64_t cap, n;
} pairset;

static uint64_t pair_key(int32_t a, int32_t b) {
  if (a > b) {
    int32_t t = a;
    a = b, b = t;
  }
  return (((uint64_t)(uint32_t)a << 32) | (uint32_t)b) + 2; /* never 0 or 1 */
}

static int pairset_init(pairset *s, int64_t n) {
  s->cap = 16;
  while (s->cap < 2 * n + 16) s->cap *= 2;
  s->key = calloc((size_t)s->cap, sizeof(uint64_t));
  s->n = 0;
  return s->key != NULL;
}

static int64_t pairset_slot(const pairset *s, uint64_t k, int for_insert) {
  int64_t mask = s->cap - 1, i = (int64_t)(pm_mix64(k) & (uint64_t)mask), tomb = -1;
  for (;;) {
    uint64_t v = s->key[i];
    if (v == k) return i;
    if (v == 0) return for_insert && tomb >= 0 ? tomb : (for_insert ? i : -1);
    if (v == 1 && tomb < 0) tomb = i;
    i = (i + 1) & mask;
  }
}

static int pairset_has(const pairset *s, int32_t a, int32_t b) {
  return pairset_slot(s, pair_key(a, b), 0) >= 0;
}

/* Capacity is fixed at init to twice the expected count: flips keep the edge count constant. */
static void pairset_add(pairset *s, int32_t a, int32_t b) {
  uint64_t k = pair_key(a, b);
  int64_t i = pairset_slot(s, k, 1);
  if (s->key[i] != k) s->key[i] = k, s->n++;
}

static void pairset_del(pairset *s, int32_t a, int32_t b) {
  int64_t i = pairset_slot(s, pair_key(a, b), 0);
  if (i >= 0) s->key[i] = 1, s->n--;
}

/* ---- step 2: one face ------------------------------------------------------------------------ */

typedef struct face_work {
  /* points of the face's parameter-space triangulation */
  int32_t np, capp;
  double *uv;     /* [2*np] raw (u, v) */
  double snap2;   /* squared (u, v) distance under which two points of one node are one point */
  int32_t *next_of_node; /* [np] the node's previous point (a chain per node), -1 at the end */
  int32_t *head;  /* [mesh nnode] the node's latest point, -1 when none (allocated per face) */
  double *xy;     /* [2*np] what is triangulated (u, v after the affine map) */
  int32_t *node;  /* [np] mesh node of each point */
  int32_t nc, capc;
  int32_t *cons;  /* [2*nc] constraint edges between points */
  int32_t *cons_seg; /* [nc] the chain position (chains) of each constraint's curve segment:
                        the segment from ch->node[k] to ch->node[k + 1]; -1 along a pole */
  pm_use *cons_use;  /* [nc] the face's use of that segment's curve (its pcurve) */
  /* the face's distinct nodes, numbered locally: points map to them (loc[p]); each has the
   * surface's unit normal at it (zero at a pole, where the surface has none) */
  int32_t nloc;
  int32_t *loc;   /* [np] local node of each point */
  int32_t *gnode; /* [nloc] mesh node of each local node */
  double *nrm;    /* [3*nloc] */
  double *lxyz;   /* [3*nloc] 3D position of each local node */
  int32_t capl;   /* room of loc-indexed arrays (gnode, nrm, lxyz) */
  int32_t npole, cappole;
  int32_t *pole;  /* mesh nodes that are poles of this face (their points are copies) */
  /* the triangulation, in point indices until it is chosen, then in local nodes (the flips work
   * on nodes: two fan triangles at a pole or two sides of a seam share nodes, not points) */
  int32_t ntri;
  int32_t *tri;   /* [3*ntri] */
  int32_t *nbr;   /* [3*ntri] triangle across edge (tri[3t+k], tri[3t+(k+1)%3]), -1 none */
  uint8_t *fixed; /* [3*ntri] 1 when that edge is a constraint */
} face_work;

typedef struct face_out {
  int32_t ntri;
  int32_t *tri; /* [3*ntri] mesh nodes, oriented */
  int32_t pole, flips, cap_hit, curved;
  int32_t metric_flips; /* parameter-plane flips under the local metric */
  double asp_before, asp_after; /* sums over the face's triangles (curved faces) */
  double max_before, max_after; /* maxima over them */
  int32_t degen_before, degen_after; /* degenerate triangles (left out of the sums) */
  int32_t nnew;   /* nodes the face added (split_repeats): ids vbase + k in tri, until the
                     caller appends them to the mesh */
  int32_t vbase;
  double *new_xyz, *new_uv; /* [3*nnew], [2*nnew] */
  int32_t nmoved;  /* interior nodes the smoothing moved (face_smooth.h): their mesh ids, */
  int32_t *moved;  /* new positions and parameters, written to the mesh by the caller */
  double *moved_xyz, *moved_uv; /* [3*nmoved], [2*nmoved] */
  int32_t smooth_moves; /* accepted moves over all sweeps */
  pm_status status;
  pm_error err;
} face_out;

static void face_work_free(face_work *w) {
  free(w->next_of_node), free(w->head);
  free(w->loc), free(w->gnode), free(w->nrm), free(w->lxyz), free(w->pole);
  free(w->uv), free(w->xy), free(w->node), free(w->cons), free(w->cons_seg), free(w->cons_use);
  free(w->tri), free(w->nbr), free(w->fixed);
  memset(w, 0, sizeof *w);
}

/* Add a point of node `node` at uv; returns its index, or -1 when out of memory. A node's image
 * reached twice through different pcurves (a vertex where two curves of a loop meet, a seam
 * vertex touched by a hole) may differ in the last bits; within w->snap2 the earlier point is
 * reused, so the triangulation never sees two points a rounding error apart. Images far apart
 * (the two sides of a seam, the copies of a pole) stay distinct. */
static int add_point(face_work *w, const double uv[2], int32_t node) {
  for (int32_t q = w->head[node]; q >= 0; q = w->next_of_node[q]) {
    double du = w->uv[2 * q] - uv[0], dv = w->uv[2 * q + 1] - uv[1];
    if (du * du + dv * dv <= w->snap2) return q;
  }
  if (w->np == w->capp) {
    int32_t cap = w->capp ? 2 * w->capp : 256;
    double *a = realloc(w->uv, sizeof(double) * 2 * (size_t)cap);
    if (!a) return -1;
    w->uv = a;
    int32_t *b = realloc(w->node, sizeof(int32_t) * (size_t)cap);
    if (!b) return -1;
    w->node = b;
    int32_t *c = realloc(w->next_of_node, sizeof(int32_t) * (size_t)cap);
    if (!c) return -1;
    w->next_of_node = c;
    w->capp = cap;
  }
  w->uv[2 * w->np] = uv[0], w->uv[2 * w->np + 1] = uv[1];
  w->node[w->np] = node;
  w->next_of_node[w->np] = w->head[node];
  w->head[node] = w->np;
  return w->np++;
}

/* Constrain the edge between points a and b, the curve segment at chain position seg (-1: none)
 * of the use `use` (NULL with seg -1). */
static int add_constraint(face_work *w, int32_t a, int32_t b, int32_t seg, const pm_use *use) {
  if (a == b) return 0;
  if (w->nc == w->capc) {
    int32_t cap = w->capc ? 2 * w->capc : 256;
    int32_t *c = realloc(w->cons, sizeof(int32_t) * 2 * (size_t)cap);
    if (!c) return -1;
    w->cons = c;
    int32_t *g = realloc(w->cons_seg, sizeof(int32_t) * (size_t)cap);
    if (!g) return -1;
    w->cons_seg = g;
    pm_use *u = realloc(w->cons_use, sizeof(pm_use) * (size_t)cap);
    if (!u) return -1;
    w->cons_use = u;
    w->capc = cap;
  }
  w->cons[2 * w->nc] = a, w->cons[2 * w->nc + 1] = b;
  w->cons_seg[w->nc] = seg;
  if (use) w->cons_use[w->nc] = *use;
  else memset(&w->cons_use[w->nc], 0, sizeof(pm_use));
  w->nc++;
  return 0;
}

/* A pole (the image of a degenerate curve: a sphere's pole, a cone's apex) is one node, but a
 * segment in the face's parameter space. Copies of its node are placed along that segment, as a
 * chain of constraint edges: at the segment's start (its end is the next use's start) and at the
 * parameters where the face nodes closest to the pole project onto it. (Copies anywhere else --
 * an even spacing was tried -- put a copy just beside the end of a seam through the pole, where
 * the parameter-space triangulation then joins it to two seam nodes: a triangle on a straight
 * ruling of a cone, of zero area in 3D.) Each node next to the pole then finds a copy right "above" it, so the parameter-space
 * triangles around the pole lift to a fan in angular order around it; triangles between two
 * copies collapse onto the pole and are dropped. With only the two end copies, a node close to
 * the pole would be joined to a copy far away along the segment, giving a triangle that wraps
 * around the pole in 3D. */
static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static pm_status add_pole_copies(const pm_cell *f, const pm_use *use, double tlo, double thi,
                                 int32_t node, const pm_mesh *mesh, const buckets *fb,
                                 face_work *w, int32_t *first, int32_t *prev, int32_t seg,
                                 const pm_use *seg_use, pm_error *err) {
  double t0 = use->sense >= 0 ? tlo : thi, t1 = use->sense >= 0 ? thi : tlo;
  double A[2], B[2];
  pm_face_curve_uv(f, use, t0, A);
  pm_face_curve_uv(f, use, t1, B);
  double d[2] = {B[0] - A[0], B[1] - A[1]}, len2 = d[0] * d[0] + d[1] * d[1];
  int32_t nf = fb->off[f->index + 1] - fb->off[f->index];
  double *s = malloc(sizeof(double) * ((size_t)nf + 40));
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t ns = 0;
  s[ns++] = 0;
  if (len2 > 0 && nf > 0) {
    /* The face nodes nearest to the segment: within three times the smallest distance. */
    double dmin = INFINITY;
    for (int32_t k = fb->off[f->index]; k < fb->off[f->index + 1]; ++k) {
      const double *p = &mesh->node_par[2 * fb->ids[k]];
      double cr = fabs((p[0] - A[0]) * d[1] - (p[1] - A[1]) * d[0]) / sqrt(len2);
      dmin = fmin(dmin, cr);
    }
    for (int32_t k = fb->off[f->index]; k < fb->off[f->index + 1]; ++k) {
      const double *p = &mesh->node_par[2 * fb->ids[k]];
      double cr = fabs((p[0] - A[0]) * d[1] - (p[1] - A[1]) * d[0]) / sqrt(len2);
      double sp = ((p[0] - A[0]) * d[0] + (p[1] - A[1]) * d[1]) / len2;
      if (cr <= 3 * dmin && sp > 0 && sp < 1) s[ns++] = sp;
    }
  }
  qsort(s, (size_t)ns, sizeof(double), cmp_double);
  if (w->npole == w->cappole) {
    int32_t cap = w->cappole ? 2 * w->cappole : 4;
    int32_t *g = realloc(w->pole, sizeof(int32_t) * (size_t)cap);
    if (!g) {
      free(s);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    w->pole = g, w->cappole = cap;
  }
  w->pole[w->npole++] = node;
  pm_status st = PM_OK;
  double last = -1;
  for (int32_t k = 0; k < ns; ++k) {
    if (s[k] - last < 1e-6) continue; /* copies closer than this add nothing */
    last = s[k];
    double uv[2];
    pm_face_curve_uv(f, use, t0 + (t1 - t0) * s[k], uv);
    int32_t q = add_point(w, uv, node);
    /* the edge into the first copy is the curve segment that reaches the pole (seg) */
    if (q < 0 || (*prev >= 0 && add_constraint(w, *prev, q, seg, seg_use))) {
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      break;
    }
    if (*first < 0) *first = q;
    *prev = q, seg = -1, seg_use = NULL;
  }
  free(s);
  return st;
}

/* The points of face f: the node chains of its loops (through the pcurves of each use) as closed
 * constrained polygons, its embedded curves as open constrained chains, and, unless
 * boundary_only, its own nodes. Each constraint keeps its curve segment (cons_seg). */
static pm_status gather_face_points(const pm_model *m, const pm_cell *f, const pm_mesh *mesh,
                                    const chains *ch, const buckets *fb, int boundary_only,
                                    face_work *w, pm_error *err) {
  w->head = malloc(sizeof(int32_t) * ((size_t)mesh->nnode + 1));
  if (!w->head) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < mesh->nnode; ++i) w->head[i] = -1;
  /* 1e-9 of the parameter box: far below any two distinct nodes, far above rounding. */
  double du = f->hi[0] - f->lo[0], dv = f->hi[1] - f->lo[1];
  w->snap2 = 1e-18 * (du * du + dv * dv);
  for (int32_t l = 0; l < f->nloop; ++l) {
    const pm_loop *lp = &f->loop[l];
    int32_t first = -1, prev = -1; /* the loop's first point and the last one added */
    int32_t seg = -1; /* the curve segment that leaves prev along the loop, */
    const pm_use *seg_use = NULL; /* and its use */
    for (int32_t k = 0; k < lp->nuse; ++k) {
      const pm_use *use = &lp->use[k];
      int32_t c = use->cell, a = ch->off[c], b = ch->off[c + 1];
      if (m->cells[PM_CURVE][c].degenerate) {
        pm_status s = add_pole_copies(f, use, ch->t[a], ch->t[b - 1], ch->node[a], mesh, fb, w,
                                      &first, &prev, seg, seg_use, err);
        if (s) return s;
        seg = -1, seg_use = NULL;
        continue;
      }
      /* Every chain node but the last in the use's direction: the last is the next use's first. */
      for (int32_t q = 0; q < b - a - 1; ++q) {
        int32_t i = use->sense >= 0 ? a + q : b - 1 - q;
        double uv[2];
        pm_face_curve_uv(f, use, ch->t[i], uv);
        int32_t p = add_point(w, uv, ch->node[i]);
        if (p < 0) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        if (prev >= 0 && add_constraint(w, prev, p, seg, seg_use))
          return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        if (first < 0) first = p;
        prev = p;
        seg = use->sense >= 0 ? i : i - 1, seg_use = use;
      }
    }
    if (prev >= 0 && prev != first && add_constraint(w, prev, first, seg, seg_use))
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t e = 0; e < f->nembed; ++e) {
    pm_cellref r = f->embed[e];
    if (r.dim == PM_CURVE) {
      pm_use use = {r.index, 1, 0};
      int32_t prev = -1;
      for (int32_t i = ch->off[r.index]; i < ch->off[r.index + 1]; ++i) {
        double uv[2];
        pm_face_curve_uv(f, &use, ch->t[i], uv);
        int32_t p = add_point(w, uv, ch->node[i]);
        if (p < 0) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        if (prev >= 0 && add_constraint(w, prev, p, i - 1, &use))
          return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        prev = p;
      }
    }
  }
  for (int32_t k = fb->off[f->index]; k < fb->off[f->index + 1] && !boundary_only; ++k) {
    int32_t id = fb->ids[k];
    if (add_point(w, &mesh->node_par[2 * id], id) < 0)
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  w->xy = malloc(sizeof(double) * 2 * (size_t)(w->np ? w->np : 1));
  if (!w->xy) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  memcpy(w->xy, w->uv, sizeof(double) * 2 * (size_t)w->np);
  return PM_OK;
}

/* Number the face's distinct nodes locally and give each the surface's unit normal, from the
 * (u, v) of its first point; a pole has no normal (zero). */
static pm_status local_nodes(const pm_cell *f, const pm_mesh *mesh, face_work *w, pm_error *err) {
  w->loc = malloc(sizeof(int32_t) * (size_t)(w->capp ? w->capp : 1));
  w->capl = w->np ? w->np : 1;
  w->gnode = malloc(sizeof(int32_t) * (size_t)w->capl);
  w->nrm = malloc(sizeof(double) * 3 * (size_t)w->capl);
  w->lxyz = malloc(sizeof(double) * 3 * (size_t)w->capl);
  if (!w->loc || !w->gnode || !w->nrm || !w->lxyz)
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  w->nloc = 0;
  for (int32_t p = 0; p < w->np; ++p) {
    /* head[node] chains the node's points from the last added: the node's local number is set
     * when its first point in index order is reached. */
    int32_t first = p;
    for (int32_t q = w->head[w->node[p]]; q >= 0; q = w->next_of_node[q]) first = q < first ? q : first;
    if (first < p) {
      w->loc[p] = w->loc[first];
      continue;
    }
    int32_t l = w->nloc++;
    w->loc[p] = l;
    w->gnode[l] = w->node[p];
    memcpy(&w->lxyz[3 * l], &mesh->xyz[3 * (size_t)w->node[p]], 3 * sizeof(double));
    double *n = &w->nrm[3 * l];
    pm_v3_zero(n);
    int pole = 0;
    for (int32_t k = 0; k < w->npole; ++k) pole |= w->pole[k] == w->node[p];
    if (pole) continue;
    pm_face_point fp;
    pm_face_eval(f, &w->uv[2 * p], 1, &fp);
    /* A singular point that is not a listed pole (a seam vertex at an apex): no normal either
     * (PM_CONNECT_NORMAL_MIN_SIN). */
    pm_face_point_normal(&fp, PM_CONNECT_NORMAL_MIN_SIN, n);
  }
  return PM_OK;
}

/* Convert the chosen triangulation from points to local nodes (a constraint between two copies
 * of one pole vanishes; a seam segment stays a constraint between its two nodes). */
static void to_local_nodes(face_work *w) {
  for (int32_t i = 0; i < 3 * w->ntri; ++i) w->tri[i] = w->loc[w->tri[i]];
  int32_t n = 0;
  for (int32_t k = 0; k < w->nc; ++k) {
    int32_t a = w->loc[w->cons[2 * k]], b = w->loc[w->cons[2 * k + 1]];
    if (a == b) continue;
    w->cons[2 * n] = a, w->cons[2 * n + 1] = b;
    w->cons_seg[n] = w->cons_seg[k], w->cons_use[n] = w->cons_use[k], ++n;
  }
  w->nc = n;
}

/* papers/001 eq. 16: the linear map A of the parameter plane that best preserves distances,
 * min sum (|A du_ij| - |r_ij|)^2 over neighbouring pairs. We solve it in squared form, for the
 * symmetric positive definite Q = A^T A: min sum w_ij (du_ij^T Q du_ij - |r_ij|^2)^2 with
 * w_ij = 1 / |r_ij|^4 (relative errors, so small and large edges count alike) -- linear least
 * squares in the three entries of Q, with the same minimizer as eq. 16 when the fit is exact --
 * then A = Q^(1/2), the symmetric square root (det A > 0 keeps orientations). The pairs are the
 * edges of a first, unscaled triangulation, without those longer than half a period along a
 * periodic parameter: such an edge joins points next to each other across the seam, and its
 * short chord against its long parameter step read as a squeezed parameter (a cylinder 300 high
 * of radius 100, robust/statreport__Cylinder_1.brep: the unscaled plane is 48 times taller than
 * wide, its triangulation joins the two sides of the seam, and the fit squeezed u until the
 * scaled triangulation wrapped round the cylinder). Returns 0 (and leaves xy unscaled) when Q
 * is not positive definite. */
static int affine_scale(const pm_cell *f, face_work *w, const pm_mesh *mesh,
                        const pm_cdt_result *first) {
  /* Interior edges appear in two triangles and so count twice, boundary edges once. */
  double N[3][3] = {{0}}, rhs[3] = {0};
  int used = 0;
  for (int32_t t = 0; t < first->ntri; ++t)
    for (int k = 0; k < 3; ++k) {
      int32_t a = first->tri[3 * t + k], b = first->tri[3 * t + (k + 1) % 3];
      int32_t na = w->node[a], nb = w->node[b];
      if (na == nb) continue;
      double du = w->uv[2 * a] - w->uv[2 * b], dv = w->uv[2 * a + 1] - w->uv[2 * b + 1];
      if ((f->periodic[0] && fabs(du) > 0.5 * f->period[0]) ||
          (f->periodic[1] && fabs(dv) > 0.5 * f->period[1]))
        continue;
      double r2 = pm_v3_dist2(&mesh->xyz[3 * na], &mesh->xyz[3 * nb]);
      if (!(r2 > 0) || (du == 0 && dv == 0)) continue;
      double phi[3] = {du * du, 2 * du * dv, dv * dv}, wt = 1.0 / (r2 * r2);
      for (int i = 0; i < 3; ++i) {
        rhs[i] += wt * phi[i] * r2;
        for (int j = 0; j < 3; ++j) N[i][j] += wt * phi[i] * phi[j];
      }
      ++used;
    }
  if (used < 3) return 0;
  /* Solve the 3x3 normal equations by Cramer's rule. */
  double det = N[0][0] * (N[1][1] * N[2][2] - N[1][2] * N[2][1]) -
               N[0][1] * (N[1][0] * N[2][2] - N[1][2] * N[2][0]) +
               N[0][2] * (N[1][0] * N[2][1] - N[1][1] * N[2][0]);
  if (!(fabs(det) > 0) || !isfinite(det)) return 0;
  double q[3];
  for (int c = 0; c < 3; ++c) {
    double M[3][3];
    memcpy(M, N, sizeof M);
    for (int r = 0; r < 3; ++r) M[r][c] = rhs[r];
    q[c] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
            M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
            M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) / det;
  }
  double a = q[0], b = q[1], c = q[2];
  if (!(a > 0 && a * c - b * b > 1e-12 * (a + c) * (a + c))) return 0;
  /* Symmetric square root of [[a, b], [b, c]]: sqrt(Q) = (Q + sqrt(det) I) / sqrt(tr + 2 sqrt(det)). */
  double sd = sqrt(a * c - b * b), s = sqrt(a + c + 2 * sd);
  double A00 = (a + sd) / s, A01 = b / s, A11 = (c + sd) / s;
  for (int32_t i = 0; i < w->np; ++i) {
    double u = w->uv[2 * i], v = w->uv[2 * i + 1];
    w->xy[2 * i] = A00 * u + A01 * v;
    w->xy[2 * i + 1] = A01 * u + A11 * v;
  }
  return 1;
}

/* Adjacency of the triangulation (over nvert vertices: points or local nodes): nbr and the
 * constraint flags. */
static pm_status build_adjacency(face_work *w, int32_t nvert, pm_error *err) {
  w->nbr = malloc(sizeof(int32_t) * 3 * (size_t)(w->ntri ? w->ntri : 1));
  w->fixed = calloc(3 * (size_t)(w->ntri ? w->ntri : 1), 1);
  if (!w->nbr || !w->fixed) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < 3 * w->ntri; ++i) w->nbr[i] = -1;
  pm_edges e = {0};
  pm_status s = pm_edges_build(nvert, w->tri, w->ntri, 3, &e, err);
  if (s) return s;
  for (int64_t k = 0; k < e.nedge; ++k) {
    if (e.off[k + 1] - e.off[k] != 2) continue;
    int32_t t0 = e.elem[e.off[k]], t1 = e.elem[e.off[k] + 1];
    int32_t a = e.ends[2 * k], b = e.ends[2 * k + 1];
    for (int q = 0; q < 3; ++q) {
      int32_t x = w->tri[3 * t0 + q], y = w->tri[3 * t0 + (q + 1) % 3];
      if ((x == a && y == b) || (x == b && y == a)) w->nbr[3 * t0 + q] = t1;
      x = w->tri[3 * t1 + q], y = w->tri[3 * t1 + (q + 1) % 3];
      if ((x == a && y == b) || (x == b && y == a)) w->nbr[3 * t1 + q] = t0;
    }
  }
  pm_edges_free(&e);
  /* Constraint edges: sort-free check through a pair set of constrained point pairs. */
  pairset cs;
  if (!pairset_init(&cs, w->nc)) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t k = 0; k < w->nc; ++k) pairset_add(&cs, w->cons[2 * k], w->cons[2 * k + 1]);
  for (int32_t t = 0; t < w->ntri; ++t)
    for (int q = 0; q < 3; ++q)
      w->fixed[3 * t + q] = (uint8_t)pairset_has(&cs, w->tri[3 * t + q], w->tri[3 * t + (q + 1) % 3]);
  free(cs.key);
  return PM_OK;
}

/* Circumcentre and squared circumradius of a 3D triangle; returns 0 when degenerate. */
static int circumsphere(const double a[3], const double b[3], const double c[3], double ctr[3],
                        double *r2) {
  double ab[3], ac[3], n[3], t1[3], t2[3], num[3];
  pm_v3_sub(ab, b, a), pm_v3_sub(ac, c, a);
  pm_v3_cross(n, ab, ac);
  double nn = pm_v3_dot(n, n);
  if (!(nn > 1e-30 * pm_v3_dot(ab, ab) * pm_v3_dot(ac, ac))) return 0;
  /* ctr = a + ((|ab|^2 ac - |ac|^2 ab) x n) / (2 |n|^2) */
  pm_v3_scale(t1, ac, pm_v3_dot(ab, ab));
  pm_v3_scale(t2, ab, pm_v3_dot(ac, ac));
  pm_v3_sub(t1, t1, t2);
  pm_v3_cross(num, t1, n);
  pm_v3_axpy(ctr, a, 0.5 / nn, num);
  *r2 = pm_v3_dist2(ctr, a);
  return 1;
}

/* Is p strictly inside the diametric ball of triangle (a, b, c)? (A degenerate triangle's ball
 * is unbounded: everything is inside, so it is always flipped away when allowed.) */
static int in_ball(const double *a, const double *b, const double *c, const double *p, double *r2) {
  double ctr[3];
  if (!circumsphere(a, b, c, ctr, r2)) {
    *r2 = 0;
    return 1;
  }
  return pm_v3_dist2(p, ctr) < *r2 * (1 - 1e-12);
}

/* The 3D position of local node l. */
static const double *P3(const face_work *w, const pm_mesh *mesh, int32_t l) {
  (void)mesh;
  return &w->lxyz[3 * l];
}

/* A triangle of local nodes (a, b, c) is acceptable when it is not degenerate in 3D and its
 * normal agrees with the surface's normal at each of its nodes that has one -- so a flip never
 * folds the mesh over, and a triangle reaching round a pole or an apex is refused. */
static int acceptable(const face_work *w, const pm_mesh *mesh, int32_t a, int32_t b, int32_t c) {
  const double *A = P3(w, mesh, a), *B = P3(w, mesh, b), *C = P3(w, mesh, c);
  double ab[3], ac[3], n[3];
  pm_v3_sub(ab, B, A), pm_v3_sub(ac, C, A);
  pm_v3_cross(n, ab, ac);
  double scale = pm_v3_dot(ab, ab) + pm_v3_dot(ac, ac);
  if (!(pm_v3_dot(n, n) > 1e-20 * scale * scale)) return 0;
  const int32_t v[3] = {a, b, c};
  for (int k = 0; k < 3; ++k)
    if (pm_v3_dot(n, &w->nrm[3 * v[k]]) < 0) return 0;
  return 1;
}

/* Flip the edge (a, b) = (tri[t1][q1], tri[t1][q1 + 1]) shared by t1 = (a, b, c) and
 * t2 = (b, a, d) (edge q2 of t2) to (c, d): t1 becomes (a, d, c), t2 becomes (b, c, d), and the
 * neighbours and constraint flags follow. The outer edges of the pair are then edges 0 and 2 of
 * t1 and t2. */
static void flip_pair(face_work *w, int32_t t1, int q1, int32_t t2, int q2) {
  int32_t a = w->tri[3 * t1 + q1], b = w->tri[3 * t1 + (q1 + 1) % 3], c = w->tri[3 * t1 + (q1 + 2) % 3];
  int32_t d = w->tri[3 * t2 + (q2 + 2) % 3];
  /* Neighbours across the outer edges: (b, c), (c, a) of t1 and (a, d), (d, b) of t2. */
  int32_t n_bc = w->nbr[3 * t1 + (q1 + 1) % 3], n_ca = w->nbr[3 * t1 + (q1 + 2) % 3];
  int32_t n_ad = w->nbr[3 * t2 + (q2 + 1) % 3], n_db = w->nbr[3 * t2 + (q2 + 2) % 3];
  uint8_t f_bc = w->fixed[3 * t1 + (q1 + 1) % 3], f_ca = w->fixed[3 * t1 + (q1 + 2) % 3];
  uint8_t f_ad = w->fixed[3 * t2 + (q2 + 1) % 3], f_db = w->fixed[3 * t2 + (q2 + 2) % 3];
  /* t1 becomes (a, d, c), t2 becomes (b, c, d). */
  int32_t T1[3] = {a, d, c}, T2[3] = {b, c, d};
  int32_t N1[3] = {n_ad, t2, n_ca}, N2[3] = {n_bc, t1, n_db};
  uint8_t F1[3] = {f_ad, 0, f_ca}, F2[3] = {f_bc, 0, f_db};
  for (int q = 0; q < 3; ++q) {
    w->tri[3 * t1 + q] = T1[q], w->nbr[3 * t1 + q] = N1[q], w->fixed[3 * t1 + q] = F1[q];
    w->tri[3 * t2 + q] = T2[q], w->nbr[3 * t2 + q] = N2[q], w->fixed[3 * t2 + q] = F2[q];
  }
  /* Point the neighbours that changed sides back at the right triangle. */
  if (n_ad >= 0)
    for (int q = 0; q < 3; ++q)
      if (w->nbr[3 * n_ad + q] == t2) w->nbr[3 * n_ad + q] = t1;
  if (n_bc >= 0)
    for (int q = 0; q < 3; ++q)
      if (w->nbr[3 * n_bc + q] == t1) w->nbr[3 * n_bc + q] = t2;
}

/* Edge flips towards empty diametric balls (papers/001 section 4.3): an edge (a, b) shared by
 * (a, b, c) and (b, a, d) is flipped to (c, d) when a diametric ball of the pair contains the
 * opposite vertex and either the flipped pair has empty balls or -- the paper's tie-break for
 * edges that would flip back and forth -- both pairs fail and the flipped pair has the larger
 * minimum circumradius. A pair holding an inverted or degenerate triangle is flipped whenever the
 * flipped pair is acceptable, whatever the balls say. Guards: a constrained edge is never flipped; the flipped triangles must
 * be acceptable (non-degenerate, agreeing with the surface normal); the new edge must not exist
 * yet (no duplicate triangle); at most max_flips flips (termination is then guaranteed whatever
 * the surface; the cap is counted when hit). */
static void flip_face(face_work *w, const pm_mesh *mesh, int64_t max_flips, face_out *out,
                      uint8_t *dirty) {
  if (w->ntri < 2) return;
  pairset edges;
  if (!pairset_init(&edges, 3 * (int64_t)w->ntri)) return;
  for (int32_t t = 0; t < w->ntri; ++t)
    for (int q = 0; q < 3; ++q) pairset_add(&edges, w->tri[3 * t + q], w->tri[3 * t + (q + 1) % 3]);
  /* A FIFO of half-edges (t, q), with an in-queue flag; each edge enters through one side. */
  int64_t cap = 3 * (int64_t)w->ntri;
  int32_t *queue = malloc(sizeof(int32_t) * (size_t)cap);
  uint8_t *inq = calloc((size_t)cap, 1);
  if (!queue || !inq) {
    free(queue), free(inq), free(edges.key);
    return;
  }
  int64_t head = 0, size = 0;
  for (int32_t t = 0; t < w->ntri; ++t)
    for (int q = 0; q < 3; ++q) {
      int32_t u = w->nbr[3 * t + q];
      if (u > t && !w->fixed[3 * t + q]) queue[(head + size++) % cap] = 3 * t + q, inq[3 * t + q] = 1;
    }
  int64_t flips = 0;
  while (size > 0) {
    int32_t he = queue[head];
    head = (head + 1) % cap, --size;
    inq[he] = 0;
    int32_t t1 = he / 3, q1 = he % 3, t2 = w->nbr[he];
    if (t2 < 0 || w->fixed[he]) continue;
    int32_t a = w->tri[3 * t1 + q1], b = w->tri[3 * t1 + (q1 + 1) % 3], c = w->tri[3 * t1 + (q1 + 2) % 3];
    int q2 = 0;
    while (q2 < 3 && !(w->tri[3 * t2 + q2] == b && w->tri[3 * t2 + (q2 + 1) % 3] == a)) ++q2;
    if (q2 == 3) continue; /* inconsistent orientation: leave it */
    int32_t d = w->tri[3 * t2 + (q2 + 2) % 3];
    const double *A = P3(w, mesh, a), *B = P3(w, mesh, b), *C = P3(w, mesh, c), *D = P3(w, mesh, d);
    if (c == d || pairset_has(&edges, c, d)) continue;
    /* A pair with an inverted or degenerate triangle (left by the parameter-space triangulation
     * where the parametrization is strongly distorted) is flipped whenever the flipped pair is
     * acceptable: untangling comes before the ball criterion. */
    int tangled = !acceptable(w, mesh, a, b, c) || !acceptable(w, mesh, b, a, d);
    if (!tangled) {
      double r1, r2, r3, r4;
      int bad_old = in_ball(A, B, C, D, &r1) | in_ball(B, A, D, C, &r2);
      if (!bad_old) continue;
      int bad_new = in_ball(A, D, C, B, &r3) | in_ball(B, C, D, A, &r4);
      if (bad_new && !(fmin(r3, r4) > fmin(r1, r2))) continue;
    }
    if (!acceptable(w, mesh, a, d, c) || !acceptable(w, mesh, b, c, d)) continue;
    if (flips >= max_flips) {
      out->cap_hit = 1;
      break;
    }
    flip_pair(w, t1, q1, t2, q2);
    if (dirty) dirty[a] = dirty[b] = dirty[c] = dirty[d] = 1;
    pairset_del(&edges, a, b);
    pairset_add(&edges, c, d);
    ++flips;
    /* The four outer edges may now violate. */
    int32_t re[4] = {3 * t1 + 0, 3 * t1 + 2, 3 * t2 + 0, 3 * t2 + 2};
    for (int k = 0; k < 4; ++k)
      if (!inq[re[k]] && w->nbr[re[k]] >= 0 && !w->fixed[re[k]] && size < cap) {
        queue[(head + size++) % cap] = re[k];
        inq[re[k]] = 1;
      }
  }
  out->flips += (int32_t)flips;
  free(queue), free(inq), free(edges.key);
}

/* Is the triangle of points a, b, c (3D positions in xyz) degenerate? */
static int lifts_flat(const double *xyz, int32_t a, int32_t b, int32_t c) {
  return pm_tri_degenerate(&xyz[3 * a], &xyz[3 * b], &xyz[3 * c]);
}

/* Does the pair (a, b, c), (b, a, d) hold a triangle of no area in 3D that the flip to (c, d)
 * removes without making another? */
static int flat_pair_flips(const double *xyz, int32_t a, int32_t b, int32_t c, int32_t d) {
  return (lifts_flat(xyz, a, b, c) || lifts_flat(xyz, b, a, d)) && !lifts_flat(xyz, c, d, b) &&
         !lifts_flat(xyz, d, c, a);
}

/* Edge flips in the parameter plane under the surface's local metric. One affine map per face
 * (eq. 16) is exact only where the first fundamental form [E F; F G] is the same all over the
 * face. On a face whose parametrization is strongly uneven the Delaunay triangulation of the
 * scaled plane joins nodes far apart in 3D: long triangles across curved strips, which lift to
 * folded triangles and needles that the 3D flips, each kept acceptable, cannot all undo. Two
 * such faces: the B-spline thread of bottle.brep (gmsh face 4), where |Su| runs from about 2.5
 * at the ends of u to 48 in the middle and the angle between Su and Sv from 87 to 41 degrees
 * (estimated from the triangles of its bubble mesh), and a cone, whose |Su| shrinks to zero at
 * the apex (robust/statreport__Cone_1.brep). Here each interior edge (a, b) between (a, b, c) and
 * (b, a, d) is flipped to (c, d) when d lies inside the circle through a, b, c measured in the
 * metric averaged over the four points (the anisotropic Delaunay criterion, the metric fixed per
 * quadrilateral) and the quadrilateral is strictly convex in (u, v) -- so the triangulation stays
 * a planar one of the same points and constraints, only its connections change. An edge
 * between two copies of one seam node, and a pair holding a triangle of no area in 3D, are
 * flipped whatever the metric says when the flip is convex (and, for the flat one, makes no flat
 * triangle). A constrained edge is never flipped, nor one touching a point whose node appears
 * twice in the pair otherwise (a seam wrap, left to split_repeats); the flips are capped (the metric differs from one quadrilateral
 * to the next, so the criterion is not a global one and could cycle). Works on w->tri in point
 * indices; returns the number of flips, -1 when out of memory. */
static int64_t metric_flips(const pm_cell *f, face_work *w, int64_t max_flips, pm_error *err) {
  if (w->ntri < 2) return 0;
  double *met = malloc(sizeof(double) * 6 * (size_t)w->np), *xyz = met + 3 * (size_t)w->np;
  if (!met) return -1;
  for (int32_t p = 0; p < w->np; ++p) {
    pm_face_point fp;
    pm_face_eval(f, &w->uv[2 * p], 1, &fp);
    memcpy(&xyz[3 * p], fp.p, sizeof fp.p);
    met[3 * p] = pm_v3_dot(fp.su, fp.su);
    met[3 * p + 1] = pm_v3_dot(fp.su, fp.sv);
    met[3 * p + 2] = pm_v3_dot(fp.sv, fp.sv);
    for (int k = 0; k < 3; ++k)
      if (!isfinite(met[3 * p + k])) met[3 * p + k] = 0;
  }
  if (build_adjacency(w, w->np, err)) {
    free(met);
    return -1;
  }
  int64_t cap = 3 * (int64_t)w->ntri;
  int32_t *queue = malloc(sizeof(int32_t) * (size_t)cap);
  uint8_t *inq = calloc((size_t)cap, 1);
  if (!queue || !inq) {
    free(met), free(queue), free(inq);
    return -1;
  }
  int64_t head = 0, size = 0, flips = 0;
  for (int32_t t = 0; t < w->ntri; ++t)
    for (int q = 0; q < 3; ++q)
      if (w->nbr[3 * t + q] > t && !w->fixed[3 * t + q]) queue[size++] = 3 * t + q, inq[3 * t + q] = 1;
  while (size > 0 && flips < max_flips) {
    int32_t he = queue[head];
    head = (head + 1) % cap, --size;
    inq[he] = 0;
    int32_t t1 = he / 3, q1 = he % 3, t2 = w->nbr[he];
    if (t2 < 0 || w->fixed[he]) continue;
    int32_t a = w->tri[3 * t1 + q1], b = w->tri[3 * t1 + (q1 + 1) % 3], c = w->tri[3 * t1 + (q1 + 2) % 3];
    int q2 = 0;
    while (q2 < 3 && !(w->tri[3 * t2 + q2] == b && w->tri[3 * t2 + (q2 + 1) % 3] == a)) ++q2;
    if (q2 == 3) continue;
    int32_t d = w->tri[3 * t2 + (q2 + 2) % 3];
    const int32_t v[4] = {a, b, c, d};
    /* An edge between the two copies of one seam node (a triangle wrapped round the period) has
     * no length in 3D: any convex alternative is better, so it is flipped without the metric
     * test. Other repeated nodes leave the pair alone. */
    int twice = 0, wrap = w->node[a] == w->node[b];
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) twice |= (i != 0 || j != 1) && w->node[v[i]] == w->node[v[j]];
    if (twice) continue;
    const double *A = &w->uv[2 * a], *B = &w->uv[2 * b], *C = &w->uv[2 * c], *D = &w->uv[2 * d];
    /* Strictly convex: c and d on either side of (a, b), a and b on either side of (c, d). */
    if (pm_orient2d(A, B, C) * pm_orient2d(A, B, D) >= 0) continue;
    if (pm_orient2d(C, D, A) * pm_orient2d(C, D, B) >= 0) continue;
    /* So has a triangle whose corners lie on one line in 3D: a seam node, the next one along
     * the seam and a copy of the apex, all on one straight ruling of a cone (statreport/
     * Cone_1.brep, where the mesher left no face node as close to the apex as the seam's first
     * node). Each side of the seam holds one, the two repeat each other, and their edge into
     * the apex is then used four times; split_repeats would split it at its (u, v) middle, a
     * point just beside the seam node (a needle). Flipping it away, when neither new triangle
     * is flat, leaves a fan round the apex. */
    if (!wrap) wrap = flat_pair_flips(xyz, a, b, c, d);
    if (!wrap) {
      double E = 0, F = 0, G = 0;
      for (int i = 0; i < 4; ++i) E += met[3 * v[i]], F += met[3 * v[i] + 1], G += met[3 * v[i] + 2];
      double det = E * G - F * F;
      if (!(E > 0) || !(det > 1e-12 * (E + G) * (E + G))) continue;
      /* Cholesky factor L of [E F; F G] (upper triangular, det L > 0 keeps orientations): the
       * metric lengths are Euclidean lengths of L (uv - uv_a). */
      double l00 = sqrt(E), l01 = F / l00, l11 = sqrt(det) / l00;
      double X[4][2];
      for (int i = 0; i < 4; ++i) {
        double du = w->uv[2 * v[i]] - A[0], dv = w->uv[2 * v[i] + 1] - A[1];
        X[i][0] = l00 * du + l01 * dv, X[i][1] = l11 * dv;
      }
      int o = pm_orient2d(X[0], X[1], X[2]);
      if (o == 0 || o * pm_incircle(X[0], X[1], X[2], X[3]) <= 0) continue;
    }
    flip_pair(w, t1, q1, t2, q2);
    ++flips;
    int32_t re[4] = {3 * t1 + 0, 3 * t1 + 2, 3 * t2 + 0, 3 * t2 + 2};
    for (int k = 0; k < 4; ++k)
      if (!inq[re[k]] && w->nbr[re[k]] >= 0 && !w->fixed[re[k]] && size < cap) {
        queue[(head + size++) % cap] = re[k];
        inq[re[k]] = 1;
      }
  }
  free(met), free(queue), free(inq);
  free(w->nbr), free(w->fixed);
  w->nbr = NULL, w->fixed = NULL;
  return flips;
}

/* Sum and maximum of R/l_min over the face's non-degenerate triangles; degenerate ones (zero
 * area in 3D) are counted apart, their R/l_min being unbounded. */
static double sum_aspect(const face_work *w, const pm_mesh *mesh, double *max, int32_t *ndegen) {
  double s = 0;
  for (int32_t t = 0; t < w->ntri; ++t) {
    pm_tri_measure q;
    pm_tri_measure_eval(P3(w, mesh, w->tri[3 * t]), P3(w, mesh, w->tri[3 * t + 1]),
                        P3(w, mesh, w->tri[3 * t + 2]), &q);
    if (q.degenerate) {
      (*ndegen)++;
      continue;
    }
    s += q.aspect_ratio;
    *max = fmax(*max, q.aspect_ratio);
  }
  return s;
}

/* Is the face curved? Its largest principal curvature at a few inside points, relative to the
 * model size. */
static int face_is_curved(const pm_cell *f, double diag) {
  for (int a = 1; a <= 3; ++a)
    for (int b = 1; b <= 3; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * a / 4, f->lo[1] + (f->hi[1] - f->lo[1]) * b / 4};
      if (!pm_face_inside(f, uv)) continue;
      double k1, k2;
      pm_face_curvatures(f, uv, &k1, &k2, NULL);
      if (fabs(k1) * diag > 1e-6) return 1;
    }
  return 0;
}

static int is_pole(const face_work *w, int32_t node) {
  for (int32_t k = 0; k < w->npole; ++k)
    if (w->pole[k] == node) return 1;
  return 0;
}

/* Step 2, `smooth`: p->smooth sweeps of face_smooth.h over the face's interior nodes, each
 * followed by the 3D flips again (the moves change which balls are empty). Only nodes that lie
 * on this face alone move -- not a curve's, a vertex's, a pole's or one the repair added -- so
 * faces stay independent and the caller writes the moves into the mesh in face order. */
static pm_status smooth_face(const pm_cell *f, const pm_mesh *mesh, const pm_connect_params *p,
                             face_work *w, face_out *out, pm_error *err) {
  int32_t nv = w->nloc;
  double *uv = malloc(sizeof(double) * 2 * (size_t)(nv ? nv : 1));
  uint8_t *movable = calloc((size_t)(nv ? nv : 1), 1);
  int32_t *npoint = calloc((size_t)(nv ? nv : 1), sizeof(int32_t));
  uint8_t *dirty = malloc((size_t)(nv ? nv : 1));
  if (!uv || !movable || !npoint || !dirty) goto nomem;
  for (int32_t q = w->np - 1; q >= 0; --q) {
    int32_t l = w->loc[q];
    npoint[l]++;
    uv[2 * l] = w->uv[2 * q], uv[2 * l + 1] = w->uv[2 * q + 1];
  }
  int32_t nmov = 0;
  for (int32_t l = 0; l < nv; ++l) {
    int32_t g = w->gnode[l];
    movable[l] = g < mesh->nnode && mesh->node_dim[g] == PM_FACE && npoint[l] == 1 &&
                 !is_pole(w, g) && pm_v3_dot(&w->nrm[3 * l], &w->nrm[3 * l]) > 0;
    nmov += movable[l];
  }
  if (nmov > 0) {
    /* Each sweep tries only the nodes whose ring changed since their last try (face_smooth.h):
     * the flips after a sweep mark the nodes of the triangles they change. */
    memset(dirty, 1, (size_t)nv);
    for (int k = 0; k < p->smooth; ++k) {
      int32_t n = pm_face_smooth_sweep(f, nv, w->lxyz, uv, w->nrm, movable, w->ntri, w->tri,
                                       p->needle_moves ? PM_CONNECT_NEEDLE_DEG : 0, dirty);
      if (n < 0) goto nomem;
      out->smooth_moves += n;
      if (n == 0) break;
      if (p->flips != PM_FLIP_NONE)
        flip_face(w, mesh, (int64_t)p->max_flips_per_tri * w->ntri, out, dirty);
    }
    out->moved = malloc(sizeof(int32_t) * (size_t)nmov);
    out->moved_xyz = malloc(sizeof(double) * 3 * (size_t)nmov);
    out->moved_uv = malloc(sizeof(double) * 2 * (size_t)nmov);
    if (!out->moved || !out->moved_xyz || !out->moved_uv) goto nomem;
    for (int32_t l = 0; l < nv; ++l) {
      if (!movable[l]) continue;
      int32_t g = w->gnode[l], k = out->nmoved;
      if (memcmp(&w->lxyz[3 * l], &mesh->xyz[3 * (size_t)g], 3 * sizeof(double)) == 0) continue;
      out->moved[k] = g;
      memcpy(&out->moved_xyz[3 * k], &w->lxyz[3 * l], 3 * sizeof(double));
      memcpy(&out->moved_uv[2 * k], &uv[2 * l], 2 * sizeof(double));
      out->nmoved++;
    }
  }
  free(uv), free(movable), free(npoint), free(dirty);
  return PM_OK;
nomem:
  free(uv), free(movable), free(npoint), free(dirty);
  return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
}

/* Take a CDT's triangles into w->tri: merged points mapped to their representative, triangles
 * collapsed onto a pole (two corners on one node: the two ends of a degenerate pcurve) dropped
 * and counted. */
static pm_status take_triangles(face_work *w, const pm_cdt_result *cdt, int32_t *pole,
                                pm_error *err) {
  w->tri = malloc(sizeof(int32_t) * 3 * (size_t)(cdt->ntri ? cdt->ntri : 1));
  if (!w->tri) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  w->ntri = 0;
  for (int32_t t = 0; t < cdt->ntri; ++t) {
    int32_t v[3];
    for (int q = 0; q < 3; ++q) {
      v[q] = cdt->tri[3 * t + q];
      if (cdt->merged_into) v[q] = cdt->merged_into[v[q]];
    }
    int32_t na = w->node[v[0]], nb = w->node[v[1]], nc = w->node[v[2]];
    int32_t twice = na == nb || na == nc ? na : (nb == nc ? nb : -1);
    if (twice >= 0 && is_pole(w, twice)) {
      (*pole)++;
      continue;
    }
    /* Two corners on one node that is not a pole: the two sides of a seam, joined across the
     * whole period where the face has too few nodes to go round. Kept for split_repeats, which
     * splits it; what still collapses afterwards is dropped there. */
    memcpy(&w->tri[3 * w->ntri], v, sizeof v);
    w->ntri++;
  }
  return PM_OK;
}

/* Node triples, sorted, for finding triangles that repeat. */
typedef struct tri_key {
  int32_t n[3]; /* sorted nodes */
  int32_t face, tri;
} tri_key;

static void sort3(int32_t *x) {
  if (x[0] > x[1]) { int32_t y = x[0]; x[0] = x[1]; x[1] = y; }
  if (x[1] > x[2]) { int32_t y = x[1]; x[1] = x[2]; x[2] = y; }
  if (x[0] > x[1]) { int32_t y = x[0]; x[0] = x[1]; x[1] = y; }
}

static int tri_key_cmp(const void *a, const void *b) {
  const tri_key *x = a, *y = b;
  for (int k = 0; k < 3; ++k)
    if (x->n[k] != y->n[k]) return (x->n[k] > y->n[k]) - (x->n[k] < y->n[k]);
  if (x->face != y->face) return (x->face > y->face) - (x->face < y->face);
  return (x->tri > y->tri) - (x->tri < y->tri);
}

/* Unacceptable triangles of a triangulation given in point indices. */
static int32_t count_unacceptable_in(const face_work *w, const pm_mesh *mesh, const int32_t *tri,
                                     int32_t ntri) {
  int32_t n = 0;
  for (int32_t t = 0; t < ntri; ++t)
    n += !acceptable(w, mesh, w->loc[tri[3 * t]], w->loc[tri[3 * t + 1]], w->loc[tri[3 * t + 2]]);
  return n;
}

/* Repeats within one face (see "repairing triangles that repeat" below): a node edge of more
 * than two triangles (a node joined to both sides of a seam where the face is too coarse to go
 * round: the ring next to a cone's apex), or two triangles on the same three nodes (a pole fan
 * of two). Each parameter-space edge behind one is split at its (u, v) middle, in the
 * triangulation as it is: the two triangles at the edge become four, and the rest is untouched
 * (a new triangulation of the whole face would start the 3D flips from another tangle). The new
 * nodes get ids from out->vbase on; the caller adds them to the mesh. */
static int cmp_i64(const void *a, const void *b) {
  int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
  return (x > y) - (x < y);
}

/* Append a point of a new node at uv (S(uv) in 3D); returns its point index or -1. */
static int32_t add_split_point(const pm_cell *f, face_work *w, face_out *out, const double uv[2]) {
  if (w->np == w->capp) {
    int32_t cap = 2 * w->capp;
    double *a = realloc(w->uv, sizeof(double) * 2 * (size_t)cap);
    if (a) w->uv = a;
    int32_t *b = realloc(w->node, sizeof(int32_t) * (size_t)cap);
    if (b) w->node = b;
    int32_t *c = realloc(w->next_of_node, sizeof(int32_t) * (size_t)cap);
    if (c) w->next_of_node = c;
    int32_t *d = realloc(w->loc, sizeof(int32_t) * (size_t)cap);
    if (d) w->loc = d;
    if (!a || !b || !c || !d) return -1;
    w->capp = cap;
  }
  /* xy holds exactly np points (gather_face_points): it grows one at a time, rarely. */
  double *x = realloc(w->xy, sizeof(double) * 2 * ((size_t)w->np + 1));
  if (!x) return -1;
  w->xy = x;
  if (w->nloc == w->capl) {
    int32_t cap = 2 * w->capl;
    int32_t *g = realloc(w->gnode, sizeof(int32_t) * (size_t)cap);
    if (g) w->gnode = g;
    double *n = realloc(w->nrm, sizeof(double) * 3 * (size_t)cap);
    if (n) w->nrm = n;
    double *l = realloc(w->lxyz, sizeof(double) * 3 * (size_t)cap);
    if (l) w->lxyz = l;
    if (!g || !n || !l) return -1;
    w->capl = cap;
  }
  double *nx = realloc(out->new_xyz, sizeof(double) * 3 * ((size_t)out->nnew + 1));
  if (nx) out->new_xyz = nx;
  double *nu = realloc(out->new_uv, sizeof(double) * 2 * ((size_t)out->nnew + 1));
  if (nu) out->new_uv = nu;
  if (!nx || !nu) return -1;
  pm_face_point fp;
  pm_face_eval(f, uv, 1, &fp);
  int32_t p = w->np++, l = w->nloc++;
  w->uv[2 * p] = uv[0], w->uv[2 * p + 1] = uv[1];
  w->xy[2 * p] = uv[0], w->xy[2 * p + 1] = uv[1]; /* not triangulated again */
  w->node[p] = out->vbase + out->nnew;
  w->next_of_node[p] = -1;
  w->loc[p] = l;
  w->gnode[l] = w->node[p];
  memcpy(&w->lxyz[3 * l], fp.p, sizeof fp.p);
  pm_face_point_normal(&fp, PM_CONNECT_NORMAL_MIN_SIN, &w->nrm[3 * l]);
  memcpy(&out->new_xyz[3 * out->nnew], fp.p, sizeof fp.p);
  out->new_uv[2 * out->nnew] = uv[0], out->new_uv[2 * out->nnew + 1] = uv[1];
  out->nnew++;
  return p;
}

/* Split parameter-space edge (p, r) of the point triangulation at its (u, v) middle, when that
 * lies in the trimmed region. 0 done or skipped, -1 out of memory. */
static int split_edge(const pm_cell *f, face_work *w, face_out *out, int32_t p, int32_t r) {
  double mid[2] = {0.5 * (w->uv[2 * p] + w->uv[2 * r]), 0.5 * (w->uv[2 * p + 1] + w->uv[2 * r + 1])};
  if (!pm_face_inside(f, mid)) return 0;
  int32_t at[2], nat = 0;
  for (int32_t t = 0; t < w->ntri && nat < 2; ++t)
    for (int q = 0; q < 3; ++q) {
      int32_t a = w->tri[3 * t + q], b = w->tri[3 * t + (q + 1) % 3];
      if ((a == p && b == r) || (a == r && b == p)) at[nat++] = 3 * t + q;
    }
  if (nat == 0) return 0;
  int32_t *g = realloc(w->tri, sizeof(int32_t) * 3 * ((size_t)w->ntri + (size_t)nat));
  if (!g) return -1;
  w->tri = g;
  int32_t m = add_split_point(f, w, out, mid);
  if (m < 0) return -1;
  for (int k = 0; k < nat; ++k) {
    int32_t t = at[k] / 3, q = at[k] % 3;
    int32_t a = w->tri[3 * t + q], b = w->tri[3 * t + (q + 1) % 3], c = w->tri[3 * t + (q + 2) % 3];
    /* (a, b, c) -> (a, m, c) and (m, b, c): the orientation is kept. */
    w->tri[3 * t + (q + 1) % 3] = m;
    int32_t *n = &w->tri[3 * w->ntri++];
    n[0] = m, n[1] = b, n[2] = c;
    (void)a;
  }
  return 0;
}

static pm_status split_repeats(const pm_cell *f, face_work *w, face_out *out, pm_error *err) {
  /* Local-node edges as (low << 32 | high) keys, sorted: a key that occurs more than twice is
   * an over-used edge; the parameter-space edges behind it are then looked up. */
  int64_t ne = 3 * (int64_t)w->ntri;
  int64_t *e = malloc(sizeof(int64_t) * (size_t)(ne ? ne : 1));
  int32_t *split = malloc(sizeof(int32_t) * 6 * (size_t)(ne ? ne : 1)); /* wraps, repeats, pillows */
  if (!e || !split) {
    free(e), free(split);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t t = 0; t < w->ntri; ++t)
    for (int q = 0; q < 3; ++q) {
      int64_t a = w->loc[w->tri[3 * t + q]], b = w->loc[w->tri[3 * t + (q + 1) % 3]];
      e[3 * t + q] = a < b ? (a << 32 | b) : (b << 32 | a);
    }
  qsort(e, (size_t)ne, sizeof(int64_t), cmp_i64);
  int64_t nsplit = 0;
  /* Triangles wrapped round the period (two corners on one node, see take_triangles): the edge
   * between the two copies. */
  for (int32_t t = 0; t < w->ntri; ++t)
    for (int q = 0; q < 3; ++q) {
      int32_t p = w->tri[3 * t + q], r = w->tri[3 * t + (q + 1) % 3];
      if (w->node[p] == w->node[r] && p != r)
        split[2 * nsplit] = p < r ? p : r, split[2 * nsplit + 1] = p < r ? r : p, ++nsplit;
    }
  for (int64_t i = 0, j; i < ne; i = j) {
    for (j = i; j < ne && e[j] == e[i]; ++j) {}
    if (j - i <= 2) continue;
    int32_t a = (int32_t)(e[i] >> 32), b = (int32_t)(e[i] & 0xffffffff);
    for (int32_t t = 0; t < w->ntri; ++t)
      for (int q = 0; q < 3; ++q) {
        int32_t p = w->tri[3 * t + q], r = w->tri[3 * t + (q + 1) % 3];
        int32_t la = w->loc[p], lb = w->loc[r];
        if (p < r && ((la == a && lb == b) || (la == b && lb == a)))
          split[2 * nsplit] = p, split[2 * nsplit + 1] = r, ++nsplit;
      }
  }
  free(e);
  /* Two triangles on the same three nodes whose edges are each used twice (a closed pillow):
   * each one's longest parameter-space edge. */
  if (nsplit == 0 && w->ntri > 1) {
    tri_key *k = malloc(sizeof(tri_key) * (size_t)w->ntri);
    if (!k) {
      free(split);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    for (int32_t t = 0; t < w->ntri; ++t) {
      for (int q = 0; q < 3; ++q) k[t].n[q] = w->loc[w->tri[3 * t + q]];
      sort3(k[t].n);
      k[t].face = 0, k[t].tri = t;
    }
    qsort(k, (size_t)w->ntri, sizeof(tri_key), tri_key_cmp);
    for (int32_t t = 1; t < w->ntri; ++t) {
      if (memcmp(k[t].n, k[t - 1].n, sizeof k[t].n) != 0) continue;
      for (int c = 0; c < 2; ++c) {
        const int32_t *v = &w->tri[3 * k[t - c].tri];
        int best = 0;
        double bl = -1;
        for (int q = 0; q < 3; ++q) {
          const double *A = &w->uv[2 * v[q]], *B = &w->uv[2 * v[(q + 1) % 3]];
          double l = hypot(A[0] - B[0], A[1] - B[1]);
          if (l > bl) bl = l, best = q;
        }
        split[2 * nsplit] = v[best], split[2 * nsplit + 1] = v[(best + 1) % 3], ++nsplit;
      }
    }
    free(k);
  }
  pm_status st = PM_OK;
  for (int64_t i = 0; i < nsplit && !st; ++i) {
    /* An edge listed twice (shared by two wrapped triangles) is split once. */
    int dup = 0;
    for (int64_t k = 0; k < i && !dup; ++k)
      dup = split[2 * k] == split[2 * i] && split[2 * k + 1] == split[2 * i + 1];
    if (!dup && split_edge(f, w, out, split[2 * i], split[2 * i + 1]))
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  free(split);
  /* What still has two corners on one node collapses in 3D: drop it. */
  int32_t n = 0;
  for (int32_t t = 0; t < w->ntri; ++t) {
    const int32_t *v = &w->tri[3 * t];
    if (w->node[v[0]] == w->node[v[1]] || w->node[v[1]] == w->node[v[2]] ||
        w->node[v[0]] == w->node[v[2]]) {
      out->pole++;
      continue;
    }
    memmove(&w->tri[3 * n], v, 3 * sizeof(int32_t));
    ++n;
  }
  w->ntri = n;
  return st;
}

static void connect_face(const pm_model *m, const pm_cell *f, const pm_mesh *mesh, const chains *ch,
                         const buckets *fb, const pm_connect_params *p, face_out *out) {
  face_work w = {0};
  pm_error *err = &out->err;
  pm_cdt_result cdt = {0};
  out->vbase = mesh->nnode;
  pm_status s = gather_face_points(m, f, mesh, ch, fb, 0, &w, err);
  if (s) goto fail;
  if (w.np < 3) {
    s = pm_error_setf(err, PM_ERR_GEOM, "face %d has fewer than 3 nodes", f->tag);
    goto fail;
  }
  if ((s = local_nodes(f, mesh, &w, err))) goto fail;
  /* The unscaled triangulation; with the affine scaling (eq. 16) a second one in the scaled
   * plane, kept unless it lifts to more inverted triangles than the first (one affine map cannot
   * undo the distortion of a whole sphere near its poles). */
  s = pm_cdt_triangulate(w.xy, w.np, w.cons, w.nc, 1, 1, &cdt, err);
  if (s) goto fail_cdt;
  if ((s = take_triangles(&w, &cdt, &out->pole, err))) goto fail;
  if (p->affine && affine_scale(f, &w, mesh, &cdt)) {
    pm_cdt_result scaled = {0};
    s = pm_cdt_triangulate(w.xy, w.np, w.cons, w.nc, 1, 1, &scaled, err);
    if (s) goto fail_cdt;
    int32_t *raw_tri = w.tri, raw_n = w.ntri, raw_pole = out->pole, pole = 0;
    w.tri = NULL, w.ntri = 0;
    s = take_triangles(&w, &scaled, &pole, err);
    pm_cdt_result_free(&scaled);
    if (s) {
      free(raw_tri);
      goto fail;
    }
    if (count_unacceptable_in(&w, mesh, w.tri, w.ntri) > count_unacceptable_in(&w, mesh, raw_tri, raw_n)) {
      free(w.tri);
      w.tri = raw_tri, w.ntri = raw_n, out->pole = raw_pole;
    } else {
      free(raw_tri);
      out->pole = pole;
    }
  }
  pm_cdt_result_free(&cdt);
  if (p->metric_flips) {
    int64_t nf = metric_flips(f, &w, (int64_t)p->max_flips_per_tri * w.ntri, err);
    if (nf < 0) {
      s = err->code ? err->code : pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto fail;
    }
    out->metric_flips = (int32_t)nf;
  }
  if ((s = split_repeats(f, &w, out, err))) goto fail;
  to_local_nodes(&w);
  out->curved = face_is_curved(f, m->diagonal);
  if (out->curved) out->asp_before = sum_aspect(&w, mesh, &out->max_before, &out->degen_before);
  if (p->flips != PM_FLIP_NONE && w.ntri > 1) {
    s = build_adjacency(&w, w.nloc, err);
    if (s) goto fail;
    flip_face(&w, mesh, (int64_t)p->max_flips_per_tri * w.ntri, out, NULL);
    if (p->smooth > 0 && (s = smooth_face(f, mesh, p, &w, out, err))) goto fail;
  }
  if (out->curved) out->asp_after = sum_aspect(&w, mesh, &out->max_after, &out->degen_after);
  out->tri = malloc(sizeof(int32_t) * 3 * (size_t)(w.ntri ? w.ntri : 1));
  if (!out->tri) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto fail;
  }
  int sign = pm_face_mesh_sign(m, f->index);
  for (int32_t t = 0; t < w.ntri; ++t) {
    int32_t a = w.gnode[w.tri[3 * t]], b = w.gnode[w.tri[3 * t + 1]], c = w.gnode[w.tri[3 * t + 2]];
    out->tri[3 * t] = a;
    out->tri[3 * t + 1] = sign > 0 ? b : c;
    out->tri[3 * t + 2] = sign > 0 ? c : b;
  }
  out->ntri = w.ntri;
  face_work_free(&w);
  out->status = PM_OK;
  return;
fail_cdt:
  pm_error_prefix(err, "face %d", f->tag);
fail:
  pm_cdt_result_free(&cdt);
  face_work_free(&w);
  out->status = s ? s : PM_ERR_INTERNAL;
}

/* ---- repairing triangles that repeat ----------------------------------------------------------- */

/* Two triangles on the same three nodes make a mesh the checker rejects (a duplicate element, an
 * edge of four triangles). The parameter-space triangulation gives them in two places:
 *   - a pole with only two neighbouring nodes (a cone's apex when the mesher put a single node
 *     near it: statreport/Cone_1.brep): its fan closes with the same triangle twice, once on
 *     each side of the seam;
 *   - two faces that share both curves of a corner (an internal face bounded by the same curves
 *     as a face of the skin: the wing root of step/wing_fuselage.step): the corner's triangle,
 *     made of the vertex and the first node along each curve, is the same in both.
 * Neither is a matter of the triangulation alone: the node set has to change. A face node is
 * added at the middle of the repeated triangle's longest edge that is not a curve segment
 * (projected onto the face), which splits that edge in one face only, and the face is connected
 * again; the first of two faces keeps its triangle. REPAIR_ROUNDS bounds the rounds. */
#define REPAIR_ROUNDS 4

/* The node to add for repeated triangle (a, b, c) of face f: the middle of its longest edge that
 * is no curve segment, projected onto f; 0 when it lies in f's trimmed region. */
static int repair_point(const pm_model *m, const pm_mesh *mesh, const pairset *segs, int32_t f,
                        const int32_t v[3], double uv[2], double xyz[3]) {
  const pm_cell *fc = &m->cells[PM_FACE][f];
  int best = -1;
  double bestl = -1;
  for (int k = 0; k < 3; ++k) {
    int32_t a = v[k], b = v[(k + 1) % 3];
    if (pairset_has(segs, a, b)) continue;
    double l = pm_v3_dist2(&mesh->xyz[3 * a], &mesh->xyz[3 * b]);
    if (l > bestl) bestl = l, best = k;
  }
  if (best < 0) return -1;
  const double *A = &mesh->xyz[3 * v[best]], *B = &mesh->xyz[3 * v[(best + 1) % 3]];
  double mid[3] = {0.5 * (A[0] + B[0]), 0.5 * (A[1] + B[1]), 0.5 * (A[2] + B[2])};
  /* A face node of the triangle is the natural start of the projection. */
  const double *guess = NULL;
  for (int k = 0; k < 3 && !guess; ++k)
    if (mesh->node_dim[v[k]] == PM_FACE && mesh->node_cell[v[k]] == f) guess = &mesh->node_par[2 * v[k]];
  double dist;
  if (pm_cell_project(fc, mid, guess, uv, xyz, &dist, NULL) != PM_OK) return -1;
  pm_cell_wrap(fc, uv);
  if (!pm_face_inside(fc, uv) || !(dist <= sqrt(bestl))) return -1;
  return 0;
}

/* Find the repeated triangles of the faces' outputs and add a repair node for each to the mesh;
 * `redo` flags the faces that received one. Returns the number of nodes added, or -1 when out of
 * memory. */
static int32_t repair_repeats(const pm_model *m, pm_mesh *mesh, const face_out *fo, uint8_t *redo,
                              pm_error *err) {
  int32_t nf = m->count[PM_FACE];
  int64_t nt = 0;
  for (int32_t f = 0; f < nf; ++f) nt += fo[f].ntri;
  tri_key *k = malloc(sizeof(tri_key) * (size_t)(nt ? nt : 1));
  pairset segs;
  if (!k || !pairset_init(&segs, mesh->nseg)) {
    free(k);
    pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    return -1;
  }
  for (int32_t i = 0; i < mesh->nseg; ++i) pairset_add(&segs, mesh->seg[2 * i], mesh->seg[2 * i + 1]);
  int64_t n = 0;
  for (int32_t f = 0; f < nf; ++f)
    for (int32_t t = 0; t < fo[f].ntri; ++t) {
      memcpy(k[n].n, &fo[f].tri[3 * t], 3 * sizeof(int32_t));
      sort3(k[n].n);
      k[n].face = f, k[n].tri = t, ++n;
    }
  qsort(k, (size_t)n, sizeof(tri_key), tri_key_cmp);
  int32_t added = 0;
  for (int64_t i = 1; i < n && added >= 0; ++i) {
    if (memcmp(k[i].n, k[i - 1].n, sizeof k[i].n) != 0) continue;
    /* k[i] repeats k[i - 1]: the later one (face order, then triangle order) is repaired, once
     * per face and round. */
    int32_t f = k[i].face;
    if (redo[f]) continue;
    double uv[2], xyz[3];
    if (repair_point(m, mesh, &segs, f, &fo[f].tri[3 * k[i].tri], uv, xyz)) continue;
    if (pm_mesh_add_node(mesh, xyz, PM_FACE, f, uv, NULL, err)) {
      added = -1;
      break;
    }
    redo[f] = 1;
    ++added;
  }
  free(k), free(segs.key);
  return added;
}

/* Remove the nodes flagged in drop and renumber what the connection has built so far (vertex
 * nodes, buckets, chains). */
static pm_status drop_and_rebuild(const pm_model *m, pm_mesh *mesh, const uint8_t *drop,
                                  int32_t *vnode, buckets *cb, buckets *fb, chains *ch,
                                  pm_error *err) {
  compact_nodes(mesh, drop);
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == PM_VERTEX) vnode[mesh->node_cell[i]] = i;
  buckets_free(cb), buckets_free(fb), chains_free(ch);
  pm_status s = buckets_build(mesh, PM_CURVE, m->count[PM_CURVE], cb, err);
  if (!s) s = buckets_build(mesh, PM_FACE, m->count[PM_FACE], fb, err);
  if (!s) s = chains_build(m, mesh, cb, vnode, ch, err);
  return s;
}

/* Step 1a: a curve node at the parameter of the node before it in its chain, or of the curve's
 * end, adds a segment of no length: its two ends are one point of every face the curve bounds,
 * and the parameter-space triangulation of those faces fails on it, or joins it to a copy of
 * itself. So does a curve node within CURVE_NODE_MERGE_REL of the diagonal of a vertex node or
 * of a curve node before it in index order, on its curve or another (of a run of close nodes,
 * the first is kept): nearer than that the two are one point of the model (below, at 1e-10,
 * the checker would reject them as one node twice), and any triangle on the segment between
 * them is a needle of no size. Such nodes are dropped. A mesher
 * that clamps its curve nodes to the curve's parameter range can leave several at an end: psys
 * on robust/step__SampleCrankshaft4A.stp left eleven, on curves 35 and 324, 1e-11 of the
 * diagonal apart at the point where both curves end, 0.14 off their end vertex, and three more
 * 1.5e-7 to 5.6e-7 apart (up to 1.7e-9 of the diagonal): a 0-degree triangle joined one of the
 * face's nodes to two of them. Parameters within 1e-12 of the curve's range are the same. */
#define CURVE_NODE_MERGE_REL 1e-7 /* above OpenCASCADE's confusion tolerance (1e-7 model units)
                                     on models of 1 to 1000 units, far below the feature floor */
/* Flag every curve node that has a vertex node, or a curve node of lower index, within tol (a
 * sweep along x; the flagged set is a property of the pairs, so it does not depend on the order
 * of the sweep). Returns the count, -1 when out of memory. */
static int32_t flag_duplicate_curve_nodes(const pm_mesh *mesh, double tol, uint8_t *drop) {
  int32_t n = 0;
  tnode *k = malloc(sizeof(tnode) * ((size_t)mesh->nnode + 1)); /* keyed by x */
  if (!k) return -1;
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] <= PM_CURVE) k[n++] = (tnode){mesh->xyz[3 * (size_t)i], i};
  qsort(k, (size_t)n, sizeof(tnode), tnode_cmp);
  int32_t ndrop = 0;
  for (int32_t a = 0; a < n; ++a)
    for (int32_t b = a + 1; b < n && k[b].t - k[a].t <= tol; ++b) {
      int32_t i = k[a].id, j = k[b].id;
      if (pm_v3_dist2(&mesh->xyz[3 * (size_t)i], &mesh->xyz[3 * (size_t)j]) > tol * tol) continue;
      /* the one to drop: a curve node, the later one when both are */
      int32_t d = mesh->node_dim[i] == PM_VERTEX ? j : mesh->node_dim[j] == PM_VERTEX ? i : (i > j ? i : j);
      if (mesh->node_dim[d] == PM_CURVE && !drop[d]) drop[d] = 1, ++ndrop;
    }
  free(k);
  return ndrop;
}

static pm_status drop_coincident_curve_nodes(const pm_model *m, pm_mesh *mesh, int32_t *vnode,
                                            buckets *cb, buckets *fb, chains *ch,
                                            pm_connect_report *rep, pm_error *err) {
  uint8_t *drop = calloc((size_t)mesh->nnode + 1, 1);
  if (!drop) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t ndrop = flag_duplicate_curve_nodes(mesh, CURVE_NODE_MERGE_REL * m->diagonal, drop);
  if (ndrop < 0) {
    free(drop);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const int32_t a = ch->off[c], b = ch->off[c + 1];
    const pm_cell *cv = &m->cells[PM_CURVE][c];
    const double tol = 1e-12 * fabs(cv->hi[0] - cv->lo[0]);
    double last = ch->t[a];
    for (int32_t k = a + 1; k + 1 < b; ++k) {
      if (drop[ch->node[k]]) continue;
      if (ch->t[k] - last <= tol || ch->t[b - 1] - ch->t[k] <= tol) {
        drop[ch->node[k]] = 1, ++ndrop;
        continue;
      }
      last = ch->t[k];
    }
  }
  pm_status s = PM_OK;
  if (ndrop) {
    rep->dropped_nodes += ndrop;
    s = drop_and_rebuild(m, mesh, drop, vnode, cb, fb, ch, err);
  }
  free(drop);
  return s;
}

/* Step 1b over all faces (flag_crossed_nodes): drop the flagged face nodes and renumber what
 * the connection has built so far (vertex nodes, buckets, chains). */
static pm_status drop_crossed_nodes(const pm_model *m, pm_mesh *mesh, int32_t *vnode, buckets *cb,
                                    buckets *fb, chains *ch, pm_connect_report *rep,
                                    pm_error *err) {
  uint8_t *drop = calloc((size_t)mesh->nnode + 1, 1);
  if (!drop) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t nf = m->count[PM_FACE], ndrop = 0, oom = 0;
  /* Each face flags only its own nodes, so faces run in parallel. */
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : ndrop) reduction(| : oom)
  for (int32_t f = 0; f < nf; ++f) {
    int32_t n = flag_crossed_nodes(m, &m->cells[PM_FACE][f], mesh, ch, fb, drop);
    if (n < 0) oom = 1;
    else ndrop += n;
  }
  pm_status s = PM_OK;
  if (oom) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  else if (ndrop) {
    rep->crossed_nodes = ndrop;
    s = drop_and_rebuild(m, mesh, drop, vnode, cb, fb, ch, err);
  }
  free(drop);
  return s;
}

/* ---- step 1c: boundary chords that cross in a face's parameter plane ---------------------- */

/* A face's boundary reaches its parameter-space triangulation as chords between consecutive
 * curve nodes. Where the face is narrower than the node spacing -- a sliver between two curves,
 * or two curves that leave a vertex almost tangent (brep__test_11551.brep's face 1: a circle and
 * a curve leaving it tangentially, 0.006 apart at 0.3 from the vertex, where psys put its nodes
 * 0.16 to 0.3 apart) -- the chord of one curve can cross a chord of the other, and no
 * triangulation respects both (the triangulation names the pair and the face fails). One chord
 * of such a crossing is split at its curve's middle parameter, on the curve (a new curve node,
 * shared by every face that uses the curve), and the faces are looked at again. The chord split
 * is the one whose two halves no longer cross the other chord; when both or neither would do,
 * the longer in 3D (both when they are as long). Splitting both, or the longer only, keeps
 * the picture the same near a tangent vertex, where it is the same at every scale: the crossing
 * moves closer to the vertex round after round (the crescent of test_cad_heal did so for 16
 * rounds). The chord that sags towards the other curve is the one to split, and its halves are
 * the ones that part. CHORD_ROUNDS bounds the rounds; a
 * crossing left after them reaches the triangulation, which names it. Only proper
 * crossings count: chords that meet at a node, or where the end of one lies on the other, are
 * what the triangulation accepts. A node set without crossings is left as it is. */
#define CHORD_ROUNDS 16

typedef struct chord {
  double lo, hi; /* the chord's u range, for the sweep */
  int32_t k;     /* its constraint in the face's work */
} chord;

static int chord_cmp(const void *a, const void *b) {
  const chord *x = a, *y = b;
  if (x->lo != y->lo) return x->lo < y->lo ? -1 : 1;
  return (x->k > y->k) - (x->k < y->k);
}

/* 1 when segments ab and cd cross properly (each one's ends strictly on either side of the other). */
static int crosses(const double a[2], const double b[2], const double c[2], const double d[2]) {
  return pm_orient2d(a, b, c) * pm_orient2d(a, b, d) < 0 &&
         pm_orient2d(c, d, a) * pm_orient2d(c, d, b) < 0;
}

/* 1 when splitting constraint k of w at its curve's middle parameter leaves no proper crossing
 * of its two halves with segment cd in (u, v). */
static int split_parts(const pm_cell *f, const face_work *w, const chains *ch, int32_t k,
                       const double c[2], const double d[2]) {
  const int32_t seg = w->cons_seg[k];
  double mid[2];
  pm_face_curve_uv(f, &w->cons_use[k], 0.5 * (ch->t[seg] + ch->t[seg + 1]), mid);
  const double *a = &w->uv[2 * w->cons[2 * k]], *b = &w->uv[2 * w->cons[2 * k + 1]];
  return !crosses(a, mid, c, d) && !crosses(mid, b, c, d);
}

/* Flag in split (by chain position) the curve segments of face f whose chords cross another of
 * the face's chords in (u, v). Returns the number of crossings, -1 when out of memory. */
static int32_t flag_crossed_chords(const pm_model *m, const pm_cell *f, const pm_mesh *mesh,
                                   const chains *ch, const buckets *fb, uint8_t *split) {
  face_work w = {0};
  pm_error err;
  chord *cs = NULL;
  int32_t found = -1, n = 0;
  if (gather_face_points(m, f, mesh, ch, fb, 1, &w, &err)) goto done;
  if (!(cs = malloc(sizeof(chord) * ((size_t)w.nc + 1)))) goto done;
  for (int32_t k = 0; k < w.nc; ++k) {
    if (w.cons_seg[k] < 0) continue;
    const double *a = &w.uv[2 * w.cons[2 * k]], *b = &w.uv[2 * w.cons[2 * k + 1]];
    cs[n++] = (chord){fmin(a[0], b[0]), fmax(a[0], b[0]), k};
  }
  qsort(cs, (size_t)n, sizeof(chord), chord_cmp);
  found = 0;
  for (int32_t i = 0; i < n; ++i) {
    const int32_t *pi = &w.cons[2 * cs[i].k];
    const double *a = &w.uv[2 * pi[0]], *b = &w.uv[2 * pi[1]];
    double vlo = fmin(a[1], b[1]), vhi = fmax(a[1], b[1]);
    for (int32_t j = i + 1; j < n && cs[j].lo <= cs[i].hi; ++j) {
      const int32_t *pj = &w.cons[2 * cs[j].k];
      int32_t ni[2] = {w.node[pi[0]], w.node[pi[1]]}, nj[2] = {w.node[pj[0]], w.node[pj[1]]};
      if (ni[0] == nj[0] || ni[0] == nj[1] || ni[1] == nj[0] || ni[1] == nj[1]) continue;
      const double *c = &w.uv[2 * pj[0]], *d = &w.uv[2 * pj[1]];
      if (fmax(c[1], d[1]) < vlo || fmin(c[1], d[1]) > vhi) continue;
      if (crosses(a, b, c, d)) {
        /* Split the chord whose split parts the two; else the longer, or both when as long. */
        int ci = split_parts(f, &w, ch, cs[i].k, c, d), cj = split_parts(f, &w, ch, cs[j].k, a, b);
        double li = pm_v3_dist2(&mesh->xyz[3 * (size_t)ni[0]], &mesh->xyz[3 * (size_t)ni[1]]);
        double lj = pm_v3_dist2(&mesh->xyz[3 * (size_t)nj[0]], &mesh->xyz[3 * (size_t)nj[1]]);
        if (ci != cj) li = ci, lj = cj;
        if (li >= lj) {
#pragma omp atomic write
          split[w.cons_seg[cs[i].k]] = 1;
        }
        if (lj >= li) {
#pragma omp atomic write
          split[w.cons_seg[cs[j].k]] = 1;
        }
        ++found;
      }
    }
  }
done:
  free(cs);
  face_work_free(&w);
  return found;
}

/* Step 1c over all faces: split the crossing chords, round by round, and rebuild the curve
 * buckets and chains after each round. */
static pm_status split_crossed_chords(const pm_model *m, pm_mesh *mesh, const int32_t *vnode,
                                      buckets *cb, const buckets *fb, chains *ch,
                                      pm_connect_report *rep, pm_error *err) {
  const int32_t nf = m->count[PM_FACE], nc = m->count[PM_CURVE];
  for (int round = 0; round < CHORD_ROUNDS; ++round) {
    uint8_t *split = calloc((size_t)ch->off[nc] + 1, 1);
    if (!split) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    int32_t found = 0, oom = 0;
    /* Faces flag segments in parallel; a flag is only ever set, so the result is the union. */
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : found) reduction(| : oom)
    for (int32_t f = 0; f < nf; ++f) {
      int32_t k = flag_crossed_chords(m, &m->cells[PM_FACE][f], mesh, ch, fb, split);
      if (k < 0) oom = 1;
      else found += k;
    }
    pm_status s = oom ? pm_error_setf(err, PM_ERR_NOMEM, "out of memory") : PM_OK;
    for (int32_t c = 0; c < nc && found && !s; ++c)
      for (int32_t k = ch->off[c]; k + 1 < ch->off[c + 1] && !s; ++k) {
        if (!split[k]) continue;
        double par[2] = {0.5 * (ch->t[k] + ch->t[k + 1]), 0};
        pm_curve_point at;
        pm_curve_eval(&m->cells[PM_CURVE][c], par[0], 0, &at);
        s = pm_mesh_add_node(mesh, at.p, PM_CURVE, c, par, NULL, err);
        rep->chord_nodes++;
      }
    free(split);
    if (s || !found) return s;
    buckets_free(cb), chains_free(ch);
    if ((s = buckets_build(mesh, PM_CURVE, nc, cb, err))) return s;
    if ((s = chains_build(m, mesh, cb, vnode, ch, err))) return s;
  }
  return PM_OK;
}

/* ---- the entry point ---------------------------------------------------------------------------- */

pm_status pm_connect(const pm_model *m, pm_mesh *mesh, const pm_connect_params *p,
                     pm_connect_report *rep_out, pm_error *err) {
  pm_connect_params defaults;
  if (!p) pm_connect_params_init(&defaults), p = &defaults;
  pm_connect_report rep;
  memset(&rep, 0, sizeof rep);
  mesh->nseg = mesh->ntri = mesh->ntet = 0;
  buckets cb = {0}, fb = {0};
  chains ch = {0};
  face_out *fo = NULL;
  int32_t *vnode = NULL;
  uint8_t *redo = NULL;
  double t0 = pm_seconds();

  pm_status s = prepare_nodes(m, mesh, &rep, err);
  if (s) goto done;
  vnode = malloc(sizeof(int32_t) * ((size_t)m->count[PM_VERTEX] + 1));
  if (!vnode) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == PM_VERTEX) vnode[mesh->node_cell[i]] = i;
  if ((s = buckets_build(mesh, PM_CURVE, m->count[PM_CURVE], &cb, err))) goto done;
  if ((s = buckets_build(mesh, PM_FACE, m->count[PM_FACE], &fb, err))) goto done;
  if ((s = chains_build(m, mesh, &cb, vnode, &ch, err))) goto done;
  if ((s = drop_coincident_curve_nodes(m, mesh, vnode, &cb, &fb, &ch, &rep, err))) goto done;
  if ((s = split_crossed_chords(m, mesh, vnode, &cb, &fb, &ch, &rep, err))) goto done;
  if (p->drop_crossed && (s = drop_crossed_nodes(m, mesh, vnode, &cb, &fb, &ch, &rep, err))) goto done;
  if ((s = emit_segments(m, mesh, &ch, err))) goto done;
  double t1 = pm_seconds();
  rep.time_curves = t1 - t0;

  int32_t nf = m->count[PM_FACE];
  fo = calloc((size_t)nf + 1, sizeof(face_out));
  if (!fo) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  /* Faces are independent: triangulate them in parallel, then append in face order so the
   * result does not depend on the thread count. */
  redo = malloc((size_t)nf + 1);
  if (!redo) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  memset(redo, 1, (size_t)nf + 1);
  for (int round = 0;; ++round) {
#pragma omp parallel for schedule(dynamic, 1)
    for (int32_t f = 0; f < nf; ++f) {
      if (!redo[f]) continue;
      free(fo[f].tri), free(fo[f].new_xyz), free(fo[f].new_uv);
      free(fo[f].moved), free(fo[f].moved_xyz), free(fo[f].moved_uv);
      memset(&fo[f], 0, sizeof fo[f]);
      connect_face(m, &m->cells[PM_FACE][f], mesh, &ch, &fb, p, &fo[f]);
    }
    for (int32_t f = 0; f < nf; ++f)
      if (fo[f].status) {
        if (err) *err = fo[f].err;
        s = fo[f].status;
        goto done;
      }
    /* The smoothing's moves: each node lies on one face only, so the order does not matter. */
    for (int32_t f = 0; f < nf; ++f) {
      for (int32_t k = 0; k < fo[f].nmoved; ++k) {
        int32_t g = fo[f].moved[k];
        memcpy(&mesh->xyz[3 * (size_t)g], &fo[f].moved_xyz[3 * k], 3 * sizeof(double));
        memcpy(&mesh->node_par[2 * (size_t)g], &fo[f].moved_uv[2 * k], 2 * sizeof(double));
      }
      rep.smooth_moves += fo[f].smooth_moves;
      fo[f].nmoved = fo[f].smooth_moves = 0;
    }
    /* The nodes the faces added, in face order (so ids do not depend on the thread count). */
    for (int32_t f = 0; f < nf; ++f) {
      if (!redo[f] || fo[f].nnew == 0) continue;
      int32_t first = mesh->nnode;
      for (int32_t k = 0; k < fo[f].nnew && !s; ++k)
        s = pm_mesh_add_node(mesh, &fo[f].new_xyz[3 * k], PM_FACE, f, &fo[f].new_uv[2 * k], NULL, err);
      if (s) goto done;
      for (int32_t k = 0; k < 3 * fo[f].ntri; ++k)
        if (fo[f].tri[k] >= fo[f].vbase) fo[f].tri[k] = first + fo[f].tri[k] - fo[f].vbase;
      rep.repair_nodes += fo[f].nnew;
      fo[f].nnew = 0;
    }
    if (round == REPAIR_ROUNDS) break;
    memset(redo, 0, (size_t)nf + 1);
    int32_t added = repair_repeats(m, mesh, fo, redo, err);
    if (added < 0) {
      s = err ? err->code : PM_ERR_NOMEM;
      goto done;
    }
    if (added == 0) break;
    rep.repair_nodes += added;
    buckets_free(&fb);
    if ((s = buckets_build(mesh, PM_FACE, m->count[PM_FACE], &fb, err))) goto done;
  }
  double asp_b = 0, asp_a = 0;
  for (int32_t f = 0; f < nf && !s; ++f) {
    rep.pole_triangles += fo[f].pole;
    rep.metric_flips += fo[f].metric_flips;
    rep.flips += fo[f].flips;
    rep.flip_cap_hits += fo[f].cap_hit;
    if (fo[f].curved) {
      asp_b += fo[f].asp_before, asp_a += fo[f].asp_after, rep.curved_triangles += fo[f].ntri;
      rep.degenerate_before += fo[f].degen_before, rep.degenerate_after += fo[f].degen_after;
      rep.aspect_max_before = fmax(rep.aspect_max_before, fo[f].max_before);
      rep.aspect_max_after = fmax(rep.aspect_max_after, fo[f].max_after);
    }
    if ((s = pm_mesh_reserve(mesh, mesh->nnode, mesh->nseg, mesh->ntri + fo[f].ntri, 0, err))) break;
    for (int32_t t = 0; t < fo[f].ntri && !s; ++t)
      s = pm_mesh_add_tri(mesh, fo[f].tri[3 * t], fo[f].tri[3 * t + 1], fo[f].tri[3 * t + 2], f, err);
  }
  if (s) goto done;
  if (rep.curved_triangles > rep.degenerate_before) rep.aspect_before = asp_b / (rep.curved_triangles - rep.degenerate_before);
  if (rep.curved_triangles > rep.degenerate_after) rep.aspect_after = asp_a / (rep.curved_triangles - rep.degenerate_after);
  double t2 = pm_seconds();
  rep.time_faces = t2 - t1;

  if (p->volume != PM_VOLUME_NONE && (s = pm_connect_volumes(m, mesh, p, &rep, err))) goto done;

done:
  if (fo)
    for (int32_t f = 0; f < m->count[PM_FACE]; ++f)
      free(fo[f].tri), free(fo[f].new_xyz), free(fo[f].new_uv), free(fo[f].moved),
          free(fo[f].moved_xyz), free(fo[f].moved_uv);
  free(fo);
  free(vnode);
  free(redo);
  buckets_free(&cb), buckets_free(&fb);
  chains_free(&ch);
  if (s) mesh->nseg = mesh->ntri = mesh->ntet = 0;
  if (rep_out) *rep_out = rep;
  return s;
}
