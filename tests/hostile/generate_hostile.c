/* Writes the generated part of the hostile-input corpus: damaged copies of the valid files in
 * tests/data/hostile/seeds/, into tests/data/hostile/generated/ (see tests/data/hostile/README.md).
 *
 *   generate_hostile SEEDS_DIR OUT_DIR
 *
 * Every damage is drawn from one seeded generator (pm_rng, seed 22), so the output is the same on
 * every run; the files are committed, and test_hostile runs them. Damages:
 *   text files   cut short at 1/5 .. 4/5 of their length; a number replaced by one meant to
 *                break a reader (-5, 0, 2000000000, 1e308, nan, inf, an overflowing integer,
 *                a word); a line deleted or repeated; 32 random bytes inserted;
 *   binary files cut short; a 4- or 8-byte field overwritten with an extreme value; random
 *                bytes changed;
 *   case files   the text damages, and a brace, bracket, quote or colon deleted;
 *   CAD files    cut short, a line deleted or repeated (structural damage only: changing a
 *                number changes the geometry, which OpenCASCADE, not packmesh, interprets).
 */
#include <ctype.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/rng.h"

typedef struct text {
  char *s;
  size_t n;
} text;

static text slurp(const char *path) {
  text t = {NULL, 0};
  FILE *f = fopen(path, "rb");
  if (!f) return t;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  t.s = malloc((size_t)n + 1);
  t.n = fread(t.s, 1, (size_t)n, f);
  t.s[t.n] = '\0';
  fclose(f);
  return t;
}

static const char *out_dir;
static int written;

/* Write out_dir/<stem>.<tag><k>.<ext>. */
static void emit(const char *stem, const char *ext, const char *tag, int k, const char *data,
                 size_t n) {
  char path[1200];
  snprintf(path, sizeof path, "%s/%s.%s%d.%s", out_dir, stem, tag, k, ext);
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(data, 1, n, f) != n) {
    fprintf(stderr, "generate_hostile: cannot write %s\n", path);
    exit(1);
  }
  fclose(f);
  ++written;
}

/* Copy of t with [at, at + del) replaced by ins. */
static char *splice(const text *t, size_t at, size_t del, const char *ins, size_t nins, size_t *n) {
  *n = t->n - del + nins;
  char *r = malloc(*n + 1);
  memcpy(r, t->s, at);
  memcpy(r + at, ins, nins);
  memcpy(r + at + nins, t->s + at + del, t->n - at - del);
  r[*n] = '\0';
  return r;
}

static void cuts(const char *stem, const char *ext, const text *t, int count) {
  for (int k = 1; k <= count; ++k) emit(stem, ext, "cut", k, t->s, t->n * (size_t)k / (size_t)(count + 1));
}

/* Start offsets of the lines of t. */
static size_t lines(const text *t, size_t *start, size_t max) {
  size_t n = 0;
  for (size_t i = 0; i < t->n && n < max; ++i)
    if (i == 0 || t->s[i - 1] == '\n') start[n++] = i;
  return n;
}

static void line_damage(const char *stem, const char *ext, const text *t, pm_rng *rng, int del,
                        int dup) {
  size_t start[100000];
  size_t nl = lines(t, start, 100000);
  if (nl < 3) return;
  for (int k = 0; k < del + dup; ++k) {
    size_t l = 1 + (size_t)pm_rng_below(rng, nl - 2);
    size_t end = l + 1 < nl ? start[l + 1] : t->n, n;
    char *r = k < del ? splice(t, start[l], end - start[l], "", 0, &n)
                      : splice(t, start[l], 0, t->s + start[l], end - start[l], &n);
    emit(stem, ext, k < del ? "dropline" : "dupline", k < del ? k + 1 : k - del + 1, r, n);
    free(r);
  }
}

static void numbers(const char *stem, const char *ext, const text *t, pm_rng *rng, int count) {
  static const char *const bad[] = {"-5", "0", "2000000000", "1e308", "nan", "inf",
                                    "99999999999999999999", "x", "-1e308", "1e-320", "4294967297"};
  /* Number tokens: a digit run not inside a word. */
  size_t *at = malloc((t->n + 1) * sizeof *at), *len = malloc((t->n + 1) * sizeof *len), nt = 0;
  for (size_t i = 0; i < t->n;) {
    if (isdigit((unsigned char)t->s[i]) && (i == 0 || !isalpha((unsigned char)t->s[i - 1]))) {
      size_t j = i;
      while (j < t->n && (isalnum((unsigned char)t->s[j]) || t->s[j] == '.' || t->s[j] == '-' || t->s[j] == '+')) ++j;
      at[nt] = i, len[nt++] = j - i;
      i = j;
    } else {
      ++i;
    }
  }
  for (int k = 0; k < count && nt > 0; ++k) {
    size_t pick = (size_t)pm_rng_below(rng, nt);
    const char *b = bad[pm_rng_below(rng, sizeof bad / sizeof bad[0])];
    size_t n;
    char *r = splice(t, at[pick], len[pick], b, strlen(b), &n);
    emit(stem, ext, "num", k + 1, r, n);
    free(r);
  }
  free(at);
  free(len);
}

static void garbage(const char *stem, const char *ext, const text *t, pm_rng *rng) {
  char junk[32];
  for (int i = 0; i < 32; ++i) junk[i] = (char)pm_rng_below(rng, 256);
  size_t n;
  char *r = splice(t, (size_t)pm_rng_below(rng, t->n), 0, junk, sizeof junk, &n);
  emit(stem, ext, "junk", 1, r, n);
  free(r);
}

static void structure(const char *stem, const char *ext, const text *t, pm_rng *rng, int count) {
  size_t *at = malloc((t->n + 1) * sizeof *at), nt = 0;
  for (size_t i = 0; i < t->n; ++i)
    if (strchr("{}[]\":,", t->s[i])) at[nt++] = i;
  for (int k = 0; k < count && nt > 0; ++k) {
    size_t n;
    char *r = splice(t, at[pm_rng_below(rng, nt)], 1, "", 0, &n);
    emit(stem, ext, "punct", k + 1, r, n);
    free(r);
  }
  free(at);
}

static void binary(const char *stem, const char *ext, const text *t, pm_rng *rng) {
  cuts(stem, ext, t, 3);
  static const unsigned char vals[5][8] = {{0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff},
                                          {0xff, 0xff, 0xff, 0x7f, 0, 0, 0, 0},
                                          {0, 0, 0, 0x80, 0, 0, 0, 0},
                                          {0, 0, 0, 0, 0, 0, 0, 0},
                                          {0x00, 0x94, 0x35, 0x77, 0, 0, 0, 0}}; /* 2e9 */
  for (int k = 0; k < 5; ++k) {
    char *r = malloc(t->n);
    memcpy(r, t->s, t->n);
    size_t w = pm_rng_below(rng, 2) ? 8 : 4;
    size_t at = t->n > 120 ? 40 + 4 * (size_t)pm_rng_below(rng, (t->n - 120) / 4) : 0;
    memcpy(r + at, vals[k], w);
    emit(stem, ext, "field", k + 1, r, t->n);
    free(r);
  }
  for (int k = 0; k < 2; ++k) {
    char *r = malloc(t->n);
    memcpy(r, t->s, t->n);
    for (int c = 0; c < 4; ++c) r[pm_rng_below(rng, t->n)] = (char)pm_rng_below(rng, 256);
    emit(stem, ext, "bytes", k + 1, r, t->n);
    free(r);
  }
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: generate_hostile SEEDS_DIR OUT_DIR\n");
    return 2;
  }
  out_dir = argv[2];
  DIR *d = opendir(argv[1]);
  if (!d) {
    fprintf(stderr, "generate_hostile: cannot open %s\n", argv[1]);
    return 1;
  }
  /* Seeds in name order, so that the draws do not depend on the folder's order. */
  char names[256][256];
  int nn = 0;
  struct dirent *de;
  while ((de = readdir(d)) && nn < 256)
    if (de->d_name[0] != '.') snprintf(names[nn++], sizeof names[0], "%s", de->d_name);
  closedir(d);
  qsort(names, (size_t)nn, sizeof names[0], (int (*)(const void *, const void *))strcmp);
  pm_rng rng;
  pm_rng_init(&rng, 22, 0);
  for (int i = 0; i < nn; ++i) {
    char path[1200], stem[256];
    snprintf(path, sizeof path, "%.900s/%.255s", argv[1], names[i]);
    snprintf(stem, sizeof stem, "%.255s", names[i]);
    char *dot = strrchr(stem, '.');
    if (!dot) continue;
    *dot = '\0';
    const char *ext = dot + 1;
    text t = slurp(path);
    if (!t.s || t.n < 16) continue;
    int is_binary = strstr(stem, "bin") != NULL;
    int is_case = !strcmp(ext, "json");
    int is_cad = !strcmp(ext, "step") || !strcmp(ext, "igs") || !strcmp(ext, "brep");
    if (is_cad) {
      cuts(stem, ext, &t, 3);
      line_damage(stem, ext, &t, &rng, 2, 1);
    } else if (is_binary) {
      binary(stem, ext, &t, &rng);
    } else {
      cuts(stem, ext, &t, 4);
      numbers(stem, ext, &t, &rng, is_case ? 6 : 5);
      line_damage(stem, ext, &t, &rng, 1, 1);
      garbage(stem, ext, &t, &rng);
      if (is_case) structure(stem, ext, &t, &rng, 3);
    }
    free(t.s);
  }
  printf("%d files written to %s\n", written, out_dir);
  return 0;
}
