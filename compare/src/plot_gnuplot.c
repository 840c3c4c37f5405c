/* What the figures of a study share (plot_gnuplot.h). */
#include "compare/src/plot_gnuplot.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/base/atomic_file.h"

const char *const pm_cmp_palette[] = {"#1b9e77", "#d95f02", "#7570b3", "#e7298a",
                                      "#66a61e", "#e6ab02", "#a6761d", "#666666"};

pm_status pm_cmp_plot_write(const pm_cmp_plotctx *P, const char *file, const sbuf *b, pm_error *err) {
  if (b->bad) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  char path[4400];
  snprintf(path, sizeof path, "%s/%s", P->dir, file);
  return pm_atomic_write(path, b->s ? b->s : "", b->s ? b->n : 0, err);
}

/* A label for gnuplot inside double quotes (the terminals are noenhanced: _ and ^ print as
 * they are). */
void pm_cmp_gp_quote(const char *in, char *out, size_t len) {
  size_t k = 0;
  for (; *in && k + 3 < len; ++in) {
    if (*in == '"' || *in == '\\') out[k++] = '\\';
    out[k++] = *in;
  }
  out[k] = '\0';
}

/* The script's head: the output stem, overridable (gnuplot -e "out='x'") so the harness can draw
 * under a temporary name and rename (no half-written figure), and the loop over formats. */
void pm_cmp_gp_head(sbuf *g, const char *name, const char *title, const char *data_doc,
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

void pm_cmp_gp_tail(sbuf *g) { SB(g, "  set output\n}\n"); }

pm_cmp_figure *pm_cmp_plot_figure(pm_cmp_plotctx *P, const char *name, const char *title,
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
void pm_cmp_plot_draw(pm_cmp_plotctx *P, pm_cmp_figure *f) {
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
  const char *const ext[] = {"svg", "png", "pdf"};
  /* gnuplot's drawings and log are temporaries until renamed (or kept, the log of a failure):
   * a signal removes them. */
  int track[4];
  for (int k = 0; k < 3; ++k) {
    char tmp[4400];
    snprintf(tmp, sizeof tmp, "%s/.tmp-%s.%s", P->dir, f->name, ext[k]);
    track[k] = pm_tmp_track(tmp, 0);
  }
  track[3] = pm_tmp_track(logp, 0);
  int rc = pm_cmp_run_program(argv, P->dir, NULL, logp, PM_CMP_GNUPLOT_TIMEOUT_S, &ws, &to);
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


pm_status pm_cmp_plot_emit(pm_cmp_plotctx *P, const char *name, const char *title,
                           const char *caption, const sbuf *d, const sbuf *g, pm_error *err) {
  char file[200];
  snprintf(file, sizeof file, "%s.dat", name);
  pm_status s = pm_cmp_plot_write(P, file, d, err);
  snprintf(file, sizeof file, "%s.gp", name);
  if (!s) s = pm_cmp_plot_write(P, file, g, err);
  if (s) return s;
  pm_cmp_figure *f = pm_cmp_plot_figure(P, name, title, caption);
  if (!f) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_cmp_plot_draw(P, f);
  return PM_OK;
}

int pm_cmp_row_in(const pm_cmp_row *r, int c, int m, int w) {
  return r->icase == c && r->imethod == m && (w < 0 || r->isweep == w);
}

void pm_cmp_plot_stem(char *name) {
  for (char *p = name; *p; ++p)
    if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') ||
          *p == '_' || *p == '-'))
      *p = '_';
}
