/* A PNG encoder for the mesh pictures (plot_mesh.c): 8-bit RGB, one IDAT chunk compressed by
 * zlib, filter 0 ("none") on every scanline. Flat-coloured mesh pictures compress well without
 * the adaptive filters, and the encoder stays a page long (PNG specification, ISO/IEC 15948:
 * signature, IHDR, IDAT, IEND; each chunk's CRC-32 over its type and data, zlib's crc32).
 */
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "compare/src/raster.h"

static void put32(unsigned char *p, uint32_t v) {
  p[0] = (unsigned char)(v >> 24);
  p[1] = (unsigned char)(v >> 16);
  p[2] = (unsigned char)(v >> 8);
  p[3] = (unsigned char)v;
}

/* One chunk at out (length, type, data, CRC); returns the bytes written. */
static size_t chunk(unsigned char *out, const char *type, const unsigned char *data, size_t n) {
  put32(out, (uint32_t)n);
  memcpy(out + 4, type, 4);
  if (n) memcpy(out + 8, data, n);
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, out + 4, (uInt)(n + 4));
  put32(out + 8 + n, (uint32_t)crc);
  return n + 12;
}

pm_status pm_cmp_png_encode(const unsigned char *rgb, int w, int h, unsigned char **out,
                            size_t *len, pm_error *err) {
  *out = NULL;
  *len = 0;
  if (w <= 0 || h <= 0) return pm_error_setf(err, PM_ERR_ARG, "PNG of %d x %d pixels", w, h);
  size_t row = (size_t)w * 3 + 1, raw_n = row * (size_t)h;
  unsigned char *raw = malloc(raw_n);
  uLongf zn = compressBound((uLong)raw_n);
  unsigned char *z = malloc(zn);
  unsigned char *png = malloc(zn + 64);
  if (!raw || !z || !png) {
    free(raw), free(z), free(png);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int y = 0; y < h; ++y) {
    raw[(size_t)y * row] = 0; /* filter: none */
    memcpy(raw + (size_t)y * row + 1, rgb + (size_t)y * w * 3, (size_t)w * 3);
  }
  int zs = compress2(z, &zn, raw, (uLong)raw_n, 6);
  free(raw);
  if (zs != Z_OK) {
    free(z), free(png);
    return pm_error_setf(err, PM_ERR_NOMEM, "zlib could not compress a picture (%d)", zs);
  }
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  unsigned char ihdr[13];
  put32(ihdr, (uint32_t)w);
  put32(ihdr + 4, (uint32_t)h);
  ihdr[8] = 8;  /* bit depth */
  ihdr[9] = 2;  /* colour type: RGB */
  ihdr[10] = 0; /* deflate */
  ihdr[11] = 0; /* adaptive filtering (method 0) */
  ihdr[12] = 0; /* no interlace */
  size_t k = 0;
  memcpy(png, sig, 8);
  k = 8;
  k += chunk(png + k, "IHDR", ihdr, sizeof ihdr);
  k += chunk(png + k, "IDAT", z, zn);
  k += chunk(png + k, "IEND", NULL, 0);
  free(z);
  *out = png;
  *len = k;
  return PM_OK;
}
