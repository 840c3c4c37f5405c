/* The figures of a study, drawn by gnuplot. Every figure is three files under plots/ that a user
 * can rerun or restyle: NAME.dat (the numbers, with a comment header naming the columns),
 * NAME.gp (the script: `gnuplot NAME.gp` in plots/ redraws NAME.svg, NAME.png and NAME.pdf) and
 * the drawings themselves.
 *
 * Figures:
 *   aspect_tri, aspect_tet   R / l_min (circumradius over shortest edge) on a log scale, one box
 *                            per method per case -- the box plots of papers/001 Fig. 11 (a) and
 *                            (b). The numbers are computed here (spread.c, with quality.h's
 *                            percentile rule): Tukey's whiskers with the elements beyond them as
 *                            points, or the true min and max as in the paper ("whiskers":
 *                            "minmax"); each distinct mesh of the repeats is pooled once.
 *   radius_ratio_tri/_tet    radius ratio (2r/R, 3r/R), same layout, linear scale.
 *   min_angle_tri            minimum angle of each triangle; min_dihedral_tet for tets.
 *   time                     wall time of packmesh's run (time_s.total), mean over seeds with
 *                            min-max bars, log scale.
 *   convergence_CASE         from the runs' traces (plot_convergence.c).
 *   sweep_CASE               with a sweep: metrics against the swept value, mean over seeds with
 *                            the min-max spread.
 * With a sweep, the box plots get one figure per case with the swept values along x.
 * The pictures of the meshes are drawn by plot_mesh.c, without gnuplot.
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
#include "compare/src/plot_gnuplot.h"
#include "compare/src/study.h"

/* Degenerate elements have aspect ratio PM_QUALITY_HUGE (quality.h); a log axis up to 1e100
 * would flatten every real box, so the axis stops here and the caption says so. */
#define ASPECT_AXIS_MAX 1e6

/* ---- groups -------------------------------------------------------------------------------- */

static int has_elements(const pm_cmp_study *st, int c, int m, int w) {
  for (int i = 0; i < st->nrow; ++i)
    if (pm_cmp_row_in(&st->rows[i], c, m, w) && st->rows[i].status == PM_CMP_OK &&
        st->rows[i].elements_ok)
      return 1;
  return 0;
}

/* The box of the pooled per-element values of one group (each distinct mesh once: spread.c),
 * its outliers (the values beyond the whiskers, as "x value" lines of the data's outlier block,
 * one line per distinct value to 4 digits) appended to *out; 0 when there are none. */
static int group_summary(const pm_cmp_study *st, int c, int m, int w, const char *kind,
                         const char *column, double x, pm_cmp_box *box, sbuf *out, pm_error *err,
                         pm_status *s) {
  double *v = NULL;
  size_t n = 0, cap = 0;
  for (int i = 0; i < st->nrow && !*s; ++i)
    if (pm_cmp_row_in(&st->rows[i], c, m, w) && st->rows[i].same_mesh_as < 0)
      *s = pm_cmp_row_elements(st, &st->rows[i], kind, column, &v, &n, &cap, err);
  int got = 0;
  if (!*s && n > 0 && !(*s = pm_sort_doubles(v, n, err))) {
    pm_cmp_box_of_sorted(v, n, st->suite.whiskers_minmax, box);
    char last[32] = "", now[32];
    for (size_t i = 0; i < n; ++i) {
      if (i == box->lo_end) i = box->hi_begin;
      if (i >= n) break;
      snprintf(now, sizeof now, "%.4g", v[i]);
      if (strcmp(now, last) != 0) SB(out, "%g %s\n", x, now);
      memcpy(last, now, sizeof last);
    }
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
static pm_status boxplot(pm_cmp_plotctx *P, const boxspec *b, int only_case, pm_error *err) {
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
  pm_cmp_box *sum = calloc((size_t)ncl * nm + 1, sizeof *sum);
  int *got = calloc((size_t)ncl * nm + 1, sizeof *got), *xpos = calloc((size_t)ncl + 1, sizeof *xpos);
  sbuf *outl = calloc((size_t)nm + 1, sizeof *outl); /* each method's outliers, "x value" lines */
  int *oblocks = calloc((size_t)nm + 1, sizeof *oblocks);
  if (!sum || !got || !xpos || !outl || !oblocks) {
    free(sum), free(got), free(xpos), free(blocks), free(outl), free(oblocks);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  int nshown = 0;
  for (int k = 0; k < ncl && !s; ++k) {
    int c = sweep ? only_case : k, w = sweep ? k : -1, here = 0;
    for (int m = 0; m < nm && !s; ++m)
      if (has_elements(st, c, m, w)) /* x as placed below, if the cluster is shown */
        here |= got[k * nm + m] = group_summary(st, c, m, w, b->kind, b->column,
                                                nshown * (nm + 1) + m + 1, &sum[k * nm + m],
                                                &outl[m], err, &s);
    xpos[k] = here ? nshown++ : -1;
  }
  SB(&d, "# %s\n# one block per method (blocks separated by two blank lines, in the order of "
         "the plot command), then one block of outliers per method that has any (x value)\n"
         "# x  whisker_low  p25  median  p75  whisker_high  n  cluster  min  max   (whiskers: %s)\n",
     b->title, su->whiskers_minmax ? "min and max" : "Tukey, 1.5 IQR");
  for (int m = 0; m < nm && !s; ++m) {
    int rows = 0;
    for (int k = 0; k < ncl; ++k) {
      if (!got[k * nm + m]) continue;
      const pm_cmp_box *sm = &sum[k * nm + m];
      if (!rows) SB(&d, "# method %s\n", su->methods[m].label);
      double x = xpos[k] * (nm + 1) + m + 1;
      char cl[256];
      snprintf(cl, sizeof cl, "%s", sweep ? su->sweep_values[k] : su->cases[k].name);
      for (char *q = cl; *q; ++q)
        if (*q == ' ' || *q == '"') *q = '_';
      SB(&d, "%g %.9g %.9g %.9g %.9g %.9g %lld %s %.9g %.9g\n", x, sm->whisker_lo, sm->p25,
         sm->median, sm->p75, sm->whisker_hi, (long long)sm->n, cl, sm->min, sm->max);
      if (sm->max > top) top = sm->max;
      rows++;
    }
    if (rows) {
      SB(&d, "\n\n");
      blocks[m] = ++block;
      any = 1;
    }
  }
  for (int m = 0; m < nm; ++m) {
    d.bad |= outl[m].bad;
    if (!outl[m].n) continue;
    SB(&d, "# outliers of method %s: x value\n%s\n\n", su->methods[m].label, outl[m].s);
    oblocks[m] = ++block;
  }
  for (int m = 0; m < nm; ++m) free(outl[m].s);
  free(outl);
  free(sum);
  free(got);
  if (s || !any) {
    free(blocks);
    free(oblocks);
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
  pm_cmp_gp_head(&g, name, title,
              "x, min, p25, median, p75, max, element count, cluster; one block per method", width,
              520);
  char q[512];
  pm_cmp_gp_quote(title, q, sizeof q);
  SB(&g, "  set title \"%s\"\n", q);
  pm_cmp_gp_quote(b->ylabel, q, sizeof q);
  SB(&g, "  set ylabel \"%s\"\n", q);
  if (sweep) {
    pm_cmp_gp_quote(su->sweep_key, q, sizeof q);
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
    pm_cmp_gp_quote(sweep ? su->sweep_values[k] : su->cases[k].name, q, sizeof q);
    SB(&g, "%s\"%s\" %g", first ? "" : ", ", q, xpos[k] * (nm + 1) + (nm + 1) / 2.0);
    first = 0;
  }
  SB(&g, ") scale 0\n");
  SB(&g, "  plot \\\n");
  int first = 1;
  for (int m = 0; m < nm; ++m) {
    if (!blocks[m]) continue;
    pm_cmp_gp_quote(su->methods[m].label, q, sizeof q);
    SB(&g, "%s    data index %d using 1:3:2:6:5 with candlesticks whiskerbars 0.5 lc rgb \"%s\" "
           "lw 1.5 title \"%s\", \\\n"
           "    data index %d using 1:4:4:4:4 with candlesticks lc rgb \"black\" lw 2.5 notitle",
       first ? "" : ", \\\n", blocks[m] - 1, pm_cmp_palette[m % PM_CMP_NPALETTE], q, blocks[m] - 1);
    if (oblocks[m])
      SB(&g, ", \\\n    data index %d using 1:2 with points pt 7 ps 0.6 lc rgb \"%s\" notitle",
         oblocks[m] - 1, pm_cmp_palette[m % PM_CMP_NPALETTE]);
    first = 0;
  }
  /* The ideal value as a dashed line named in the key (a label on the plot would sit on the
   * boxes). */
  if (b->ref > 0) {
    pm_cmp_gp_quote(b->ref_label, q, sizeof q);
    SB(&g, ", \\\n    %.9g with lines dt 2 lc rgb \"#888888\" title \"%s\"", b->ref, q);
  }
  SB(&g, "\n");
  pm_cmp_gp_tail(&g);
  char file[200];
  snprintf(file, sizeof file, "%s.dat", name);
  if (!(s = pm_cmp_plot_write(P, file, &d, err))) {
    snprintf(file, sizeof file, "%s.gp", name);
    s = pm_cmp_plot_write(P, file, &g, err);
  }
  free(d.s);
  free(g.s);
  free(blocks);
  free(oblocks);
  free(xpos);
  if (s) return s;
  char cap[1024];
  snprintf(cap, sizeof cap,
           "Per element, pooled over the seeds%s (a mesh that repeats an earlier run's byte for "
           "byte is counted once): the box spans p25 to p75 with the median as a black bar, %s%s.",
           sweep ? "" : (su->nsweep ? " and the swept values" : ""),
           su->whiskers_minmax ? "the whiskers reach the minimum and the maximum (as papers/001 "
                                 "Fig. 11; the suite's \"whiskers\": \"minmax\")"
                               : "the whiskers reach the furthest elements within 1.5 IQR of "
                                 "the box (Tukey), and the elements beyond are points",
           b->logscale && top > ASPECT_AXIS_MAX
               ? "; degenerate elements (aspect ratio 1e100) lie beyond the top of the axis"
               : "");
  pm_cmp_figure *f = pm_cmp_plot_figure(P, name, title, cap);
  if (!f) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_cmp_plot_draw(P, f);
  return PM_OK;
}

/* ---- time bars ----------------------------------------------------------------------------- */

static pm_status time_bars(pm_cmp_plotctx *P, pm_error *err) {
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
        if (!pm_cmp_row_in(r, c, m, -1)) continue;
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
  pm_cmp_gp_head(&g, "time", "time per run", "x, mean, min, max, runs, case; one block per method",
              width, 480);
  SB(&g, "  set title \"time of packmesh mesh per run (mean over seeds, bars: min to max)\"\n");
  SB(&g, "  set ylabel \"seconds\"\n  set logscale y\n  set format y \"%%g\"\n");
  SB(&g, "  set key outside right top\n  set boxwidth 0.7 absolute\n");
  SB(&g, "  set style fill solid 0.6 border -1\n  set xrange [0:%d]\n", ncl * (nm + 1));
  SB(&g, "  set xtics (");
  char q[512];
  for (int c = 0; c < ncl; ++c) {
    pm_cmp_gp_quote(su->cases[c].name, q, sizeof q);
    SB(&g, "%s\"%s\" %g", c ? ", " : "", q, c * (nm + 1) + (nm + 1) / 2.0);
  }
  SB(&g, ") scale 0\n  plot \\\n");
  int first = 1;
  for (int m = 0; m < nm; ++m) {
    if (!blocks[m]) continue;
    pm_cmp_gp_quote(su->methods[m].label, q, sizeof q);
    SB(&g, "%s    data index %d using 1:2 with boxes lc rgb \"%s\" title \"%s\", \\\n"
           "    data index %d using 1:2:3:4 with yerrorbars lc rgb \"black\" pt 7 ps 0 notitle",
       first ? "" : ", \\\n", blocks[m] - 1, pm_cmp_palette[m % PM_CMP_NPALETTE], q, blocks[m] - 1);
    first = 0;
  }
  SB(&g, "\n");
  pm_cmp_gp_tail(&g);
  if ((s = pm_cmp_plot_write(P, "time.dat", &d, err)) || (s = pm_cmp_plot_write(P, "time.gp", &g, err))) goto done;
  pm_cmp_figure *f = pm_cmp_plot_figure(P, "time", "time per run",
                                "time_s.total of each run's stats (reading the input, placing "
                                "nodes, connecting, measuring), mean over the seeds; the bars "
                                "span the fastest and the slowest run.");
  if (!f) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  pm_cmp_plot_draw(P, f);
done:
  free(blocks);
  free(d.s);
  free(g.s);
  return s;
}

/* ---- sweeps -------------------------------------------------------------------------------- */

static pm_status sweep_plot(pm_cmp_plotctx *P, int c, pm_error *err) {
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
        if (!pm_cmp_row_in(r, c, m, w) || r->status != PM_CMP_OK) continue;
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
  pm_cmp_gp_head(&g, name, title,
              "swept value, then mean, min and max over the seeds of six metrics; one block "
              "per method",
              1200, 760);
  pm_cmp_gp_quote(title, q, sizeof q);
  SB(&g, "  set multiplot layout 2,3 title \"%s (mean over seeds; bars: min to max)\"\n", q);
  pm_cmp_gp_quote(su->sweep_key, q, sizeof q);
  SB(&g, "  set xlabel \"%s\"\n  set key top right font \",10\"\n", q);
  if (logx) SB(&g, "  set logscale x\n  set format x \"%%g\"\n");
  if (!numeric) SB(&g, "  set xrange [-0.5:%d]\n", su->nsweep - 1 + 1);
  for (int k = 0; k < 6; ++k) {
    pm_cmp_gp_quote(metrics[k].label, q, sizeof q);
    SB(&g, "  set ylabel \"%s\"\n  plot \\\n", q);
    int first = 1;
    for (int m = 0; m < su->nmethod; ++m) {
      if (!blocks[m]) continue;
      char lq[256];
      pm_cmp_gp_quote(su->methods[m].label, lq, sizeof lq);
      int col = 2 + 3 * k;
      SB(&g, "%s    data index %d using 1:%d:%d:%d%s with yerrorlines lw 1.5 pt 7 ps 0.6 lc rgb "
             "\"%s\" title \"%s\"",
         first ? "" : ", \\\n", blocks[m] - 1, col, col + 1, col + 2,
         numeric ? "" : ":xticlabels(20)", pm_cmp_palette[m % PM_CMP_NPALETTE], lq);
      first = 0;
    }
    SB(&g, "\n");
  }
  SB(&g, "  unset multiplot\n");
  pm_cmp_gp_tail(&g);
  char file[200];
  snprintf(file, sizeof file, "%s.dat", name);
  if ((s = pm_cmp_plot_write(P, file, &d, err))) goto done;
  snprintf(file, sizeof file, "%s.gp", name);
  if ((s = pm_cmp_plot_write(P, file, &g, err))) goto done;
  char cap[600];
  snprintf(cap, sizeof cap,
           "Each point is the mean over the seeds of the successful runs at that value of %s; "
           "the bars span the smallest and the largest run. Radius ratio and eps_t are of the "
           "%s.",
           su->sweep_key, su->cases[c].volume ? "tetrahedra" : "triangles");
  pm_cmp_figure *f = pm_cmp_plot_figure(P, name, title, cap);
  if (!f) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto done;
  }
  pm_cmp_plot_draw(P, f);
done:
  free(blocks);
  free(d.s);
  free(g.s);
  return s;
}

/* ---- all figures --------------------------------------------------------------------------- */

pm_status pm_cmp_plots(const pm_cmp_study *st, pm_cmp_figures *figs, pm_error *err) {
  memset(figs, 0, sizeof *figs);
  pm_cmp_plotctx P;
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
  for (int c = 0; c < su->ncase && !s; ++c) s = pm_cmp_plot_convergence(&P, c, err);
  for (int c = 0; c < su->ncase && !s && su->nsweep; ++c) s = sweep_plot(&P, c, err);
  if (!s) s = pm_cmp_mesh_pictures(st, figs, err);
  return s;
}

void pm_cmp_figures_clear(pm_cmp_figures *figs) {
  if (!figs) return;
  free(figs->fig);
  free(figs->pic);
  memset(figs, 0, sizeof *figs);
}
