/* The figures of a study, drawn by gnuplot. Every figure is three files under plots/ that a user
 * can rerun or restyle: NAME.dat (the numbers, with a comment header naming the columns),
 * NAME.gp (the script: `gnuplot NAME.gp` in plots/ redraws NAME.svg, NAME.png and NAME.pdf) and
 * the drawings themselves.
 *
 * Figures:
 *   aspect_tri, aspect_tet   R / l_min (circumradius over shortest edge) on a log scale, one box
 *                            per method per case: min, p25, median, p75, max -- the box plots of
 *                            papers/001 Fig. 11 (a) and (b). The five numbers are computed here
 *                            with quality.h's percentile rule (not gnuplot's Tukey whiskers), so
 *                            the whiskers are the true min and max, as in the paper.
 *   radius_ratio_tri/_tet    radius ratio (2r/R, 3r/R), same layout, linear scale.
 *   min_angle_tri            minimum angle of each triangle; min_dihedral_tet for tets.
 *   time                     wall time of packmesh's run (time_s.total), mean over seeds with
 *                            min-max bars, log scale.
 *   convergence_CASE         from the runs' traces: eps_t, eps_g (papers/003 Table 1), mean
 *                            radius ratio (papers/004 Fig. 7) and node count against the step.
 *   sweep_CASE               with a sweep: metrics against the swept value, mean over seeds with
 *                            the min-max spread.
 * With a sweep, the box plots get one figure per case with the swept values along x.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/base/atomic_file.h"
#include "common/measure/quality.h"
#include "compare/src/study.h"

#define GNUPLOT_TIMEOUT_S 60
#define MAX_TRACE_POINTS 2000 /* a curve keeps at most this many points (every k-th row) */
/* Degenerate elements have aspect ratio PM_QUALITY_HUGE (quality.h); a log axis up to 1e100
 * would flatten every real box, so the axis stops here and the caption says so. */
#define ASPECT_AXIS_MAX 1e6

static const char *const palette[] = {"#1b9e77", "#d95f02", "#7570b3", "#e7298a",
                                      "#66a61e", "#e6ab02", "#a6761d", "#666666"};
#define NPALETTE 8

typedef struct plotctx {
  const pm_cmp_study *st;
  pm_cmp_figures *figs;
  char dir[4096]; /* plots/ */
  int have_gnuplot;
} plotctx;

/* ---- text buffers and files ---------------------------------------------------------------- */

typedef struct sbuf {
  char *s;
  size_t n, cap;
  int bad;
} sbuf;

#define SB(b, ...) ((b)->bad |= pm_cmp_appendf(&(b)->s, &(b)->n, &(b)->cap, __VA_ARGS__) != 0)

static pm_status write_text(const plotctx *P, const char *file, const sbuf *b, pm_error *err) {
  if (b->bad) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  char path[4400];
  snprintf(path, sizeof path, "%s/%s", P->dir, file);
  return pm_atomic_write(path, b->s ? b->s : "", b->s ? b->n : 0, err);
}

/* A label for gnuplot inside double quotes (the terminals are noenhanced: _ and ^ print as
 * they are). */
static void gp_quote(const char *in, char *out, size_t len) {
  size_t k = 0;
  for (; *in && k + 3 < len; ++in) {
    if (*in == '"' || *in == '\\') out[k++] = '\\';
    out[k++] = *in;
  }
  out[k] = '\0';
}

/* The script's head: the output stem, overridable (gnuplot -e "out='x'") so the harness can draw
 * under a temporary name and rename (no half-written figure), and the loop over formats. */
static void script_head(sbuf *g, const char *name, const char *title, const char *data_doc,
                        int width, int height) {
  SB(g, "# packmesh compare: %s\n", title);
  SB(g, "# Data: %s.dat -- %s\n", name, data_doc);
  SB(g, "# Redraw (in this folder): gnuplot %s.gp   -> %s.svg, %s.png, %s.pdf\n", name, name, name,
     name);
  SB(g, "if (!exists(\"out\")) out = \"%s\"\n", name);
  SB(g, "data = \"%s.dat\"\n", name);
  SB(g, "do for [fmt in \"svg png pdf\"] {\n");
  SB(g, "  if (fmt eq \"svg\") { set terminal svg size %d,%d dynamic noenhanced font \"Helvetica,13\" "
        "background rgb \"white\" }\n",
     width, height);
  SB(g, "  if (fmt eq \"png\") { set terminal pngcairo size %d,%d noenhanced font \"Helvetica,13\" "
        "background rgb \"white\" }\n",
     width * 4 / 3, height * 4 / 3);
  SB(g, "  if (fmt eq \"pdf\") { set terminal pdfcairo size %.2fin,%.2fin noenhanced font "
        "\"Helvetica,10\" }\n",
     width / 100.0, height / 100.0);
  SB(g, "  set output out.\".\".fmt\n");
  SB(g, "  reset\n");
  SB(g, "  set datafile missing \"?\"\n");
  SB(g, "  set grid ytics lc rgb \"#dddddd\"\n");
  SB(g, "  set border 3\n  set tics nomirror\n");
}

static void script_tail(sbuf *g) { SB(g, "  set output\n}\n"); }

static pm_cmp_figure *add_figure(plotctx *P, const char *name, const char *title,
                                 const char *caption) {
  pm_cmp_figures *F = P->figs;
  pm_cmp_figure *f = realloc(F->fig, (size_t)(F->n + 1) * sizeof *f);
  if (!f) return NULL;
  F->fig = f;
  f = &F->fig[F->n++];
  memset(f, 0, sizeof *f);
  snprintf(f->name, sizeof f->name, "%s", name);
  snprintf(f->title, sizeof f->title, "%s", title);
  snprintf(f->caption, sizeof f->caption, "%s", caption);
  return f;
}

/* Run gnuplot on NAME.gp with out='.tmp-NAME' and rename the three drawings into place. */
static void draw(plotctx *P, pm_cmp_figure *f) {
  if (!P->have_gnuplot) {
    snprintf(f->error, sizeof f->error, "gnuplot is not installed");
    return;
  }
  char gp[256], expr[300], logp[4400];
  snprintf(gp, sizeof gp, "%s.gp", f->name);
  snprintf(expr, sizeof expr, "out='.tmp-%s'", f->name);
  snprintf(logp, sizeof logp, "%s/.%s.log", P->dir, f->name);
  char *argv[] = {"gnuplot", "-e", expr, gp, NULL};
  int ws = 0, to = 0;
  static const char *const ext[] = {"svg", "png", "pdf"};
  /* gnuplot's drawings and log are temporaries until renamed (or kept, the log of a failure):
   * a signal removes them. */
  int track[4];
  for (int k = 0; k < 3; ++k) {
    char tmp[4400];
    snprintf(tmp, sizeof tmp, "%s/.tmp-%s.%s", P->dir, f->name, ext[k]);
    track[k] = pm_tmp_track(tmp, 0);
  }
  track[3] = pm_tmp_track(logp, 0);
  int rc = pm_cmp_run_program(argv, P->dir, NULL, logp, GNUPLOT_TIMEOUT_S, &ws, &to);
  int ok = rc == 0 && !to && WIFEXITED(ws) && WEXITSTATUS(ws) == 0;
  if (!ok) {
    char *log = pm_cmp_read_file(logp, NULL);
    /* gnuplot's message is its last non-empty line. */
    char msg[400] = "";
    if (log) {
      char *line = strtok(log, "\n");
      while (line) {
        if (line[strspn(line, " ^")]) snprintf(msg, sizeof msg, "%s", line);
        line = strtok(NULL, "\n");
      }
      free(log);
    }
    snprintf(f->error, sizeof f->error, "gnuplot %s%s%s",
             to ? "timed out" : (rc ? "could not run" : "failed"), msg[0] ? ": " : "", msg);
  }
  for (int k = 0; k < 3; ++k) {
    char tmp[4400], fin[4400];
    snprintf(tmp, sizeof tmp, "%s/.tmp-%s.%s", P->dir, f->name, ext[k]);
    snprintf(fin, sizeof fin, "%s/%s.%s", P->dir, f->name, ext[k]);
    struct stat sb;
    if (ok && stat(tmp, &sb) == 0 && sb.st_size > 0) {
      if (rename(tmp, fin) != 0) ok = 0;
    } else {
      unlink(tmp);
      if (ok) {
        ok = 0;
        snprintf(f->error, sizeof f->error, "gnuplot wrote no %s file", ext[k]);
      }
    }
  }
  if (ok) unlink(logp);
  for (int k = 0; k < 4; ++k) pm_tmp_untrack(track[k]);
  f->drawn = ok;
}

/* ---- groups -------------------------------------------------------------------------------- */

/* Does row r belong to (case c, method m, sweep value w)? w < 0: any sweep value. */
static int row_in(const pm_cmp_row *r, int c, int m, int w) {
  return r->icase == c && r->imethod == m && (w < 0 || r->isweep == w);
}

static int has_elements(const pm_cmp_study *st, int c, int m, int w) {
  for (int i = 0; i < st->nrow; ++i)
    if (row_in(&st->rows[i], c, m, w) && st->rows[i].status == PM_CMP_OK &&
        st->rows[i].elements_ok)
      return 1;
  return 0;
}

/* Five numbers of the pooled per-element values of one group; 0 when there are none. */
static int group_summary(const pm_cmp_study *st, int c, int m, int w, const char *kind,
                         const char *column, pm_summary *out, pm_error *err, pm_status *s) {
  double *v = NULL;
  size_t n = 0, cap = 0;
  for (int i = 0; i < st->nrow && !*s; ++i)
    if (row_in(&st->rows[i], c, m, w))
      *s = pm_cmp_row_elements(st, &st->rows[i], kind, column, &v, &n, &cap, err);
  int got = 0;
  if (!*s && n > 0 && !(*s = pm_sort_doubles(v, n, err))) {
    out->n = (int64_t)n;
    out->min = v[0];
    out->max = v[n - 1];
    out->p25 = pm_percentile_sorted(v, n, 0.25);
    out->median = pm_percentile_sorted(v, n, 0.5);
    out->p75 = pm_percentile_sorted(v, n, 0.75);
    got = 1;
  }
  free(v);
  return got;
}

/* ---- box plots ----------------------------------------------------------------------------- */

typedef struct boxspec {
  const char *name, *title, *kind, *column, *ylabel;
  int logscale;
  double ref;        /* a dashed reference line (the equilateral / regular value), 0: none */
  const char *ref_label;
} boxspec;

/* One box plot: clusters along x (cases, or the sweep values of case `only_case`), one box per
 * method in each cluster. Returns 0 when there is nothing to draw. */
static pm_status boxplot(plotctx *P, const boxspec *b, int only_case, pm_error *err) {
  const pm_cmp_study *st = P->st;
  const pm_cmp_suite *su = &st->suite;
  int sweep = only_case >= 0;
  int ncl = sweep ? su->nsweep : su->ncase, nm = su->nmethod;
  sbuf d = {0}, g = {0};
  pm_status s = PM_OK;
  double top = 0;
  int block = 0, any = 0;
  int *blocks = calloc((size_t)nm, sizeof *blocks);
  if (!blocks) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  /* The five numbers of every (cluster, method) first; clusters without any data (a surface
   * case in a tet figure) are left out of the axis. */
  pm_summary *sum = calloc((size_t)ncl * nm + 1, sizeof *sum);
  int *got = calloc((size_t)ncl * nm + 1, sizeof *got), *xpos = calloc((size_t)ncl + 1, sizeof *xpos);
  if (!sum || !got || !xpos) {
    free(sum), free(got), free(xpos), free(blocks);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  int nshown = 0;
  for (int k = 0; k < ncl && !s; ++k) {
    int c = sweep ? only_case : k, w = sweep ? k : -1, here = 0;
    for (int m = 0; m < nm && !s; ++m)
      if (has_elements(st, c, m, w))
        here |= got[k * nm + m] = group_summary(st, c, m, w, b->kind, b->column, &sum[k * nm + m], err, &s);
    xpos[k] = here ? nshown++ : -1;
  }
  SB(&d, "# %s\n# one block per method (blocks separated by two blank lines, in the order of "
         "the plot command)\n# x  min  p25  median  p75  max  n  cluster\n",
     b->title);
  for (int m = 0; m < nm && !s; ++m) {
    int rows = 0;
    for (int k = 0; k < ncl; ++k) {
      if (!got[k * nm + m]) continue;
      const pm_summary *sm = &sum[k * nm + m];
      if (!rows) SB(&d, "# method %s\n", su->methods[m].label);
      double x = xpos[k] * (nm + 1) + m + 1;
      char cl[256];
      snprintf(cl, sizeof cl, "%s", sweep ? su->sweep_values[k] : su->cases[k].name);
      for (char *q = cl; *q; ++q)
        if (*q == ' ' || *q == '"') *q = '_';
      SB(&d, "%g %.9g %.9g %.9g %.9g %.9g %lld %s\n", x, sm->min, sm->p25, sm->median, sm->p75,
         sm->max, (long long)sm->n, cl);
      if (sm->max > top) top = sm->max;
      rows++;
    }
    if (rows) {
      SB(&d, "\n\n");
      blocks[m] = ++block;
      any = 1;
    }
  }
  free(sum);
  free(got);
  if (s || !any) {
    free(blocks);
    free(xpos);
    free(d.s);
    return s;
  }
  char name[160], title[400];
  if (sweep) {
    snprintf(name, sizeof name, "%s_%s", b->name, su->cases[only_case].name);
    for (char *q = name; *q; ++q)
      if (!((*q >= 'a' && *q <= 'z') || (*q >= 'A' && *q <= 'Z') || (*q >= '0' && *q <= '9') || *q == '_' || *q == '-'))
        *q = '_';
    snprintf(title, sizeof title, "%s, %s, against %s", b->title, su->cases[only_case].name,
             su->sweep_key);
  } else {
    snprintf(name, sizeof name, "%s", b->name);
    snprintf(title, sizeof title, "%s", b->title);
  }
  int width = 300 + 26 * nshown * (nm + 1);
  if (width < 800) width = 800;
  if (width > 1800) width = 1800;
  script_head(&g, name, title,
              "x, min, p25, median, p75, max, element count, cluster; one block per method", width,
              520);
  char q[512];
  gp_quote(title, q, sizeof q);
  SB(&g, "  set title \"%s\"\n", q);
  gp_quote(b->ylabel, q, sizeof q);
  SB(&g, "  set ylabel \"%s\"\n", q);
  if (sweep) {
    gp_quote(su->sweep_key, q, sizeof q);
    SB(&g, "  set xlabel \"%s\"\n", q);
  }
  SB(&g, "  set key outside right top\n");
  SB(&g, "  set boxwidth 0.7 absolute\n");
  SB(&g, "  set style fill solid 0.45 border -1\n");
  if (b->logscale) {
    SB(&g, "  set logscale y\n");
    SB(&g, "  set format y \"%%g\"\n");
    /* A narrow log range has one decade tic at most: label the usual values. */
    SB(&g, "  set ytics (0.5, 0.6, 0.7, 0.8, 0.9, 1, 1.2, 1.5, 2, 3, 5, 10, 20, 50, 100, 1000, "
           "1e4, 1e5, 1e6)\n");
    /* No element goes below the ideal value (0.577 triangles, 0.612 tets): start near it. */
    if (top > ASPECT_AXIS_MAX)
      SB(&g, "  set yrange [0.5:%g]  # degenerate elements (1e100) go beyond the top\n",
         ASPECT_AXIS_MAX);
    else /* just above the largest whisker, not the next decade */
      SB(&g, "  set yrange [0.5:%.3g]\n", top * 1.25 > 1 ? top * 1.25 : 1);
  }
  SB(&g, "  set xrange [0:%d]\n", nshown * (nm + 1));
  SB(&g, "  set xtics (");
  for (int k = 0, first = 1; k < ncl; ++k) {
    if (xpos[k] < 0) continue;
    gp_quote(sweep ? su->sweep_values[k] : su->cases[k].name, q, sizeof q);
    SB(&g, "%s\"%s\" %g", first ? "" : ", ", q, xpos[k] * (nm + 1) + (nm + 1) / 2.0);
    first = 0;
  }
  SB(&g, ") scale 0\n");
  SB(&g, "  plot \\\n");
  int first = 1;
  for (int m = 0; m < nm; ++m) {
    if (!blocks[m]) continue;
    gp_quote(su->methods[m].label, q, sizeof q);
    SB(&g, "%s    data index %d using 1:3:2:6:5 with candlesticks whiskerbars 0.5 lc rgb \"%s\" "
           "lw 1.5 title \"%s\", \\\n"
           "    data index %d using 1:4:4:4:4 with candlesticks lc rgb \"black\" lw 2.5 notitle",
       first ? "" : ", \\\n", blocks[m] - 1, palette[m % NPALETTE], q, blocks[m] - 1);
    first = 0;
  }
  /* The ideal value as a dashed line named in the key (a label on the plot would sit on the
   * boxes). */
  if (b->ref > 0) {
    gp_quote(b->ref_label, q, sizeof q);
    SB(&g, ", \\\n    %.9g with lines dt 2 lc rgb \"#888888\" title \"%s\"", b->ref, q);
  }
  SB(&g, "\n");
  script_tail(&g);
  char file[200];
  snprintf(file, sizeof file, "%s.dat", name);
  if (!(s = write_text(P, file, &d, err))) {
    snprintf(file, sizeof file, "%s.gp", name);
    s = write_text(P, file, &g, err);
  }
  free(d.s);
  free(g.s);
  free(blocks);
  free(xpos);
  if (s) return s;
  char cap[1024];
  snprintf(cap, sizeof cap,
           "Per element, pooled over the seeds%s: the box spans p25 to p75 with the median as "
           "a black bar, the whiskers reach the minimum and the maximum%s.",
           sweep ? "" : (su->nsweep ? " and the swept values" : ""),
           b->logscale && top > ASPECT_AXIS_MAX
               ? "; degenerate elements (aspect ratio 1e100) lie beyond the top of the axis"
               : "");
  pm_cmp_figure *f = add_figure(P, name, title, cap);
  if (!f) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  draw(P, f);
  return PM_OK;
}

/* ---- time bars ----------------------------------------------------------------------------- */

static pm_status time_bars(plotctx *P, pm_error *err) {
  const pm_cmp_study *st = P->st;
  const pm_cmp_suite *su = &st->suite;
  int nm = su->nmethod, ncl = su->ncase;
  sbuf d = {0}, g = {0};
  int block = 0;
  int *blocks = calloc((size_t)nm, sizeof *blocks);
  if (!blocks) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  SB(&d, "# time of packmesh mesh (stats time_s.total) per case and method over the successful "
         "runs\n# x  mean  min  max  runs  case\n");
  for (int m = 0; m < nm; ++m) {
    int rows = 0;
    for (int c = 0; c < ncl; ++c) {
      double sum = 0, lo = INFINITY, hi = -INFINITY;
      int n = 0;
      for (int i = 0; i < st->nrow; ++i) {
        const pm_cmp_row *r = &st->rows[i];
        if (!row_in(r, c, m, -1)) continue;
        double t = pm_cmp_row_value(r, "time_s.total");
        if (!isfinite(t)) continue;
        /* A log axis cannot show 0: a run timed at 0 s is drawn at 1 ms. */
        if (t < 1e-3) t = 1e-3;
        sum += t;
        lo = fmin(lo, t);
        hi = fmax(hi, t);
        n++;
      }
      if (!n) continue;
      if (!rows) SB(&d, "# method %s\n", su->methods[m].label);
      SB(&d, "%g %.6g %.6g %.6g %d %s\n", (double)(c * (nm + 1) + m + 1), sum / n, lo, hi, n,
         su->cases[c].name);
      rows++;
    }
    if (rows) {
      SB(&d, "\n\n");
      blocks[m] = ++block;
    }
  }
  pm_status s = PM_OK;
  if (!block) goto done;
  int width = 300 + 26 * ncl * (nm + 1);
  if (width < 800) width = 800;
  if (width > 1800) width = 1800;
  script_head(&g, "time", "time per run", "x, mean, min, max, runs, case; one block per method",
              width, 480);
  SB(&g, "  set title \"time of packmesh mesh per run (mean over seeds, bars: min to max)\"\n");
  SB(&g, "  set ylabel \"seconds\"\n  set logscale y\n  set format y \"%%g\"\n");
  SB(&g, "  set key outside right top\n  set boxwidth 0.7 absolute\n");
  SB(&g, "  set style fill solid 0.6 border -1\n  set xrange [0:%d]\n", ncl * (nm + 1));
  SB(&g, "  set xtics (");
  char q[512];
  for (int c = 0; c < ncl; ++c) {
    gp_quote(su->cases[c].name, q, sizeof q);
    SB(&g, "%s\"%s\" %g", c ? ", " : "", q, c * (nm + 1) + (nm + 1) / 2.0);
  }
  SB(&g, ") scale 0\n  plot \\\n");
  int first = 1;
  for (int m = 0; m < nm; ++m) {
    if (!blocks[m]) continue;
    gp_quote(su->methods[m].label, q, sizeof q);
    SB(&g, "%s    data index %d using 1:2 with boxes lc rgb \"%s\" title \"%s\", \\\n"
           "    data index %d using 1:2:3:4 with yerrorbars lc rgb \"black\" pt 7 ps 0 notitle",
       first ? "" : ", \\\n", blocks[m] - 1, palette[m % NPALETTE], q, blocks[m] - 1);
    first = 0;
  }
  SB(&g, "\n");
  script_tail(&g);
  if ((s = write_text(P, "time.dat", &d, err)) || (s = write_text(P, "time.gp", &g, err))) goto done;
  pm_cmp_figure *f = add_figure(P, "time", "time per run",
                                "time_s.total of each run's stats (reading the input, placing "
                                "nodes, connecting, measuring), mean over the seeds; the bars "
                                "span the fastest and the slowest run.");
  if (!f) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  draw(P, f);
done:
  free(blocks);
  free(d.s);
  free(g.s);
  return s;
}

/* ---- convergence curves from traces -------------------------------------------------------- */

typedef struct trace {
  int ncol;
  char **name;
  double *v; /* [nrow * ncol] */
  long nrow;
} trace;

static void trace_free(trace *t) {
  for (int i = 0; i < t->ncol; ++i) free(t->name[i]);
  free(t->name);
  free(t->v);
  memset(t, 0, sizeof *t);
}

static int trace_read(const char *path, trace *t) {
  memset(t, 0, sizeof *t);
  char *text = pm_cmp_read_file(path, NULL);
  if (!text) return 0;
  char *save = NULL;
  char *line = strtok_r(text, "\n", &save);
  if (!line) {
    free(text);
    return 0;
  }
  for (char *c = line; *c; ++c) t->ncol += *c == ',';
  t->ncol += line[strspn(line, " \r")] != '\0';
  if (t->ncol <= 0) {
    free(text);
    return 0;
  }
  t->name = calloc((size_t)t->ncol, sizeof *t->name);
  if (!t->name) {
    free(text);
    return 0;
  }
  char *f = line;
  for (int c = 0; c < t->ncol; ++c) {
    char *comma = strchr(f, ',');
    if (comma) *comma = '\0';
    f[strcspn(f, "\r")] = '\0';
    if (*f == '"') { /* a quoted name: drop the quotes */
      ++f;
      f[strcspn(f, "\"")] = '\0';
    }
    t->name[c] = malloc(strlen(f) + 1);
    if (t->name[c]) strcpy(t->name[c], f);
    f = comma ? comma + 1 : f + strlen(f);
  }
  long cap = 0;
  while ((line = strtok_r(NULL, "\n", &save))) {
    if (t->nrow == cap) {
      cap = cap ? 2 * cap : 1024;
      double *v = realloc(t->v, (size_t)cap * t->ncol * sizeof *v);
      if (!v) break;
      t->v = v;
    }
    char *p = line;
    for (int c = 0; c < t->ncol; ++c) {
      char *end;
      double x = strtod(p, &end);
      t->v[t->nrow * t->ncol + c] = end == p ? NAN : x;
      p = strchr(end, ',');
      if (!p) {
        for (int k = c + 1; k < t->ncol; ++k) t->v[t->nrow * t->ncol + k] = NAN;
        break;
      }
      ++p;
    }
    t->nrow++;
  }
  free(text);
  return t->nrow > 0;
}

/* The trace column of a quantity. Methods name their columns (trace.h); these are the names
 * they use for the four curves, matched loosely: the first column whose name contains one of
 * the patterns, in order. */
static int trace_col(const trace *t, const char *const *patterns) {
  for (int p = 0; patterns[p]; ++p)
    for (int c = 0; c < t->ncol; ++c)
      if (t->name[c] && strstr(t->name[c], patterns[p])) return c;
  return -1;
}

static const char *const pat_step[] = {"iteration", "step", "iter", "round", NULL};
static const char *const pat_eps_t[] = {"eps_t", NULL};
static const char *const pat_eps_g[] = {"eps_g", NULL};
static const char *const pat_rr[] = {"radius_ratio_mean", "mean_radius_ratio", "radius_ratio",
                                     "rr_mean", NULL};
static const char *const pat_nodes[] = {"nodes", "particles", "bubbles", NULL};

static pm_status convergence(plotctx *P, int c, pm_error *err) {
  const pm_cmp_study *st = P->st;
  const pm_cmp_suite *su = &st->suite;
  sbuf d = {0}, g = {0};
  int block = 0;
  int have[4] = {0, 0, 0, 0};
  int *blocks = calloc((size_t)su->nmethod, sizeof *blocks);
  if (!blocks) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  SB(&d, "# convergence of the runs on %s: one block per method (its first successful run with "
         "a trace)\n# step  eps_t  eps_g  mean_radius_ratio  nodes   (? = not traced)\n",
     su->cases[c].name);
  for (int m = 0; m < su->nmethod; ++m) {
    for (int i = 0; i < st->nrow; ++i) {
      const pm_cmp_row *r = &st->rows[i];
      if (!row_in(r, c, m, -1) || r->status != PM_CMP_OK) continue;
      char path[4400];
      snprintf(path, sizeof path, "%s/runs/%s/trace.csv", st->dir, r->id);
      trace t;
      if (!trace_read(path, &t)) {
        trace_free(&t);
        continue;
      }
      int cs = trace_col(&t, pat_step);
      int cols[4] = {trace_col(&t, pat_eps_t), trace_col(&t, pat_eps_g), trace_col(&t, pat_rr),
                     trace_col(&t, pat_nodes)};
      if (cols[0] < 0 && cols[1] < 0 && cols[2] < 0 && cols[3] < 0) {
        trace_free(&t);
        continue;
      }
      SB(&d, "# method %s, run %s\n", su->methods[m].label, r->id);
      long stride = t.nrow > MAX_TRACE_POINTS ? (t.nrow + MAX_TRACE_POINTS - 1) / MAX_TRACE_POINTS : 1;
      for (long k = 0; k < t.nrow; ++k) {
        if (k % stride && k != t.nrow - 1) continue;
        const double *row = t.v + k * t.ncol;
        double x = cs >= 0 ? row[cs] : (double)k;
        SB(&d, "%.9g", x);
        for (int q = 0; q < 4; ++q) {
          double y = cols[q] >= 0 ? row[cols[q]] : NAN;
          if (isfinite(y)) {
            SB(&d, " %.9g", y);
            have[q] = 1;
          } else {
            SB(&d, " ?");
          }
        }
        SB(&d, "\n");
      }
      SB(&d, "\n\n");
      blocks[m] = ++block;
      trace_free(&t);
      break;
    }
  }
  pm_status s = PM_OK;
  if (!block) goto done;
  char name[160], title[300], q[512];
  snprintf(name, sizeof name, "convergence_%s", su->cases[c].name);
  for (char *p = name; *p; ++p)
    if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || *p == '_' || *p == '-'))
      *p = '_';
  snprintf(title, sizeof title, "convergence on %s", su->cases[c].name);
  script_head(&g, name, title, "step, eps_t, eps_g, mean radius ratio, nodes; one block per method",
              1000, 700);
  static const char *const ylab[4] = {"eps_t (topological irregularity)",
                                      "eps_g (geometric irregularity)", "mean radius ratio",
                                      "nodes"};
  int npanel = have[0] + have[1] + have[2] + have[3];
  gp_quote(title, q, sizeof q);
  SB(&g, "  set multiplot layout %d,%d title \"%s\"\n", npanel > 2 ? 2 : 1, npanel > 1 ? 2 : 1, q);
  SB(&g, "  set xlabel \"step\"\n");
  for (int p = 0; p < 4; ++p) {
    if (!have[p]) continue;
    /* The radius ratio rises: its key goes where its curves are not. */
    SB(&g, "  set key %s right\n", p == 2 ? "bottom" : "top");
    SB(&g, "  set ylabel \"%s\"\n  plot \\\n", ylab[p]);
    int first = 1;
    for (int m = 0; m < su->nmethod; ++m) {
      if (!blocks[m]) continue;
      gp_quote(su->methods[m].label, q, sizeof q);
      SB(&g, "%s    data index %d using 1:%d with lines lw 2 lc rgb \"%s\" title \"%s\"",
         first ? "" : ", \\\n", blocks[m] - 1, p + 2, palette[m % NPALETTE], q);
      first = 0;
    }
    SB(&g, "\n");
  }
  SB(&g, "  unset multiplot\n");
  script_tail(&g);
  char file[200];
  snprintf(file, sizeof file, "%s.dat", name);
  if ((s = write_text(P, file, &d, err))) goto done;
  snprintf(file, sizeof file, "%s.gp", name);
  if ((s = write_text(P, file, &g, err))) goto done;
  pm_cmp_figure *f = add_figure(P, name, title,
                                "Per step of each method's first successful run (its --trace): "
                                "topological and geometric irregularity (papers/003 eq. 8-9, "
                                "Table 1), the mean radius ratio (papers/004 Fig. 7) and the node "
                                "count. Methods without a trace (direct meshers) have no curve.");
  if (!f) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  draw(P, f);
done:
  free(blocks);
  free(d.s);
  free(g.s);
  return s;
}

/* ---- sweeps -------------------------------------------------------------------------------- */

static pm_status sweep_plot(plotctx *P, int c, pm_error *err) {
  const pm_cmp_study *st = P->st;
  const pm_cmp_suite *su = &st->suite;
  /* Numeric sweep values give a numeric axis (log when they span more than 50x). */
  int numeric = 1;
  double lo = INFINITY, hi = -INFINITY;
  for (int w = 0; w < su->nsweep; ++w) {
    char *end;
    double x = strtod(su->sweep_values[w], &end);
    if (end == su->sweep_values[w] || *end || !isfinite(x)) numeric = 0;
    lo = fmin(lo, x);
    hi = fmax(hi, x);
  }
  int logx = numeric && lo > 0 && hi / lo > 50;
  const char *kind = su->cases[c].volume ? "tet" : "tri";
  struct {
    char key[64];
    const char *label;
  } metrics[6] = {{"", "mean radius ratio"}, {"", "min radius ratio"}, {"", "eps_t"},
                  {"nodes", "nodes"},        {"iterations", "iterations"},
                  {"time_s.total", "time (s)"}};
  /* Triangles for surface runs; tets when the case is meshed as a volume. */
  snprintf(metrics[0].key, sizeof metrics[0].key, "%s.radius_ratio.mean", kind);
  snprintf(metrics[1].key, sizeof metrics[1].key, "%s.radius_ratio.min", kind);
  snprintf(metrics[2].key, sizeof metrics[2].key, "%s.eps_t", kind);
  sbuf d = {0}, g = {0};
  int block = 0;
  int *blocks = calloc((size_t)su->nmethod, sizeof *blocks);
  if (!blocks) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  SB(&d, "# %s against %s on %s, over the seeds: for each metric its mean, min and max\n# x",
     "metrics", su->sweep_key, su->cases[c].name);
  for (int k = 0; k < 6; ++k) SB(&d, "  %s(mean min max)", metrics[k].key);
  SB(&d, "  value\n");
  for (int m = 0; m < su->nmethod; ++m) {
    int rows = 0;
    for (int w = 0; w < su->nsweep; ++w) {
      double mean[6], mn[6], mx[6];
      int cnt[6], any = 0;
      for (int k = 0; k < 6; ++k) mean[k] = 0, mn[k] = INFINITY, mx[k] = -INFINITY, cnt[k] = 0;
      for (int i = 0; i < st->nrow; ++i) {
        const pm_cmp_row *r = &st->rows[i];
        if (!row_in(r, c, m, w) || r->status != PM_CMP_OK) continue;
        for (int k = 0; k < 6; ++k) {
          double v = pm_cmp_row_value(r, metrics[k].key);
          if (!isfinite(v)) continue;
          mean[k] += v;
          mn[k] = fmin(mn[k], v);
          mx[k] = fmax(mx[k], v);
          cnt[k]++;
          any = 1;
        }
      }
      if (!any) continue;
      if (!rows) SB(&d, "# method %s\n", su->methods[m].label);
      if (numeric)
        SB(&d, "%s", su->sweep_values[w]);
      else
        SB(&d, "%d", w);
      for (int k = 0; k < 6; ++k) {
        if (cnt[k])
          SB(&d, " %.9g %.9g %.9g", mean[k] / cnt[k], mn[k], mx[k]);
        else
          SB(&d, " ? ? ?");
      }
      char v[256];
      snprintf(v, sizeof v, "%s", su->sweep_values[w]);
      for (char *p = v; *p; ++p)
        if (*p == ' ' || *p == '"') *p = '_';
      SB(&d, " %s\n", v);
      rows++;
    }
    if (rows) {
      SB(&d, "\n\n");
      blocks[m] = ++block;
    }
  }
  pm_status s = PM_OK;
  if (!block) goto done;
  char name[160], title[300], q[512];
  snprintf(name, sizeof name, "sweep_%s", su->cases[c].name);
  for (char *p = name; *p; ++p)
    if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || *p == '_' || *p == '-'))
      *p = '_';
  snprintf(title, sizeof title, "%s on %s", su->sweep_key, su->cases[c].name);
  script_head(&g, name, title,
              "swept value, then mean, min and max over the seeds of six metrics; one block "
              "per method",
              1200, 760);
  gp_quote(title, q, sizeof q);
  SB(&g, "  set multiplot layout 2,3 title \"%s (mean over seeds; bars: min to max)\"\n", q);
  gp_quote(su->sweep_key, q, sizeof q);
  SB(&g, "  set xlabel \"%s\"\n  set key top right font \",10\"\n", q);
  if (logx) SB(&g, "  set logscale x\n  set format x \"%%g\"\n");
  if (!numeric) SB(&g, "  set xrange [-0.5:%d]\n", su->nsweep - 1 + 1);
  for (int k = 0; k < 6; ++k) {
    gp_quote(metrics[k].label, q, sizeof q);
    SB(&g, "  set ylabel \"%s\"\n  plot \\\n", q);
    int first = 1;
    for (int m = 0; m < su->nmethod; ++m) {
      if (!blocks[m]) continue;
      char lq[256];
      gp_quote(su->methods[m].label, lq, sizeof lq);
      int col = 2 + 3 * k;
      SB(&g, "%s    data index %d using 1:%d:%d:%d%s with yerrorlines lw 1.5 pt 7 ps 0.6 lc rgb "
             "\"%s\" title \"%s\"",
         first ? "" : ", \\\n", blocks[m] - 1, col, col + 1, col + 2,
         numeric ? "" : ":xticlabels(20)", palette[m % NPALETTE], lq);
      first = 0;
    }
    SB(&g, "\n");
  }
  SB(&g, "  unset multiplot\n");
  script_tail(&g);
  char file[200];
  snprintf(file, sizeof file, "%s.dat", name);
  if ((s = write_text(P, file, &d, err))) goto done;
  snprintf(file, sizeof file, "%s.gp", name);
  if ((s = write_text(P, file, &g, err))) goto done;
  char cap[600];
  snprintf(cap, sizeof cap,
           "Each point is the mean over the seeds of the successful runs at that value of %s; "
           "the bars span the smallest and the largest run. Radius ratio and eps_t are of the "
           "%s.",
           su->sweep_key, su->cases[c].volume ? "tetrahedra" : "triangles");
  pm_cmp_figure *f = add_figure(P, name, title, cap);
  if (!f) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  draw(P, f);
done:
  free(blocks);
  free(d.s);
  free(g.s);
  return s;
}

/* ---- all figures --------------------------------------------------------------------------- */

pm_status pm_cmp_plots(const pm_cmp_study *st, pm_cmp_figures *figs, pm_error *err) {
  memset(figs, 0, sizeof *figs);
  plotctx P;
  memset(&P, 0, sizeof P);
  P.st = st;
  P.figs = figs;
  snprintf(P.dir, sizeof P.dir, "%s/plots", st->dir);
  pm_status s = pm_cmp_mkdirs(P.dir, err);
  if (s) return s;

  /* Is there a gnuplot? */
  char *argv[] = {"gnuplot", "--version", NULL};
  char *v = NULL;
  int ws = 0, to = 0;
  if (pm_cmp_capture(argv, NULL, 10, &v, NULL, &ws, &to) == 0 && !to && WIFEXITED(ws) &&
      WEXITSTATUS(ws) == 0) {
    v[strcspn(v, "\n")] = '\0';
    snprintf(figs->gnuplot_version, sizeof figs->gnuplot_version, "%s", v);
    P.have_gnuplot = figs->have_gnuplot = 1;
  }
  free(v);

  const pm_cmp_suite *su = &st->suite;
  static const boxspec boxes[] = {
      {"aspect_tri", "triangle aspect ratio R/l_min", "tri", "aspect_ratio",
       "R / l_min (circumradius / shortest edge)", 1, 0.57735026918962573, "equilateral 0.577"},
      {"aspect_tet", "tetrahedron aspect ratio R/l_min", "tet", "aspect_ratio",
       "R / l_min (circumradius / shortest edge)", 1, 0.61237243569579447, "regular 0.612"},
      {"radius_ratio_tri", "triangle radius ratio 2r/R", "tri", "radius_ratio",
       "radius ratio 2 r_in / R", 0, 1, "equilateral 1"},
      {"radius_ratio_tet", "tetrahedron radius ratio 3r/R", "tet", "radius_ratio",
       "radius ratio 3 r_in / R", 0, 1, "regular 1"},
      {"min_angle_tri", "triangle minimum angle", "tri", "min_angle_deg", "minimum angle (degrees)",
       0, 60, "equilateral 60"},
      {"min_dihedral_tet", "tetrahedron minimum dihedral angle", "tet", "min_angle_deg",
       "minimum dihedral angle (degrees)", 0, 70.528779365509308, "regular 70.5"},
  };
  for (size_t b = 0; b < sizeof boxes / sizeof boxes[0] && !s; ++b) {
    if (su->nsweep == 0) {
      s = boxplot(&P, &boxes[b], -1, err);
    } else {
      for (int c = 0; c < su->ncase && !s; ++c) s = boxplot(&P, &boxes[b], c, err);
    }
  }
  if (!s) s = time_bars(&P, err);
  for (int c = 0; c < su->ncase && !s; ++c) s = convergence(&P, c, err);
  for (int c = 0; c < su->ncase && !s && su->nsweep; ++c) s = sweep_plot(&P, c, err);
  return s;
}

void pm_cmp_figures_clear(pm_cmp_figures *figs) {
  if (!figs) return;
  free(figs->fig);
  memset(figs, 0, sizeof *figs);
}
