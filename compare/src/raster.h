/* A small software rasterizer for the mesh pictures of a study (plot_mesh.c), and the PNG
 * encoder that writes its images (png.c). No graphics library is needed: a picture is flat
 * triangles with a depth buffer, lines on top, a colour bar and digits, drawn at twice the
 * output resolution and averaged down (2 x 2 supersampling smooths the edges).
 */
#ifndef PM_COMPARE_RASTER_H
#define PM_COMPARE_RASTER_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PM_RASTER_SS 2 /* supersampling factor per axis */

typedef struct pm_raster {
  int w, h;      /* output size in pixels; the buffers are PM_RASTER_SS times larger per axis */
  float *rgb;    /* [3 * W * H] colour, 0..1, W = w * PM_RASTER_SS, H = h * PM_RASTER_SS */
  float *depth;  /* [W * H] larger is nearer; -INFINITY where nothing was drawn */
  size_t cap;    /* supersampled pixels the buffers hold */
} pm_raster;

/* Make r (zeroed, or used before) a white image of w x h output pixels. Its buffers are kept
 * when they are large enough: a study's pictures reuse one canvas instead of touching fresh
 * memory for each. PM_ERR_NOMEM on failure. pm_raster_clear frees the buffers. */
pm_status pm_raster_init(pm_raster *r, int w, int h, pm_error *err);
void pm_raster_clear(pm_raster *r);

/* A triangle in output pixel coordinates (x right, y down) with depth z at its corners, filled
 * with one colour where it is nearer than what is there. */
void pm_raster_triangle(pm_raster *r, const double x[3], const double y[3], const double z[3],
                        const float rgb[3]);

/* A line from (x0, y0, z0) to (x1, y1, z1), width in output pixels, blended with `alpha` over
 * the image where it is not behind a surface by more than depth_tol (depth_tol = INFINITY:
 * always drawn, for overlays). */
void pm_raster_line(pm_raster *r, double x0, double y0, double z0, double x1, double y1,
                    double z1, double width, const float rgb[3], float alpha, double depth_tol);

/* A filled rectangle in output pixels, drawn over everything. */
void pm_raster_rect(pm_raster *r, double x0, double y0, double x1, double y1, const float rgb[3]);

/* Text of digits, '.', '-', '+' and 'e' (other characters leave a gap) at output pixel (x, y),
 * its top left corner, in a 5 x 7 font scaled by `scale`. */
void pm_raster_text(pm_raster *r, double x, double y, double scale, const char *text,
                    const float rgb[3]);

/* The image averaged down to w x h, 8-bit RGB (malloc'ed, 3 * w * h bytes); NULL when out of
 * memory. */
unsigned char *pm_raster_rgb8(const pm_raster *r);

/* The colour of t in [0, 1] (clamped) on the pictures' scale: blue for the ideal end (0),
 * through pale yellow, to dark red (1) -- ColorBrewer's RdYlBu, reversed. */
void pm_raster_colour(double t, float rgb[3]);

/* An RGB8 image as PNG bytes (malloc'ed into *out, *len bytes). */
pm_status pm_cmp_png_encode(const unsigned char *rgb, int w, int h, unsigned char **out,
                            size_t *len, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_COMPARE_RASTER_H */
