/* CGAL's 2D Delaunay refinement (Mesh_2) as a peer of our methods, for planar domains (see
 * peers.h and cgal_mesh2.h).
 *
 * A run:
 *   1. the boundary: every curve is sampled so that its segments have length ~ d, the size
 *      field along it. With F(t) = integral of |C'| / d from the curve's start (the number of
 *      edges of length d that fit), the curve gets n = max(1, round(F(end))) segments (3 for a
 *      closed curve), with nodes where F = j F(end) / n. F is integrated by the trapezoid rule on
 *      steps of at most a quarter of the local d (and 1/64 of the curve), and inverted by linear
 *      interpolation. The polylines (vertex nodes shared) are Mesh_2's constraints. Chords of
 *      arcs sampled that coarsely can cross another boundary polyline although the curves do
 *      not meet (two circles at a field coarser than their gap): then the arcs alone are sampled
 *      2, 4, ... 64 times finer until the polylines are disjoint (stats key
 *      "cgal_arc_refinement": the factor's exponent);
 *   2. Mesh_2 refines (the criteria of cgal_mesh2.h with the size field and the parameters),
 *      optionally followed by Lloyd or ODT smoothing;
 *   3. classification: boundary nodes lie on our curves (t from the sampling) and vertices;
 *      points Mesh_2 added on a constraint are projected onto the curve that constraint
 *      discretizes (t) and moved there -- on an arc, Mesh_2 put them on the chord -- unless the
 *      move would turn a triangle over (then they stay on the chord, counted in the stats key
 *      "cgal_chord_nodes"); interior nodes lie on the face with (u, v) = (x, y).
 */
#include "peers/peers.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/sizing/node_budget.h"
#include "common/backends/predicates.h"
#include "peers/cgal_mesh2.h"
#include "peers/peer_common.h"

/* ---- parameters ------------------------------------------------------------------------- */

static const char *const optimizer_choices[] = {"none", "lloyd", "odt", NULL};

static const pm_param_desc cgal_desc[] = {
    {"shape_bound", PM_PARAM_DOUBLE, offsetof(peer_cgal_params, shape_bound), 0.125, 0, 0.125,
     PM_RANGE_LO_OPEN, "",
     "bad when the squared sine of the smallest angle is below this (0.125: 20.7 degrees)",
     "CGAL Delaunay_mesh_criteria_2 B (default 0.125)", NULL},
    {"size_factor", PM_PARAM_DOUBLE, offsetof(peer_cgal_params, size_factor), 1.45, 0.5, 4,
     PM_RANGE_CLOSED, "",
     "bad when the longest edge exceeds size_factor x d at the centroid",
     "size criterion of Delaunay_mesh_size_criteria_2 with d(x) for its constant bound; "
     "calibrated: mean edge / d ~ 1",
     NULL},
    {"optimizer", PM_PARAM_CHOICE, offsetof(peer_cgal_params, optimizer), PEER_CGAL_OPT_NONE, 0,
     0, PM_RANGE_CLOSED, "", "smoothing after refinement (boundary nodes fixed)",
     "Lloyd: CGAL Mesh_2::Lloyd_move_2; ODT: Alliez et al. 2005 (not in CGAL 5.5's Mesh_2)",
     optimizer_choices},
    {"opt_iterations", PM_PARAM_INT, offsetof(peer_cgal_params, opt_iterations), 10, 1, 1000,
     PM_RANGE_CLOSED, "", "maximum smoothing iterations (fewer on convergence)",
     "CGAL max_iteration_number (its examples use 10)", NULL},
};

static const pm_param_table cgal_table = {"cgal", cgal_desc,
                                          (int)(sizeof cgal_desc / sizeof cgal_desc[0])};

void peer_cgal_params_init(void *params) { pm_params_defaults(&cgal_table, params); }

/* ---- the size field --------------------------------------------------------------------- */

typedef struct size_ctx {
  const pm_sizing *size;
  int bad;
  double bad_at[2], bad_value;
} size_ctx;

static double size_at(size_ctx *c, const double xy[2]) {
  const double p[3] = {xy[0], xy[1], 0};
  double d = pm_sizing_eval(c->size, p);
  if (!(d > 0) || !isfinite(d)) {
    if (!c->bad) c->bad = 1, c->bad_at[0] = xy[0], c->bad_at[1] = xy[1], c->bad_value = d;
    return NAN;
  }
  return d;
}

static double size_callback(const double xy[2], void *user) { return size_at(user, xy); }

/* ---- boundary --------------------------------------------------------------------------- */

typedef struct bnd {
  int32_t n, cap;
  double *xy;      /* [2n] */
  int8_t *dim;     /* [n] 0 vertex, 1 curve */
  int32_t *cell;   /* [n] */
  double *t;       /* [n] curve parameter (curve points) */
  int32_t ncons, ccap;
  int32_t *cons;   /* [2 ncons] */
  int32_t *ccurve; /* [ncons] the curve each constraint discretizes */
} bnd;

static void bnd_free(bnd *b) {
  free(b->xy), free(b->dim), free(b->cell), free(b->t), free(b->cons), free(b->ccurve);
  memset(b, 0, sizeof *b);
}

static int bnd_point(bnd *b, const double xy[2], int dim, int32_t cell, double t) {
  if (b->n == b->cap) {
    int32_t cap = b->cap ? 2 * b->cap : 256;
    double *nxy = realloc(b->xy, sizeof(double) * 2 * (size_t)cap);
    if (nxy) b->xy = nxy;
    int8_t *nd = realloc(b->dim, (size_t)cap);
    if (nd) b->dim = nd;
    int32_t *nc = realloc(b->cell, sizeof(int32_t) * (size_t)cap);
    if (nc) b->cell = nc;
    double *nt = realloc(b->t, sizeof(double) * (size_t)cap);
    if (nt) b->t = nt;
    if (!nxy || !nd || !nc || !nt) return -1;
    b->cap = cap;
  }
  b->xy[2 * b->n] = xy[0], b->xy[2 * b->n + 1] = xy[1];
  b->dim[b->n] = (int8_t)dim, b->cell[b->n] = cell, b->t[b->n] = t;
  return b->n++;
}

static int bnd_cons(bnd *b, int32_t p, int32_t q, int32_t curve) {
  if (b->ncons == b->ccap) {
    int32_t cap = b->ccap ? 2 * b->ccap : 256;
    int32_t *nc = realloc(b->cons, sizeof(int32_t) * 2 * (size_t)cap);
    if (nc) b->cons = nc;
    int32_t *ncc = realloc(b->ccurve, sizeof(int32_t) * (size_t)cap);
    if (ncc) b->ccurve = ncc;
    if (!nc || !ncc) return -1;
    b->ccap = cap;
  }
  b->cons[2 * b->ncons] = p, b->cons[2 * b->ncons + 1] = q, b->ccurve[b->ncons++] = curve;
  return 0;
}

/* Sample curve c so that its segments have length ~ d (see the file comment); append its inner
 * points and its constraint chain. */
static pm_status discretize_curve(const pm_model *m, const pm_cell *c, size_ctx *sc,
                                  int64_t max_nodes, int refine, bnd *b, pm_error *err) {
  double lo = c->lo[0], hi = c->hi[0];
  int32_t v0 = c->bound[0].sense < 0 ? c->bound[0].cell : c->bound[1].cell;
  int32_t v1 = c->bound[0].sense < 0 ? c->bound[1].cell : c->bound[0].cell;
  int closed = v0 == v1;
  /* Samples (t, F) of the running integral. */
  size_t ns = 0, cap = 256;
  double *st = malloc(sizeof(double) * cap), *sf = malloc(sizeof(double) * cap);
  pm_status s = PM_OK;
  if (!st || !sf) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  size_t max_steps = (size_t)(4 * max_nodes + 4096);
  double t = lo, F = 0, g;
  pm_curve_point cp;
  pm_curve_eval(c, t, 1, &cp);
  double d = size_at(sc, cp.p), sp = hypot(cp.d1[0], cp.d1[1]);
  if (!(d > 0)) goto bad_size;
  g = sp / d;
  st[ns] = t, sf[ns++] = 0;
  while (t < hi) {
    double dt = fmin((hi - lo) / 64, sp > 0 ? 0.25 * d / sp : (hi - lo) / 64);
    double tn = fmin(hi, t + dt);
    pm_curve_eval(c, tn, 1, &cp);
    double dn = size_at(sc, cp.p);
    if (!(dn > 0)) goto bad_size;
    double spn = hypot(cp.d1[0], cp.d1[1]), gn = spn / dn;
    F += 0.5 * (g + gn) * (tn - t);
    t = tn, d = dn, sp = spn, g = gn;
    if (ns == cap) {
      cap *= 2;
      double *a = realloc(st, sizeof(double) * cap), *bb = realloc(sf, sizeof(double) * cap);
      if (a) st = a;
      if (bb) sf = bb;
      if (!a || !bb) {
        s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        goto done;
      }
    }
    st[ns] = t, sf[ns++] = F;
    if (ns > max_steps || F > (double)max_nodes) {
      s = pm_error_setf(err, PM_ERR_LIMIT,
                        "cgal: curve %d needs more than %lld boundary nodes (the node cap)",
                        c->tag, (long long)max_nodes);
      goto done;
    }
  }
  long n = lround(F);
  if (n < (closed ? 3 : 1)) n = closed ? 3 : 1;
  if (refine > 0 && strcmp(c->cls->name, "segment") != 0) n <<= refine;
  if (n > max_nodes) {
    s = pm_error_setf(err, PM_ERR_LIMIT,
                      "cgal: curve %d needs more than %lld boundary nodes (the node cap)", c->tag,
                      (long long)max_nodes);
    goto done;
  }
  int32_t prev = v0;
  size_t k = 1;
  for (long j = 1; j < n; ++j) {
    double target = F * (double)j / (double)n;
    while (k + 1 < ns && sf[k] < target) ++k;
    double f0 = sf[k - 1], f1 = sf[k];
    double tj = f1 > f0 ? st[k - 1] + (st[k] - st[k - 1]) * (target - f0) / (f1 - f0) : st[k];
    pm_curve_eval(c, tj, 0, &cp);
    int32_t id = bnd_point(b, cp.p, PM_CURVE, c->index, tj);
    if (id < 0 || bnd_cons(b, prev, id, c->index) < 0) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto done;
    }
    prev = id;
  }
  if (bnd_cons(b, prev, v1, c->index) < 0) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  (void)m;
  goto done;
bad_size:
  s = pm_error_setf(err, PM_ERR_ARG, "cgal: the size field is %g at (%g, %g), not > 0",
                    sc->bad_value, sc->bad_at[0], sc->bad_at[1]);
done:
  free(st), free(sf);
  return s;
}

/* ---- the run ---------------------------------------------------------------------------- */

/* Points Mesh_2 added on constraints, moved onto their curves; a move that would turn a
 * triangle over is undone. Returns the number of points left on their chord. */
static int32_t snap_to_curves(const pm_model *m, pm_mesh *mesh, const double *chord,
                              const uint8_t *moved) {
  int32_t left = 0;
  for (int pass = 0; pass < 8; ++pass) {
    int changed = 0;
    for (int32_t t = 0; t < mesh->ntri; ++t) {
      const int32_t *v = &mesh->tri[3 * t];
      if (pm_orient2d(&mesh->xyz[3 * v[0]], &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[2]]) > 0)
        continue;
      for (int q = 0; q < 3; ++q)
        if (moved[v[q]] && (mesh->xyz[3 * v[q]] != chord[2 * v[q]] ||
                            mesh->xyz[3 * v[q] + 1] != chord[2 * v[q] + 1])) {
          mesh->xyz[3 * v[q]] = chord[2 * v[q]], mesh->xyz[3 * v[q] + 1] = chord[2 * v[q] + 1];
          ++left, changed = 1;
        }
    }
    if (!changed) break;
  }
  (void)m;
  return left;
}

static pm_status cgal_run(const pm_run_input *in, const void *params_v, pm_run_output *out,
                          pm_error *err) {
  out->mesh = NULL;
  out->iterations = 0;
  out->stop_reason[0] = '\0';
  if (!in || !in->model || !params_v)
    return pm_error_setf(err, PM_ERR_ARG, "cgal: no model or parameters");
  const pm_model *m = in->model;
  const peer_cgal_params *p = params_v;
  pm_status s = pm_params_check(&cgal_table, p, err);
  if (s) return s;
  if (in->max_nodes <= 0)
    return pm_error_setf(err, PM_ERR_ARG, "cgal: the node cap must be > 0, got %lld",
                         (long long)in->max_nodes);
  if (!peer_is_planar_domain(m))
    return pm_error_setf(err, PM_ERR_ARG,
                         "cgal (CGAL Mesh_2) meshes planar domains of segments and arcs only; "
                         "'%s' is not one",
                         m->name);
  pm_sizing *own = NULL;
  const pm_sizing *size = in->size;
  if (!size) {
    if ((s = peer_default_size(m, NULL, in->seed, in->threads, &own, err))) return s;
    size = own;
  }
  if ((s = pm_node_budget_check(m, size, in->max_nodes, "node cap", "cgal", err))) {
    pm_sizing_destroy(own);
    return s;
  }

  size_ctx sc = {size, 0, {0, 0}, 0};
  bnd b = {0};
  peer_mesh2_result res = {0};
  pm_mesh *mesh = NULL;
  double *chord = NULL;
  uint8_t *moved = NULL;
  int32_t chord_left = 0;
  double t_boundary = 0;
  int refine = 0;
  for (;; ++refine) {
    double tb = pm_seconds();
    for (int32_t v = 0; v < m->count[PM_VERTEX] && !s; ++v)
      if (bnd_point(&b, m->cells[PM_VERTEX][v].xyz, PM_VERTEX, v, 0) < 0)
        s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t c = 0; c < m->count[PM_CURVE] && !s; ++c)
      s = discretize_curve(m, &m->cells[PM_CURVE][c], &sc, in->max_nodes, refine, &b, err);
    t_boundary += pm_seconds() - tb;
    if (s) break;

    peer_mesh2_input mi;
    memset(&mi, 0, sizeof mi);
    mi.npts = b.n, mi.xy = b.xy;
    mi.ncons = b.ncons, mi.cons = b.cons;
    mi.size = size_callback, mi.user = &sc;
    mi.shape_bound = p->shape_bound;
    mi.size_factor = p->size_factor;
    mi.optimizer = p->optimizer == PEER_CGAL_OPT_LLOYD ? PEER_MESH2_LLOYD
                   : p->optimizer == PEER_CGAL_OPT_ODT ? PEER_MESH2_ODT
                                                       : PEER_MESH2_NONE;
    mi.opt_iterations = p->opt_iterations;
    mi.max_points = in->max_nodes > INT32_MAX ? INT32_MAX : (int32_t)in->max_nodes;
    s = peer_mesh2_run(&mi, &res, err);
    if (s != PM_ERR_GEOM) break;
    if (refine == 6) {
      pm_error_setf(err, PM_ERR_GEOM,
                    "cgal: the boundary polylines of '%s' cross even with its arcs sampled 64 "
                    "times finer than the size field asks; the field is too coarse for the domain",
                    m->name);
      break;
    }
    s = PM_OK;
    b.n = 0, b.ncons = 0;
  }
  if (!s && sc.bad)
    s = pm_error_setf(err, PM_ERR_ARG, "cgal: the size field is %g at (%g, %g), not > 0",
                      sc.bad_value, sc.bad_at[0], sc.bad_at[1]);
  double t1 = pm_seconds();
  if (!s) {
    mesh = pm_mesh_create();
    chord = malloc(sizeof(double) * 2 * ((size_t)res.npts + 1));
    moved = calloc((size_t)res.npts + 1, 1);
    if (!mesh || !chord || !moved) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  if (!s) s = pm_mesh_reserve(mesh, res.npts, res.nseg, res.ntri, 0, err);
  for (int32_t i = 0; i < res.npts && !s; ++i) {
    double xyz[3] = {res.xy[2 * i], res.xy[2 * i + 1], 0}, par[2] = {0, 0};
    chord[2 * i] = xyz[0], chord[2 * i + 1] = xyz[1];
    if (i < b.n) {
      if (b.dim[i] == PM_VERTEX) {
        s = pm_mesh_add_node(mesh, m->cells[PM_VERTEX][b.cell[i]].xyz, PM_VERTEX, b.cell[i], NULL,
                             NULL, err);
      } else {
        par[0] = b.t[i];
        s = pm_mesh_add_node(mesh, xyz, PM_CURVE, b.cell[i], par, NULL, err);
      }
    } else if (res.on_cons[i] >= 0) {
      int32_t k = res.on_cons[i], curve = b.ccurve[k];
      const pm_cell *c = &m->cells[PM_CURVE][curve];
      /* Start the projection from the parameter halfway between the piece's ends. */
      int32_t e0 = b.cons[2 * k], e1 = b.cons[2 * k + 1];
      double t_a = b.dim[e0] == PM_CURVE ? b.t[e0] : c->lo[0];
      double t_b = b.dim[e1] == PM_CURVE ? b.t[e1] : c->hi[0];
      double guess = 0.5 * (t_a + t_b);
      s = pm_cell_project(c, xyz, &guess, par, NULL, NULL, err);
      if (!s) {
        double on[3];
        pm_cell_point(c, par, on);
        moved[i] = 1;
        s = pm_mesh_add_node(mesh, on, PM_CURVE, curve, par, NULL, err);
      }
    } else {
      par[0] = xyz[0], par[1] = xyz[1];
      s = pm_mesh_add_node(mesh, xyz, PM_FACE, 0, par, NULL, err);
    }
  }
  for (int32_t k = 0; k < res.nseg && !s; ++k)
    s = pm_mesh_add_seg(mesh, res.seg[2 * k], res.seg[2 * k + 1], b.ccurve[res.seg_cons[k]], err);
  for (int32_t t = 0; t < res.ntri && !s; ++t)
    s = pm_mesh_add_tri(mesh, res.tri[3 * t], res.tri[3 * t + 1], res.tri[3 * t + 2], 0, err);
  if (!s) chord_left = snap_to_curves(m, mesh, chord, moved);
  if (!s && mesh->nnode > in->max_nodes)
    s = pm_error_setf(err, PM_ERR_LIMIT, "cgal made %d nodes, more than the cap %lld",
                      (int)mesh->nnode, (long long)in->max_nodes);
  double t_convert = pm_seconds() - t1;
  if (!s) {
    pm_observe_time(in->observer, "boundary", t_boundary, NULL);
    pm_observe_time(in->observer, "refine", res.time_refine, NULL);
    if (p->optimizer != PEER_CGAL_OPT_NONE)
      pm_observe_time(in->observer, "optimize", res.time_optimize, NULL);
    pm_observe_time(in->observer, "convert", t_convert, NULL);
    pm_observe_number(in->observer, "cgal_boundary_nodes", b.n, NULL);
    pm_observe_number(in->observer, "cgal_chord_nodes", chord_left, NULL);
    pm_observe_number(in->observer, "cgal_hole_seeds", res.nseeds, NULL);
    pm_observe_number(in->observer, "cgal_arc_refinement", refine, NULL);
    snprintf(out->stop_reason, sizeof out->stop_reason, "CGAL Mesh_2 refinement done%s%s",
             p->optimizer == PEER_CGAL_OPT_NONE ? ""
             : p->optimizer == PEER_CGAL_OPT_LLOYD ? "; Lloyd: " : "; ODT: ",
             res.opt_stop);
    /* Refinement inserts points until no face is bad: it has no iterations to count; the
     * smoothing iterations are the run's iterations. */
    out->iterations = res.opt_iterations;
    out->mesh = mesh;
    mesh = NULL;
  }
  pm_mesh_destroy(mesh);
  free(chord), free(moved);
  peer_mesh2_result_free(&res);
  bnd_free(&b);
  pm_sizing_destroy(own);
  return s;
}

const pm_method peer_cgal = {"cgal",
                             "CGAL's 2D Delaunay refinement (Mesh_2), planar domains only",
                             &cgal_table,
                             sizeof(peer_cgal_params),
                             peer_cgal_params_init,
                             cgal_run,
                             1,
                             0,
                             peer_default_size};
