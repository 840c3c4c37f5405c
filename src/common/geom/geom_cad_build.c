/* Building the cell complex of a gmsh/OpenCASCADE model (papers/003 section 2.1) for the
 * geom_cad backend: cells from gmsh entities, curve ends, degenerate and closed curves, face
 * periodicity from seams, trimming loops rebuilt in (u, v), volume orientation, embedded cells.
 * Why each of these is rebuilt rather than read from gmsh is in geom_cad.h and
 * /work/shared/cad/GMSH_API.md.
 */
#include <gmshc.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/geom_cad_private.h"
#include "common/base/vec3.h"

/* ---- gmsh entity lists ------------------------------------------------------------------- */

typedef struct tag_list {
  int32_t n;
  int *tag; /* sorted ascending; the cell index is the position */
} tag_list;

static int cmp_int(const void *a, const void *b) {
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

static pm_status list_entities(int dim, tag_list *tl, pm_error *err) {
  int *dt = NULL;
  size_t n = 0;
  int ierr = 0;
  gmshModelGetEntities(&dt, &n, dim, &ierr);
  if (ierr) {
    if (dt) gmshFree(dt);
    return pm_gmsh_error(err, PM_ERR_BACKEND, "listing the model's entities");
  }
  tl->n = (int32_t)(n / 2);
  tl->tag = malloc(sizeof(int) * (size_t)(tl->n ? tl->n : 1));
  if (!tl->tag) {
    if (dt) gmshFree(dt);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t i = 0; i < tl->n; ++i) tl->tag[i] = dt[2 * i + 1];
  if (dt) gmshFree(dt);
  /* gmsh lists entities by tag already; sorting makes "index = rank of the tag" a guarantee. */
  qsort(tl->tag, (size_t)tl->n, sizeof(int), cmp_int);
  return PM_OK;
}

static int32_t index_of(const tag_list *tl, int tag) {
  const int *p = bsearch(&tag, tl->tag, (size_t)tl->n, sizeof(int), cmp_int);
  return p ? (int32_t)(p - tl->tag) : -1;
}

/* Boundary entity tags of (dim, tag), with multiplicity (a seam appears twice), signs dropped.
 * The caller frees *out with free(). */
static int boundary_tags(int dim, int tag, int **out, int32_t *n) {
  int in[2] = {dim, tag};
  int *dt = NULL;
  size_t nd = 0;
  int ierr = 0;
  gmshModelGetBoundary(in, 2, &dt, &nd, 0, 1, 0, &ierr);
  *n = 0;
  *out = malloc(sizeof(int) * (nd / 2 + 1));
  if (!*out) {
    if (dt) gmshFree(dt);
    return -1;
  }
  if (!ierr)
    for (size_t i = 0; i < nd / 2; ++i) (*out)[(*n)++] = abs(dt[2 * i + 1]);
  if (dt) gmshFree(dt);
  return ierr ? -1 : 0;
}

/* Map gmsh's type string to a class name. */
static const char *class_name(int dim, const char *gtype) {
  if (dim == PM_FACE) {
    if (!strncmp(gtype, "BSpline", 7)) return "bspline";
    if (!strncmp(gtype, "Bezier", 6)) return "bezier";
    if (strstr(gtype, "Revolution")) return "revolution";
    if (strstr(gtype, "Extrusion")) return "extrusion";
    if (strstr(gtype, "Offset")) return "offset";
    return "other";
  }
  if (!strncmp(gtype, "BSpline", 7)) return "bspline";
  if (!strncmp(gtype, "Bezier", 6)) return "bezier";
  if (!strncmp(gtype, "Trimmed", 7)) return "trimmed";
  if (strstr(gtype, "Offset")) return "offset";
  return "other";
}

static void entity_type(int dim, int tag, char *buf, size_t len) {
  char *t = NULL;
  int ierr = 0;
  gmshModelGetType(dim, tag, &t, &ierr);
  snprintf(buf, len, "%s", (!ierr && t) ? t : "Unknown");
  if (t) gmshFree(t);
}

static int param_bounds(int dim, int tag, double *lo, double *hi) {
  double *a = NULL, *b = NULL;
  size_t na = 0, nb = 0;
  int ierr = 0;
  gmshModelGetParametrizationBounds(dim, tag, &a, &na, &b, &nb, &ierr);
  int ok = !ierr && na == (size_t)dim && nb == (size_t)dim;
  for (int k = 0; ok && k < dim; ++k) {
    lo[k] = a[k], hi[k] = b[k];
    ok = isfinite(lo[k]) && isfinite(hi[k]);
  }
  if (a) gmshFree(a);
  if (b) gmshFree(b);
  return ok ? 0 : -1;
}

/* Pcurve of curve `ctag` on face `ftag` at n parameters, pcurve `which`. */
static int pcurve(int ctag, int ftag, int32_t n, const double *t, int which, double *uv) {
  double *r = NULL;
  size_t nr = 0;
  int ierr = 0;
  gmshModelReparametrizeOnSurface(1, ctag, (double *)t, (size_t)n, ftag, &r, &nr, which, &ierr);
  int ok = !ierr && nr == 2 * (size_t)n && r;
  for (size_t i = 0; ok && i < nr; ++i) ok = isfinite(r[i]);
  if (ok) memcpy(uv, r, sizeof(double) * nr);
  if (r) gmshFree(r);
  return ok ? 0 : -1;
}

/* Embedded entities of (dim, tag) as gmsh reports them, appended to cell c. */
static pm_status add_embedded(pm_cell *c, int dim, int tag, const tag_list tl[4], pm_error *err) {
  int *dt = NULL;
  size_t nd = 0;
  int ierr = 0;
  gmshModelMeshGetEmbedded(dim, tag, &dt, &nd, &ierr);
  if (ierr || nd == 0) {
    if (dt) gmshFree(dt);
    return PM_OK;
  }
  pm_cellref *e = realloc(c->embed, sizeof(pm_cellref) * ((size_t)c->nembed + nd / 2));
  if (!e) {
    gmshFree(dt);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  c->embed = e;
  for (size_t i = 0; i < nd / 2; ++i) {
    int ed = dt[2 * i];
    if (ed < 0 || ed >= dim) continue;
    int32_t idx = index_of(&tl[ed], dt[2 * i + 1]);
    if (idx < 0) continue;
    int dup = 0;
    for (int32_t k = 0; k < c->nembed; ++k)
      dup |= c->embed[k].dim == ed && c->embed[k].index == idx;
    if (!dup) c->embed[c->nembed++] = (pm_cellref){ed, idx};
  }
  gmshFree(dt);
  return PM_OK;
}

/* ---- curves ------------------------------------------------------------------------------ */

/* Samples along a curve for the degenerate test. */
#define DEGEN_SAMPLES 9
/* A curve whose samples all lie within DEGEN_TOL x diagonal of each other has zero length (a
 * sphere pole, a cone apex: gmsh's type "Unknown", length 0); the shortest real edge of the
 * shared models is 4e-5 x diagonal. A closed curve (one end vertex) is degenerate up to
 * DEGEN_CLOSED_TOL: exporters leave poles as loops a rounding error long (U_Joint_2.stp: a loop
 * of 1.9e-5 on a model of diagonal 137, 1.4e-7 of it), and a loop that short cannot carry the
 * two nodes a closed curve needs without folding the triangles around it. */
#define DEGEN_TOL 1e-9
#define DEGEN_CLOSED_TOL 1e-6
/* A closed curve's ends coincide within OCC's usual precision, relative to the model. */
#define CLOSE_TOL 1e-7

static pm_status build_curve(pm_cell *c, int tag, const tag_list tl[4], const double *vxyz,
                             double diag, pm_error *err) {
  cad_cell *cc = c->impl;
  c->tag = tag;
  if (param_bounds(1, tag, c->lo, c->hi))
    return pm_gmsh_error(err, PM_ERR_GEOM, "curve without a parameter range");
  char gtype[64];
  entity_type(1, tag, gtype, sizeof gtype);

  double ts[DEGEN_SAMPLES];
  for (int k = 0; k < DEGEN_SAMPLES; ++k)
    ts[k] = c->lo[0] + (c->hi[0] - c->lo[0]) * k / (DEGEN_SAMPLES - 1);
  pm_curve_point cp[DEGEN_SAMPLES];
  if (cad_gmsh_curve(tag, DEGEN_SAMPLES, ts, 0, 1, cp))
    return pm_gmsh_error(err, PM_ERR_GEOM, "evaluating a curve");
  pm_v3_copy(cc->fallback, cp[DEGEN_SAMPLES / 2].p);
  double spread = 0;
  for (int k = 1; k < DEGEN_SAMPLES; ++k) spread = fmax(spread, pm_v3_dist(cp[k].p, cp[0].p));
  const double *c0 = cp[0].p, *c1 = cp[DEGEN_SAMPLES - 1].p;

  /* End vertices: gmsh lists them, but the first need not be at t = lo (a reversed edge):
   * decide by geometry. */
  int *vt;
  int32_t nv;
  if (boundary_tags(1, tag, &vt, &nv)) {
    free(vt);
    return pm_gmsh_error(err, PM_ERR_BACKEND, "reading a curve's end points");
  }
  int32_t va = -1, vb = -1;
  for (int32_t k = 0; k < nv; ++k) {
    int32_t vi = index_of(&tl[PM_VERTEX], vt[k]);
    if (vi < 0) continue;
    if (va < 0)
      va = vi;
    else if (vb < 0 && vi != va)
      vb = vi;
  }
  free(vt);
  if (va >= 0) {
    c->bound = malloc(sizeof(pm_use) * 2);
    if (!c->bound) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    c->nbound = 2;
    int32_t start = va, end = va;
    if (vb >= 0) {
      const double *pa = vxyz + 3 * va, *pb = vxyz + 3 * vb;
      double keep = pm_v3_dist(c0, pa) + pm_v3_dist(c1, pb);
      double swap = pm_v3_dist(c0, pb) + pm_v3_dist(c1, pa);
      start = keep <= swap ? va : vb;
      end = keep <= swap ? vb : va;
    }
    c->bound[0] = (pm_use){start, -1, 0};
    c->bound[1] = (pm_use){end, +1, 0};
  }
  int closed = c->nbound == 2 && c->bound[0].cell == c->bound[1].cell;
  c->degenerate = spread <= (closed ? DEGEN_CLOSED_TOL : DEGEN_TOL) * diag;
  if (!c->degenerate && !(c->hi[0] > c->lo[0]))
    return pm_error_setf(err, PM_ERR_GEOM, "curve with an empty parameter range");
  if ((closed || c->nbound == 0) && !c->degenerate && pm_v3_dist(c0, c1) <= CLOSE_TOL * diag) {
    c->periodic[0] = 1;
    c->period[0] = c->hi[0] - c->lo[0];
  }
  const char *name;
  if (cad_fit(c, gtype, diag, &cc->form))
    name = cad_form_name(cc->form.kind);
  else
    name = c->degenerate ? "degenerate" : class_name(PM_CURVE, gtype);
  c->cls = cad_class(PM_CURVE, name);
  return PM_OK;
}

/* ---- face loops -------------------------------------------------------------------------- */

/* One traversable pcurve: a use of a boundary curve on the face, with its end points.
 *
 * A curve used once can still have two pcurves a period apart: gmsh's `which` selects between
 * the pcurves of the curve's two orientations, and OpenCASCADE keeps two for an edge that lies
 * on the seam line of a periodic surface even where the face uses it once (a partial cylinder
 * bounded by the seam line, bl3d_3.brep; a seam split where the loop crosses it,
 * 1385_Laufrad_1000.stp). Which of the two the loop runs along is only known from its
 * neighbours: such a seg is `ambiguous` and the walk picks the side whose end continues the loop
 * in (u, v), which unwraps the loop across the seam. */
typedef struct seg {
  int32_t curve;    /* curve index */
  int8_t side;      /* pcurve selector (`which`) */
  int8_t ambiguous; /* 1: side is chosen by the walk between uv and alt */
  int32_t v[2];     /* vertex at t = lo and t = hi (negative: a curve without vertices) */
  double uv[2][2];  /* pcurve at t = lo and t = hi (of `side`) */
  double alt[2][2]; /* ambiguous segs: the other pcurve (side 1 - side) */
  int used;
} seg;

/* Make the other pcurve of an ambiguous seg its own. */
static void seg_flip_side(seg *g) {
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 2; ++k) {
      double t = g->uv[e][k];
      g->uv[e][k] = g->alt[e][k], g->alt[e][k] = t;
    }
  g->side = (int8_t)(1 - g->side);
}

/* Two visits of one vertex are one junction when their (u, v) agree within JUNCTION_TOL x the
 * box diagonal: a vertex has one (u, v) on a regular surface up to the period, so distinct
 * visits are a period (or a pole segment) apart, while pcurves of one vertex agree to about
 * 1e-4 of the box even on loosely toleranced files (CATALOG.md). */
#define JUNCTION_TOL 1e-3
/* Without a shared vertex, a pcurve end within GAP_MATCH x the box diagonal still continues a
 * loop (trim.c bridges gaps up to 2e-2 of the box diagonal). */
#define GAP_MATCH 2e-2

typedef struct raw_loop {
  int32_t n;
  int32_t *seg;  /* [n] seg indices */
  int8_t *sense; /* [n] */
} raw_loop;

static void seg_start(const seg *s, int sense, int32_t *v, const double **uv) {
  *v = s->v[sense > 0 ? 0 : 1];
  *uv = s->uv[sense > 0 ? 0 : 1];
}

static double dist2d(const double a[2], const double b[2]) {
  return hypot(a[0] - b[0], a[1] - b[1]);
}

/* A pole the file does not model: some B-rep writers and IGES sewing drop degenerate edges,
 * leaving a loop that returns to one vertex at two different (u, v) along a singular side of
 * the surface (bearing.iges). Such a gap gets a degenerate curve of our own: a point in 3D
 * whose pcurve on this face is the segment between the two (u, v). */
typedef struct synth {
  int32_t vertex;    /* the vertex the gap is at */
  int32_t face;      /* index of the only face that uses it */
  double a[2], b[2]; /* the pcurve: from a at t = 0 to b at t = 1 */
} synth;

/* What building faces needs beyond the face itself. */
typedef struct face_ctx {
  const tag_list *tl;
  double diag;
  const pm_cell *curves; /* [nc] the curves, built already */
  int32_t nc;
  synth *syn; /* synthetic degenerate curves, curve index nc + k */
  int32_t nsyn, capsyn;
  double lo[2], hi[2]; /* the parameter box of the face being built */
} face_ctx;

/* S is constant (within SINGULAR_TOL x diagonal) along the (u, v) segment a-b: a pole side. */
#define SINGULAR_TOL 1e-7

static int singular_segment(int ftag, const double a[2], const double b[2], double diag) {
  double uv[10];
  for (int i = 0; i < 5; ++i) {
    double w = i / 4.0;
    uv[2 * i] = a[0] + w * (b[0] - a[0]), uv[2 * i + 1] = a[1] + w * (b[1] - a[1]);
  }
  pm_face_point fp[5];
  if (cad_gmsh_face(ftag, 5, uv, 0, fp)) return 0;
  for (int i = 1; i < 5; ++i)
    if (pm_v3_dist(fp[i].p, fp[0].p) > SINGULAR_TOL * diag) return 0;
  return 1;
}

/* When the walk at vertex v, (u, v) = from, goes on at to (the same vertex) across a singular
 * side, append a synthetic degenerate seg from -> to (used) and return its index, else -1. */
static int32_t bridge(face_ctx *fc, int32_t face, int ftag, seg *s, int32_t *ns, int32_t v,
                      const double from[2], const double to[2], double uvdiag) {
  if (v < 0 || hypot(to[0] - from[0], to[1] - from[1]) <= JUNCTION_TOL * uvdiag) return -1;
  if (!singular_segment(ftag, from, to, fc->diag)) return -1;
  if (fc->nsyn == fc->capsyn) {
    int32_t cap = fc->capsyn ? 2 * fc->capsyn : 16;
    synth *n = realloc(fc->syn, sizeof(synth) * (size_t)cap);
    if (!n) return -2;
    fc->syn = n, fc->capsyn = cap;
  }
  synth *y = &fc->syn[fc->nsyn];
  y->vertex = v, y->face = face;
  y->a[0] = from[0], y->a[1] = from[1], y->b[0] = to[0], y->b[1] = to[1];
  seg *g = &s[(*ns)++];
  g->curve = fc->nc + fc->nsyn++;
  g->side = 0;
  g->v[0] = g->v[1] = v;
  g->uv[0][0] = from[0], g->uv[0][1] = from[1], g->uv[1][0] = to[0], g->uv[1][1] = to[1];
  g->ambiguous = 0;
  g->used = 1;
  return *ns - 1;
}

/* How far a pcurve's ends lie outside the face's parameter box (0 inside). */
static double box_excess(const face_ctx *fc, const double uv[2][2]) {
  double x = 0;
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 2; ++k)
      x += fmax(0, fc->lo[k] - uv[e][k]) + fmax(0, uv[e][k] - fc->hi[k]);
  return x;
}

/* Chain the segs into closed walks: from the end of the last seg, continue with the unused seg
 * end at the same vertex nearest in (u, v), or close the walk when its start is at least as near
 * (closing wins ties, so that a loop touching another at its start vertex closes there). Gaps
 * across a singular side are bridged (see synth). `s` has room for 2 ns + 1 segs. */
static int chain_walks(face_ctx *fc, int32_t face, int ftag, seg *s, int32_t *pns, double uvdiag,
                       raw_loop **loops, int32_t *nloops) {
  const int32_t ns0 = *pns;
  const size_t cap = 2 * (size_t)ns0 + 1;
  int32_t *order = malloc(sizeof(int32_t) * cap);
  int8_t *sense = malloc(cap);
  raw_loop *L = malloc(sizeof(raw_loop) * cap);
  if (!order || !sense || !L) {
    free(order), free(sense), free(L);
    return -1;
  }
  int32_t no = 0, nl = 0;
  /* Seeds: segs with one pcurve first, so that an ambiguous seg's side is decided by a
   * neighbour; a walk of ambiguous segs only starts on the side nearer the parameter box. */
  for (int32_t pass = 0; pass < 2 * ns0; ++pass) {
    const int32_t seed = pass % ns0;
    if (s[seed].used || (pass < ns0 && s[seed].ambiguous)) continue;
    if (s[seed].ambiguous && box_excess(fc, s[seed].alt) < box_excess(fc, s[seed].uv))
      seg_flip_side(&s[seed]);
    int32_t first = no;
    s[seed].used = 1;
    order[no] = seed, sense[no] = 1, ++no;
    const int32_t v0 = s[seed].v[0];
    const double *uv0 = s[seed].uv[0];
    int32_t cv = s[seed].v[1];
    const double *cuv = s[seed].uv[1];
    for (;;) {
      double dclose = cv == v0 ? dist2d(cuv, uv0) : DBL_MAX;
      int32_t best = -1;
      int be = 0;
      double bestd = DBL_MAX;
      int bflip = 0; /* the best end is on the other pcurve of an ambiguous seg */
      for (int32_t j = 0; j < ns0; ++j) {
        if (s[j].used) continue;
        for (int e = 0; e < 2; ++e) {
          if (s[j].v[e] != cv) continue;
          for (int a = 0; a <= s[j].ambiguous; ++a) {
            double d = dist2d(a ? s[j].alt[e] : s[j].uv[e], cuv);
            if (d < bestd) bestd = d, best = j, be = e, bflip = a;
          }
        }
      }
      if (best < 0) {
        /* No seg at this vertex: the nearest end in (u, v), if near enough. */
        if (dclose == DBL_MAX && dist2d(cuv, uv0) <= GAP_MATCH * uvdiag) dclose = dist2d(cuv, uv0);
        for (int32_t j = 0; j < ns0; ++j) {
          if (s[j].used) continue;
          for (int e = 0; e < 2; ++e)
            for (int a = 0; a <= s[j].ambiguous; ++a) {
              double d = dist2d(a ? s[j].alt[e] : s[j].uv[e], cuv);
              if (d <= GAP_MATCH * uvdiag && d < bestd) bestd = d, best = j, be = e, bflip = a;
            }
        }
      }
      if (best >= 0 && bflip && !(dclose <= bestd)) seg_flip_side(&s[best]);
      const int closing = best < 0 || dclose <= bestd;
      const int32_t tv = closing ? v0 : s[best].v[be];
      const double *tuv = closing ? uv0 : s[best].uv[be];
      if (tv == cv && (!closing || dclose < DBL_MAX)) {
        int32_t b = bridge(fc, face, ftag, s, pns, cv, cuv, tuv, uvdiag);
        if (b == -2) {
          free(order), free(sense), free(L);
          return -1;
        }
        if (b >= 0) order[no] = b, sense[no] = 1, ++no;
      }
      if (closing) break;
      s[best].used = 1;
      order[no] = best, sense[no] = (int8_t)(be == 0 ? 1 : -1), ++no;
      cv = s[best].v[1 - be];
      cuv = s[best].uv[1 - be];
    }
    L[nl].n = no - first;
    L[nl].seg = order + first;
    L[nl].sense = sense + first;
    ++nl;
  }
  *loops = L;
  *nloops = nl;
  if (nl == 0) free(order), free(sense);
  return 0;
}

/* Append a loop of uses to face f. */
static int push_loop(pm_cell *f, const seg *s, const int32_t *idx, const int8_t *sense, int32_t n) {
  pm_loop *l = realloc(f->loop, sizeof(pm_loop) * ((size_t)f->nloop + 1));
  if (!l) return -1;
  f->loop = l;
  pm_loop *lp = &f->loop[f->nloop];
  memset(lp, 0, sizeof *lp);
  lp->use = malloc(sizeof(pm_use) * (size_t)n);
  if (!lp->use) return -1;
  lp->nuse = n;
  for (int32_t k = 0; k < n; ++k) lp->use[k] = (pm_use){s[idx[k]].curve, sense[k], s[idx[k]].side};
  /* Outer or hole is left to pm_model_finish (signed area and nesting): the pcurves' direction
   * says nothing reliable about it (GMSH_API.md). */
  lp->outer = -1;
  f->nloop++;
  return 0;
}

/* Split a closed walk where it passes a junction twice (loops touching at a vertex, like the
 * hole of cyl_loop_seam.brep meeting the seam): each return to a junction on the stack closes a
 * sub-loop. The even-odd inside test does not care how the edges are grouped, but the outer/hole
 * classification and the meshers' boundary chains do. */
static int split_walk(pm_cell *f, const seg *s, const raw_loop *w, double uvdiag) {
  int32_t *st = malloc(sizeof(int32_t) * (size_t)w->n);
  int8_t *ss = malloc((size_t)w->n);
  if (!st || !ss) {
    free(st), free(ss);
    return -1;
  }
  int32_t top = 0;
  for (int32_t k = 0; k < w->n; ++k) {
    int32_t vk;
    const double *uk;
    seg_start(&s[w->seg[k]], w->sense[k], &vk, &uk);
    for (int32_t p = 0; p < top; ++p) {
      int32_t vp;
      const double *up;
      seg_start(&s[st[p]], ss[p], &vp, &up);
      if (vp == vk && dist2d(up, uk) <= JUNCTION_TOL * uvdiag) {
        if (push_loop(f, s, st + p, ss + p, top - p)) {
          free(st), free(ss);
          return -1;
        }
        top = p;
        break;
      }
    }
    st[top] = w->seg[k], ss[top] = w->sense[k], ++top;
  }
  int rc = top > 0 ? push_loop(f, s, st, ss, top) : 0;
  free(st), free(ss);
  return rc;
}

/* Period P along parameter k of face `tag`: the surface closes on itself, S(lo + P) = S(lo) at a
 * few points along the seam line u_k = lo_k. Checked at the seam rather than at interior points,
 * because a closed B-spline surface that is not periodic in OCC's sense is defined on one period
 * only (S(u + P) would extrapolate); evaluation wraps parameters into [lo, lo + P) before asking
 * gmsh, so closure is what periodic evaluation needs. */
static int check_period(int tag, const double lo[2], const double hi[2], int k, double P,
                        double diag) {
  double uv[12];
  for (int i = 0; i < 3; ++i) {
    double w = lo[1 - k] + (hi[1 - k] - lo[1 - k]) * (2 * i + 1) / 6.0;
    uv[4 * i + k] = lo[k], uv[4 * i + 1 - k] = w;
    uv[4 * i + 2 + k] = lo[k] + P, uv[4 * i + 3 - k] = w;
  }
  pm_face_point fp[6];
  if (cad_gmsh_face(tag, 6, uv, 0, fp)) return 0;
  for (int i = 0; i < 3; ++i)
    if (pm_v3_dist(fp[2 * i].p, fp[2 * i + 1].p) > CLOSE_TOL * diag) return 0;
  return 1;
}

static pm_status build_face(face_ctx *fc, int32_t index, pm_cell *f, int tag, pm_error *err) {
  cad_cell *cc = f->impl;
  const tag_list *tl = fc->tl;
  const double diag = fc->diag;
  f->tag = tag;
  if (param_bounds(2, tag, f->lo, f->hi))
    return pm_gmsh_error(err, PM_ERR_GEOM, "surface without a parameter range");
  char gtype[64];
  entity_type(2, tag, gtype, sizeof gtype);
  const double uvdiag = hypot(f->hi[0] - f->lo[0], f->hi[1] - f->lo[1]);
  if (!(uvdiag > 0)) return pm_error_setf(err, PM_ERR_GEOM, "surface with an empty parameter box");
  fc->lo[0] = f->lo[0], fc->lo[1] = f->lo[1], fc->hi[0] = f->hi[0], fc->hi[1] = f->hi[1];
  {
    double c[2] = {0.5 * (f->lo[0] + f->hi[0]), 0.5 * (f->lo[1] + f->hi[1])};
    pm_face_point fp;
    if (cad_gmsh_face(tag, 1, c, 0, &fp))
      return pm_gmsh_error(err, PM_ERR_GEOM, "evaluating a surface");
    pm_v3_copy(cc->fallback, fp.p);
  }

  int *bt;
  int32_t nb;
  if (boundary_tags(2, tag, &bt, &nb)) {
    free(bt);
    return pm_gmsh_error(err, PM_ERR_BACKEND, "reading a surface's boundary");
  }
  /* Distinct curves and their multiplicity. */
  seg *s = malloc(sizeof(seg) * (2 * (size_t)nb + 1)); /* room for bridges (chain_walks) */
  int32_t ns = 0;
  if (!s) {
    free(bt);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  pm_status st = PM_OK;
  for (int32_t i = 0; i < nb && !st; ++i) {
    int dup = 0;
    for (int32_t j = 0; j < i; ++j) dup |= bt[j] == bt[i];
    if (dup) continue;
    int mult = 0;
    for (int32_t j = i; j < nb; ++j) mult += bt[j] == bt[i];
    int32_t ci = index_of(&tl[PM_CURVE], bt[i]);
    if (ci < 0) continue;
    const pm_cell *c = &fc->curves[ci];
    int32_t v0 = c->nbound == 2 ? c->bound[0].cell : -(ci + 2);
    int32_t v1 = c->nbound == 2 ? c->bound[1].cell : -(ci + 2);
    double tt[3] = {c->lo[0], c->hi[0], 0.5 * (c->lo[0] + c->hi[0])};
    double uvs[2][6];
    if (pcurve(c->tag, tag, 3, tt, 0, uvs[0])) {
      st = pm_error_setf(err, PM_ERR_GEOM, "curve %d has no pcurve on it", c->tag);
      break;
    }
    int sides = 1, twin = pcurve(c->tag, tag, 3, tt, 1, uvs[1]) == 0;
    if (twin && mult == 1 && !c->degenerate) {
      double dmid = dist2d(uvs[0] + 4, uvs[1] + 4), dend = dist2d(uvs[0], uvs[1]);
      twin = fmax(dmid, dend) > JUNCTION_TOL * uvdiag; /* a second pcurve, a period away */
    }
    if (twin && mult == 1 && !c->degenerate) {
      seg *g = &s[ns++];
      g->curve = ci, g->side = 0, g->ambiguous = 1, g->used = 0;
      g->v[0] = v0, g->v[1] = v1;
      for (int e = 0; e < 2; ++e)
        for (int k = 0; k < 2; ++k) g->uv[e][k] = uvs[0][2 * e + k], g->alt[e][k] = uvs[1][2 * e + k];
      continue;
    }
    if (mult >= 2 && twin) {
      /* A seam: its two pcurves differ (by the period). A curve used twice with one pcurve (a
       * slit) gives two uses of side 0. */
      double dmid = dist2d(uvs[0] + 4, uvs[1] + 4), dend = dist2d(uvs[0], uvs[1]);
      if (fmax(dmid, dend) > 1e-9 * uvdiag) {
        sides = 2;
        /* Periodicity: the difference of the two pcurves, along one parameter. */
        double d[2] = {uvs[1][4] - uvs[0][4], uvs[1][5] - uvs[0][5]};
        if (c->degenerate) d[0] = uvs[1][0] - uvs[0][0], d[1] = uvs[1][1] - uvs[0][1];
        for (int k = 0; k < 2; ++k) {
          double P = fabs(d[k]);
          if (f->periodic[k] || !(P > 1e-6 * uvdiag) || fabs(d[1 - k]) > 1e-6 * P) continue;
          if (check_period(tag, f->lo, f->hi, k, P, diag)) f->periodic[k] = 1, f->period[k] = P;
        }
      }
    }
    for (int u = 0; u < mult; ++u) {
      seg *g = &s[ns++];
      g->curve = ci;
      g->side = (int8_t)(sides == 2 && u == 1 ? 1 : 0);
      g->ambiguous = 0;
      g->v[0] = v0, g->v[1] = v1;
      const double *p = uvs[g->side];
      g->uv[0][0] = p[0], g->uv[0][1] = p[1], g->uv[1][0] = p[2], g->uv[1][1] = p[3];
      g->used = 0;
    }
  }
  free(bt);
  if (!st && ns == 0) st = pm_error_setf(err, PM_ERR_GEOM, "no boundary curve");
  if (!st) {
    raw_loop *walks = NULL;
    int32_t nw = 0;
    if (chain_walks(fc, index, tag, s, &ns, uvdiag, &walks, &nw))
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t w = 0; w < nw && !st; ++w)
      if (split_walk(f, s, &walks[w], uvdiag))
        st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    if (walks && nw > 0) free(walks[0].seg), free(walks[0].sense); /* the walks share them */
    free(walks);
  }
  free(s);
  if (st) return st;

  const char *name;
  if (cad_fit(f, gtype, diag, &cc->form))
    name = cad_form_name(cc->form.kind);
  else
    name = class_name(PM_FACE, gtype);
  f->cls = cad_class(PM_FACE, name);
  return add_embedded(f, 2, tag, tl, err);
}

/* ---- volumes ----------------------------------------------------------------------------- */

static pm_status build_volume(pm_cell *v, int tag, const tag_list tl[4], pm_error *err) {
  v->tag = tag;
  v->cls = cad_class(PM_VOLUME, "volume");
  int *ft;
  int32_t nf;
  if (boundary_tags(3, tag, &ft, &nf)) {
    free(ft);
    return pm_gmsh_error(err, PM_ERR_BACKEND, "reading a volume's boundary");
  }
  v->bound = malloc(sizeof(pm_use) * (size_t)(nf ? nf : 1));
  v->embed = malloc(sizeof(pm_cellref) * (size_t)(nf ? nf : 1));
  if (!v->bound || !v->embed) {
    free(ft);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t i = 0; i < nf; ++i) {
    int32_t fi = index_of(&tl[PM_FACE], ft[i]);
    if (fi < 0) continue;
    int mult = 0, seen = 0;
    for (int32_t j = 0; j < nf; ++j) mult += ft[j] == ft[i];
    for (int32_t j = 0; j < i; ++j) seen |= ft[j] == ft[i];
    if (seen) continue;
    if (mult >= 2) /* Listed twice in one shell: material on both sides, an internal face. */
      v->embed[v->nembed++] = (pm_cellref){PM_FACE, fi};
    else
      v->bound[v->nbound++] = (pm_use){fi, +1, 0}; /* sense fixed after pm_model_finish */
  }
  free(ft);
  return add_embedded(v, 3, tag, tl, err);
}

/* Faces whose upward adjacency names a volume whose boundary does not list them lie inside it
 * (OpenCASCADE's internal faces after a fragment); gmshModelMeshGetEmbedded reports those too
 * in 4.8.4, this catches a version that does not. */
static pm_status embed_by_adjacency(pm_model *m, const tag_list tl[4], pm_error *err) {
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    int *up = NULL, *down = NULL;
    size_t nu = 0, nd = 0;
    int ierr = 0;
    gmshModelGetAdjacencies(2, tl[PM_FACE].tag[i], &up, &nu, &down, &nd, &ierr);
    for (size_t k = 0; !ierr && k < nu; ++k) {
      int32_t vi = index_of(&tl[PM_VOLUME], up[k]);
      if (vi < 0) continue;
      pm_cell *v = &m->cells[PM_VOLUME][vi];
      int listed = 0;
      for (int32_t q = 0; q < v->nbound; ++q) listed |= v->bound[q].cell == i;
      for (int32_t q = 0; q < v->nembed; ++q)
        listed |= v->embed[q].dim == PM_FACE && v->embed[q].index == i;
      if (listed) continue;
      pm_cellref *e = realloc(v->embed, sizeof(pm_cellref) * ((size_t)v->nembed + 1));
      if (!e) {
        gmshFree(up), gmshFree(down);
        return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      }
      v->embed = e;
      v->embed[v->nembed++] = (pm_cellref){PM_FACE, i};
    }
    if (up) gmshFree(up);
    if (down) gmshFree(down);
  }
  return PM_OK;
}

/* ---- volume orientation ------------------------------------------------------------------ */

/* +1 when gmsh's normal (outward on a solid, following the face's orientation in the B-rep)
 * agrees with the natural normal Su x Sv, -1 when it is opposite, 0 when undecided. Sampled at
 * points inside the trimmed region where the chart is regular. */
static int normal_sign(const pm_cell *f) {
  double uv[2 * 8];
  int n = 0;
  for (int a = 0; a < 7 && n < 8; ++a)
    for (int b = 0; b < 7 && n < 8; ++b) {
      double q[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (a + 0.5) / 7,
                     f->lo[1] + (f->hi[1] - f->lo[1]) * (b + 0.5) / 7};
      if (!pm_face_inside(f, q)) continue;
      uv[2 * n] = q[0], uv[2 * n + 1] = q[1], ++n;
    }
  if (n == 0) uv[0] = 0.5 * (f->lo[0] + f->hi[0]), uv[1] = 0.5 * (f->lo[1] + f->hi[1]), n = 1;
  const cad_cell *cc = f->impl;
  double *nr = NULL;
  size_t nn = 0;
  int ierr = 0;
  cad_guard g;
  if (cad_enter(cc->cm, &g) == 0)
    gmshModelGetNormal(f->tag, uv, 2 * (size_t)n, &nr, &nn, &ierr);
  else
    ierr = 1;
  cad_leave(&g);
  double sum = 0;
  for (int i = 0; !ierr && i < n && nn == 3 * (size_t)n; ++i) {
    pm_face_point fp;
    pm_face_eval(f, uv + 2 * i, 1, &fp);
    double c[3];
    pm_v3_cross(c, fp.su, fp.sv);
    double lc = pm_v3_norm(c), ln = pm_v3_norm(nr + 3 * i);
    if (!(lc > 1e-12 * pm_v3_norm(fp.su) * pm_v3_norm(fp.sv)) || !(ln > 0.5)) continue;
    sum += pm_v3_dot(c, nr + 3 * i) / (lc * ln);
  }
  if (nr) gmshFree(nr);
  return sum > 0 ? 1 : (sum < 0 ? -1 : 0);
}

/* Senses of the faces of every volume (geom.h: +1 when Su x Sv points out of the volume).
 * A face of one volume: gmshModelGetNormal is outward on solids. A face shared by two volumes:
 * gmsh's normal is outward for one of them only and its oriented boundary signs are all +1, so
 * the sense comes from the neighbours: in a closed shell oriented outwards every edge is run in
 * opposite directions by its two faces, and each face's loops (oriented by pm_model_finish,
 * outer counter-clockwise about Su x Sv) give the direction it runs the edge in. */
static pm_status orient_volumes(pm_model *m, pm_error *err) {
  const int32_t nf = m->count[PM_FACE], nc = m->count[PM_CURVE];
  int *nsign = calloc((size_t)(nf ? nf : 1), sizeof(int));
  int32_t *first = malloc(sizeof(int32_t) * (size_t)(nc ? nc : 1));
  int32_t *second = malloc(sizeof(int32_t) * (size_t)(nc ? nc : 1));
  int8_t *dfirst = malloc((size_t)(nc ? nc : 1)), *dsecond = malloc((size_t)(nc ? nc : 1));
  int32_t *uses = malloc(sizeof(int32_t) * (size_t)(nc ? nc : 1));
  if (!nsign || !first || !second || !dfirst || !dsecond || !uses) {
    free(nsign), free(first), free(second), free(dfirst), free(dsecond), free(uses);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t i = 0; i < nf; ++i) nsign[i] = 2; /* not computed yet */
  for (int32_t vi = 0; vi < m->count[PM_VOLUME]; ++vi) {
    pm_cell *v = &m->cells[PM_VOLUME][vi];
    int8_t *known = calloc((size_t)(v->nbound ? v->nbound : 1), 1);
    if (!known) {
      free(nsign), free(first), free(second), free(dfirst), free(dsecond), free(uses);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    for (int32_t k = 0; k < v->nbound; ++k) {
      const pm_cell *f = &m->cells[PM_FACE][v->bound[k].cell];
      if (f->nup != 1) continue;
      if (nsign[f->index] == 2) nsign[f->index] = normal_sign(f);
      if (nsign[f->index] != 0) v->bound[k].sense = (int8_t)nsign[f->index], known[k] = 1;
    }
    /* Edge uses within this volume's faces: (face position, direction), for curves used once
     * per face by exactly two faces. */
    for (int32_t c = 0; c < nc; ++c) uses[c] = 0;
    for (int32_t k = 0; k < v->nbound; ++k) {
      const pm_cell *f = &m->cells[PM_FACE][v->bound[k].cell];
      for (int32_t q = 0; q < f->nbound; ++q) {
        int32_t c = f->bound[q].cell;
        int twice = 0;
        for (int32_t r = 0; r < f->nbound; ++r) twice |= r != q && f->bound[r].cell == c;
        if (twice || m->cells[PM_CURVE][c].degenerate) continue;
        if (uses[c] == 0) first[c] = k, dfirst[c] = f->bound[q].sense;
        if (uses[c] == 1) second[c] = k, dsecond[c] = f->bound[q].sense;
        uses[c]++;
      }
    }
    /* Propagate s_a d_a = -s_b d_b until nothing changes. */
    for (int changed = 1; changed;) {
      changed = 0;
      for (int32_t c = 0; c < nc; ++c) {
        if (uses[c] != 2) continue;
        int32_t a = first[c], b = second[c];
        if (a == b || known[a] == known[b]) continue;
        if (known[a])
          v->bound[b].sense = (int8_t)(-v->bound[a].sense * dfirst[c] * dsecond[c]), known[b] = 1;
        else
          v->bound[a].sense = (int8_t)(-v->bound[b].sense * dfirst[c] * dsecond[c]), known[a] = 1;
        changed = 1;
      }
    }
    /* Left over (a volume made only of shared faces): gmsh's normal is taken as outward for the
     * first volume the face bounds and inward for the other. */
    for (int32_t k = 0; k < v->nbound; ++k) {
      if (known[k]) continue;
      const pm_cell *f = &m->cells[PM_FACE][v->bound[k].cell];
      if (nsign[f->index] == 2) nsign[f->index] = normal_sign(f);
      int s = nsign[f->index] ? nsign[f->index] : 1;
      v->bound[k].sense = (int8_t)((f->nup > 0 && f->up[0] != vi) ? -s : s);
    }
    free(known);
  }
  free(nsign), free(first), free(second), free(dfirst), free(dsecond), free(uses);
  return PM_OK;
}

/* ---- the model --------------------------------------------------------------------------- */

/* Release what temporary cells own (before they are moved into the model). */
static void free_cells(pm_cell *c, int32_t n) {
  for (int32_t i = 0; c && i < n; ++i) {
    for (int32_t l = 0; l < c[i].nloop; ++l) free(c[i].loop[l].use);
    free(c[i].loop), free(c[i].bound), free(c[i].embed);
  }
  free(c);
}

/* Move temporary cells into the model's (which pm_model_alloc set up: dim, index, model). */
static void move_cells(pm_model *m, int d, int32_t at, pm_cell *src, const cad_cell *src_cc,
                       int32_t n) {
  cad_model *cm = m->impl;
  for (int32_t i = 0; i < n; ++i) {
    pm_cell *c = &m->cells[d][at + i];
    const pm_model *owner = c->model;
    const int32_t idx = c->index;
    *c = src[i];
    c->dim = d, c->index = idx, c->model = owner;
    cm->cells[d][at + i] = src_cc[i];
    cm->cells[d][at + i].cm = cm;
    c->impl = &cm->cells[d][at + i];
    memset(&src[i], 0, sizeof src[i]); /* ownership moved */
  }
}

/* The model is built in two phases: curves and faces first into temporary cells (a face's loops
 * may need degenerate curves the file lacks, which changes the number of curves), then the
 * model is allocated and the cells moved in. */
pm_status cad_build(const char *gname, const char *label, pm_model **out, pm_error *err) {
  *out = NULL;
  tag_list tl[4] = {{0, NULL}, {0, NULL}, {0, NULL}, {0, NULL}};
  pm_model *m = NULL;
  double *vxyz = NULL;
  pm_cell *tc = NULL, *tf = NULL;
  cad_cell *tcc = NULL, *tfc = NULL;
  face_ctx fc = {0};
  pm_status s = PM_OK;
  int ierr = 0;
  for (int d = 0; d < 4 && !s; ++d) s = list_entities(d, &tl[d], err);
  if (s) goto done;
  const int32_t nv = tl[0].n, nc = tl[1].n, nf = tl[2].n;

  /* The model's size for the relative tolerances (gmsh pads the box by OCC's tolerance). */
  double box[6];
  gmshModelGetBoundingBox(-1, -1, &box[0], &box[1], &box[2], &box[3], &box[4], &box[5], &ierr);
  double diag = ierr ? 0 : pm_v3_dist(box, box + 3);
  if (!(diag > 0) || !isfinite(diag)) diag = 1;

  vxyz = malloc(sizeof(double) * 3 * (size_t)(nv ? nv : 1));
  tc = calloc((size_t)(nc ? nc : 1), sizeof(pm_cell));
  tcc = calloc((size_t)(nc ? nc : 1), sizeof(cad_cell));
  tf = calloc((size_t)(nf ? nf : 1), sizeof(pm_cell));
  tfc = calloc((size_t)(nf ? nf : 1), sizeof(cad_cell));
  if (!vxyz || !tc || !tcc || !tf || !tfc) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int32_t i = 0; i < nv; ++i) {
    double *x = NULL;
    size_t nx = 0;
    ierr = 0;
    gmshModelGetValue(0, tl[0].tag[i], NULL, 0, &x, &nx, &ierr);
    if (ierr || nx != 3 || !isfinite(x[0]) || !isfinite(x[1]) || !isfinite(x[2])) {
      if (x) gmshFree(x);
      s = pm_error_setf(err, PM_ERR_GEOM, "point %d cannot be evaluated", tl[0].tag[i]);
      goto done;
    }
    pm_v3_copy(vxyz + 3 * i, x);
    gmshFree(x);
  }
  for (int32_t i = 0; i < nc && !s; ++i) {
    tc[i].dim = PM_CURVE, tc[i].index = i, tc[i].impl = &tcc[i];
    s = build_curve(&tc[i], tl[1].tag[i], tl, vxyz, diag, err);
    if (s) pm_error_prefix(err, "curve %d", tl[1].tag[i]);
  }
  fc.tl = tl, fc.diag = diag, fc.curves = tc, fc.nc = nc;
  for (int32_t i = 0; i < nf && !s; ++i) {
    tf[i].dim = PM_FACE, tf[i].index = i, tf[i].impl = &tfc[i];
    s = build_face(&fc, i, &tf[i], tl[2].tag[i], err);
    if (s) pm_error_prefix(err, "surface %d", tl[2].tag[i]);
  }
  if (s) goto done;

  int32_t count[4] = {nv, nc + fc.nsyn, nf, tl[3].n};
  if ((s = pm_model_alloc(count, &m, err)) || (s = cad_attach(m, gname, err))) goto done;
  snprintf(m->name, sizeof m->name, "%s", label);
  /* OpenCASCADE's confusion tolerance is 1e-7 model units; never below 1e-9 of the model. */
  m->tol = fmax(1e-7, 1e-9 * diag);
  cad_model *cm = m->impl;
  for (int32_t i = 0; i < nv; ++i) {
    pm_cell *c = &m->cells[PM_VERTEX][i];
    c->tag = tl[0].tag[i];
    c->cls = cad_class(PM_VERTEX, "point");
    pm_v3_copy(c->xyz, vxyz + 3 * i);
    pm_v3_copy(cm->cells[PM_VERTEX][i].fallback, c->xyz);
  }
  move_cells(m, PM_CURVE, 0, tc, tcc, nc);
  int maxtag = nc ? tl[1].tag[nc - 1] : 0;
  for (int32_t k = 0; k < fc.nsyn; ++k) {
    pm_cell *c = &m->cells[PM_CURVE][nc + k];
    cad_cell *cc = c->impl;
    const synth *y = &fc.syn[k];
    /* Not a gmsh curve: a tag above gmsh's, for output files and messages. */
    c->tag = maxtag + 1 + k;
    c->lo[0] = 0, c->hi[0] = 1;
    c->degenerate = 1;
    c->bound = malloc(sizeof(pm_use) * 2);
    if (!c->bound) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto done;
    }
    c->nbound = 2;
    c->bound[0] = (pm_use){y->vertex, -1, 0};
    c->bound[1] = (pm_use){y->vertex, +1, 0};
    c->cls = cad_class(PM_CURVE, "degenerate");
    cc->form.kind = CAD_POINT;
    pm_v3_copy(cc->form.o, vxyz + 3 * y->vertex);
    pm_v3_copy(cc->fallback, cc->form.o);
    cc->synthetic = 1;
    cc->synth_face = y->face;
    cc->synth_uv[0] = y->a[0], cc->synth_uv[1] = y->a[1];
    cc->synth_uv[2] = y->b[0], cc->synth_uv[3] = y->b[1];
  }
  move_cells(m, PM_FACE, 0, tf, tfc, nf);
  for (int32_t i = 0; i < count[PM_VOLUME] && !s; ++i) {
    s = build_volume(&m->cells[PM_VOLUME][i], tl[3].tag[i], tl, err);
    if (s) pm_error_prefix(err, "volume %d", tl[3].tag[i]);
  }
  if (!s) s = embed_by_adjacency(m, tl, err);
  if (!s) s = cad_build_grids(m, err);
  if (!s) s = cad_check_pcurves(m, PM_FEATURE_FLOOR * diag, err);
  if (!s) s = pm_model_finish(m, err);
  if (!s) s = orient_volumes(m, err);
done:
  for (int d = 0; d < 4; ++d) free(tl[d].tag);
  free(vxyz);
  free_cells(tc, tl[1].n);
  free_cells(tf, tl[2].n);
  free(tcc), free(tfc), free(fc.syn);
  if (s) {
    if (m) {
      pm_model_destroy(m); /* removes the gmsh model (cad_attach) */
    } else {
      /* Failed before the model existed: the gmsh model is still the current one. */
      int rerr = 0;
      gmshModelRemove(&rerr);
    }
    return s;
  }
  *out = m;
  return PM_OK;
}
