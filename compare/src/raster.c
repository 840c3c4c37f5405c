/* The rasterizer of raster.h: edge functions over each triangle's bounding box with a depth
 * test, lines as the pixels within half their width of the segment, blended over the image, and a 5 x 7 bitmap font of
 * the characters a colour bar's numbers need. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "compare/src/raster.h"

pm_status pm_raster_init(pm_raster *r, int w, int h, pm_error *err) {
  if (w <= 0 || h <= 0 || w > 8192 || h > 8192)
    return pm_error_setf(err, PM_ERR_ARG, "picture of %d x %d pixels", w, h);
  size_t n = (size_t)w * h * PM_RASTER_SS * PM_RASTER_SS;
  if (n > r->cap) {
    float *rgb = realloc(r->rgb, 3 * n * sizeof *rgb);
    if (rgb) r->rgb = rgb;
    float *depth = rgb ? realloc(r->depth, n * sizeof *depth) : NULL;
    if (depth) r->depth = depth;
    if (!rgb || !depth) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    r->cap = n;
  }
  r->w = w, r->h = h;
  for (size_t i = 0; i < 3 * n; ++i) r->rgb[i] = 1.0f;
  for (size_t i = 0; i < n; ++i) r->depth[i] = -INFINITY;
  return PM_OK;
}

void pm_raster_clear(pm_raster *r) {
  free(r->rgb);
  free(r->depth);
  memset(r, 0, sizeof *r);
}

/* The supersampled pixels of the box [x0, x1] x [y0, y1], clipped to the image. */
static void pixel_box(const pm_raster *r, double x0, double x1, double y0, double y1, int *px0,
                      int *px1, int *py0, int *py1) {
  const int W = r->w * PM_RASTER_SS, H = r->h * PM_RASTER_SS;
  *px0 = x0 < 0 ? 0 : (int)floor(x0);
  *py0 = y0 < 0 ? 0 : (int)floor(y0);
  *px1 = x1 > W - 1 ? W - 1 : (int)ceil(x1);
  *py1 = y1 > H - 1 ? H - 1 : (int)ceil(y1);
}

/* Fill the triangle (supersampled coordinates) at the pixel centres inside it that are nearer
 * than what is there. */
static void fill(pm_raster *r, const double X[3], const double Y[3], const double Z[3],
                 const float rgb[3]) {
  const int W = r->w * PM_RASTER_SS;
  double area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
  if (!(fabs(area) > 1e-12)) return;
  int x0, x1, y0, y1;
  pixel_box(r, fmin(X[0], fmin(X[1], X[2])), fmax(X[0], fmax(X[1], X[2])),
            fmin(Y[0], fmin(Y[1], Y[2])), fmax(Y[0], fmax(Y[1], Y[2])), &x0, &x1, &y0, &y1);
  for (int py = y0; py <= y1; ++py)
    for (int px = x0; px <= x1; ++px) {
      double cx = px + 0.5, cy = py + 0.5;
      /* Barycentric weights by edge functions; a centre on a shared edge belongs to both
       * triangles, which only repaints it with the same depth order. */
      double w0 = ((X[1] - cx) * (Y[2] - cy) - (X[2] - cx) * (Y[1] - cy)) / area;
      double w1 = ((X[2] - cx) * (Y[0] - cy) - (X[0] - cx) * (Y[2] - cy)) / area;
      double w2 = 1 - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      double z = w0 * Z[0] + w1 * Z[1] + w2 * Z[2];
      size_t i = (size_t)py * W + px;
      if (z < r->depth[i]) continue;
      r->depth[i] = (float)z;
      memcpy(r->rgb + 3 * i, rgb, 3 * sizeof *rgb);
    }
}

void pm_raster_triangle(pm_raster *r, const double x[3], const double y[3], const double z[3],
                        const float rgb[3]) {
  double X[3], Y[3];
  for (int k = 0; k < 3; ++k) X[k] = x[k] * PM_RASTER_SS, Y[k] = y[k] * PM_RASTER_SS;
  fill(r, X, Y, z, rgb);
}

void pm_raster_line(pm_raster *r, double x0, double y0, double z0, double x1, double y1,
                    double z1, double width, const float rgb[3], float alpha, double depth_tol) {
  const int W = r->w * PM_RASTER_SS, H = r->h * PM_RASTER_SS;
  double ax = x0 * PM_RASTER_SS, ay = y0 * PM_RASTER_SS, bx = x1 * PM_RASTER_SS,
         by = y1 * PM_RASTER_SS;
  double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  double hw = 0.5 * width * PM_RASTER_SS;
  if (hw < 0.5) hw = 0.5; /* thinner than a subpixel would leave gaps */
  /* Along the major axis, the pixels within reach of the line in the other: cost in proportion
   * to the line's length, not its bounding box. Every pixel centre within half the width of the
   * segment is blended once (a line drawn as two triangles would blend the centres of their
   * shared diagonal twice). */
  int steep = fabs(dy) > fabs(dx);
  double u0 = steep ? ay : ax, u1 = steep ? by : bx, du = steep ? dy : dx, dv = steep ? dx : dy;
  double v0 = steep ? ax : ay, reach = hw * (len2 > 0 ? sqrt(len2) / fmax(fabs(du), 1e-12) : 1);
  int ulo = (int)floor(fmin(u0, u1) - hw), uhi = (int)ceil(fmax(u0, u1) + hw);
  int ulim = steep ? H - 1 : W - 1, vlim = steep ? W - 1 : H - 1;
  if (ulo < 0) ulo = 0;
  if (uhi > ulim) uhi = ulim;
  for (int pu = ulo; pu <= uhi; ++pu) {
    double s = fabs(du) > 1e-12 ? (pu + 0.5 - u0) / du : 0;
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    double vc = v0 + s * dv;
    int vlo = (int)floor(vc - reach - 1), vhi = (int)ceil(vc + reach + 1);
    if (vlo < 0) vlo = 0;
    if (vhi > vlim) vhi = vlim;
    for (int pv = vlo; pv <= vhi; ++pv) {
      int px = steep ? pv : pu, py = steep ? pu : pv;
      double cx = px + 0.5 - ax, cy = py + 0.5 - ay;
      double t = len2 > 0 ? (cx * dx + cy * dy) / len2 : 0;
      if (t < 0) t = 0;
      if (t > 1) t = 1;
      double ex = cx - t * dx, ey = cy - t * dy;
      if (ex * ex + ey * ey > hw * hw) continue;
      size_t i = (size_t)py * W + px;
      double z = z0 + t * (z1 - z0);
      if (z + depth_tol < r->depth[i]) continue;
      for (int c = 0; c < 3; ++c) r->rgb[3 * i + c] += alpha * (rgb[c] - r->rgb[3 * i + c]);
    }
  }
}

void pm_raster_rect(pm_raster *r, double x0, double y0, double x1, double y1, const float rgb[3]) {
  const int W = r->w * PM_RASTER_SS, H = r->h * PM_RASTER_SS;
  int a = (int)floor(x0 * PM_RASTER_SS), b = (int)ceil(x1 * PM_RASTER_SS);
  int c = (int)floor(y0 * PM_RASTER_SS), d = (int)ceil(y1 * PM_RASTER_SS);
  for (int py = c < 0 ? 0 : c; py < d && py < H; ++py)
    for (int px = a < 0 ? 0 : a; px < b && px < W; ++px)
      memcpy(r->rgb + 3 * ((size_t)py * W + px), rgb, 3 * sizeof *rgb);
}

/* 5 x 7 glyphs, one byte per row, the low 5 bits left to right. */
static const struct {
  char c;
  unsigned char row[7];
} font[] = {
    {'0', {0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e}}, {'1', {0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e}},
    {'2', {0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f}}, {'3', {0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e}},
    {'4', {0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02}}, {'5', {0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e}},
    {'6', {0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e}}, {'7', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e}}, {'9', {0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c}}, {'-', {0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00}},
    {'+', {0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00}}, {'e', {0x00, 0x00, 0x0e, 0x11, 0x1f, 0x10, 0x0e}},
};

void pm_raster_text(pm_raster *r, double x, double y, double scale, const char *text,
                    const float rgb[3]) {
  for (; *text; ++text, x += 6 * scale) {
    for (size_t g = 0; g < sizeof font / sizeof font[0]; ++g) {
      if (font[g].c != *text) continue;
      for (int row = 0; row < 7; ++row)
        for (int col = 0; col < 5; ++col)
          if (font[g].row[row] & (0x10 >> col))
            pm_raster_rect(r, x + col * scale, y + row * scale, x + (col + 1) * scale,
                           y + (row + 1) * scale, rgb);
    }
  }
}

unsigned char *pm_raster_rgb8(const pm_raster *r) {
  unsigned char *out = malloc((size_t)r->w * r->h * 3);
  if (!out) return NULL;
  const int W = r->w * PM_RASTER_SS;
  for (int y = 0; y < r->h; ++y)
    for (int x = 0; x < r->w; ++x)
      for (int c = 0; c < 3; ++c) {
        float s = 0;
        for (int j = 0; j < PM_RASTER_SS; ++j)
          for (int i = 0; i < PM_RASTER_SS; ++i)
            s += r->rgb[3 * ((size_t)(y * PM_RASTER_SS + j) * W + x * PM_RASTER_SS + i) + c];
        s /= PM_RASTER_SS * PM_RASTER_SS;
        out[3 * ((size_t)y * r->w + x) + c] =
            (unsigned char)lrintf(255.0f * (s < 0 ? 0 : s > 1 ? 1 : s));
      }
  return out;
}

void pm_raster_colour(double t, float rgb[3]) {
  /* RdYlBu (ColorBrewer, 7 classes), from blue to red. */
  static const float stop[7][3] = {{0x45, 0x75, 0xb4}, {0x91, 0xbf, 0xdb}, {0xe0, 0xf3, 0xf8},
                                   {0xff, 0xff, 0xbf}, {0xfe, 0xe0, 0x90}, {0xfc, 0x8d, 0x59},
                                   {0xd7, 0x30, 0x27}};
  if (!(t > 0)) t = 0;
  if (t > 1) t = 1;
  double s = t * 6;
  int k = (int)s;
  if (k > 5) k = 5;
  double f = s - k;
  for (int c = 0; c < 3; ++c)
    rgb[c] = (float)(((1 - f) * stop[k][c] + f * stop[k + 1][c]) / 255.0);
}
