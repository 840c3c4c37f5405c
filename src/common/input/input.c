/* Opening what the command line names as an input (see input.h). */
#include "common/input/input.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/base/clock.h"
#include "common/input/cases.h"
#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"
#include "common/geom/planar_check.h"

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

static pm_status read_file(const char *path, char **text, size_t *len, pm_error *err) {
  *text = NULL;
  /* Regular files only: opening a FIFO would wait for a writer. */
  struct stat st;
  if (stat(path, &st) != 0)
    return pm_error_setf(err, PM_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
  if (!S_ISREG(st.st_mode))
    return pm_error_setf(err, PM_ERR_IO, "cannot open '%s': %s", path,
                         S_ISDIR(st.st_mode) ? "it is a directory" : "not a regular file");
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
  *len = n;
  return PM_OK;
}

/* ---- strict case files ------------------------------------------------------------------ */

/* A key or text from the file, for a message: at most 40 bytes, what is not printable as '?'. */
static void quoted(const char *t, char out[48]) {
  size_t k = 0;
  for (; t && t[k] && k < 40; ++k) out[k] = (t[k] >= 32 && t[k] < 127) ? t[k] : '?';
  if (t && t[k]) out[k++] = '.', out[k++] = '.';
  out[k] = '\0';
}

/* The JSON type of j, for messages. */
static const char *json_type(const cJSON *j) {
  if (cJSON_IsString(j)) return "a string";
  if (cJSON_IsNumber(j)) return "a number";
  if (cJSON_IsBool(j)) return "a boolean";
  if (cJSON_IsNull(j)) return "null";
  if (cJSON_IsArray(j)) return "an array";
  if (cJSON_IsObject(j)) return "an object";
  return "invalid";
}

/* Every key of obj is one of allowed[] and none appears twice. `where` names obj. */
static pm_status check_keys(const char *path, const cJSON *obj, const char *where,
                            const char *const *allowed, int nallowed, pm_error *err) {
  int seen[8] = {0};
  for (const cJSON *c = obj->child; c; c = c->next) {
    int k = 0;
    while (k < nallowed && strcmp(c->string ? c->string : "", allowed[k]) != 0) ++k;
    char q[48];
    quoted(c->string, q);
    if (k == nallowed) {
      char list[160] = "";
      for (int i = 0; i < nallowed; ++i) {
        strncat(list, i ? ", \"" : "\"", sizeof list - strlen(list) - 1);
        strncat(list, allowed[i], sizeof list - strlen(list) - 1);
        strncat(list, "\"", sizeof list - strlen(list) - 1);
      }
      return pm_error_setf(err, PM_ERR_PARSE, "%s: unknown key \"%s\" in %s (known: %s)", path, q,
                           where, list);
    }
    if (seen[k]++)
      return pm_error_setf(err, PM_ERR_PARSE, "%s: key \"%s\" appears twice in %s", path, q, where);
  }
  return PM_OK;
}

/* [x, y]: two numbers. */
static pm_status read_point(const char *path, const cJSON *a, const char *what, int l, int k,
                            double p[2], pm_error *err) {
  const cJSON *x = cJSON_GetArrayItem(a, 0), *y = cJSON_GetArrayItem(a, 1);
  if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 2 || !cJSON_IsNumber(x) || !cJSON_IsNumber(y))
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: loop %d piece %d: \"%s\" must be [x, y], two numbers (got %s%s)",
                         path, l, k, what, json_type(a),
                         cJSON_IsArray(a) && cJSON_GetArraySize(a) != 2 ? " of another length" : "");
  p[0] = x->valuedouble, p[1] = y->valuedouble;
  return PM_OK;
}

static pm_status read_piece(const char *path, const cJSON *pc, int l, int k, pm_planar_piece *p,
                            pm_error *err) {
  if (!cJSON_IsObject(pc))
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: loop %d piece %d must be {\"line\": [x, y]} or {\"arc\": {\"from\": "
                         "[x, y], \"centre\": [x, y], \"ccw\": true}}, not %s",
                         path, l, k, json_type(pc));
  char where[64];
  snprintf(where, sizeof where, "loop %d piece %d", l, k);
  static const char *const piece_keys[] = {"line", "arc"};
  pm_status s = check_keys(path, pc, where, piece_keys, 2, err);
  if (s) return s;
  const cJSON *line = cJSON_GetObjectItemCaseSensitive(pc, "line");
  const cJSON *arc = cJSON_GetObjectItemCaseSensitive(pc, "arc");
  if (line && arc)
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: loop %d piece %d has both \"line\" and \"arc\"; a piece is one or "
                         "the other",
                         path, l, k);
  if (!line && !arc)
    return pm_error_setf(err, PM_ERR_PARSE, "%s: loop %d piece %d has neither \"line\" nor \"arc\"",
                         path, l, k);
  if (line) {
    p->kind = PM_PIECE_LINE;
    return read_point(path, line, "line", l, k, p->start, err);
  }
  if (!cJSON_IsObject(arc))
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: loop %d piece %d: \"arc\" must be an object {\"from\": [x, y], "
                         "\"centre\": [x, y], \"ccw\": true}, not %s",
                         path, l, k, json_type(arc));
  snprintf(where, sizeof where, "loop %d piece %d's \"arc\"", l, k);
  static const char *const arc_keys[] = {"from", "centre", "ccw"};
  if ((s = check_keys(path, arc, where, arc_keys, 3, err))) return s;
  const cJSON *from = cJSON_GetObjectItemCaseSensitive(arc, "from");
  const cJSON *centre = cJSON_GetObjectItemCaseSensitive(arc, "centre");
  const cJSON *ccw = cJSON_GetObjectItemCaseSensitive(arc, "ccw");
  if (!from || !centre)
    return pm_error_setf(err, PM_ERR_PARSE, "%s: loop %d piece %d: the arc needs \"%s\"", path, l,
                         k, from ? "centre" : "from");
  if ((s = read_point(path, from, "from", l, k, p->start, err)) ||
      (s = read_point(path, centre, "centre", l, k, p->centre, err)))
    return s;
  if (ccw && !cJSON_IsBool(ccw))
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: loop %d piece %d: \"ccw\" must be true or false, not %s", path, l, k,
                         json_type(ccw));
  p->kind = PM_PIECE_ARC;
  p->ccw = ccw ? cJSON_IsTrue(ccw) : 1; /* counter-clockwise unless told otherwise */
  return PM_OK;
}

static pm_status planar_from_json(const char *path, const char *name, const cJSON *loops,
                                  pm_model **model, pm_error *err) {
  int nloop = cJSON_GetArraySize(loops);
  if (!cJSON_IsArray(loops) || nloop < 1)
    return pm_error_setf(err, PM_ERR_PARSE, "%s: \"loops\" must be a non-empty array of loops", path);
  pm_planar_loop *pl = calloc((size_t)nloop, sizeof *pl);
  pm_planar_piece **pieces = calloc((size_t)nloop, sizeof *pieces);
  pm_status s = PM_OK;
  if (!pl || !pieces) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  int l = 0;
  for (const cJSON *loop = loops->child; loop && !s; loop = loop->next, ++l) {
    int n = cJSON_GetArraySize(loop);
    if (!cJSON_IsArray(loop) || n < 1) {
      s = pm_error_setf(err, PM_ERR_PARSE, "%s: loop %d must be a non-empty array of pieces, not %s",
                        path, l, cJSON_IsArray(loop) ? "an empty array" : json_type(loop));
      break;
    }
    pieces[l] = calloc((size_t)n, sizeof(pm_planar_piece));
    if (!pieces[l]) {
      s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      break;
    }
    int k = 0;
    for (const cJSON *pc = loop->child; pc && !s; pc = pc->next, ++k)
      s = read_piece(path, pc, l, k, &pieces[l][k], err);
    pl[l].n = n;
    pl[l].piece = pieces[l];
  }
  /* The domain's own faults (crossings, holes outside, zero lengths), named before building. */
  if (!s && (s = pm_planar_check(nloop, pl, err))) pm_error_prefix(err, "%s", path);
  if (!s) {
    s = pm_planar_model(name, nloop, pl, model, err);
    if (s) pm_error_prefix(err, "%s", path);
  }
done:
  if (pieces)
    for (int i = 0; i < nloop; ++i) free(pieces[i]);
  free(pieces);
  free(pl);
  return s;
}

/* Line and column of byte `off` of text, for messages. */
static void line_col(const char *text, size_t off, long *line, long *col) {
  *line = 1, *col = 1;
  for (size_t i = 0; i < off; ++i) {
    if (text[i] == '\n')
      ++*line, *col = 1;
    else
      ++*col;
  }
}

pm_status pm_case_file_parse(const char *path, const char *text, size_t len, pm_model **model,
                             pm_sizing **size, pm_error *err) {
  *model = NULL;
  if (size) *size = NULL;
  if (!path) path = "(case file)";
  const char *nul = memchr(text, '\0', len);
  if (nul)
    return pm_error_setf(err, PM_ERR_PARSE, "%s: a NUL byte at byte %ld: not a text file", path,
                         (long)(nul - text));
  const char *end = NULL;
  cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
  if (!root) {
    const char *at = cJSON_GetErrorPtr();
    size_t off = at && at >= text && at <= text + len ? (size_t)(at - text) : 0;
    long line, col;
    line_col(text, off, &line, &col);
    return pm_error_setf(err, PM_ERR_PARSE, "%s: not valid JSON (line %ld, column %ld)", path, line,
                         col);
  }
  pm_status s = PM_OK;
  size_t off = end && end >= text && end <= text + len ? (size_t)(end - text) : len;
  while (off < len && strchr(" \t\r\n", text[off])) ++off;
  if (off < len) {
    long line, col;
    line_col(text, off, &line, &col);
    s = pm_error_setf(err, PM_ERR_PARSE,
                      "%s: text after the end of the JSON object (line %ld, column %ld)", path,
                      line, col);
  }
  static const char *const top_keys[] = {"name", "domain", "size"};
  static const char *const domain_keys[] = {"loops", "file", "case"};
  if (!s && !cJSON_IsObject(root))
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: a case file is a JSON object, not %s", path,
                      json_type(root));
  if (!s) s = check_keys(path, root, "the top level", top_keys, 3, err);
  const cJSON *domain = cJSON_GetObjectItemCaseSensitive(root, "domain");
  const cJSON *sz = cJSON_GetObjectItemCaseSensitive(root, "size");
  const cJSON *nm = cJSON_GetObjectItemCaseSensitive(root, "name");
  if (!s && nm && !cJSON_IsString(nm))
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"name\" must be a string, not %s", path, json_type(nm));
  if (!s && sz && !cJSON_IsNumber(sz) && !cJSON_IsString(sz))
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"size\" must be a number or an expression string, not %s",
                      path, json_type(sz));
  if (!s && !domain) s = pm_error_setf(err, PM_ERR_PARSE, "%s: missing object \"domain\"", path);
  if (!s && !cJSON_IsObject(domain))
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"domain\" must be an object, not %s", path,
                      json_type(domain));
  if (!s) s = check_keys(path, domain, "\"domain\"", domain_keys, 3, err);
  if (s) {
    cJSON_Delete(root);
    return s;
  }
  const cJSON *loops = cJSON_GetObjectItemCaseSensitive(domain, "loops");
  const cJSON *file = cJSON_GetObjectItemCaseSensitive(domain, "file");
  const cJSON *cas = cJSON_GetObjectItemCaseSensitive(domain, "case");
  char name[256];
  snprintf(name, sizeof name, "%s", cJSON_IsString(nm) ? nm->valuestring : path);
  pm_sizing *case_size = NULL;
  if ((loops != NULL) + (file != NULL) + (cas != NULL) != 1) {
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"domain\" needs exactly one of \"loops\", \"file\" or \"case\"",
                      path);
  } else if (loops) {
    s = planar_from_json(path, name, loops, model, err);
  } else if (file) {
    if (!cJSON_IsString(file) || !file->valuestring[0]) {
      s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"file\" must name a CAD file, not %s", path,
                        cJSON_IsString(file) ? "an empty string" : json_type(file));
    } else {
      const char *f = file->valuestring;
      char full[4096];
      const char *slash = strrchr(path, '/');
      if (f[0] == '/' || !slash)
        snprintf(full, sizeof full, "%s", f);
      else
        snprintf(full, sizeof full, "%.*s/%s", (int)(slash - path), path, f);
      s = is_cad(full) ? pm_cad_load(full, model, err)
                       : pm_error_setf(err, PM_ERR_PARSE,
                                       "%s: \"file\" must name a CAD file (.step .stp .iges .igs .brep)",
                                       path);
    }
  } else if (!cJSON_IsString(cas)) {
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: \"case\" must be a case name, not %s", path,
                      json_type(cas));
  } else {
    s = pm_case_open(cas->valuestring, model, sz ? NULL : &case_size, err);
    if (s) pm_error_prefix(err, "%s", path);
  }
  if (!s && sz) {
    char num[64];
    const char *txt = num;
    if (cJSON_IsNumber(sz))
      snprintf(num, sizeof num, "%.17g", sz->valuedouble);
    else
      txt = sz->valuestring;
    if ((s = pm_sizing_parse(txt, &case_size, err))) pm_error_prefix(err, "%s: \"size\"", path);
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

static pm_status open_case_file(const char *path, pm_model **model, pm_sizing **size,
                                pm_error *err) {
  char *text = NULL;
  size_t len = 0;
  pm_status s = read_file(path, &text, &len, err);
  if (s) return s;
  s = pm_case_file_parse(path, text, len, model, size, err);
  free(text);
  return s;
}

/* The model of a spec, without the timing. */
static pm_status open_spec(const char *spec, pm_model **model, pm_sizing **default_size,
                           pm_error *err) {
  if (strncmp(spec, "case:", 5) == 0) return pm_case_open(spec + 5, model, default_size, err);
  if (is_cad(spec)) return pm_cad_load(spec, model, err);
  if (has_ext(spec, ".json")) return open_case_file(spec, model, default_size, err);
  return pm_error_setf(err, PM_ERR_ARG,
                       "cannot tell what '%s' is: give a CAD file (.step .stp .iges .igs .brep), "
                       "case:NAME or a case file (.json)",
                       spec);
}

pm_status pm_input_open(const char *spec, pm_model **model, pm_sizing **default_size,
                        pm_error *err) {
  *model = NULL;
  if (default_size) *default_size = NULL;
  if (!spec || !spec[0]) return pm_error_setf(err, PM_ERR_ARG, "no input given");
  const double t0 = pm_seconds();
  pm_status s = open_spec(spec, model, default_size, err);
  if (!s) (*model)->time_open = pm_seconds() - t0;
  return s;
}
