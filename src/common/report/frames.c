/* Snapshots of a particle run (see frames.h). */
#include "common/report/frames.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/base/atomic_file.h"

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

static pm_status write_vtu(const pm_frames *f, const char *path, int32_t n, const double *xyz,
                           const double *radius, const int8_t *dim, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  FILE *o = a.f;
  (void)f;
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
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%.9g\n", radius[i]);
  fprintf(o, "</DataArray>\n<DataArray type=\"Int32\" Name=\"cell_dim\" format=\"ascii\">\n");
  for (int32_t i = 0; i < n; ++i) fprintf(o, "%d\n", (int)dim[i]);
  fprintf(o, "</DataArray>\n</PointData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
  return pm_atomic_commit(&a, err);
}

/* A planar model's snapshot: the boundary curves as polylines and the particles as circles,
 * coloured by the dimension of their cell. */
static pm_status write_svg(const pm_frames *f, const char *path, int64_t step, int32_t n,
                           const double *xyz, const double *radius, const int8_t *dim,
                           pm_error *err) {
  const pm_model *m = f->model;
  double x0 = m->box[0], y0 = m->box[1], w = m->box[3] - m->box[0], h = m->box[4] - m->box[1];
  double pad = 0.03 * fmax(w, h), scale = 800.0 / fmax(w + 2 * pad, h + 2 * pad);
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  FILE *o = a.f;
  fprintf(o, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\">\n"
             "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
          (w + 2 * pad) * scale, (h + 2 * pad) * scale + 24);
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
    }
    fprintf(o, "\"/>\n");
  }
  static const char *colour[4] = {"#d62728", "#ff7f0e", "#1f77b4", "#2ca02c"};
  for (int32_t i = 0; i < n; ++i)
    fprintf(o, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" fill=\"none\" stroke=\"%s\" "
               "stroke-width=\"0.8\"/>\n",
            SX(xyz[3 * i]), SY(xyz[3 * i + 1]), radius[i] * scale, colour[dim[i] & 3]);
  fprintf(o, "<text x=\"8\" y=\"%.0f\" font-family=\"sans-serif\" font-size=\"14\">step %lld, "
             "%d particles</text>\n</svg>\n",
          (h + 2 * pad) * scale + 18, (long long)step, (int)n);
#undef SX
#undef SY
  return pm_atomic_commit(&a, err);
}

pm_status pm_frames_add(pm_frames *f, int64_t step, int32_t n, const double *xyz,
                        const double *radius, const int8_t *dim, pm_error *err) {
  if (f->n >= FRAMES_MAX) return PM_OK;
  if (f->n == f->cap) {
    int32_t cap = f->cap ? 2 * f->cap : 64;
    int64_t *st = realloc(f->step, sizeof(int64_t) * (size_t)cap);
    if (!st) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    f->step = st, f->cap = cap;
  }
  char path[4200];
  snprintf(path, sizeof path, "%s/frame_%06d.vtu", f->dir, (int)f->n);
  pm_status s = write_vtu(f, path, n, xyz, radius, dim, err);
  if (s) return s;
  /* Planar: every cell lies in z = 0 (the analytic backend's domains). */
  if (f->model->dim == 2 && f->model->box[2] == 0 && f->model->box[5] == 0) {
    snprintf(path, sizeof path, "%s/frame_%06d.svg", f->dir, (int)f->n);
    if ((s = write_svg(f, path, step, n, xyz, radius, dim, err))) return s;
  }
  f->step[f->n++] = step;
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
