/* The study's viewer/ folder, behind the 3D viewer of report.html:
 *   three.min.js, three.LICENSE   three.js (a well-kept WebGL library) and its licence, copied
 *                                 when the report is written from $PM_THREE_JS or Debian's
 *                                 libjs-three; nothing third-party is in packmesh's tree
 *   viewer.js                     packmesh's own viewer (compare/viewer/viewer.js, built into
 *                                 the library as pm_cmp_viewer_js by compare/embed.cmake)
 *   mesh_CASE.js                  the case's meshes as JS data, one per method (its first
 *                                 successful run): nodes, surface triangles, and the triangles'
 *                                 R/l_min, radius ratio and smallest angle
 * All loaded by <script> tags (no fetch), so report.html works offline from file://.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/base/atomic_file.h"
#include "common/mesh/mesh.h"
#include "compare/src/study.h"

#define DEFAULT_THREE "/usr/share/javascript/three/three.min.js"
#define DEFAULT_LICENCE "/usr/share/doc/libjs-three/copyright"
/* A mesh above this many triangles is left out of the viewer (the page would take minutes to
 * load); the report's pictures still show it. */
#define MAX_VIEWER_TRIANGLES 400000

extern const unsigned char pm_cmp_viewer_js[];
extern const unsigned long pm_cmp_viewer_js_len;

void pm_cmp_viewer_case_file(const pm_cmp_study *st, int c, char *buf, size_t len) {
  snprintf(buf, len, "viewer/mesh_%s.js", st->suite.cases[c].name);
  for (char *p = buf + strlen("viewer/"); *p; ++p)
    if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') ||
          *p == '_' || *p == '-' || *p == '.'))
      *p = '_';
}

/* A JSON string (labels and names are the suite's: quotes and backslashes escaped, control
 * characters dropped). */
static void js_string(sbuf *b, const char *t) {
  SB(b, "\"");
  for (; *t; ++t) {
    if (*t == '"' || *t == '\\')
      SB(b, "\\%c", *t);
    else if (*t == '<') /* no "</script>" inside a script */
      SB(b, "\\u003c");
    else if ((unsigned char)*t >= 0x20)
      SB(b, "%c", *t);
  }
  SB(b, "\"");
}

static void js_numbers(sbuf *b, const double *v, int32_t n, const char *fmt) {
  SB(b, "[");
  for (int32_t i = 0; i < n; ++i) {
    if (i) SB(b, ",");
    /* Degenerate elements carry 1e100 (element_measure.h); any finite value is kept. */
    if (isfinite(v[i]))
      SB(b, fmt, v[i]);
    else
      SB(b, "null");
  }
  SB(b, "]");
}

static pm_status case_file(const pm_cmp_study *st, int c, double colour_max, int *written,
                           pm_error *err) {
  const pm_cmp_suite *su = &st->suite;
  sbuf b = {0};
  *written = 0;
  SB(&b, "/* packmesh comparison '");
  for (const char *t = su->name; *t; ++t)
    if (*t != '*' && (unsigned char)*t >= 0x20) SB(&b, "%c", *t);
  SB(&b, "': the meshes of one case for viewer.js. */\n"
         "window.PM_VIEWER = window.PM_VIEWER || {cases: []};\n"
         "window.PM_VIEWER.cases.push({\"name\": ");
  js_string(&b, su->cases[c].name);
  SB(&b, ", \"colour_max\": %.4g, \"methods\": [\n", colour_max);
  int nmesh = 0, flat = 1;
  pm_status s = PM_OK;
  for (int m = 0; m < su->nmethod && !s; ++m) {
    int i = pm_cmp_first_ok_row(st, c, m);
    if (i < 0) continue;
    pm_mesh *mesh = NULL;
    pm_element_values v;
    if (pm_cmp_row_mesh(st, &st->rows[i], &mesh, &v, NULL)) continue;
    if (mesh->ntri > 0 && mesh->ntri <= MAX_VIEWER_TRIANGLES) {
      SB(&b, "%s{\"label\": ", nmesh ? ",\n" : "");
      js_string(&b, su->methods[m].label);
      SB(&b, ", \"run\": ");
      js_string(&b, st->rows[i].id);
      SB(&b, ", \"nodes\": %d, \"tets\": %d,\n\"xyz\": ", (int)mesh->nnode, (int)mesh->ntet);
      js_numbers(&b, mesh->xyz, 3 * mesh->nnode, "%.7g");
      for (int32_t k = 0; k < mesh->nnode; ++k)
        flat &= mesh->xyz[3 * k + 2] == 0;
      SB(&b, ",\n\"tri\": [");
      for (int32_t k = 0; k < 3 * mesh->ntri; ++k) SB(&b, k ? ",%d" : "%d", (int)mesh->tri[k]);
      SB(&b, "],\n\"values\": {");
      for (int q = 0; q < PM_ELEMENT_VALUES; ++q) {
        SB(&b, "%s\"%s\": ", q ? ",\n" : "", pm_element_value_names[q]);
        js_numbers(&b, v.tri[q], mesh->ntri, "%.5g");
      }
      SB(&b, "}}");
      nmesh++;
    }
    pm_element_values_clear(&v);
    pm_mesh_destroy(mesh);
    if (b.bad) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  SB(&b, "], \"flat\": %s});\n", flat ? "true" : "false");
  if (!s && b.bad) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  if (!s && nmesh) {
    char rel[400], path[4800];
    pm_cmp_viewer_case_file(st, c, rel, sizeof rel);
    snprintf(path, sizeof path, "%s/%s", st->dir, rel);
    s = pm_atomic_write(path, b.s, b.n, err);
    *written = !s;
  }
  free(b.s);
  return s;
}

static pm_status copy_file(const char *from, const char *dir, const char *name, pm_error *err) {
  size_t n = 0;
  char *text = pm_cmp_read_file(from, &n);
  if (!text) return pm_error_setf(err, PM_ERR_IO, "cannot read %s", from);
  char path[4400];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  pm_status s = pm_atomic_write(path, text, n, err);
  free(text);
  return s;
}

/* The licence of the three.js copied: Debian's copyright file for libjs-three's; for one that
 * $PM_THREE_JS names, a licence file beside it (LICENSE, as three.js ships it). 0: none. */
static int licence_of(const char *three, int from_env, char *out, size_t len) {
  if (!from_env) {
    snprintf(out, len, "%s", DEFAULT_LICENCE);
    return access(out, R_OK) == 0;
  }
  static const char *const names[] = {"LICENSE", "LICENSE.txt", "LICENSE.md", "copyright"};
  char dir[4096];
  snprintf(dir, sizeof dir, "%s", three);
  char *slash = strrchr(dir, '/');
  if (slash)
    *slash = '\0';
  else
    snprintf(dir, sizeof dir, ".");
  for (size_t k = 0; k < sizeof names / sizeof names[0]; ++k) {
    snprintf(out, len, "%s/%s", dir, names[k]);
    if (access(out, R_OK) == 0) return 1;
  }
  return 0;
}

pm_status pm_cmp_viewer_write(const pm_cmp_study *st, double colour_max, pm_cmp_viewer *v,
                              pm_error *err) {
  memset(v, 0, sizeof *v);
  const char *env = getenv("PM_THREE_JS");
  const int from_env = env && env[0];
  const char *three = from_env ? env : DEFAULT_THREE;
  char licence[4400];
  if (access(three, R_OK) != 0) {
    snprintf(v->note, sizeof v->note,
             "The 3D viewer is not available: three.js was not found at %s (install Debian's "
             "libjs-three, or set PM_THREE_JS to a three.min.js, and write the report again).",
             three);
    return PM_OK;
  }
  if (!licence_of(three, from_env, licence, sizeof licence)) {
    snprintf(v->note, sizeof v->note,
             "The 3D viewer is not available: no licence file was found for %s (%s), and "
             "three.js is not copied without its licence.",
             three, from_env ? "a LICENSE file beside it" : DEFAULT_LICENCE);
    return PM_OK;
  }
  v->case_written = calloc((size_t)st->suite.ncase + 1, sizeof *v->case_written);
  if (!v->case_written) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  char dir[4200];
  snprintf(dir, sizeof dir, "%s/viewer", st->dir);
  pm_status s = pm_cmp_mkdirs(dir, err);
  if (!s) s = copy_file(three, dir, "three.min.js", err);
  if (!s) s = copy_file(licence, dir, "three.LICENSE", err);
  if (!s) {
    char path[4400];
    snprintf(path, sizeof path, "%s/viewer.js", dir);
    s = pm_atomic_write(path, pm_cmp_viewer_js, pm_cmp_viewer_js_len, err);
  }
  int any = 0;
  for (int c = 0; c < st->suite.ncase && !s; ++c) {
    s = case_file(st, c, colour_max, &v->case_written[c], err);
    any |= v->case_written[c];
  }
  if (s) return s;
  v->available = any;
  if (any)
    snprintf(v->note, sizeof v->note,
             "three.js from %s, copied with its licence into viewer/ (three.LICENSE).", three);
  else
    snprintf(v->note, sizeof v->note, "The 3D viewer has no mesh to show: no run succeeded.");
  return PM_OK;
}

void pm_cmp_viewer_clear(pm_cmp_viewer *v) {
  if (!v) return;
  free(v->case_written);
  memset(v, 0, sizeof *v);
}
