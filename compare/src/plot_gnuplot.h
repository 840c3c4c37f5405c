/* What the figures of a study share (plot.c: box plots, time bars, sweeps; plot_convergence.c:
 * the convergence panels): the text buffer a figure's data and script grow in, the head and tail
 * of a gnuplot script that draws SVG, PNG and PDF under a temporary name, the figure list of the
 * report, and running gnuplot on one script (time-limited, drawings renamed into place). */
#ifndef PM_COMPARE_PLOT_GNUPLOT_H
#define PM_COMPARE_PLOT_GNUPLOT_H

#include "compare/src/study.h"

#define PM_CMP_GNUPLOT_TIMEOUT_S 60

/* The colours of the methods, in suite order (ColorBrewer Dark2, then grey). */
extern const char *const pm_cmp_palette[];
#define PM_CMP_NPALETTE 8

typedef struct pm_cmp_plotctx {
  const pm_cmp_study *st;
  pm_cmp_figures *figs;
  char dir[4096]; /* plots/ */
  int have_gnuplot;
} pm_cmp_plotctx;

/* Write plots/FILE from b, atomically. */
pm_status pm_cmp_plot_write(const pm_cmp_plotctx *P, const char *file, const sbuf *b, pm_error *err);

/* A label for gnuplot inside double quotes (the terminals are noenhanced: _ and ^ print as
 * they are). */
void pm_cmp_gp_quote(const char *in, char *out, size_t len);

/* The script's head (the output stem, overridable with gnuplot -e "out='x'", and the loop over
 * the three formats, each `reset`) and its tail. */
void pm_cmp_gp_head(sbuf *g, const char *name, const char *title, const char *data_doc, int width,
                    int height);
void pm_cmp_gp_tail(sbuf *g);

/* Append a figure to the report's list; NULL when out of memory. */
pm_cmp_figure *pm_cmp_plot_figure(pm_cmp_plotctx *P, const char *name, const char *title,
                                  const char *caption);

/* Run gnuplot on NAME.gp and rename its drawings into place; f->drawn or f->error says how it
 * went. */
void pm_cmp_plot_draw(pm_cmp_plotctx *P, pm_cmp_figure *f);

/* A figure's files and drawing: plots/NAME.dat from d, plots/NAME.gp from g, the figure added
 * to the report's list and drawn. */
pm_status pm_cmp_plot_emit(pm_cmp_plotctx *P, const char *name, const char *title,
                           const char *caption, const sbuf *d, const sbuf *g, pm_error *err);

/* Does row r belong to (case c, method m, sweep value w)? w < 0: any sweep value. */
int pm_cmp_row_in(const pm_cmp_row *r, int c, int m, int w);

/* A figure's file stem from text: letters, digits, _ and - kept, the rest made _. */
void pm_cmp_plot_stem(char *name);

/* The convergence figure of case c from the runs' traces (plot_convergence.c); nothing when no
 * run of the case has a trace. */
pm_status pm_cmp_plot_convergence(pm_cmp_plotctx *P, int c, pm_error *err);

#endif /* PM_COMPARE_PLOT_GNUPLOT_H */
