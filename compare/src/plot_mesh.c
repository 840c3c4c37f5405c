/* Pictures of the meshes of a study: plots/mesh_CASE_LABEL.png and .svg for the first successful
 * run of each case and method, and plots/mesh_CASE_LABEL_worst.png and .svg, a zoom on that
 * mesh's worst element.
 *
 * So that methods are seen side by side, every picture of a case has the same camera and frame:
 * planar cases are drawn flat (x right, y up); surfaces and volumes from one fixed direction
 * (azimuth -60, elevation 30 degrees), Lambert-shaded from a light near the eye, their surface
 * triangles with edges where they are large enough to see. Triangles are coloured by R/l_min
 * (papers/001 Fig. 11's measure) on one log scale for the whole study, from the equilateral
 * 0.577 to the largest 99th percentile of the pictured meshes, so that one colour means one
 * value in every picture. The zoom is centred on the worst triangle (seen face-on, with the
 * triangles around it) or, for a volume mesh, on the worst tet (shaded, with the edges of the
 * tets that share a node with it).
 *
 * Drawn by raster.c (PNG) and as SVG polygons in depth order; no graphics library or helper
 * program is needed. The time they take is kept in figs->picture_s for the report.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/base/atomic_file.h"
#include "common/base/clock.h"
#include "common/base/summary.h"
#include "common/base/vec3.h"
#include "compare/src/raster.h"
#include "compare/src/study.h"

#define IDEAL_ASPECT 0.57735026918962573 /* R/l_min of the equilateral triangle */
#define MAIN_W 640                       /* the mesh's part of a picture, in pixels */
#define WORST_W 360
#define MARGIN 14
#define BAR_W 78 /* the colour bar and its numbers, right of the mesh */

/* A view: an orthographic camera (right, up, towards the eye) and the map to pixels. */
typedef struct view {
  double r[3], u[3], f[3];
  double x0, y1, scale; /* pixel = ((p.r - x0) scale + MARGIN, (y1 - p.u) scale + MARGIN) */
  int w, h;             /* the whole picture */
  int flat;             /* planar: no shading */
  double depth_tol;     /* an edge this far behind the surface is still drawn */
} view;

static void project(const view *v, const double p[3], double *x, double *y, double *z) {
  *x = (pm_v3_dot(p, v->r) - v->x0) * v->scale + MARGIN;
  *y = (v->y1 - pm_v3_dot(p, v->u)) * v->scale + MARGIN;
  *z = pm_v3_dot(p, v->f);
}

/* A camera looking along -f, with `up` kept as upright as it can be. */
static void camera(view *v, const double f[3], const double up[3]) {
  pm_v3_copy(v->f, f);
  pm_v3_normalize(v->f);
  pm_v3_cross(v->r, up, v->f);
  if (pm_v3_normalize(v->r) < 1e-9) { /* looking along up: take another */
    double other[3] = {0, 1, 0};
    pm_v3_cross(v->r, other, v->f);
    pm_v3_normalize(v->r);
  }
  pm_v3_cross(v->u, v->f, v->r);
}

/* Frame the box [x0, x1] x [y0, y1] (camera coordinates) in a picture whose mesh part is
 * `width` pixels wide (its height follows the box, within [width / 3, 1.25 width]). */
static void frame(view *v, double x0, double x1, double y0, double y1, int width, int bar) {
  double bw = fmax(x1 - x0, 1e-300), bh = fmax(y1 - y0, 1e-300);
  int h = (int)lround(width * bh / bw);
  if (h < width / 3) h = width / 3;
  if (h > width * 5 / 4) h = width * 5 / 4;
  v->scale = fmin(width / bw, h / bh);
  /* Centre the box in the frame. */
  v->x0 = 0.5 * (x0 + x1) - 0.5 * width / v->scale;
  v->y1 = 0.5 * (y0 + y1) + 0.5 * h / v->scale;
  v->w = width + 2 * MARGIN + (bar ? BAR_W : 0);
  v->h = h + 2 * MARGIN;
}

/* The colour scale's position of an R/l_min value. */
static double scale_t(double aspect, double top) {
  return log(fmax(aspect, IDEAL_ASPECT) / IDEAL_ASPECT) / log(top / IDEAL_ASPECT);
}

static void shade(const view *v, const double n[3], float rgb[3]) {
  if (v->flat) return;
  /* A light above and right of the eye; both sides lit (an inner face seen through a gap). */
  double l[3];
  for (int k = 0; k < 3; ++k) l[k] = v->f[k] + 0.5 * v->u[k] + 0.3 * v->r[k];
  pm_v3_normalize(l);
  double len = pm_v3_norm(n);
  double c = len > 0 ? fabs(pm_v3_dot(n, l)) / len : 1;
  float k = (float)(0.45 + 0.55 * c);
  for (int i = 0; i < 3; ++i) rgb[i] *= k;
}

static void hex(const float rgb[3], char out[8]) {
  int c[3];
  for (int k = 0; k < 3; ++k) c[k] = (int)lrintf(255.0f * (rgb[k] < 0 ? 0 : rgb[k] > 1 ? 1 : rgb[k]));
  snprintf(out, 8, "#%02x%02x%02x", c[0], c[1], c[2]);
}

/* ---- what is drawn: a list of flat polygons and lines, shared by the PNG and the SVG ---------- */

typedef struct poly {
  double x[3], y[3], z[3];
  float rgb[3];
  double depth; /* for the SVG's painter's order */
} poly;

typedef struct line {
  double x[2], y[2], z[2];
  float rgb[3], alpha;
  double width;
} line;

typedef struct scene {
  poly *p;
  size_t np, capp;
  line *l;
  size_t nl, capl;
  int bad;
} scene;

/* Room for one more item in *arr (n items of `size` bytes, cap allocated); 0 when out of
 * memory (the scene is then marked bad). */
static int room(scene *s, void **arr, size_t n, size_t *cap, size_t size) {
  if (n < *cap) return 1;
  size_t c = *cap ? 2 * *cap : 1024;
  void *p = realloc(*arr, c * size);
  if (!p) {
    s->bad = 1;
    return 0;
  }
  *arr = p, *cap = c;
  return 1;
}

static void add_poly(scene *s, const view *v, const double *a, const double *b, const double *c,
                     const float rgb[3]) {
  if (!room(s, (void **)&s->p, s->np, &s->capp, sizeof *s->p)) return;
  poly *q = &s->p[s->np++];
  const double *pt[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) project(v, pt[k], &q->x[k], &q->y[k], &q->z[k]);
  memcpy(q->rgb, rgb, sizeof q->rgb);
  q->depth = (q->z[0] + q->z[1] + q->z[2]) / 3;
}

static void add_line(scene *s, const view *v, const double *a, const double *b, const float rgb[3],
                     float alpha, double width) {
  if (!room(s, (void **)&s->l, s->nl, &s->capl, sizeof *s->l)) return;
  line *q = &s->l[s->nl++];
  project(v, a, &q->x[0], &q->y[0], &q->z[0]);
  project(v, b, &q->x[1], &q->y[1], &q->z[1]);
  memcpy(q->rgb, rgb, sizeof q->rgb);
  q->alpha = alpha, q->width = width;
}

static int by_depth(const void *a, const void *b) {
  double x = ((const poly *)a)->depth, y = ((const poly *)b)->depth;
  return (x > y) - (x < y);
}

/* The colour bar's numbers: the ideal value, round values in between, the top. */
static int bar_ticks(double top, int height, double *tick) {
  static const double round_values[] = {0.6, 0.7, 0.8, 1, 1.2, 1.5, 2, 3, 5, 10, 20, 50, 100, 1e3};
  int n = 0;
  tick[n++] = IDEAL_ASPECT;
  double last = 0; /* pixels from the bottom */
  for (size_t k = 0; k < sizeof round_values / sizeof round_values[0]; ++k) {
    double t = scale_t(round_values[k], top), px = t * height;
    if (round_values[k] <= IDEAL_ASPECT || t >= 1 || px - last < 16 || (1 - t) * height < 16)
      continue;
    tick[n++] = round_values[k];
    last = px;
  }
  tick[n++] = top;
  return n;
}

static void tick_text(double v, char *out, size_t len) {
  snprintf(out, len, v == IDEAL_ASPECT ? "%.3f" : "%.3g", v);
}

/* Both files of a picture, atomically. */
static pm_status render(const pm_cmp_study *st, pm_raster *canvas, const view *v, scene *s,
                        int bar, double top, const char *title, const char *label,
                        const char *name, pm_error *err) {
  if (s->bad) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_raster *r = canvas;
  pm_status rs = pm_raster_init(r, v->w, v->h, err);
  if (rs) return rs;
  for (size_t i = 0; i < s->np; ++i) pm_raster_triangle(r, s->p[i].x, s->p[i].y, s->p[i].z, s->p[i].rgb);
  for (size_t i = 0; i < s->nl; ++i) {
    const line *l = &s->l[i];
    pm_raster_line(r, l->x[0], l->y[0], l->z[0], l->x[1], l->y[1], l->z[1], l->width, l->rgb,
                   l->alpha, v->depth_tol);
  }
  const float black[3] = {0.1f, 0.1f, 0.1f};
  double tick[20];
  int nt = 0, bx = v->w - BAR_W + 8, by0 = MARGIN + 4, by1 = v->h - MARGIN - 4;
  if (bar) {
    for (int y = by0; y < by1; ++y) {
      float c[3];
      pm_raster_colour((double)(by1 - y) / (by1 - by0), c);
      pm_raster_rect(r, bx, y, bx + 16, y + 1, c);
    }
    nt = bar_ticks(top, by1 - by0, tick);
    for (int k = 0; k < nt; ++k) {
      double y = by1 - scale_t(tick[k], top) * (by1 - by0);
      char t[32];
      tick_text(tick[k], t, sizeof t);
      pm_raster_rect(r, bx + 16, y - 0.5, bx + 21, y + 0.5, black);
      pm_raster_text(r, bx + 24, y - 3.5, 1, t, black);
    }
  }
  if (label) pm_raster_text(r, MARGIN, 4, 1.4, label, black);
  unsigned char *rgb = pm_raster_rgb8(r), *png = NULL;
  size_t png_n = 0;
  if (!rgb) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  rs = pm_cmp_png_encode(rgb, v->w, v->h, &png, &png_n, err);
  free(rgb);
  char path[4400];
  if (!rs) {
    snprintf(path, sizeof path, "%s/plots/%s.png", st->dir, name);
    rs = pm_atomic_write(path, png, png_n, err);
  }
  free(png);
  if (rs) return rs;

  /* The SVG: far polygons first. */
  qsort(s->p, s->np, sizeof *s->p, by_depth);
  sbuf g = {0};
  SB(&g, "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
         "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" viewBox=\"0 0 %d %d\">\n"
         "<title>",
     v->w, v->h, v->w, v->h);
  for (const char *c = title; *c; ++c) {
    if (*c == '<' || *c == '>' || *c == '&')
      SB(&g, "%s", *c == '<' ? "&lt;" : *c == '>' ? "&gt;" : "&amp;");
    else
      SB(&g, "%c", *c);
  }
  SB(&g, "</title>\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
         "<g stroke-linejoin=\"round\">\n");
  for (size_t i = 0; i < s->np; ++i) {
    char c[8];
    hex(s->p[i].rgb, c);
    /* The fill's own colour as a hairline stroke closes the seams between polygons. */
    SB(&g, "<polygon points=\"%.1f,%.1f %.1f,%.1f %.1f,%.1f\" fill=\"%s\" stroke=\"%s\" "
           "stroke-width=\"0.3\"/>\n",
       s->p[i].x[0], s->p[i].y[0], s->p[i].x[1], s->p[i].y[1], s->p[i].x[2], s->p[i].y[2], c, c);
  }
  SB(&g, "</g>\n<g fill=\"none\" stroke-linecap=\"round\">\n");
  for (size_t i = 0; i < s->nl; ++i) {
    const line *l = &s->l[i];
    char c[8];
    hex(l->rgb, c);
    SB(&g, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" "
           "stroke-opacity=\"%.2f\" stroke-width=\"%.2f\"/>\n",
       l->x[0], l->y[0], l->x[1], l->y[1], c, l->alpha, l->width);
  }
  SB(&g, "</g>\n");
  if (bar) {
    int nslice = 48;
    for (int k = 0; k < nslice; ++k) {
      float c[3];
      char hx[8];
      pm_raster_colour((k + 0.5) / nslice, c);
      hex(c, hx);
      double y = by1 - (k + 1.0) / nslice * (by1 - by0);
      SB(&g, "<rect x=\"%d\" y=\"%.2f\" width=\"16\" height=\"%.2f\" fill=\"%s\"/>\n", bx, y,
         (double)(by1 - by0) / nslice + 0.3, hx);
    }
    for (int k = 0; k < nt; ++k) {
      double y = by1 - scale_t(tick[k], top) * (by1 - by0);
      char t[32];
      tick_text(tick[k], t, sizeof t);
      SB(&g, "<line x1=\"%d\" y1=\"%.1f\" x2=\"%d\" y2=\"%.1f\" stroke=\"#1a1a1a\"/>"
             "<text x=\"%d\" y=\"%.1f\" font-family=\"Helvetica,Arial,sans-serif\" "
             "font-size=\"11\">%s</text>\n",
         bx + 16, y, bx + 21, y, bx + 24, y + 4, t);
    }
    SB(&g, "<text x=\"%d\" y=\"%d\" font-family=\"Helvetica,Arial,sans-serif\" font-size=\"11\" "
           "transform=\"rotate(-90 %d %d)\">R/l_min</text>\n",
       v->w - 6, (by0 + by1) / 2, v->w - 6, (by0 + by1) / 2);
  }
  if (label)
    SB(&g, "<text x=\"%d\" y=\"13\" font-family=\"Helvetica,Arial,sans-serif\" "
           "font-size=\"12\">%s</text>\n",
       MARGIN, label);
  SB(&g, "</svg>\n");
  if (g.bad) {
    free(g.s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  snprintf(path, sizeof path, "%s/plots/%s.svg", st->dir, name);
  rs = pm_atomic_write(path, g.s, g.n, err);
  free(g.s);
  return rs;
}

/* ---- one mesh --------------------------------------------------------------------------------- */

typedef struct loaded {
  pm_mesh *m;
  pm_element_values v;
} loaded;

static pm_status load(const pm_cmp_study *st, const pm_cmp_row *r, loaded *L, pm_error *err) {
  return pm_cmp_row_mesh(st, r, &L->m, &L->v, err);
}

static void unload(loaded *L) {
  pm_element_values_clear(&L->v);
  pm_mesh_destroy(L->m);
  memset(L, 0, sizeof *L);
}

/* Index of the element with the largest R/l_min (first of equals); -1 when there is none. */
static int32_t worst_of(const double *aspect, int32_t n) {
  int32_t w = -1;
  for (int32_t i = 0; i < n; ++i)
    if (w < 0 || aspect[i] > aspect[w]) w = i;
  return w;
}

static void tri_normal(const pm_mesh *m, int32_t t, double n[3]) {
  const double *a = m->xyz + 3 * m->tri[3 * t], *b = m->xyz + 3 * m->tri[3 * t + 1],
               *c = m->xyz + 3 * m->tri[3 * t + 2];
  double e1[3], e2[3];
  pm_v3_sub(e1, b, a);
  pm_v3_sub(e2, c, a);
  pm_v3_cross(n, e1, e2);
}

static void tri_colour(const view *v, const loaded *L, int32_t t, double top, float rgb[3]) {
  pm_raster_colour(scale_t(L->v.tri[1][t], top), rgb);
  double n[3];
  tri_normal(L->m, t, n);
  shade(v, n, rgb);
}

static int cmp_i64(const void *a, const void *b) {
  int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
  return (x > y) - (x < y);
}

/* The triangles (those with keep[t], or all when keep is NULL) and their edges, each edge once,
 * faint when the triangles are small on screen. */
static void add_triangles(scene *s, const view *v, const loaded *L, const unsigned char *keep,
                          double top) {
  const pm_mesh *m = L->m;
  int64_t *e = malloc((size_t)m->ntri * 3 * sizeof *e + 1);
  if (!e) {
    s->bad = 1;
    return;
  }
  size_t ne = 0;
  double len_px = 0;
  for (int32_t t = 0; t < m->ntri; ++t) {
    if (keep && !keep[t]) continue;
    const int32_t *q = m->tri + 3 * t;
    float rgb[3];
    tri_colour(v, L, t, top, rgb);
    add_poly(s, v, m->xyz + 3 * q[0], m->xyz + 3 * q[1], m->xyz + 3 * q[2], rgb);
    for (int k = 0; k < 3; ++k) {
      int32_t a = q[k], b = q[(k + 1) % 3];
      if (a > b) a = q[(k + 1) % 3], b = q[k];
      e[ne++] = (int64_t)a * m->nnode + b;
      len_px += pm_v3_dist(m->xyz + 3 * a, m->xyz + 3 * b) * v->scale;
    }
  }
  if (!ne) {
    free(e);
    return;
  }
  len_px /= (double)ne;
  /* Edges of a few pixels would turn the picture grey: fade them out below 8 pixels. */
  float alpha = (float)fmin(0.75, fmax(0.0, (len_px - 2) / 8));
  if (alpha > 0.05) {
    qsort(e, ne, sizeof *e, cmp_i64);
    const float dark[3] = {0.12f, 0.12f, 0.12f};
    for (size_t i = 0; i < ne; ++i) {
      if (i && e[i] == e[i - 1]) continue;
      int32_t a = (int32_t)(e[i] / m->nnode), b = (int32_t)(e[i] % m->nnode);
      add_line(s, v, m->xyz + 3 * a, m->xyz + 3 * b, dark, alpha, len_px > 30 ? 1.0 : 0.6);
    }
  }
  free(e);
}

/* The zoom on the worst element: the worst triangle face-on among the triangles near it, or the
 * worst tet with the edges of the tets sharing a node with it. */
static pm_status worst_picture(const pm_cmp_study *st, pm_raster *canvas, const view *whole,
                               const loaded *L, double top, const char *name, const char *title,
                               double *value, pm_error *err) {
  const pm_mesh *m = L->m;
  int tets = m->ntet > 0;
  int32_t w = tets ? worst_of(L->v.tet[1], m->ntet) : worst_of(L->v.tri[1], m->ntri);
  if (w < 0) return pm_error_setf(err, PM_ERR_ARG, "the mesh has no %s", tets ? "tet" : "triangle");
  int nv = tets ? 4 : 3;
  const int32_t *el = tets ? m->tet + 4 * w : m->tri + 3 * w;
  *value = tets ? L->v.tet[1][w] : L->v.tri[1][w];
  double c[3] = {0, 0, 0}, lmax = 0;
  for (int k = 0; k < nv; ++k) pm_v3_axpy(c, c, 1.0 / nv, m->xyz + 3 * el[k]);
  for (int a = 0; a < nv; ++a)
    for (int b = a + 1; b < nv; ++b)
      lmax = fmax(lmax, pm_v3_dist(m->xyz + 3 * el[a], m->xyz + 3 * el[b]));
  if (!(lmax > 0)) lmax = 1e-9;
  /* A tet is framed close (its neighbours are wires around it); a triangle with room for the
   * triangles around it. */
  double radius = (tets ? 1.2 : 2.5) * lmax;
  view v = *whole;
  if (!tets && !whole->flat) {
    double n[3], up[3] = {0, 0, 1};
    tri_normal(m, w, n);
    if (pm_v3_normalize(n) > 0) camera(&v, n, up);
  }
  frame(&v, pm_v3_dot(c, v.r) - radius, pm_v3_dot(c, v.r) + radius, pm_v3_dot(c, v.u) - radius,
        pm_v3_dot(c, v.u) + radius, WORST_W, 0);
  scene s = {0};
  const float black[3] = {0, 0, 0}, grey[3] = {0.35f, 0.35f, 0.35f};
  if (!tets) {
    /* The triangles within 2 radii, so that a fold of the surface behind stays out. */
    unsigned char *keep = calloc((size_t)m->ntri + 1, 1);
    if (!keep) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t t = 0; t < m->ntri; ++t)
      for (int k = 0; k < 3 && !keep[t]; ++k)
        keep[t] = pm_v3_dist(m->xyz + 3 * m->tri[3 * t + k], c) < 2 * radius;
    add_triangles(&s, &v, L, keep, top);
    free(keep);
  } else {
    float rgb[3];
    pm_raster_colour(scale_t(*value, top), rgb);
    static const int face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    for (int f = 0; f < 4; ++f) {
      double e1[3], e2[3], n[3];
      const double *a = m->xyz + 3 * el[face[f][0]], *b = m->xyz + 3 * el[face[f][1]],
                   *cc = m->xyz + 3 * el[face[f][2]];
      pm_v3_sub(e1, b, a);
      pm_v3_sub(e2, cc, a);
      pm_v3_cross(n, e1, e2);
      float col[3] = {rgb[0], rgb[1], rgb[2]};
      shade(&v, n, col);
      add_poly(&s, &v, a, b, cc, col);
    }
    for (int32_t t = 0; t < m->ntet; ++t) {
      const int32_t *q = m->tet + 4 * t;
      int shares = 0;
      for (int a = 0; a < 4 && !shares; ++a)
        for (int b = 0; b < 4; ++b) shares |= q[a] == el[b];
      if (!shares || t == w) continue;
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
          add_line(&s, &v, m->xyz + 3 * q[a], m->xyz + 3 * q[b], grey, 0.5f, 0.8);
    }
  }
  /* The worst element's outline over everything. */
  for (int a = 0; a < nv; ++a)
    for (int b = a + 1; b < nv; ++b)
      if (tets || b == a + 1 || (a == 0 && b == 2))
        add_line(&s, &v, m->xyz + 3 * el[a], m->xyz + 3 * el[b], black, 1.0f, 2.2);
  /* The outline and the tets' edges show through: a zoom is read as a wireframe around its
   * element. */
  v.depth_tol = INFINITY;
  char label[48];
  snprintf(label, sizeof label, "%.4g", *value);
  pm_status rs = render(st, canvas, &v, &s, 0, top, title, label, name, err);
  free(s.p);
  free(s.l);
  return rs;
}

/* ---- the study --------------------------------------------------------------------------------- */

static void file_stem(char *out, size_t len, const char *a, const char *b, const char *tail) {
  snprintf(out, len, "mesh_%s_%s%s", a, b, tail);
  for (char *p = out; *p; ++p)
    if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') ||
          *p == '_' || *p == '-'))
      *p = '_';
}

static pm_cmp_picture *add_picture(pm_cmp_figures *F) {
  pm_cmp_picture *p = realloc(F->pic, (size_t)(F->npic + 1) * sizeof *p);
  if (!p) return NULL;
  F->pic = p;
  p = &F->pic[F->npic++];
  memset(p, 0, sizeof *p);
  return p;
}

pm_status pm_cmp_mesh_pictures(const pm_cmp_study *st, pm_cmp_figures *figs, pm_error *err) {
  const double t0 = pm_seconds();
  const clock_t c0 = clock();
  const pm_cmp_suite *su = &st->suite;
  pm_status s = PM_OK;
  /* First pass: the colour scale's top, the largest 99th percentile of R/l_min over the meshes
   * pictured (triangles; and tets, whose worst is pictured too), at least 1. */
  double top = 1;
  for (int c = 0; c < su->ncase && !s; ++c)
    for (int m = 0; m < su->nmethod && !s; ++m) {
      int i = pm_cmp_first_ok_row(st, c, m);
      loaded L;
      if (i < 0 || load(st, &st->rows[i], &L, NULL)) continue;
      for (int tet = 0; tet < 2 && !s; ++tet) {
        int32_t n = tet ? L.m->ntet : L.m->ntri;
        if (!n) continue;
        double *v = malloc((size_t)n * sizeof *v);
        if (!v) {
          s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
          break;
        }
        memcpy(v, tet ? L.v.tet[1] : L.v.tri[1], (size_t)n * sizeof *v);
        if (!(s = pm_sort_doubles(v, (size_t)n, err))) {
          double p99 = pm_percentile_sorted(v, (size_t)n, 0.99);
          if (isfinite(p99) && p99 < 1e6 && p99 > top) top = p99;
        }
        free(v);
      }
      unload(&L);
    }
  /* Two significant digits, rounded up. */
  double mag = pow(10, floor(log10(top)) - 1);
  top = ceil(top / mag - 1e-9) * mag;
  figs->colour_max = top;
  pm_raster canvas = {0}; /* one canvas for every picture (raster.h) */

  for (int c = 0; c < su->ncase && !s; ++c) {
    /* The case's camera, and the frame around all its meshes. */
    loaded *L = calloc((size_t)su->nmethod, sizeof *L);
    int *row = malloc((size_t)su->nmethod * sizeof *row);
    if (!L || !row) {
      free(L), free(row);
      pm_raster_clear(&canvas);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int m = 0; m < su->nmethod; ++m) {
      row[m] = pm_cmp_first_ok_row(st, c, m);
      if (row[m] < 0) continue;
      pm_error e = {0};
      pm_cmp_picture *p = add_picture(figs);
      if (!p) {
        s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        break;
      }
      p->icase = c, p->imethod = m, p->row = row[m];
      file_stem(p->name, sizeof p->name, su->cases[c].name, su->methods[m].label, "");
      if (load(st, &st->rows[row[m]], &L[m], &e)) {
        snprintf(p->error, sizeof p->error, "%s", e.msg);
        row[m] = -1;
        continue;
      }
      for (int32_t k = 0; k < L[m].m->nnode; ++k)
        for (int d = 0; d < 3; ++d) {
          lo[d] = fmin(lo[d], L[m].m->xyz[3 * k + d]);
          hi[d] = fmax(hi[d], L[m].m->xyz[3 * k + d]);
        }
    }
    view v;
    memset(&v, 0, sizeof v);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    v.flat = isfinite(diag) && hi[2] - lo[2] <= 1e-9 * diag;
    const double az = -60 * M_PI / 180, el = 30 * M_PI / 180;
    double f[3] = {cos(el) * cos(az), cos(el) * sin(az), sin(el)}, up[3] = {0, 0, 1};
    if (v.flat) f[0] = 0, f[1] = 0, f[2] = 1, up[0] = 0, up[1] = 1, up[2] = 0;
    camera(&v, f, up);
    /* The frame: the box's corners seen by the camera. */
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < 8 && isfinite(diag); ++k) {
      double p[3] = {k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]};
      x0 = fmin(x0, pm_v3_dot(p, v.r)), x1 = fmax(x1, pm_v3_dot(p, v.r));
      y0 = fmin(y0, pm_v3_dot(p, v.u)), y1 = fmax(y1, pm_v3_dot(p, v.u));
    }
    if (isfinite(diag)) {
      frame(&v, x0, x1, y0, y1, MAIN_W, 1);
      v.depth_tol = 2e-3 * diag;
    }
    int first = figs->npic;
    for (int m = 0; m < su->nmethod && !s; ++m) {
      if (row[m] < 0) continue;
      pm_cmp_picture *p = NULL;
      for (int k = first - 1; k >= 0; --k)
        if (figs->pic[k].icase == c && figs->pic[k].imethod == m && !figs->pic[k].worst)
          p = &figs->pic[k];
      if (!p) continue;
      const pm_cmp_row *r = &st->rows[row[m]];
      char title[400];
      snprintf(title, sizeof title, "%s, %s (run %s): %d nodes, %d triangles%s", su->cases[c].name,
               su->methods[m].label, r->id, (int)L[m].m->nnode, (int)L[m].m->ntri,
               L[m].m->ntet ? " on the surface" : "");
      scene sc = {0};
      add_triangles(&sc, &v, &L[m], NULL, top);
      pm_error e = {0};
      if (render(st, &canvas, &v, &sc, 1, top, title, NULL, p->name, &e)) {
        if (e.code == PM_ERR_IO) s = pm_error_setf(err, e.code, "%s", e.msg);
        snprintf(p->error, sizeof p->error, "%s", e.msg);
      } else {
        p->drawn = 1;
      }
      free(sc.p);
      free(sc.l);
      char tets[48] = "";
      if (L[m].m->ntet) snprintf(tets, sizeof tets, " on the surface, %d tets", (int)L[m].m->ntet);
      snprintf(p->caption, sizeof p->caption, "%s: %s, %d nodes, %d triangles%s (run %s).",
               su->methods[m].label, su->cases[c].name, (int)L[m].m->nnode, (int)L[m].m->ntri,
               tets, r->id);
      /* Its zoom. */
      pm_cmp_picture *z = add_picture(figs);
      if (!z) {
        s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        break;
      }
      z->icase = c, z->imethod = m, z->row = row[m], z->worst = 1;
      file_stem(z->name, sizeof z->name, su->cases[c].name, su->methods[m].label, "_worst");
      snprintf(title, sizeof title, "%s, %s: the worst %s", su->cases[c].name,
               su->methods[m].label, L[m].m->ntet ? "tet" : "triangle");
      e = (pm_error){0};
      if (worst_picture(st, &canvas, &v, &L[m], top, z->name, title, &z->worst_value, &e)) {
        if (e.code == PM_ERR_IO) s = pm_error_setf(err, e.code, "%s", e.msg);
        snprintf(z->error, sizeof z->error, "%s", e.msg);
      } else {
        z->drawn = 1;
      }
      snprintf(z->caption, sizeof z->caption, "%s's worst %s: R/l_min %.4g%s.",
               su->methods[m].label, L[m].m->ntet ? "tet" : "triangle", z->worst_value,
               L[m].m->ntet ? " (the edges of the tets around it in grey)"
                            : " (outlined, seen face-on with the triangles around it)");
    }
    for (int m = 0; m < su->nmethod; ++m) unload(&L[m]);
    free(L);
    free(row);
  }
  pm_raster_clear(&canvas);
  figs->picture_s = pm_seconds() - t0;
  figs->picture_cpu_s = (double)(clock() - c0) / CLOCKS_PER_SEC;
  return s;
}
