/* Opening what the command line names as an input (see input.h). */
#include "common/input.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/cases.h"
#include "common/geom_analytic.h"
#include "common/geom_cad.h"

/* Case files are small; anything larger is not one. */
#define CASE_FILE_MAX (16 << 20)

static int has_ext(const char *path, const char *ext) {
  size_t n = strlen(path), e = strlen(ext);
  if (n < e) return 0;
  for (size_t i = 0; i < e; ++i)
    if (tolower((unsigned char)path[n - e + i]) != ext[i]) return 0;
  return 1;
}

static int is_cad(const char *path) {
  static const char *const ext[] = {".step", ".stp", ".iges", ".igs", ".brep"};
  for (size_t i = 0; i < sizeof ext / sizeof ext[0]; ++i)
    if (has_ext(path, ext[i])) return 1;
  return 0;
}

static pm_status read_file(const char *path, char **text, pm_error *err) {
  *text = NULL;
  FILE *f = fopen(path, "rb");
  if (!f) return pm_error_setf(err, PM_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
  char *buf = malloc(CASE_FILE_MAX + 1);
  if (!buf) {
    fclose(f);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory reading '%s'", path);
  }
  size_t n = fread(buf, 1, CASE_FILE_MAX + 1, f);
  int bad = ferror(f);
  fclose(f);
  if (bad) {
    free(buf);
    return pm_error_setf(err, PM_ERR_IO, "cannot read '%s'", path);
  }
  if (n > CASE_FILE_MAX) {
    free(buf);
    return pm_error_setf(err, PM_ERR_PARSE, "'%s' is too large for a case file", path);
  }
  buf[n] = '\0';
  *text = buf;
  return PM_OK;
}

static int read_point(const cJSON *a, double p[2]) {
  if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 2) return 0;
  const cJSON *x = cJSON_GetArrayItem(a, 0), *y = cJSON_GetArrayItem(a, 1);
  if (!cJSON_IsNumber(x) || !cJSON_IsNumber(y)) return 0;
  p[0] = x->valuedouble, p[1] = y->valuedouble;
  return 1;
}

static pm_status planar_from_json(const char *path, const char *name, const cJSON *loops,
                                  pm_model **model, pm_error *err) {
  int nloop = cJSON_GetArraySize(loops);
  if (!cJSON_IsArray(loops) || nloop < 1)
    return pm_error_setf(err, PM_ERR_PARSE, "%s: \"loops\" must be a non-empty array", path);
  pm_planar_loop *pl = calloc((size_t)nloop, sizeof *pl);
  pm_planar_piece **pieces = calloc((size_t)nloop, sizeof *pieces);
  pm_status s = PM_OK;
  if (!pl || !pieces) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  for (int l = 0; l < nloop && !s; ++l) {
    const cJSON *loop = cJSON_GetArrayItem(loops, l);
    int n = cJSON_GetArraySize(loop);
    if (!cJSON_IsArray(loop) || n < 1) {
      s = pm_error_setf(err, PM_ERR_PARSE, "%s: loop %d must be a non-empty array of pieces", path, l);
      break;
    }
    pieces[l] = calloc((size_t)n, sizeof(pm_planar_piece));
    if (!pieces[l]) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      break;
    }
    for (int k = 0; k < n; ++k) {
      const cJSON *pc = cJSON_GetArrayItem(loop, k);
      const cJSON *line = cJSON_GetObjectItemCaseSensitive(pc, "line");
      const cJSON *arc = cJSON_GetObjectItemCaseSensitive(pc, "arc");
      pm_planar_piece *p = &pieces[l][k];
      if (line && read_point(line, p->start)) {
        p->kind = PM_PIECE_LINE;
      } else if (arc && cJSON_IsObject(arc) &&
                 read_point(cJSON_GetObjectItemCaseSensitive(arc, "from"), p->start) &&
                 read_point(cJSON_GetObjectItemCaseSensitive(arc, "centre"), p->centre)) {
        const cJSON *ccw = cJSON_GetObjectItemCaseSensitive(arc, "ccw");
        p->kind = PM_PIECE_ARC;
        p->ccw = ccw ? cJSON_IsTrue(ccw) : 1;
      } else {
        s = pm_error_setf(err, PM_ERR_PARSE,
                          "%s: loop %d piece %d must be {\"line\": [x, y]} or {\"arc\": {\"from\": "
                          "[x, y], \"centre\": [x, y], \"ccw\": true}}",
                          path, l, k);
        break;
      }
    }
    pl[l].n = n;
    pl[l].piece = pieces[l];
  }
  if (!s) {
    s = pm_planar_model(name, nloop, pl, model, err);
    if (s) pm_error_prefix(err, "%s", path);
  }
done:
  if (pieces)
    for (int l = 0; l < nloop; ++l) free(pieces[l]);
  free(pieces);
  free(pl);
  return s;
}

static pm_status open_case_file(const char *path, pm_model **model, pm_sizing **size,
                                pm_error *err) {
  char *text = NULL;
  pm_status s = read_file(path, &text, err);
  if (s) return s;
  cJSON *root = cJSON_Parse(text);
  if (!root) {
    const char *at = cJSON_GetErrorPtr();
    long off = at && at >= text ? (long)(at - text) : -1;
    free(text);
    return pm_error_setf(err, PM_ERR_PARSE, "%s: not valid JSON (near byte %ld)", path, off);
  }
  free(text);
  const cJSON *domain = cJSON_GetObjectItemCaseSensitive(root, "domain");
  const cJSON *sz = cJSON_GetObjectItemCaseSensitive(root, "size");
  const cJSON *nm = cJSON_GetObjectItemCaseSensitive(root, "name");
  char name[256];
  snprintf(name, sizeof name, "%s", cJSON_IsString(nm) ? nm->valuestring : path);
  pm_sizing *case_size = NULL;
  if (!cJSON_IsObject(domain)) {
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: missing object \"domain\"", path);
  } else if (cJSON_GetObjectItemCaseSensitive(domain, "loops")) {
    s = planar_from_json(path, name, cJSON_GetObjectItemCaseSensitive(domain, "loops"), model, err);
  } else if (cJSON_IsString(cJSON_GetObjectItemCaseSensitive(domain, "file"))) {
    const char *file = cJSON_GetObjectItemCaseSensitive(domain, "file")->valuestring;
    char full[4096];
    const char *slash = strrchr(path, '/');
    if (file[0] == '/' || !slash)
      snprintf(full, sizeof full, "%s", file);
    else
      snprintf(full, sizeof full, "%.*s/%s", (int)(slash - path), path, file);
    s = is_cad(full) ? pm_cad_load(full, model, err)
                     : pm_error_setf(err, PM_ERR_PARSE, "%s: \"file\" must name a CAD file", path);
  } else if (cJSON_IsString(cJSON_GetObjectItemCaseSensitive(domain, "case"))) {
    s = pm_case_open(cJSON_GetObjectItemCaseSensitive(domain, "case")->valuestring, model,
                     sz ? NULL : &case_size, err);
  } else {
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"domain\" needs \"loops\", \"file\" or \"case\"", path);
  }
  if (!s && sz) {
    char num[64];
    const char *txt = NULL;
    if (cJSON_IsNumber(sz)) {
      snprintf(num, sizeof num, "%.17g", sz->valuedouble);
      txt = num;
    } else if (cJSON_IsString(sz)) {
      txt = sz->valuestring;
    }
    if (!txt)
      s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"size\" must be a number or an expression string", path);
    else if ((s = pm_sizing_parse(txt, &case_size, err)))
      pm_error_prefix(err, "%s", path);
  }
  cJSON_Delete(root);
  if (s) {
    pm_model_destroy(*model);
    *model = NULL;
    pm_sizing_destroy(case_size);
    return s;
  }
  if (size)
    *size = case_size;
  else
    pm_sizing_destroy(case_size);
  return PM_OK;
}

pm_status pm_input_open(const char *spec, pm_model **model, pm_sizing **default_size,
                        pm_error *err) {
  *model = NULL;
  if (default_size) *default_size = NULL;
  if (!spec || !spec[0]) return pm_error_setf(err, PM_ERR_ARG, "no input given");
  if (strncmp(spec, "case:", 5) == 0) return pm_case_open(spec + 5, model, default_size, err);
  if (is_cad(spec)) return pm_cad_load(spec, model, err);
  if (has_ext(spec, ".json")) return open_case_file(spec, model, default_size, err);
  return pm_error_setf(err, PM_ERR_ARG,
                       "cannot tell what '%s' is: give a CAD file (.step .stp .iges .igs .brep), "
                       "case:NAME or a case file (.json)",
                       spec);
}
