/* What a CAD file declares about itself (see cad_declared.h). */
#include "common/geom/cad_declared.h"

#include <ctype.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "common/geom/cad_probe.h"

/* ---- IGES ------------------------------------------------------------------------------------ */

/* An integer field of a fixed-column record: blanks and leading spaces allowed, 0 when blank;
 * -1 when it holds something else. */
static long field(const char *rec, size_t len, size_t col, size_t width) {
  long v = 0;
  int digits = 0;
  for (size_t i = col; i < col + width && i < len; ++i) {
    char c = rec[i];
    if (c == ' ') {
      if (digits) break;
      continue;
    }
    if (c == '+' && !digits) continue;
    if (c < '0' || c > '9') return -1;
    if (v > 100000000L) return -1;
    v = 10 * v + (c - '0');
    ++digits;
  }
  return v;
}

static pm_status iges(const char *path, const char *text, size_t len, pm_error *err) {
  static const char order[] = "SGDPT";
  long count[5] = {0, 0, 0, 0, 0};
  int last = 0; /* index in order[] of the last section seen */
  const char *t_rec = NULL;
  size_t t_len = 0;
  /* The Directory entries: (type, parameter pointer, parameter record count) of each, found in
   * a first pass; a second pass is not needed since the Parameter count is known at the end. */
  long nrec = 0, dline = 0, pending_type = 0, pending_ptr = 0;
  long bad_entry = -1, bad_type = 0, bad_lo = 0, bad_hi = 0;
  long *entry_lo = NULL, *entry_hi = NULL, *entry_type = NULL;
  size_t nentry = 0, cap = 0;
  pm_status s = PM_OK;
  for (size_t at = 0; at < len && !s;) {
    const char *rec = text + at;
    const char *nl = memchr(rec, '\n', len - at);
    size_t rl = nl ? (size_t)(nl - rec) : len - at;
    at += rl + 1;
    if (rl > 0 && rec[rl - 1] == '\r') --rl;
    ++nrec;
    size_t blank = 0;
    while (blank < rl && (rec[blank] == ' ' || rec[blank] == '\t')) ++blank;
    if (blank == rl) continue; /* blank lines (after the Terminate record, as some writers do) */
    if (nrec == 1 && rl >= 73 && (rec[72] == 'C' || rec[72] == 'B')) return PM_OK; /* compressed, binary */
    if (rl < 80 && !nl) {
      s = pm_error_setf(err, PM_ERR_PARSE,
                        "%s line %ld: the file ends inside an IGES record: it is truncated", path,
                        nrec);
      break;
    }
    if (rl < 73) {
      s = pm_error_setf(err, PM_ERR_PARSE,
                        "%s line %ld: not an 80-column IGES record (%zu characters)", path, nrec, rl);
      break;
    }
    const char *sec = strchr(order, rec[72]);
    if (!sec || !rec[72]) {
      s = pm_error_setf(err, PM_ERR_PARSE, "%s line %ld: unknown IGES section letter '%c'", path,
                        nrec, isprint((unsigned char)rec[72]) ? rec[72] : '?');
      break;
    }
    int k = (int)(sec - order);
    if (k < last) {
      s = pm_error_setf(err, PM_ERR_PARSE, "%s line %ld: a %c record after the %c section", path,
                        nrec, order[k], order[last]);
      break;
    }
    if (last == 4) {
      s = pm_error_setf(err, PM_ERR_PARSE, "%s line %ld: a record after the Terminate record", path,
                        nrec);
      break;
    }
    last = k;
    count[k]++;
    /* Columns 74-80 number the records of each section from 1: a record missing or repeated
     * shows there even where the counts were made to agree. */
    long seq = field(rec, rl, 73, 7);
    if (seq != count[k]) {
      s = pm_error_setf(err, PM_ERR_PARSE,
                        "%s line %ld: %c record number %ld where %ld is due: a record is missing, "
                        "repeated or damaged",
                        path, nrec, order[k], seq, count[k]);
      break;
    }
    if (k == 4) t_rec = rec, t_len = rl;
    if (k == 2) {
      /* Directory entry: type (columns 1-8) and parameter pointer (9-16) on its first record,
       * parameter record count (columns 25-32) on its second. */
      if (dline++ % 2 == 0) {
        pending_type = field(rec, rl, 0, 8);
        pending_ptr = field(rec, rl, 8, 8);
      } else {
        long n = field(rec, rl, 24, 8);
        if (nentry == cap) {
          size_t c = cap ? 2 * cap : 1024;
          long *lo = realloc(entry_lo, c * sizeof *lo);
          if (lo) entry_lo = lo;
          long *hi = lo ? realloc(entry_hi, c * sizeof *hi) : NULL;
          if (hi) entry_hi = hi;
          long *ty = hi ? realloc(entry_type, c * sizeof *ty) : NULL;
          if (!ty) {
            s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory reading %s", path);
            break;
          }
          entry_type = ty, cap = c;
        }
        if (pending_ptr < 0 || n < 0 || pending_type < 0) {
          if (bad_entry < 0) bad_entry = (long)nentry + 1, bad_type = pending_type, bad_lo = -1;
        }
        entry_type[nentry] = pending_type;
        entry_lo[nentry] = pending_ptr;
        entry_hi[nentry] = pending_ptr + n - 1;
        ++nentry;
      }
    }
  }
  if (!s && !t_rec)
    s = pm_error_setf(err, PM_ERR_PARSE,
                      "%s: the IGES file has no Terminate record: it is truncated (%ld Directory "
                      "and %ld Parameter records read)",
                      path, count[2], count[3]);
  if (!s) {
    static const char *const name[4] = {"Start", "Global", "Directory", "Parameter"};
    for (int k = 0; k < 4 && !s; ++k) {
      char letter = order[k];
      long declared = -1;
      for (size_t f = 0; f + 8 <= t_len && f < 32; f += 8)
        if (t_rec[f] == letter) declared = field(t_rec, t_len, f + 1, 7);
      if (declared < 0)
        s = pm_error_setf(err, PM_ERR_PARSE, "%s: the IGES Terminate record gives no %s count",
                          path, name[k]);
      else if (declared != count[k])
        s = pm_error_setf(err, PM_ERR_PARSE,
                          "%s: the IGES Terminate record declares %ld %s records, the file holds "
                          "%ld: it is truncated or damaged",
                          path, declared, name[k], count[k]);
    }
  }
  if (!s && count[2] % 2 != 0)
    s = pm_error_setf(err, PM_ERR_PARSE,
                      "%s: the IGES Directory has %ld records, not whole two-record entries", path,
                      count[2]);
  for (size_t i = 0; i < nentry && !s && bad_entry < 0; ++i)
    if (entry_lo[i] < 1 || entry_hi[i] < entry_lo[i] || entry_hi[i] > count[3])
      bad_entry = (long)i + 1, bad_type = entry_type[i], bad_lo = entry_lo[i], bad_hi = entry_hi[i];
  if (!s && bad_entry > 0) {
    if (bad_lo < 0)
      s = pm_error_setf(err, PM_ERR_PARSE, "%s: IGES Directory entry %ld has unreadable fields", path,
                        bad_entry);
    else
      s = pm_error_setf(err, PM_ERR_PARSE,
                        "%s: IGES Directory entry %ld (entity type %ld) has its parameters on "
                        "records %ld to %ld, the Parameter section has %ld: it is truncated or "
                        "damaged",
                        path, bad_entry, bad_type, bad_lo, bad_hi, count[3]);
  }
  free(entry_lo);
  free(entry_hi);
  free(entry_type);
  return s;
}

/* ---- STEP ------------------------------------------------------------------------------------ */

typedef struct ids {
  uint64_t *v;
  size_t n, cap;
} ids;

static int push(ids *a, uint64_t x) {
  if (a->n == a->cap) {
    size_t c = a->cap ? 2 * a->cap : 4096;
    uint64_t *p = realloc(a->v, c * sizeof *p);
    if (!p) return 0;
    a->v = p, a->cap = c;
  }
  a->v[a->n++] = x;
  return 1;
}

static int cmp_u64(const void *pa, const void *pb) {
  uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
  return (a > b) - (a < b);
}

/* Does text at i begin with keyword kw (case-insensitive), not followed by a letter, digit or
 * '-' (so "END-ISO-10303-21" is not "END")? */
static int keyword(const char *text, size_t len, size_t i, const char *kw) {
  size_t n = strlen(kw);
  if (len - i < n || strncasecmp(text + i, kw, n) != 0) return 0;
  if (i + n < len && (isalnum((unsigned char)text[i + n]) || text[i + n] == '-' || text[i + n] == '_'))
    return 0;
  return 1;
}

static long line_of(const char *text, size_t at) {
  long line = 1;
  for (size_t i = 0; i < at; ++i) line += text[i] == '\n';
  return line;
}

static pm_status step(const char *path, const char *text, size_t len, pm_error *err) {
  size_t i = 0;
  if (len >= 3 && (unsigned char)text[0] == 0xEF && (unsigned char)text[1] == 0xBB &&
      (unsigned char)text[2] == 0xBF)
    i = 3; /* a UTF-8 byte-order mark */
  while (i < len && isspace((unsigned char)text[i])) ++i;
  if (!keyword(text, len, i, "ISO-10303-21"))
    return pm_error_setf(err, PM_ERR_PARSE, "%s: not a STEP file: it does not begin with ISO-10303-21;",
                         path);
  ids def = {0}, ref = {0};
  pm_status s = PM_OK;
  int in_data = 0, ended = 0, data_sections = 0;
  size_t data_at = 0;
  /* Whether nothing of the statement being read has been read yet. */
  int at_start = 1;
  while (i < len && !s && !ended) {
    char c = text[i];
    if (c == '\'') { /* a string; '' is a quote inside it */
      for (++i; i < len; ++i)
        if (text[i] == '\'') {
          if (i + 1 < len && text[i + 1] == '\'')
            ++i;
          else
            break;
        }
      ++i;
      at_start = 0;
      continue;
    }
    if (c == '/' && i + 1 < len && text[i + 1] == '*') {
      const char *e = NULL;
      for (size_t k = i + 2; k + 1 < len; ++k)
        if (text[k] == '*' && text[k + 1] == '/') {
          e = text + k + 2;
          break;
        }
      i = e ? (size_t)(e - text) : len;
      continue;
    }
    if (isspace((unsigned char)c)) {
      ++i;
      continue;
    }
    if (c == ';') {
      at_start = 1;
      ++i;
      continue;
    }
    if (at_start && !in_data) {
      if (keyword(text, len, i, "DATA")) {
        in_data = 1;
        ++data_sections;
        data_at = i;
      } else if (keyword(text, len, i, "END-ISO-10303-21")) {
        ended = 1;
        break;
      }
    } else if (at_start && in_data && keyword(text, len, i, "ENDSEC")) {
      in_data = 0;
    }
    if (in_data && c == '#') {
      size_t k = i + 1;
      uint64_t id = 0;
      int digits = 0;
      while (k < len && isdigit((unsigned char)text[k]) && digits < 19) id = 10 * id + (uint64_t)(text[k++] - '0'), ++digits;
      if (digits) {
        size_t q = k;
        while (q < len && isspace((unsigned char)text[q])) ++q;
        int defines = at_start && q < len && text[q] == '=';
        if (!(defines ? push(&def, id) : push(&ref, id)))
          s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory reading %s", path);
        i = k;
        at_start = 0;
        continue;
      }
    }
    at_start = 0;
    ++i;
  }
  if (!s && in_data)
    s = pm_error_setf(err, PM_ERR_PARSE,
                      "%s: the STEP DATA section opened on line %ld is not closed by ENDSEC; "
                      "(the file is truncated)",
                      path, line_of(text, data_at));
  if (!s && !ended)
    s = pm_error_setf(err, PM_ERR_PARSE,
                      "%s: the STEP file does not end with END-ISO-10303-21; (it is truncated)", path);
  if (!s && data_sections == 0)
    s = pm_error_setf(err, PM_ERR_PARSE, "%s: the STEP file has no DATA section", path);
  if (!s) {
    if (def.n > 1) qsort(def.v, def.n, sizeof *def.v, cmp_u64);
    for (size_t k = 1; k < def.n && !s; ++k)
      if (def.v[k] == def.v[k - 1])
        s = pm_error_setf(err, PM_ERR_PARSE, "%s: STEP entity #%llu is defined twice", path,
                          (unsigned long long)def.v[k]);
    for (size_t k = 0; k < ref.n && !s; ++k)
      if (def.n == 0 || !bsearch(&ref.v[k], def.v, def.n, sizeof *def.v, cmp_u64))
        s = pm_error_setf(err, PM_ERR_PARSE,
                          "%s: STEP entity #%llu is referred to but not defined: the file is "
                          "damaged or incomplete",
                          path, (unsigned long long)ref.v[k]);
  }
  free(def.v);
  free(ref.v);
  return s;
}

/* ---- BREP ------------------------------------------------------------------------------------ */

/* The words of one line (CR LF or LF ended), at most `max`; their count. */
static int words(const char *line, size_t n, const char **w, size_t *wl, int max) {
  int k = 0;
  for (size_t i = 0; i < n && k < max;) {
    while (i < n && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= n) break;
    size_t j = i;
    while (j < n && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    w[k] = line + i, wl[k++] = j - i;
    i = j;
  }
  return k;
}

static pm_status brep(const char *path, const char *text, size_t len, pm_error *err) {
  long declared = -1, types = 0, stars = 0, line = 0, tline = 0;
  int root = 0;
  for (size_t at = 0; at < len;) {
    const char *rec = text + at;
    const char *nl = memchr(rec, '\n', len - at);
    size_t rl = nl ? (size_t)(nl - rec) : len - at;
    at += rl + 1;
    ++line;
    const char *w[4];
    size_t wl[4];
    int nw = words(rec, rl, w, wl, 4);
    if (declared < 0) {
      if (nw == 2 && wl[0] == 7 && !memcmp(w[0], "TShapes", 7)) {
        char *end;
        declared = strtol(w[1], &end, 10);
        if (end != w[1] + wl[1] || declared < 0)
          return pm_error_setf(err, PM_ERR_PARSE, "%s line %ld: unreadable TShapes count", path, line);
        tline = line;
      }
      continue;
    }
    if (types < declared || stars < types) {
      /* A record: its type alone on a line, ..., its sub-shapes ended by '*'. */
      static const char *const kinds[] = {"Ve", "Ed", "Wi", "Fa", "Sh", "So", "CS", "Co"};
      if (nw == 1 && wl[0] == 2)
        for (int k = 0; k < 8; ++k)
          if (!memcmp(w[0], kinds[k], 2)) {
            if (stars < types)
              return pm_error_setf(err, PM_ERR_PARSE,
                                   "%s line %ld: shape record %ld begins before record %ld ends "
                                   "(no '*'): the file is damaged",
                                   path, line, types + 1, types);
            ++types;
          }
      size_t e = rl;
      while (e > 0 && (rec[e - 1] == ' ' || rec[e - 1] == '\t' || rec[e - 1] == '\r')) --e;
      if (e > 0 && rec[e - 1] == '*') ++stars;
      continue;
    }
    /* After the records: the root shape, an orientation and two numbers ("+1 0"). */
    if (nw >= 2 && strchr("+-ie", w[0][0]) && wl[0] > 1) {
      root = 1;
      break;
    }
    if (nw > 0) break;
  }
  if (declared < 0)
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: the BREP file has no TShapes section: it is truncated or not an "
                         "OpenCASCADE BREP file",
                         path);
  if (types != declared || stars != declared)
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: the BREP TShapes section (line %ld) declares %ld shapes, the file "
                         "holds %ld: it is truncated or damaged",
                         path, tline, declared, stars < types ? stars : types);
  if (!root)
    return pm_error_setf(err, PM_ERR_PARSE,
                         "%s: the BREP file ends without its root shape: it is truncated", path);
  return PM_OK;
}

/* ---- entry points ---------------------------------------------------------------------------- */

static int ends_with(const char *path, const char *ext) {
  size_t n = strlen(path), e = strlen(ext);
  return n >= e && strcasecmp(path + n - e, ext) == 0;
}

pm_status pm_cad_check_declared_text(const char *path, pm_cad_kind kind, const char *text,
                                     size_t len, pm_error *err) {
  switch (kind) {
    case PM_CAD_STEP: return step(path, text, len, err);
    case PM_CAD_IGES: return iges(path, text, len, err);
    case PM_CAD_BREP: return brep(path, text, len, err);
  }
  return PM_OK;
}

pm_status pm_cad_check_declared(const char *path, pm_error *err) {
  pm_cad_kind kind;
  if (ends_with(path, ".step") || ends_with(path, ".stp"))
    kind = PM_CAD_STEP;
  else if (ends_with(path, ".iges") || ends_with(path, ".igs"))
    kind = PM_CAD_IGES;
  else if (ends_with(path, ".brep"))
    kind = PM_CAD_BREP;
  else
    return PM_OK;
  struct stat st;
  if (stat(path, &st) != 0)
    return pm_error_setf(err, PM_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
  if (!S_ISREG(st.st_mode)) return pm_error_setf(err, PM_ERR_IO, "%s: not a regular file", path);
  FILE *f = fopen(path, "rb");
  if (!f) return pm_error_setf(err, PM_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
  size_t len = (size_t)st.st_size;
  char *text = malloc(len ? len : 1);
  if (!text) {
    fclose(f);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory reading %s", path);
  }
  size_t got = fread(text, 1, len, f);
  fclose(f);
  pm_status s = got != len ? pm_error_setf(err, PM_ERR_IO, "%s: cannot read it whole", path)
                           : pm_cad_check_declared_text(path, kind, text, len, err);
  free(text);
  /* As geom_cad words what OpenCASCADE cannot read: "<file>: cannot parse the file: <why>". */
  if (s == PM_ERR_PARSE && err && strncmp(err->msg, path, strlen(path)) == 0) {
    char why[sizeof err->msg];
    const char *rest = err->msg + strlen(path);
    snprintf(why, sizeof why, "%s", rest[0] == ':' ? rest + 2 : rest + 1);
    pm_error_setf(err, PM_ERR_PARSE, "%s: cannot parse the file: %s", path, why);
  }
  /* What no count can tell: OpenCASCADE's BREP reader may never end on a damaged record. */
  if (!s && kind == PM_CAD_BREP) s = pm_cad_probe(path, "brep", err);
  return s;
}
