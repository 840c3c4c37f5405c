/* Snapshots of a particle run (see frames.h). */
#include "common/report/frames.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/base/atomic_file.h"
#include "common/base/summary.h"
#include "common/connect/connect.h"
#include "common/mesh/mesh.h"

/* Snapshots kept in the .pvd index; a run writes at most this many (the method picks the
 * interval), so a frames folder never grows without bound. */
#define FRAMES_MAX 100000

struct pm_frames {
  char *dir;
  const pm_model *model;
  int32_t n;
  int64_t *step; /* [n] */
  int32_t cap;
};

static pm_status make_dirs(const char *dir, pm_error *err) {
  char path[4096];
  if (snprintf(path, sizeof path, "%s", dir) >= (int)sizeof path)
    return pm_error_setf(err, PM_ERR_ARG, "frames folder name too long");
  for (char *p = path + 1; *p; ++p) {
    if (*p != '/') continue;
    *p = '\0';
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
      return pm_error_setf(err, PM_ERR_IO, "cannot create folder '%s': %s", path, strerror(errno));
    *p = '/';
  }
  if (mkdir(path, 0777) != 0 && errno != EEXIST)
    return pm_error_setf(err, PM_ERR_IO, "cannot create folder '%s': %s", path, strerror(errno));
  struct stat st;
  if (stat(path, &st) != 0 || !S_ISDIR(st.st_mode))
    return pm_error_setf(err, PM_ERR_IO, "'%s' is not a folder", path);
  return PM_OK;
}

pm_status pm_frames_create(const char *dir, const pm_model *model, pm_frames **out,
                           pm_error *err) {
  *out = NULL;
  pm_status s = make_dirs(dir, err);
  if (s) return s;
  pm_frames *f = calloc(1, sizeof *f);
  if (!f || !(f->dir = strdup(dir))) {
    free(f);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  f->model = model;
  *out = f;
  return PM_OK;
}

static pm_status write_vtu(const char *path, const pm_run_frame *fr, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  FILE *o = a.f;
  const int32_t n = fr->n;
  const double *xyz = fr->xyz;
  fprintf(o, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" "
             "byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"%d\" "
             "NumberOfCells=\"%d\">\n<Points>\n<DataArray type=\"Float64\" "
             "NumberOfComponents=\"3\" format=\"ascii\">\n",
          (int)n, (int)n);
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%.9g %.9g %.9g\n", xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  fprintf(o, "</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int32\" Name=\"connectivity\" "
             "format=\"ascii\">\n");
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%d\n", (int)i);
  fprintf(o, "</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">\n");
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%d\n", (int)i + 1);
  fprintf(o, "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
  for (int32_t i = 0; i < n; ++i) fputs("1\n", o); /* VTK_VERTEX */
  fprintf(o, "</DataArray>\n</Cells>\n<PointData Scalars=\"radius\">\n<DataArray "
             "type=\"Float64\" Name=\"radius\" format=\"ascii\">\n");
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%.9g\n", fr->radius[i]);
  fprintf(o, "</DataArray>\n<DataArray type=\"Int32\" Name=\"cell_dim\" format=\"ascii\">\n");
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%d\n", (int)fr->dim[i]);
  if (fr->energy) {
    fprintf(o, "</DataArray>\n<DataArray type=\"Float64\" Name=\"energy\" format=\"ascii\">\n");
    for (int32_t i = 0; i < n; ++i) fprintf(o, "%.9g\n", fr->energy[i]);
  }
  fprintf(o, "</DataArray>\n</PointData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
  return pm_atomic_commit(&a, err);
}

/* The triangulation of the snapshot's particles by the connection step every mesh is made with
 * (connect.h), drawn faintly under them: what the mesh would be if the run stopped here. NULL
 * when the particles cannot be connected yet (a face without its boundary chain in an early
 * phase, crossing chains): the picture then shows the particles alone. */
static pm_mesh *triangulate(const pm_model *m, const pm_run_frame *fr) {
  if (!fr->cell || !fr->par) return NULL;
  pm_mesh *mesh = pm_mesh_create();
  if (!mesh) return NULL;
  pm_status s = pm_mesh_reserve(mesh, fr->n, 0, 0, 0, NULL);
  for (int32_t i = 0; i < fr->n && !s; ++i)
    if (fr->dim[i] <= PM_FACE)
      s = pm_mesh_add_node(mesh, &fr->xyz[3 * i], fr->dim[i], fr->cell[i],
                           fr->dim[i] == PM_VERTEX ? NULL : &fr->par[2 * i], NULL, NULL);
  pm_connect_params cp;
  pm_connect_params_init(&cp);
  if (!s) s = pm_connect(m, mesh, &cp, NULL, NULL);
  if (s) {
    pm_mesh_destroy(mesh);
    return NULL;
  }
  return mesh;
}

/* A colour for t in [0, 1] on viridis (five stops, linear between them). */
static void energy_colour(double t, char out[8]) {
  static const double stop[5][3] = {{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98},
                                    {253, 231, 37}};
  t = !(t > 0) ? 0 : t > 1 ? 1 : t;
  int k = t >= 1 ? 3 : (int)(t * 4);
  double f = t * 4 - k;
  int c[3];
  for (int q = 0; q < 3; ++q) c[q] = (int)lround(stop[k][q] + f * (stop[k + 1][q] - stop[k][q]));
  snprintf(out, 8, "#%02x%02x%02x", c[0] & 255, c[1] & 255, c[2] & 255);
}

/* The frame's energy scale: its 5th and 95th percentiles (a few particles far from the rest
 * would flatten the colours of all others). */
static void energy_range(const pm_run_frame *fr, double *lo, double *hi) {
  *lo = 0, *hi = 1;
  double *v = malloc(sizeof(double) * ((size_t)fr->n + 1));
  if (!v) return;
  int32_t k = 0;
  for (int32_t i = 0; i < fr->n; ++i)
    if (isfinite(fr->energy[i])) v[k++] = fr->energy[i];
  if (k > 0 && !pm_sort_doubles(v, (size_t)k, NULL)) {
    *lo = pm_percentile_sorted(v, (size_t)k, 0.05);
    *hi = pm_percentile_sorted(v, (size_t)k, 0.95);
  }
  if (!(*hi > *lo)) *hi = *lo + 1;
  free(v);
}

/* A planar model's snapshot, twice: an SVG picture and the same picture's numbers for gnuplot
 * (`packmesh animate` draws its GIF from them). Under the particles, faintly, their
 * triangulation; the boundary curves in black; each particle a circle of draw_scale x its radius,
 * coloured by its energy (filled, the frame's own 5-95% range) when the method gives one, else
 * outlined in the colour of its cell's dimension; the phase, step and count written below. */
static pm_status write_pictures(const pm_frames *f, const char *svg_path, const char *dat_path,
                                const pm_run_frame *fr, pm_error *err) {
  const pm_model *m = f->model;
  double x0 = m->box[0], y0 = m->box[1], w = m->box[3] - m->box[0], h = m->box[4] - m->box[1];
  double pad = 0.03 * fmax(w, h), scale = 800.0 / fmax(w + 2 * pad, h + 2 * pad);
  pm_mesh *tri = triangulate(m, fr);
  double elo = 0, ehi = 1;
  if (fr->energy) energy_range(fr, &elo, &ehi);
  char title[200];
  snprintf(title, sizeof title, "phase %d (%s): step %lld, %d particles%s", fr->phase,
           fr->phase_name ? fr->phase_name : "", (long long)fr->step, (int)fr->n,
           fr->energy ? ", coloured by energy" : "");
  pm_atomic_file a, b;
  pm_status s = pm_atomic_begin(&a, svg_path, 1, err);
  if (s) {
    pm_mesh_destroy(tri);
    return s;
  }
  if ((s = pm_atomic_begin(&b, dat_path, 1, err))) {
    pm_atomic_abort(&a);
    pm_mesh_destroy(tri);
    return s;
  }
  FILE *o = a.f, *g = b.f;
  fprintf(o, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
             "viewBox=\"0 0 %.0f %.0f\">\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
          (w + 2 * pad) * scale, (h + 2 * pad) * scale + 24, (w + 2 * pad) * scale,
          (h + 2 * pad) * scale + 24);
  fprintf(g, "# title: %s\n# box: %.9g %.9g %.9g %.9g\n# triangles: %d\n# filled: %d\n", title,
          x0 - pad, y0 - pad, x0 + w + pad, y0 + h + pad, tri ? (int)tri->ntri : 0,
          fr->energy != NULL);
  fprintf(g, "# index 0: boundary polylines; 1: triangle edges; 2: particles x y radius rgb\n");
#define SX(x) (((x) - x0 + pad) * scale)
#define SY(y) ((h + pad - ((y) - y0)) * scale)
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = &m->cells[PM_CURVE][c];
    fprintf(o, "<polyline fill=\"none\" stroke=\"black\" stroke-width=\"1.5\" points=\"");
    for (int k = 0; k <= 64; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / 64.0;
      pm_curve_point cp;
      pm_curve_eval(cv, t, 0, &cp);
      fprintf(o, "%.2f,%.2f ", SX(cp.p[0]), SY(cp.p[1]));
      fprintf(g, "%.9g %.9g\n", cp.p[0], cp.p[1]);
    }
    fprintf(o, "\"/>\n");
    fprintf(g, "\n");
  }
  fprintf(g, "\n\n");
  if (tri) {
    fprintf(o, "<path fill=\"none\" stroke=\"#b0b0b0\" stroke-width=\"0.6\" d=\"");
    for (int32_t t = 0; t < tri->ntri; ++t) {
      const int32_t *v = &tri->tri[3 * t];
      const double *p0 = &tri->xyz[3 * v[0]], *p1 = &tri->xyz[3 * v[1]], *p2 = &tri->xyz[3 * v[2]];
      fprintf(o, "M%.2f %.2fL%.2f %.2fL%.2f %.2fZ", SX(p0[0]), SY(p0[1]), SX(p1[0]), SY(p1[1]),
              SX(p2[0]), SY(p2[1]));
      fprintf(g, "%.9g %.9g\n%.9g %.9g\n%.9g %.9g\n%.9g %.9g\n\n", p0[0], p0[1], p1[0], p1[1],
              p2[0], p2[1], p0[0], p0[1]);
    }
    fprintf(o, "\"/>\n");
  } else {
    fprintf(g, "nan nan\n"); /* the block must exist; animate draws it only with triangles */
  }
  fprintf(g, "\n\n");
  static const char *colour[4] = {"#d62728", "#ff7f0e", "#1f77b4", "#2ca02c"};
  for (int32_t i = 0; i < fr->n; ++i) {
    const double x = fr->xyz[3 * i], y = fr->xyz[3 * i + 1], r = fr->draw_scale * fr->radius[i];
    char c[8];
    if (fr->energy) {
      energy_colour((fr->energy[i] - elo) / (ehi - elo), c);
      fprintf(o, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" fill=\"%s\" fill-opacity=\"0.55\" "
                 "stroke=\"%s\" stroke-width=\"0.6\"/>\n",
              SX(x), SY(y), r * scale, c, c);
    } else {
      snprintf(c, sizeof c, "%s", colour[fr->dim[i] & 3]);
      fprintf(o, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" fill=\"none\" stroke=\"%s\" "
                 "stroke-width=\"0.8\"/>\n",
              SX(x), SY(y), r * scale, c);
    }
    fprintf(g, "%.9g %.9g %.9g %ld\n", x, y, r, strtol(c + 1, NULL, 16)); /* rgb as 0xRRGGBB */
  }
  fprintf(o, "<text x=\"8\" y=\"%.0f\" font-family=\"sans-serif\" font-size=\"14\">%s</text>\n"
             "</svg>\n",
          (h + 2 * pad) * scale + 18, title);
#undef SX
#undef SY
  pm_mesh_destroy(tri);
  s = pm_atomic_commit(&a, err);
  if (s) {
    pm_atomic_abort(&b);
    return s;
  }
  return pm_atomic_commit(&b, err);
}

pm_status pm_frames_add(pm_frames *f, const pm_run_frame *fr, pm_error *err) {
  if (f->n >= FRAMES_MAX) return PM_OK;
  if (f->n == f->cap) {
    int32_t cap = f->cap ? 2 * f->cap : 64;
    int64_t *st = realloc(f->step, sizeof(int64_t) * (size_t)cap);
    if (!st) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    f->step = st, f->cap = cap;
  }
  char path[4200], dat[4200];
  snprintf(path, sizeof path, "%s/frame_%06d.vtu", f->dir, (int)f->n);
  pm_status s = write_vtu(path, fr, err);
  if (s) return s;
  /* Planar: every cell lies in z = 0 (the analytic backend's domains). */
  if (f->model->dim == 2 && f->model->box[2] == 0 && f->model->box[5] == 0) {
    snprintf(path, sizeof path, "%s/frame_%06d.svg", f->dir, (int)f->n);
    snprintf(dat, sizeof dat, "%s/frame_%06d.dat", f->dir, (int)f->n);
    if ((s = write_pictures(f, path, dat, fr, err))) return s;
  }
  f->step[f->n++] = fr->step;
  return PM_OK;
}

pm_status pm_frames_finish(pm_frames *f, pm_error *err) {
  char path[4200];
  snprintf(path, sizeof path, "%s/frames.pvd", f->dir);
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  fprintf(a.f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n"
               "<Collection>\n");
  for (int32_t i = 0; i < f->n; ++i)
    fprintf(a.f, "<DataSet timestep=\"%lld\" file=\"frame_%06d.vtu\"/>\n", (long long)f->step[i], (int)i);
  fprintf(a.f, "</Collection>\n</VTKFile>\n");
  return pm_atomic_commit(&a, err);
}

int32_t pm_frames_count(const pm_frames *f) { return f->n; }

void pm_frames_destroy(pm_frames *f) {
  if (!f) return;
  free(f->dir);
  free(f->step);
  free(f);
}
