/* gmsh's surface algorithms (MeshAdapt, Delaunay, Frontal-Delaunay) and its 3D Delaunay as
 * peers of our methods (see peers.h).
 *
 * One run, under one gmsh_session scope (which holds the gmsh lock and restores the previous
 * current model):
 *   1. the gmsh model: a CAD model's own (pm_cad_gmsh_model), or, for a planar analytic domain,
 *      a temporary model built by peer_gmsh_planar.c and removed afterwards;
 *   2. options: gmsh's options are global, so every option set here is saved first and restored
 *      afterwards. The size field governs alone: the size callback returns d(x), and
 *      Mesh.MeshSizeFromPoints = 0, Mesh.MeshSizeFromCurvature = 0,
 *      Mesh.MeshSizeExtendFromBoundary = 0, Mesh.MeshSizeMin = 0, Mesh.MeshSizeMax = 1e22,
 *      Mesh.MeshSizeFactor = 1 switch off every other source and bound; gmsh's floor of 7 nodes
 *      per circle (Mesh.MinimumCirclePoints) is lowered to 3, the least a closed curve needs (and
 *      what the CGAL peer and the connection step use), and Mesh.MinimumCurvePoints is 3;
 *   3. gmshModelMeshGenerate(2) with Mesh.Algorithm = 1 / 5 / 6; with --volume and volume=gmsh,
 *      gmshModelMeshGenerate(3) with Mesh.Algorithm3D = 1 (Delaunay);
 *   4. the mesh becomes a pm_mesh classified on our cells (node dimension, cell, parameters;
 *      element tags = cell indices) -- on a CAD model gmsh's parameters are ours (geom_cad
 *      evaluates through gmsh's parametrization), on a planar domain curve nodes are projected
 *      onto our curves (t) and face nodes get (u, v) = (x, y);
 *   5. gmsh's mesh is cleared (gmshModelMeshClear) whatever happened, so the CAD model is
 *      pristine for the next run, and the callback removed.
 * Then, with --volume and volume=tetgen, TetGen refines the volumes of gmsh's surface mesh
 * (pm_connect_volumes of connect.h, the same volume step as our methods), and each face's
 * triangles are oriented by geom.h's rule.
 *
 * gmsh runs single-threaded: General.NumThreads = 1 (gmsh_session) is not enough, because gmsh's
 * meshers open OpenMP parallel regions that follow the calling thread's OpenMP thread count,
 * which gmsh_session restores to the program's after starting gmsh. With two threads, gmsh 4.8.4
 * gives a different mesh from run to run (MeshAdapt on qi3: 733 to 750 nodes; Frontal-Delaunay:
 * the same count, coordinates differing). So the peer sets the calling thread's OpenMP thread
 * count to 1 and Mesh.MaxNumThreads1D/2D/3D to 1 while gmsh meshes, restoring both afterwards:
 * the mesh is then the same for the same input, and the size callback is called from this
 * thread only (pm_sizing_eval is thread-safe anyway).
 */
#include "peers/peers.h"

#include <gmshc.h>

#include <math.h>
#include <omp.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/sizing/node_budget.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/base/vec3.h"
#include "peers/peer_common.h"
#include "peers/peer_gmsh_planar.h"
#include "common/connect/connect.h"

/* ---- parameters ------------------------------------------------------------------------- */

static const char *const volume_choices[] = {"gmsh", "tetgen", NULL};

static const pm_param_desc gmsh_desc[] = {
    {"smoothing", PM_PARAM_INT, offsetof(peer_gmsh_params, smoothing), 1, 0, 100,
     PM_RANGE_CLOSED, "", "Laplacian smoothing passes on the surface mesh",
     "gmsh option Mesh.Smoothing (default 1)", NULL},
    {"optimize", PM_PARAM_BOOL, offsetof(peer_gmsh_params, optimize), 1, 0, 1, PM_RANGE_CLOSED,
     "", "optimize the tets of gmsh's 3D Delaunay (volume=gmsh)",
     "gmsh option Mesh.Optimize (default 1)", NULL},
    {"volume", PM_PARAM_CHOICE, offsetof(peer_gmsh_params, volume), PEER_GMSH_VOLUME_GMSH, 0, 0,
     PM_RANGE_CLOSED, "",
     "the volume mesher with --volume: gmsh's 3D Delaunay, or TetGen refining gmsh's surface mesh",
     "gmsh Mesh.Algorithm3D = 1; TetGen -q as in papers/001 sec. 4.4", volume_choices},
    {"radius_edge", PM_PARAM_DOUBLE, offsetof(peer_gmsh_params, radius_edge), 1.5, 1, 10,
     PM_RANGE_LO_OPEN, "", "volume=tetgen: bound on a tet's circumradius / shortest edge",
     "TetGen -q (papers/001 sec. 4.4)", NULL},
    {"flip_flat", PM_PARAM_BOOL, offsetof(peer_gmsh_params, flip_flat), 1, 0, 1, PM_RANGE_CLOSED,
     "", "flip gmsh's triangles of no 3D area (three nodes on a line) with their neighbour",
     "packmesh's choice: a face's pcurve straying from a straight curve lets gmsh join three of "
     "its nodes (bottle.brep); not with gmsh's 3D Delaunay, whose tets use gmsh's triangles",
     NULL},
};

#define NDESC ((int)(sizeof gmsh_desc / sizeof gmsh_desc[0]))

static const pm_param_table table_meshadapt = {"gmsh-meshadapt", gmsh_desc, NDESC};
static const pm_param_table table_delaunay = {"gmsh-delaunay", gmsh_desc, NDESC};
static const pm_param_table table_frontal = {"gmsh-frontal", gmsh_desc, NDESC};

void peer_gmsh_params_init(void *params) { pm_params_defaults(&table_frontal, params); }

/* ---- options ---------------------------------------------------------------------------- */

typedef struct gopt {
  const char *name;
  double value, saved;
  int have_saved;
} gopt;

enum {
  O_ALGO, O_ALGO3D, O_EXTEND, O_POINTS, O_CURV, O_MIN, O_MAX, O_FACTOR, O_SMOOTH, O_OPT,
  O_NETGEN, O_ORDER, O_RECOMB, O_SUBDIV, O_THR1, O_THR2, O_THR3, O_CIRC, O_CURVE, O_COUNT
};

static void options_init(gopt *o, int algorithm, const peer_gmsh_params *p) {
  static const char *const names[O_COUNT] = {
      "Mesh.Algorithm", "Mesh.Algorithm3D", "Mesh.MeshSizeExtendFromBoundary",
      "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature", "Mesh.MeshSizeMin",
      "Mesh.MeshSizeMax", "Mesh.MeshSizeFactor", "Mesh.Smoothing", "Mesh.Optimize",
      "Mesh.OptimizeNetgen", "Mesh.ElementOrder", "Mesh.RecombineAll",
      "Mesh.SubdivisionAlgorithm", "Mesh.MaxNumThreads1D", "Mesh.MaxNumThreads2D",
      "Mesh.MaxNumThreads3D", "Mesh.MinimumCirclePoints", "Mesh.MinimumCurvePoints"};
  const double values[O_COUNT] = {algorithm, 1, 0, 0, 0, 0, 1e22, 1, p->smoothing, p->optimize,
                                  0, 1, 0, 0, 1, 1, 1, 3, 3};
  for (int i = 0; i < O_COUNT; ++i) o[i] = (gopt){names[i], values[i], 0, 0};
}

static pm_status options_set(gopt *o, pm_error *err) {
  for (int i = 0; i < O_COUNT; ++i) {
    int ierr = 0;
    gmshOptionGetNumber(o[i].name, &o[i].saved, &ierr);
    if (ierr) return pm_gmsh_error(err, PM_ERR_BACKEND, "reading a gmsh option");
    o[i].have_saved = 1;
    gmshOptionSetNumber(o[i].name, o[i].value, &ierr);
    if (ierr) return pm_gmsh_error(err, PM_ERR_BACKEND, "setting a gmsh option");
  }
  return PM_OK;
}

static void options_restore(gopt *o) {
  for (int i = O_COUNT - 1; i >= 0; --i) {
    int ierr = 0;
    if (o[i].have_saved) gmshOptionSetNumber(o[i].name, o[i].saved, &ierr);
  }
}

/* ---- the size callback ------------------------------------------------------------------ */

typedef struct size_ctx {
  const pm_sizing *size;
  double fallback;  /* returned where d is unusable, so gmsh finishes and the run can fail */
  int bad;          /* a value was not finite and > 0 */
  double bad_at[3], bad_value;
} size_ctx;

static double size_callback(int dim, int tag, double x, double y, double z, void *data) {
  (void)dim, (void)tag;
  size_ctx *c = data;
  const double p[3] = {x, y, z};
  double d = pm_sizing_eval(c->size, p);
  if (!(d > 0) || !isfinite(d)) {
    if (!c->bad) {
      c->bad = 1;
      c->bad_at[0] = x, c->bad_at[1] = y, c->bad_at[2] = z;
      c->bad_value = d;
    }
    return c->fallback;
  }
  return d;
}

/* ---- gmsh mesh -> pm_mesh --------------------------------------------------------------- */

typedef struct node_key {
  size_t tag;
  int32_t index;
} node_key;

static int cmp_node_key(const void *a, const void *b) {
  size_t x = ((const node_key *)a)->tag, y = ((const node_key *)b)->tag;
  return x < y ? -1 : x > y;
}

static int32_t node_index(const node_key *keys, int32_t n, size_t tag) {
  int32_t lo = 0, hi = n - 1;
  while (lo <= hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (keys[mid].tag == tag) return keys[mid].index;
    if (keys[mid].tag < tag) lo = mid + 1;
    else hi = mid - 1;
  }
  return -1;
}

/* Classify one gmsh node on our cell (dim, cell) and add it. */
static pm_status add_node(const pm_model *m, pm_mesh *mesh, int planar, int dim, int32_t cell,
                          const double *x, const double *gpar, int npar, pm_error *err) {
  double xyz[3] = {x[0], x[1], x[2]}, par[2] = {0, 0};
  const pm_cell *c = &m->cells[dim][cell];
  if (dim == PM_VERTEX) {
    if (planar) pm_v3_copy(xyz, c->xyz);
  } else if (dim == PM_CURVE) {
    if (planar) {
      double dist = 0;
      pm_status s = pm_cell_project(c, x, NULL, par, NULL, &dist, err);
      if (s) return s;
      if (!(dist <= 1e-6 * m->diagonal))
        return pm_error_setf(err, PM_ERR_BACKEND,
                             "a gmsh node lies %g off curve %d of the planar domain", dist,
                             (int)cell);
      pm_cell_point(c, par, xyz);
    } else if (npar >= 1) {
      par[0] = gpar[0];
    }
  } else if (dim == PM_FACE) {
    if (planar) {
      par[0] = x[0], par[1] = x[1], xyz[2] = 0;
    } else if (npar >= 2) {
      par[0] = gpar[0], par[1] = gpar[1];
    }
  }
  return pm_mesh_add_node(mesh, xyz, dim, cell, par, NULL, err);
}

/* The nodes of dimensions 0..maxdim, entity by entity; keys map gmsh node tags to indices. */
static pm_status convert_nodes(const pm_model *m, const peer_tagmap *map, int planar, int maxdim,
                               pm_mesh *mesh, node_key **keys_out, pm_error *err) {
  node_key *keys = NULL;
  size_t nkeys = 0, cap = 0;
  pm_status s = PM_OK;
  for (int dim = 0; dim <= maxdim && !s; ++dim) {
    int ierr = 0, *dt = NULL;
    size_t ndt = 0;
    gmshModelGetEntities(&dt, &ndt, dim, &ierr);
    if (ierr) {
      s = pm_gmsh_error(err, PM_ERR_BACKEND, "listing gmsh entities");
      break;
    }
    for (size_t e = 0; e + 1 < ndt && !s; e += 2) {
      int tag = dt[e + 1];
      size_t *nt = NULL, nn = 0, nc = 0, np = 0;
      double *coord = NULL, *par = NULL;
      gmshModelMeshGetNodes(&nt, &nn, &coord, &nc, &par, &np, dim, tag, 0, 1, &ierr);
      if (ierr) {
        s = pm_gmsh_error(err, PM_ERR_BACKEND, "reading gmsh's nodes");
      } else if (nn > 0) {
        int32_t cell = peer_tagmap_find(map, dim, tag);
        int npar = (dim == 1 || dim == 2) && np == (size_t)dim * nn ? dim : 0;
        if (cell < 0)
          s = pm_error_setf(err, PM_ERR_INTERNAL, "gmsh entity (%d, %d) is no cell of model '%s'",
                            dim, tag, m->name);
        /* A stray CAD point's node (geom.h) would duplicate another vertex's. */
        if (!s && dim == PM_VERTEX && m->cells[PM_VERTEX][cell].stray) nn = 0;
        if (!s && nkeys + nn > cap) {
          size_t ncap = cap ? cap : 1024;
          while (ncap < nkeys + nn) ncap *= 2;
          node_key *grown = realloc(keys, sizeof *keys * ncap);
          if (!grown) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
          else keys = grown, cap = ncap;
        }
        if (!s && nkeys + nn > (size_t)INT32_MAX)
          s = pm_error_setf(err, PM_ERR_LIMIT, "gmsh made more than 2^31 nodes");
        for (size_t k = 0; k < nn && !s; ++k) {
          keys[nkeys++] = (node_key){nt[k], mesh->nnode};
          s = add_node(m, mesh, planar, dim, cell, &coord[3 * k], npar ? &par[npar * k] : NULL,
                       npar, err);
        }
      }
      if (nt) gmshFree(nt);
      if (coord) gmshFree(coord);
      if (par) gmshFree(par);
    }
    if (dt) gmshFree(dt);
  }
  if (!s && nkeys) qsort(keys, nkeys, sizeof *keys, cmp_node_key);
  if (s) {
    free(keys);
    keys = NULL;
  }
  *keys_out = keys;
  return s;
}

/* Elements of dimensions 1..maxdim, tagged with our cell indices. Element types: 1 = 2-node
 * line, 2 = 3-node triangle, 4 = 4-node tet, 15 = point (ignored). */
static pm_status convert_elements(const pm_model *m, const peer_tagmap *map, int maxdim,
                                  const node_key *keys, int32_t nkeys, pm_mesh *mesh,
                                  pm_error *err) {
  pm_status s = PM_OK;
  for (int dim = 1; dim <= maxdim && !s; ++dim) {
    int ierr = 0, *dt = NULL;
    size_t ndt = 0;
    gmshModelGetEntities(&dt, &ndt, dim, &ierr);
    if (ierr) {
      s = pm_gmsh_error(err, PM_ERR_BACKEND, "listing gmsh entities");
      break;
    }
    for (size_t e = 0; e + 1 < ndt && !s; e += 2) {
      int tag = dt[e + 1], *types = NULL;
      size_t ntypes = 0, **etags = NULL, *etags_n = NULL, netags = 0, **enodes = NULL,
             *enodes_n = NULL, nenodes = 0;
      gmshModelMeshGetElements(&types, &ntypes, &etags, &etags_n, &netags, &enodes, &enodes_n,
                               &nenodes, dim, tag, &ierr);
      if (ierr) {
        s = pm_gmsh_error(err, PM_ERR_BACKEND, "reading gmsh's elements");
        ntypes = 0;
      }
      int32_t cell = peer_tagmap_find(map, dim, tag);
      for (size_t k = 0; k < ntypes && !s; ++k) {
        int per = types[k] == 1 ? 2 : types[k] == 2 ? 3 : types[k] == 4 ? 4 : 0;
        if (types[k] == 15) continue;
        if (per == 0 || per != dim + 1) {
          s = pm_error_setf(err, PM_ERR_BACKEND,
                            "gmsh made elements of type %d on entity (%d, %d); only lines, "
                            "triangles and tets are expected",
                            types[k], dim, tag);
          break;
        }
        if (cell < 0) {
          s = pm_error_setf(err, PM_ERR_INTERNAL, "gmsh entity (%d, %d) is no cell of model '%s'",
                            dim, tag, m->name);
          break;
        }
        size_t ne = enodes_n[k] / (size_t)per;
        for (size_t i = 0; i < ne && !s; ++i) {
          int32_t v[4];
          for (int q = 0; q < per; ++q) {
            v[q] = node_index(keys, nkeys, enodes[k][(size_t)per * i + (size_t)q]);
            if (v[q] < 0)
              s = pm_error_setf(err, PM_ERR_BACKEND, "a gmsh element names an unknown node");
          }
          if (s) break;
          if (per == 2) {
            s = pm_mesh_add_seg(mesh, v[0], v[1], cell, err);
          } else if (per == 3) {
            s = pm_mesh_add_tri(mesh, v[0], v[1], v[2], cell, err);
          } else {
            /* Positive orientation (mesh.h); gmsh's tets are, but a flat one may not be. */
            const double *a = &mesh->xyz[3 * v[0]], *b = &mesh->xyz[3 * v[1]],
                         *c = &mesh->xyz[3 * v[2]], *d = &mesh->xyz[3 * v[3]];
            double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            double ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            double ad[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
            double vol = ab[0] * (ac[1] * ad[2] - ac[2] * ad[1]) -
                         ab[1] * (ac[0] * ad[2] - ac[2] * ad[0]) +
                         ab[2] * (ac[0] * ad[1] - ac[1] * ad[0]);
            if (vol < 0) {
              int32_t x = v[2];
              v[2] = v[3], v[3] = x;
            }
            s = pm_mesh_add_tet(mesh, v[0], v[1], v[2], v[3], cell, err);
          }
        }
      }
      for (size_t k = 0; k < netags; ++k) gmshFree(etags[k]);
      for (size_t k = 0; k < nenodes; ++k) gmshFree(enodes[k]);
      if (types) gmshFree(types);
      if (etags) gmshFree(etags);
      if (etags_n) gmshFree(etags_n);
      if (enodes) gmshFree(enodes);
      if (enodes_n) gmshFree(enodes_n);
    }
    if (dt) gmshFree(dt);
  }
  return s;
}

/* Refuse a volume mesh the field makes hopeless before gmsh's 3D mesher grows it (node_budget.h):
 * gmsh's surface mesh, converted and oriented as the run's result will be, bounds the volumes
 * measured. (A field fine on the surfaces and far too fine inside passes the run's first check.) */
static pm_status volume_budget(const pm_model *m, const peer_tagmap *map, int planar,
                               const pm_sizing *size, int64_t cap, const char *method,
                               pm_error *err) {
  pm_mesh *surface = pm_mesh_create();
  if (!surface) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  node_key *keys = NULL;
  pm_status s = convert_nodes(m, map, planar, 2, surface, &keys, err);
  if (!s) s = convert_elements(m, map, 2, keys, surface->nnode, surface, err);
  if (!s) {
    peer_orient_faces(m, surface);
    s = pm_node_budget_check_volume(m, surface, size, cap, "node cap", method, err);
  }
  free(keys);
  pm_mesh_destroy(surface);
  return s;
}

/* Every face gmsh knows must have triangles, every volume tets when asked for: gmsh reports a
 * face it failed to mesh in its log, not always through ierr. */
static pm_status check_complete(const pm_model *m, const pm_mesh *mesh, int want_tets,
                                const char *method, pm_error *err) {
  int32_t nf = m->count[PM_FACE], nv = m->count[PM_VOLUME];
  uint8_t *has = calloc((size_t)nf + (size_t)nv + 1, 1);
  if (!has) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t t = 0; t < mesh->ntri; ++t) has[mesh->tri_cell[t]] = 1;
  for (int32_t t = 0; t < mesh->ntet; ++t) has[nf + mesh->tet_cell[t]] = 1;
  pm_status s = PM_OK;
  for (int32_t f = 0; f < nf && !s; ++f)
    if (!has[f]) {
      char what[400];
      snprintf(what, sizeof what, "%s made no triangles on face %d of '%.200s'", method,
               m->cells[PM_FACE][f].tag, m->name);
      s = pm_gmsh_error(err, PM_ERR_BACKEND, what);
    }
  for (int32_t v = 0; v < nv && want_tets && !s; ++v)
    if (!has[nf + v]) {
      char what[400];
      snprintf(what, sizeof what, "%s made no tets in volume %d of '%.200s'", method,
               m->cells[PM_VOLUME][v].tag, m->name);
      s = pm_gmsh_error(err, PM_ERR_BACKEND, what);
    }
  free(has);
  return s;
}

/* ---- the run ---------------------------------------------------------------------------- */

static unsigned long temp_counter = 0; /* guarded by the gmsh lock */

static pm_status gmsh_run(const pm_method *self, int algorithm, const char *algorithm_name,
                          const pm_run_input *in, const void *params_v, pm_run_output *out,
                          pm_error *err) {
  out->mesh = NULL;
  out->iterations = 0;
  out->stop_reason[0] = '\0';
  if (!in || !in->model || !params_v)
    return pm_error_setf(err, PM_ERR_ARG, "%s: no model or parameters", self->name);
  const pm_model *m = in->model;
  const peer_gmsh_params *p = params_v;
  pm_status s = pm_params_check(self->params, p, err);
  if (s) return s;
  if (in->max_nodes <= 0)
    return pm_error_setf(err, PM_ERR_ARG, "%s: the node cap must be > 0, got %lld", self->name,
                         (long long)in->max_nodes);
  int planar = peer_is_planar_domain(m);
  const char *cad = pm_cad_gmsh_model(m);
  if (!planar && !cad)
    return pm_error_setf(err, PM_ERR_ARG,
                         "%s meshes CAD models and planar domains of segments and arcs; model "
                         "'%s' is neither",
                         self->name, m->name);

  pm_sizing *own = NULL;
  const pm_sizing *size = in->size;
  if (!size) {
    if ((s = peer_default_size(m, NULL, in->seed, in->threads, &own, err))) return s;
    size = own;
  }
  if ((s = pm_node_budget_check(m, size, in->max_nodes, "node cap", self->name, err))) {
    pm_sizing_destroy(own);
    return s;
  }
  int want_volume = in->volume && m->count[PM_VOLUME] > 0;
  int gmsh_volume = want_volume && p->volume == PEER_GMSH_VOLUME_GMSH;

  pm_mesh *mesh = pm_mesh_create();
  peer_tagmap map = {0};
  node_key *keys = NULL;
  size_ctx sc = {size, m->diagonal > 0 ? m->diagonal : 1, 0, {0, 0, 0}, 0};
  gopt opts[O_COUNT];
  options_init(opts, algorithm, p);
  double t_surface = 0, t_volume = 0, t_convert = 0, t_tetgen = 0;
  if (!mesh) {
    pm_sizing_destroy(own);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }

  /* Everything gmsh happens inside one scope, on one OpenMP thread (see the file comment). */
  pm_gmsh_scope scope;
  char temp_name[64];
  pm_gmsh_lock();
  int omp_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  if (!cad) snprintf(temp_name, sizeof temp_name, "pm_peer_planar_%lu", ++temp_counter);
  s = pm_gmsh_scope_enter(&scope, cad ? cad : temp_name, cad ? 0 : 1, err);
  if (s) {
    omp_set_num_threads(omp_threads);
    pm_gmsh_unlock();
    pm_mesh_destroy(mesh);
    pm_sizing_destroy(own);
    return s;
  }
  int ierr = 0, callback_set = 0, meshed = 0;
  if (planar) {
    s = peer_gmsh_build_planar(m, &map, err);
  } else {
    for (int d = 0; d <= 3 && !s; ++d)
      for (int32_t i = 0; i < m->count[d] && !s; ++i)
        s = peer_tagmap_add(&map, d, m->cells[d][i].tag, i, err);
    if (!s) s = peer_tagmap_finish(&map, err);
  }
  if (!s) s = options_set(opts, err);
  if (!s) {
    gmshModelMeshSetSizeCallback(size_callback, &sc, &ierr);
    if (ierr) s = pm_gmsh_error(err, PM_ERR_BACKEND, "setting gmsh's size callback");
    else callback_set = 1;
  }
  if (!s) {
    double t0 = pm_seconds();
    meshed = 1;
    /* A mesh another user left on the model would be extended, not replaced. */
    gmshModelMeshClear(NULL, 0, &ierr);
    if (!ierr) gmshModelMeshGenerate(2, &ierr);
    t_surface = pm_seconds() - t0;
    if (ierr) {
      char what[400];
      snprintf(what, sizeof what, "%s (gmsh %s) could not mesh the surfaces of '%.200s'", self->name,
               algorithm_name, m->name);
      s = pm_gmsh_error(err, PM_ERR_BACKEND, what);
    }
  }
  if (!s && gmsh_volume && !sc.bad)
    s = volume_budget(m, &map, planar, size, in->max_nodes, self->name, err);
  if (!s && gmsh_volume) {
    double t0 = pm_seconds();
    gmshModelMeshGenerate(3, &ierr);
    t_volume = pm_seconds() - t0;
    if (ierr) {
      char what[400];
      snprintf(what, sizeof what, "%s (gmsh 3D Delaunay) could not mesh the volumes of '%.200s'",
               self->name, m->name);
      s = pm_gmsh_error(err, PM_ERR_BACKEND, what);
    }
  }
  if (!s && sc.bad)
    s = pm_error_setf(err, PM_ERR_ARG, "%s: the size field is %g at (%g, %g, %g), not > 0",
                      self->name, sc.bad_value, sc.bad_at[0], sc.bad_at[1], sc.bad_at[2]);
  if (!s) {
    double t0 = pm_seconds();
    int maxdim = gmsh_volume ? 3 : 2;
    s = convert_nodes(m, &map, planar, maxdim, mesh, &keys, err);
    if (!s) s = convert_elements(m, &map, maxdim, keys, mesh->nnode, mesh, err);
    if (!s) s = check_complete(m, mesh, gmsh_volume, self->name, err);
    t_convert = pm_seconds() - t0;
  }
  /* Leave gmsh as it was: no mesh, no callback, the options restored. */
  if (meshed) gmshModelMeshClear(NULL, 0, &ierr);
  if (callback_set) gmshModelMeshRemoveSizeCallback(&ierr);
  options_restore(opts);
  pm_gmsh_scope_leave(&scope, cad ? 0 : 1);
  omp_set_num_threads(omp_threads);
  pm_gmsh_unlock();
  free(keys);
  peer_tagmap_free(&map);

  if (!s) peer_orient_faces(m, mesh);
  int32_t flat_flips = 0;
  if (!s && p->flip_flat && !gmsh_volume && (flat_flips = peer_flip_flat_triangles(mesh)) < 0)
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  /* volume=tetgen: the connection layer's volume step on gmsh's own surface triangles, so that
   * the volume mesher is the same as for our methods. */
  pm_connect_report vrep;
  memset(&vrep, 0, sizeof vrep);
  if (!s && want_volume && !gmsh_volume) {
    pm_connect_params cp;
    pm_connect_params_init(&cp);
    cp.volume = PM_VOLUME_REFINE;
    cp.radius_edge = p->radius_edge;
    cp.max_nodes = in->max_nodes > INT32_MAX ? 0 : (int32_t)in->max_nodes;
    s = pm_connect_volumes(m, mesh, &cp, &vrep, err);
    t_tetgen = vrep.time_volumes;
    if (s) pm_error_prefix(err, "%s, volume=tetgen", self->name);
  }
  if (!s && mesh->nnode > in->max_nodes)
    s = pm_error_setf(err, PM_ERR_LIMIT, "%s made %d nodes, more than the cap %lld", self->name,
                      (int)mesh->nnode, (long long)in->max_nodes);
  pm_sizing_destroy(own);
  if (s) {
    pm_mesh_destroy(mesh);
    return s;
  }
  pm_observe_time(in->observer, "surface", t_surface, NULL);
  if (gmsh_volume) pm_observe_time(in->observer, "volume", t_volume, NULL);
  if (want_volume && !gmsh_volume) pm_observe_time(in->observer, "volume", t_tetgen, NULL);
  pm_observe_time(in->observer, "convert", t_convert, NULL);
  pm_observe_number(in->observer, "flat_triangle_flips", flat_flips, NULL);
  if (want_volume && !gmsh_volume) {
    pm_observe_number(in->observer, "tetgen_steiner", vrep.steiner, NULL);
    pm_observe_number(in->observer, "tetgen_flat_tet_flips", vrep.flat_tet_flips, NULL);
  }
  out->mesh = mesh;
  char flipped[64] = "";
  if (flat_flips)
    snprintf(flipped, sizeof flipped, ", %d flat triangle%s flipped", (int)flat_flips,
             flat_flips == 1 ? "" : "s");
  snprintf(out->stop_reason, sizeof out->stop_reason, "gmsh %s%s%s", algorithm_name,
           !want_volume ? "" : gmsh_volume ? " + gmsh 3D Delaunay" : " + TetGen refinement",
           flipped);
  return PM_OK;
}

static pm_status run_meshadapt(const pm_run_input *in, const void *params, pm_run_output *out,
                               pm_error *err) {
  return gmsh_run(&peer_gmsh_meshadapt, 1, "MeshAdapt", in, params, out, err);
}

static pm_status run_delaunay(const pm_run_input *in, const void *params, pm_run_output *out,
                              pm_error *err) {
  return gmsh_run(&peer_gmsh_delaunay, 5, "Delaunay", in, params, out, err);
}

static pm_status run_frontal(const pm_run_input *in, const void *params, pm_run_output *out,
                             pm_error *err) {
  return gmsh_run(&peer_gmsh_frontal, 6, "Frontal-Delaunay", in, params, out, err);
}

const pm_method peer_gmsh_meshadapt = {
    "gmsh-meshadapt", "gmsh's MeshAdapt surface algorithm (Mesh.Algorithm = 1)",
    &table_meshadapt, sizeof(peer_gmsh_params), peer_gmsh_params_init, run_meshadapt, 0, 0,
    peer_default_size};

const pm_method peer_gmsh_delaunay = {
    "gmsh-delaunay", "gmsh's Delaunay surface algorithm (Mesh.Algorithm = 5)", &table_delaunay,
    sizeof(peer_gmsh_params), peer_gmsh_params_init, run_delaunay, 0, 0, peer_default_size};

const pm_method peer_gmsh_frontal = {
    "gmsh-frontal", "gmsh's Frontal-Delaunay surface algorithm (Mesh.Algorithm = 6)",
    &table_frontal, sizeof(peer_gmsh_params), peer_gmsh_params_init, run_frontal, 0, 0,
    peer_default_size};
