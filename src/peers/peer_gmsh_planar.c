/* Planar analytic domains as gmsh OpenCASCADE geometry (see peer_gmsh_planar.h). */
#include "peers/peer_gmsh_planar.h"

#include <gmshc.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/gmsh_session.h"

/* The geometry of one model curve, read back through the evaluation interface (geom_analytic
 * keeps its own data private): arcs are parametrized by arc length, so C'' = -(C - centre) / R^2
 * gives the centre and radius at t = lo, and the turn of C' into C'' the direction. */
typedef struct curve_geo {
  int arc;            /* 0: segment, 1: arc */
  int32_t v0, v1;     /* end vertices (start, end) */
  double c[2], R;     /* arc: centre and radius */
  double th0, span;   /* arc: start angle and angle travelled (> 0) */
  double s;           /* arc: +1 counter-clockwise, -1 clockwise */
} curve_geo;

static pm_status read_curve(const pm_cell *c, curve_geo *g, pm_error *err) {
  memset(g, 0, sizeof *g);
  if (c->nbound != 2)
    return pm_error_setf(err, PM_ERR_GEOM, "curve %d has %d end vertices, not 2", c->index,
                         (int)c->nbound);
  g->v0 = c->bound[0].sense < 0 ? c->bound[0].cell : c->bound[1].cell;
  g->v1 = c->bound[0].sense < 0 ? c->bound[1].cell : c->bound[0].cell;
  g->arc = strcmp(c->cls->name, "arc") == 0;
  if (!g->arc) return PM_OK;
  pm_curve_point cp;
  pm_curve_eval(c, c->lo[0], 2, &cp);
  double k2 = cp.d2[0] * cp.d2[0] + cp.d2[1] * cp.d2[1];
  double sp = hypot(cp.d1[0], cp.d1[1]);
  if (!(k2 > 0) || !(sp > 0))
    return pm_error_setf(err, PM_ERR_GEOM, "arc %d has no curvature", c->index);
  g->R = 1 / (sqrt(k2) / (sp * sp)); /* curvature |C''| / |C'|^2 for C' orthogonal to C'' */
  double scale = g->R * g->R / (sp * sp);
  g->c[0] = cp.p[0] + cp.d2[0] * scale;
  g->c[1] = cp.p[1] + cp.d2[1] * scale;
  g->th0 = atan2(cp.p[1] - g->c[1], cp.p[0] - g->c[0]);
  g->s = cp.d1[0] * cp.d2[1] - cp.d1[1] * cp.d2[0] > 0 ? 1.0 : -1.0;
  g->span = (c->hi[0] - c->lo[0]) * sp / g->R;
  return PM_OK;
}

/* Add an arc as an exact rational quadratic B-spline between existing points a and b; the
 * intermediate control points are recorded in aux (to be removed: they are no part of the
 * topology). */
static int add_rational_arc(const curve_geo *g, int a, int b, int *aux, int *naux, int *ierr) {
  int k = (int)ceil(g->span / (0.5 * M_PI) - 1e-9);
  if (k < 1) k = 1;
  double phi = g->span / k, w = cos(0.5 * phi), rm = g->R / w;
  int np = 2 * k + 1;
  int pts[2 * 8 + 1];
  double wt[2 * 8 + 1], knots[8 + 1];
  int mult[8 + 1];
  pts[0] = a, wt[0] = 1;
  for (int j = 0; j < k; ++j) {
    double am = g->th0 + g->s * (j + 0.5) * phi;
    pts[2 * j + 1] = gmshModelOccAddPoint(g->c[0] + rm * cos(am), g->c[1] + rm * sin(am), 0, 0,
                                          -1, ierr);
    if (*ierr) return -1;
    aux[(*naux)++] = pts[2 * j + 1];
    wt[2 * j + 1] = w;
    if (j < k - 1) {
      double ae = g->th0 + g->s * (j + 1) * phi;
      pts[2 * j + 2] = gmshModelOccAddPoint(g->c[0] + g->R * cos(ae), g->c[1] + g->R * sin(ae),
                                            0, 0, -1, ierr);
      if (*ierr) return -1;
      aux[(*naux)++] = pts[2 * j + 2];
      wt[2 * j + 2] = 1;
    }
  }
  pts[np - 1] = b, wt[np - 1] = 1;
  for (int j = 0; j <= k; ++j) {
    knots[j] = (double)j / k;
    mult[j] = (j == 0 || j == k) ? 3 : 2;
  }
  return gmshModelOccAddBSpline(pts, (size_t)np, -1, 2, wt, (size_t)np, knots, (size_t)k + 1,
                                mult, (size_t)k + 1, ierr);
}

/* ---- verification ----------------------------------------------------------------------- */

static pm_status map_points(const pm_model *m, double tol, peer_tagmap *map, pm_error *err) {
  int ierr = 0, *dt = NULL;
  size_t n = 0;
  gmshModelGetEntities(&dt, &n, 0, &ierr);
  if (ierr) return pm_gmsh_error(err, PM_ERR_BACKEND, "listing gmsh points");
  pm_status s = PM_OK;
  uint8_t *used = calloc((size_t)m->count[PM_VERTEX] + 1, 1);
  if (!used) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  if (!s && (int32_t)(n / 2) != m->count[PM_VERTEX])
    s = pm_error_setf(err, PM_ERR_BACKEND,
                      "the gmsh geometry has %d points for the model's %d vertices", (int)(n / 2),
                      (int)m->count[PM_VERTEX]);
  for (size_t i = 0; i + 1 < n && !s; i += 2) {
    double *x = NULL;
    size_t nx = 0;
    gmshModelGetValue(0, dt[i + 1], NULL, 0, &x, &nx, &ierr);
    if (ierr || nx < 3) {
      if (x) gmshFree(x);
      s = pm_gmsh_error(err, PM_ERR_BACKEND, "evaluating a gmsh point");
      break;
    }
    int32_t found = -1;
    for (int32_t v = 0; v < m->count[PM_VERTEX] && found < 0; ++v) {
      const double *p = m->cells[PM_VERTEX][v].xyz;
      if (!used[v] && hypot(x[0] - p[0], x[1] - p[1]) <= tol && fabs(x[2]) <= tol) found = v;
    }
    gmshFree(x);
    if (found < 0) {
      s = pm_error_setf(err, PM_ERR_BACKEND, "gmsh point %d lies on no vertex of the model",
                        dt[i + 1]);
      break;
    }
    used[found] = 1;
    s = peer_tagmap_add(map, 0, dt[i + 1], found, err);
  }
  free(used);
  if (dt) gmshFree(dt);
  return s;
}

/* The end vertices (cells) of gmsh curve `tag`, -1 when missing. */
static pm_status curve_ends(const peer_tagmap *map, int tag, int32_t ends[2], pm_error *err) {
  int ierr = 0, *bt = NULL;
  size_t nb = 0;
  int dim_tag[2] = {1, tag};
  gmshModelGetBoundary(dim_tag, 2, &bt, &nb, 0, 1, 0, &ierr);
  if (ierr) return pm_gmsh_error(err, PM_ERR_BACKEND, "reading a gmsh curve's end points");
  ends[0] = ends[1] = -1;
  /* A closed curve lists its one vertex once or twice. */
  for (size_t i = 0; i + 1 < nb && i < 4; i += 2) ends[i / 2] = peer_tagmap_find(map, 0, bt[i + 1]);
  if (nb == 2) ends[1] = ends[0];
  if (bt) gmshFree(bt);
  return PM_OK;
}

static pm_status map_curves(const pm_model *m, const curve_geo *geo, double tol, peer_tagmap *map,
                            pm_error *err) {
  int ierr = 0, *dt = NULL;
  size_t n = 0;
  gmshModelGetEntities(&dt, &n, 1, &ierr);
  if (ierr) return pm_gmsh_error(err, PM_ERR_BACKEND, "listing gmsh curves");
  pm_status s = PM_OK;
  uint8_t *used = calloc((size_t)m->count[PM_CURVE] + 1, 1);
  if (!used) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  if (!s && (int32_t)(n / 2) != m->count[PM_CURVE])
    s = pm_error_setf(err, PM_ERR_BACKEND,
                      "the gmsh geometry has %d curves for the model's %d curves", (int)(n / 2),
                      (int)m->count[PM_CURVE]);
  for (size_t i = 0; i + 1 < n && !s; i += 2) {
    int tag = dt[i + 1];
    int32_t ends[2] = {-1, -1};
    if ((s = curve_ends(map, tag, ends, err))) break;
    double *lo = NULL, *hi = NULL, *x = NULL;
    size_t nlo = 0, nhi = 0, nx = 0;
    gmshModelGetParametrizationBounds(1, tag, &lo, &nlo, &hi, &nhi, &ierr);
    double t[3] = {0, 0, 0};
    if (!ierr && nlo >= 1 && nhi >= 1) {
      t[0] = lo[0], t[1] = 0.5 * (lo[0] + hi[0]), t[2] = hi[0];
      gmshModelGetValue(1, tag, t, 3, &x, &nx, &ierr);
    }
    if (lo) gmshFree(lo);
    if (hi) gmshFree(hi);
    if (ierr || nx < 9) {
      if (x) gmshFree(x);
      s = pm_gmsh_error(err, PM_ERR_BACKEND, "evaluating a gmsh curve");
      break;
    }
    int32_t found = -1;
    for (int32_t c = 0; c < m->count[PM_CURVE] && found < 0; ++c) {
      if (used[c]) continue;
      int same = (geo[c].v0 == ends[0] && geo[c].v1 == ends[1]) ||
                 (geo[c].v0 == ends[1] && geo[c].v1 == ends[0]);
      if (!same) continue;
      int on = 1;
      for (int k = 0; k < 3 && on; ++k) {
        double par, dist = INFINITY;
        if (pm_cell_project(&m->cells[PM_CURVE][c], &x[3 * k], NULL, &par, NULL, &dist, NULL) ||
            !(dist <= tol))
          on = 0;
      }
      if (on) found = c;
    }
    gmshFree(x);
    if (found < 0) {
      s = pm_error_setf(err, PM_ERR_BACKEND, "gmsh curve %d lies on no curve of the model", tag);
      break;
    }
    used[found] = 1;
    s = peer_tagmap_add(map, 1, tag, found, err);
  }
  free(used);
  if (dt) gmshFree(dt);
  return s;
}

/* ---- building --------------------------------------------------------------------------- */

pm_status peer_gmsh_build_planar(const pm_model *m, peer_tagmap *map, pm_error *err) {
  const pm_cell *face = &m->cells[PM_FACE][0];
  int32_t nv = m->count[PM_VERTEX], nc = m->count[PM_CURVE];
  curve_geo *geo = calloc((size_t)nc + 1, sizeof *geo);
  int *vtag = malloc(sizeof(int) * ((size_t)nv + 1));
  int *ctag = malloc(sizeof(int) * ((size_t)nc + 1));
  int *aux = malloc(sizeof(int) * (17 * (size_t)nc + 1));
  int *rm = malloc(sizeof(int) * (34 * (size_t)nc + 2));
  int *loops = malloc(sizeof(int) * ((size_t)face->nloop + 1));
  int *ltags = NULL;
  int naux = 0, ierr = 0;
  pm_status s = PM_OK;
  if (!geo || !vtag || !ctag || !aux || !rm || !loops) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t c = 0; c < nc && !s; ++c) s = read_curve(&m->cells[PM_CURVE][c], &geo[c], err);
  if (s) goto done;

  /* Points: every vertex a non-closed curve ends at (a full circle brings its own). */
  for (int32_t v = 0; v < nv; ++v) vtag[v] = -1;
  for (int32_t c = 0; c < nc && !ierr; ++c) {
    const pm_cell *cc = &m->cells[PM_CURVE][c];
    if (cc->periodic[0]) continue;
    int32_t ends[2] = {geo[c].v0, geo[c].v1};
    for (int k = 0; k < 2 && !ierr; ++k)
      if (vtag[ends[k]] < 0) {
        const double *p = m->cells[PM_VERTEX][ends[k]].xyz;
        vtag[ends[k]] = gmshModelOccAddPoint(p[0], p[1], 0, 0, -1, &ierr);
      }
  }
  if (ierr) {
    s = pm_gmsh_error(err, PM_ERR_BACKEND, "adding a gmsh point");
    goto done;
  }

  /* Curves. */
  for (int32_t c = 0; c < nc && !ierr; ++c) {
    const pm_cell *cc = &m->cells[PM_CURVE][c];
    const curve_geo *g = &geo[c];
    if (!g->arc) {
      ctag[c] = gmshModelOccAddLine(vtag[g->v0], vtag[g->v1], -1, &ierr);
    } else if (cc->periodic[0]) {
      ctag[c] = gmshModelOccAddCircle(g->c[0], g->c[1], 0, g->R, -1, g->th0, g->th0 + 2 * M_PI,
                                      &ierr);
    } else if (g->span <= 0.9 * M_PI) {
      int centre = gmshModelOccAddPoint(g->c[0], g->c[1], 0, 0, -1, &ierr);
      if (ierr) break;
      aux[naux++] = centre;
      ctag[c] = gmshModelOccAddCircleArc(vtag[g->v0], centre, vtag[g->v1], -1, &ierr);
    } else {
      ctag[c] = add_rational_arc(g, vtag[g->v0], vtag[g->v1], aux, &naux, &ierr);
    }
  }
  if (ierr) {
    s = pm_gmsh_error(err, PM_ERR_BACKEND, "adding a gmsh curve");
    goto done;
  }
  /* Construction points (centres, control points) are no part of the topology. */
  if (naux > 0) {
    for (int k = 0; k < naux; ++k) rm[2 * k] = 0, rm[2 * k + 1] = aux[k];
    gmshModelOccRemove(rm, 2 * (size_t)naux, 0, &ierr);
    if (ierr) {
      s = pm_gmsh_error(err, PM_ERR_BACKEND, "removing gmsh construction points");
      goto done;
    }
  }

  /* The face: its loops, outer first (geom.h keeps outer loops first). */
  for (int32_t l = 0; l < face->nloop; ++l) {
    const pm_loop *lp = &face->loop[l];
    free(ltags);
    ltags = malloc(sizeof(int) * ((size_t)lp->nuse + 1));
    if (!ltags) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto done;
    }
    for (int32_t k = 0; k < lp->nuse; ++k) ltags[k] = ctag[lp->use[k].cell];
    loops[l] = gmshModelOccAddCurveLoop(ltags, (size_t)lp->nuse, -1, &ierr);
    if (ierr) {
      s = pm_gmsh_error(err, PM_ERR_BACKEND, "adding a gmsh curve loop");
      goto done;
    }
  }
  gmshModelOccAddPlaneSurface(loops, (size_t)face->nloop, -1, &ierr);
  if (!ierr) gmshModelOccSynchronize(&ierr);
  if (ierr) {
    s = pm_gmsh_error(err, PM_ERR_BACKEND, "adding the gmsh plane surface");
    goto done;
  }

  /* The correspondence, verified. */
  double tol = 1e-9 * (m->diagonal > 0 ? m->diagonal : 1);
  if ((s = map_points(m, tol, map, err))) goto done;
  if ((s = peer_tagmap_finish(map, err))) goto done;
  if ((s = map_curves(m, geo, tol, map, err))) goto done;
  int *dt = NULL;
  size_t n = 0;
  gmshModelGetEntities(&dt, &n, 2, &ierr);
  if (ierr) {
    s = pm_gmsh_error(err, PM_ERR_BACKEND, "listing gmsh surfaces");
    goto done;
  }
  if (n != 2) {
    s = pm_error_setf(err, PM_ERR_BACKEND, "the gmsh geometry has %d surfaces for the model's 1",
                      (int)(n / 2));
  } else {
    s = peer_tagmap_add(map, 2, dt[1], 0, err);
  }
  if (dt) gmshFree(dt);
  if (!s) s = peer_tagmap_finish(map, err);

done:
  free(geo), free(vtag), free(ctag), free(aux), free(rm), free(loops), free(ltags);
  if (s) pm_error_prefix(err, "planar domain '%s' for gmsh", m->name);
  return s;
}
