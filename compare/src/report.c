/* report.md and report.html of a study: the summary tables per case and method, the figures,
 * the published figures a suite quotes for reference, the failed runs with their messages (and
 * the runs not finished, when --collect writes it mid-study), the exact command of every run,
 * the inputs (the suite itself) and where it ran (the machines or Slurm nodes of the runs,
 * library versions and the machine writing the report). Both files come from one pass over the same content: a tiny writer emits
 * each block as Markdown and as HTML. The HTML is self-contained (inline style) and refers to
 * the figures by relative paths, so the study folder can be moved or archived whole.
 */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/base/atomic_file.h"
#include "compare/src/study.h"

#define CELL 1100 /* bytes of a table cell (an error message is up to 1024) */

typedef struct doc {
  sbuf md, html;
} doc;

static void html_esc(sbuf *b, const char *t) {
  for (; *t; ++t) {
    switch (*t) {
      case '&': SB(b, "&amp;"); break;
      case '<': SB(b, "&lt;"); break;
      case '>': SB(b, "&gt;"); break;
      case '"': SB(b, "&quot;"); break;
      default: {
        char c[2] = {*t, 0};
        SB(b, "%s", c);
      }
    }
  }
}

/* A Markdown table cell: '|' escaped, line breaks as spaces. */
static void md_cell(sbuf *b, const char *t) {
  for (; *t; ++t) {
    if (*t == '|')
      SB(b, "\\|");
    else if (*t == '\n' || *t == '\r')
      SB(b, " ");
    else {
      char c[2] = {*t, 0};
      SB(b, "%s", c);
    }
  }
}

static void doc_h(doc *d, int level, const char *text) {
  SB(&d->md, "\n%.*s %s\n\n", level, "######", text);
  SB(&d->html, "<h%d>", level);
  html_esc(&d->html, text);
  SB(&d->html, "</h%d>\n", level);
}

static void doc_p(doc *d, const char *text) {
  SB(&d->md, "%s\n\n", text);
  SB(&d->html, "<p>");
  html_esc(&d->html, text);
  SB(&d->html, "</p>\n");
}

static void doc_code(doc *d, const char *text, const char *lang) {
  SB(&d->md, "```%s\n%s%s```\n\n", lang ? lang : "", text,
     text[0] && text[strlen(text) - 1] == '\n' ? "" : "\n");
  SB(&d->html, "<pre><code>");
  html_esc(&d->html, text);
  SB(&d->html, "</code></pre>\n");
}

static void doc_table_head(doc *d, int n, const char *const *h) {
  SB(&d->md, "|");
  for (int i = 0; i < n; ++i) {
    SB(&d->md, " ");
    md_cell(&d->md, h[i]);
    SB(&d->md, " |");
  }
  SB(&d->md, "\n|");
  for (int i = 0; i < n; ++i) SB(&d->md, "%s|", i ? "---:" : "---");
  SB(&d->md, "\n");
  SB(&d->html, "<table>\n<tr>");
  for (int i = 0; i < n; ++i) {
    SB(&d->html, "<th>");
    html_esc(&d->html, h[i]);
    SB(&d->html, "</th>");
  }
  SB(&d->html, "</tr>\n");
}

/* A row; a cell starting with "`" is code in both formats. */
static void doc_table_row(doc *d, int n, char cells[][CELL]) {
  SB(&d->md, "|");
  for (int i = 0; i < n; ++i) {
    SB(&d->md, " ");
    md_cell(&d->md, cells[i]);
    SB(&d->md, " |");
  }
  SB(&d->md, "\n");
  SB(&d->html, "<tr>");
  for (int i = 0; i < n; ++i) {
    SB(&d->html, i ? "<td class=\"n\">" : "<td>");
    html_esc(&d->html, cells[i]);
    SB(&d->html, "</td>");
  }
  SB(&d->html, "</tr>\n");
}

static void doc_table_end(doc *d) {
  SB(&d->md, "\n");
  SB(&d->html, "</table>\n");
}

/* ---- numbers ------------------------------------------------------------------------------- */

static void fmt_num(char *out, size_t len, double v, int digits) {
  if (!isfinite(v))
    snprintf(out, len, "-");
  else
    snprintf(out, len, "%.*g", digits, v);
}

/* Mean of a key over the OK rows of (case, method, sweep value w; w < 0: all). */
static double mean_of(const pm_cmp_study *st, int c, int m, int w, const char *key, int *nok) {
  double sum = 0;
  int n = 0, ok = 0;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (r->icase != c || r->imethod != m || (w >= 0 && r->isweep != w)) continue;
    if (r->status != PM_CMP_OK) continue;
    ok++;
    double v = pm_cmp_row_value(r, key);
    if (isfinite(v)) {
      sum += v;
      n++;
    }
  }
  if (nok) *nok = ok;
  return n ? sum / n : NAN;
}

static int count_rows(const pm_cmp_study *st, int c, int m, int w) {
  int n = 0;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    n += r->icase == c && r->imethod == m && (w < 0 || r->isweep == w);
  }
  return n;
}

/* "yes" when every OK row's checker said valid, "no (k)" otherwise. */
static void valid_of(const pm_cmp_study *st, int c, int m, int w, char *out, size_t len) {
  int bad = 0, n = 0;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (r->icase != c || r->imethod != m || (w >= 0 && r->isweep != w)) continue;
    if (r->status != PM_CMP_OK) continue;
    const pm_stats_item *it = pm_stats_flat_find(&r->flat, "valid");
    n++;
    if (!it || !it->is_text || strcmp(it->text, "true") != 0) bad++;
  }
  if (!n)
    snprintf(out, len, "-");
  else if (!bad)
    snprintf(out, len, "yes");
  else
    snprintf(out, len, "no (%d of %d)", bad, n);
}

/* ---- sections ------------------------------------------------------------------------------ */

typedef struct col {
  const char *head, *key;
  int digits;
} col;

static const col tri_cols[] = {
    {"nodes", "nodes", 7},
    {"triangles", "triangles", 7},
    {"mean radius ratio", "tri.radius_ratio.mean", 4},
    {"min radius ratio", "tri.radius_ratio.min", 3},
    {"median R/l_min", "tri.aspect_ratio.median", 4},
    {"p75 R/l_min", "tri.aspect_ratio.p75", 4},
    {"min angle", "tri.min_angle_deg.min", 3},
    {"eps_t", "tri.eps_t", 3},
    {"eps_g", "tri.eps_g", 3},
    {"time (s)", "time_s.total", 3},
};
static const col tet_cols[] = {
    {"nodes", "nodes", 7},
    {"surface nodes", "surface_nodes", 7},
    {"tets", "tets", 7},
    {"mean radius ratio", "tet.radius_ratio.mean", 4},
    {"min radius ratio", "tet.radius_ratio.min", 3},
    {"median R/l_min", "tet.aspect_ratio.median", 4},
    {"p75 R/l_min", "tet.aspect_ratio.p75", 4},
    {"min dihedral", "tet.min_dihedral_deg.min", 3},
    {"eps_t", "tet.eps_t", 3},
    {"eps_g", "tet.eps_g", 3},
    {"time (s)", "time_s.total", 3},
};
/* Triangles by site (quality.h): where the worse triangles of each method sit. */
static const col site_cols[] = {
    {"boundary", "tri.by_site.boundary.count", 7},
    {"median R/l_min", "tri.by_site.boundary.aspect_ratio.median", 4},
    {"irregular", "tri.by_site.irregular.count", 7},
    {"median R/l_min", "tri.by_site.irregular.aspect_ratio.median", 4},
    {"regular", "tri.by_site.regular.count", 7},
    {"median R/l_min", "tri.by_site.regular.aspect_ratio.median", 4},
};
#define NCOL 11 /* the most columns of a table above */
#define COLS(a) ((int)(sizeof(a) / sizeof((a)[0])))
_Static_assert(COLS(tri_cols) <= NCOL && COLS(tet_cols) <= NCOL && COLS(site_cols) <= NCOL,
               "a summary table has more columns than NCOL");

static int any_value(const pm_cmp_study *st, int c, const char *key) {
  for (int i = 0; i < st->nrow; ++i)
    if (st->rows[i].icase == c && isfinite(pm_cmp_row_value(&st->rows[i], key))) return 1;
  return 0;
}

static void summary_table(doc *d, const pm_cmp_study *st, int c, const col *cols, int ncol) {
  const pm_cmp_suite *su = &st->suite;
  const char *h[NCOL + 5];
  int nh = 0;
  h[nh++] = "method";
  if (su->nsweep) h[nh++] = su->sweep_key;
  h[nh++] = "ok runs";
  h[nh++] = "distinct";
  for (int k = 0; k < ncol; ++k) h[nh++] = cols[k].head;
  if (su->match_nodes) h[nh++] = su->match_surface ? "surface nodes vs reference" : "nodes vs reference";
  h[nh++] = "valid";
  doc_table_head(d, nh, h);
  int nw = su->nsweep ? su->nsweep : 1;
  for (int m = 0; m < su->nmethod; ++m)
    for (int w = 0; w < nw; ++w) {
      int ww = su->nsweep ? w : -1;
      int total = count_rows(st, c, m, ww);
      if (!total) continue;
      char cells[NCOL + 5][CELL];
      int k = 0, ok = 0;
      snprintf(cells[k++], CELL, "%s", su->methods[m].label);
      if (su->nsweep) snprintf(cells[k++], CELL, "%s", su->sweep_values[w]);
      mean_of(st, c, m, ww, "nodes", &ok);
      int distinct = pm_cmp_distinct_count(st, c, m, ww);
      snprintf(cells[k++], CELL, "%d/%d", ok, total);
      snprintf(cells[k++], CELL, "%d", distinct);
      for (int q = 0; q < ncol; ++q) {
        double mean, sd;
        int n;
        pm_cmp_mean_sd(st, c, m, ww, cols[q].key, &mean, &sd, &n);
        fmt_num(cells[k], CELL, mean, cols[q].digits);
        if (n > 1) { /* the spread over the seeds, to two digits */
          size_t at = strlen(cells[k]);
          snprintf(cells[k] + at, CELL - at, " ± %.2g", sd);
        }
        k++;
      }
      if (su->match_nodes) {
        if (m == su->reference) {
          snprintf(cells[k++], CELL, "reference");
        } else {
          /* Largest relative difference over the rows: what "within 3%" has to hold for. */
          double worst = NAN;
          for (int i = 0; i < st->nrow; ++i) {
            const pm_cmp_row *r = &st->rows[i];
            if (r->icase != c || r->imethod != m || (ww >= 0 && r->isweep != ww)) continue;
            if (r->status != PM_CMP_OK || r->ref_row < 0) continue;
            /* The count the runs were matched on: all nodes, or the surface nodes. */
            const pm_cmp_row *rr = &st->rows[r->ref_row];
            double ref = su->match_surface ? pm_cmp_row_value(rr, "surface_nodes") : (double)rr->nodes;
            double mine = su->match_surface ? pm_cmp_row_value(r, "surface_nodes") : (double)r->nodes;
            double rel = (mine - ref) / ref;
            if (!isfinite(worst) || fabs(rel) > fabs(worst)) worst = rel;
          }
          if (isfinite(worst))
            snprintf(cells[k++], CELL, "%+.1f%%", 100 * worst);
          else
            snprintf(cells[k++], CELL, "-");
        }
      }
      valid_of(st, c, m, ww, cells[k], CELL);
      k++;
      doc_table_row(d, k, cells);
    }
  doc_table_end(d);
}

/* Published figures a case quotes: {"source": "...", "method": "label", "note": "...",
 * "values": {"stats key": number, ...}}; with "method", the measured mean is put beside each. */
static void reference_table(doc *d, const pm_cmp_study *st, int c) {
  const pm_cmp_case *cs = &st->suite.cases[c];
  if (!cs->ref_json) return;
  cJSON *ref = cJSON_Parse(cs->ref_json);
  if (!ref) return;
  const cJSON *src = cJSON_GetObjectItemCaseSensitive(ref, "source");
  const cJSON *meth = cJSON_GetObjectItemCaseSensitive(ref, "method");
  const cJSON *note = cJSON_GetObjectItemCaseSensitive(ref, "note");
  const cJSON *vals = cJSON_GetObjectItemCaseSensitive(ref, "values");
  int m = -1;
  for (int i = 0; cJSON_IsString(meth) && i < st->suite.nmethod; ++i)
    if (strcmp(st->suite.methods[i].label, meth->valuestring) == 0) m = i;
  char p[1200];
  snprintf(p, sizeof p, "Published figures for %s, from %s%s%s%s", cs->name,
           cJSON_IsString(src) ? src->valuestring : "the literature",
           m >= 0 ? ", beside the mean measured here with " : "",
           m >= 0 ? st->suite.methods[m].label : "",
           m >= 0 ? " (the paper's machine and code differ: times compare only in order of "
                    "magnitude)."
                  : ".");
  doc_p(d, p);
  if (cJSON_IsString(note)) doc_p(d, note->valuestring);
  if (cJSON_IsObject(vals)) {
    const char *h[3] = {"quantity", "published", "measured here"};
    doc_table_head(d, m >= 0 ? 3 : 2, h);
    for (const cJSON *v = vals->child; v; v = v->next) {
      char cells[3][CELL];
      snprintf(cells[0], CELL, "%s", v->string);
      if (cJSON_IsNumber(v))
        fmt_num(cells[1], CELL, v->valuedouble, 6);
      else if (cJSON_IsString(v))
        snprintf(cells[1], CELL, "%s", v->valuestring);
      else
        snprintf(cells[1], CELL, "-");
      if (m >= 0) {
        double mean, sd;
        int n;
        pm_cmp_mean_sd(st, c, m, -1, v->string, &mean, &sd, &n);
        fmt_num(cells[2], CELL, mean, 6);
      }
      doc_table_row(d, m >= 0 ? 3 : 2, cells);
    }
    doc_table_end(d);
  }
  cJSON_Delete(ref);
}

static void figure(doc *d, const pm_cmp_figure *f) {
  doc_h(d, 3, f->title);
  if (f->drawn) {
    SB(&d->md, "![%s](plots/%s.png)\n\n", f->title, f->name);
    SB(&d->md, "%s Files: [SVG](plots/%s.svg), [PDF](plots/%s.pdf), [gnuplot script](plots/%s.gp), "
               "[data](plots/%s.dat).\n\n",
       f->caption, f->name, f->name, f->name, f->name);
    SB(&d->html, "<figure><a href=\"plots/%s.svg\"><img src=\"plots/%s.png\" alt=\"", f->name,
       f->name);
    html_esc(&d->html, f->title);
    SB(&d->html, "\"></a><figcaption>");
    html_esc(&d->html, f->caption);
    SB(&d->html,
       " Files: <a href=\"plots/%s.svg\">SVG</a>, <a href=\"plots/%s.pdf\">PDF</a>, "
       "<a href=\"plots/%s.gp\">gnuplot script</a>, <a href=\"plots/%s.dat\">data</a>."
       "</figcaption></figure>\n",
       f->name, f->name, f->name, f->name);
  } else {
    char p[1200];
    snprintf(p, sizeof p,
             "Not drawn (%s). The script plots/%s.gp and its data plots/%s.dat are there: run "
             "`gnuplot %s.gp` in plots/ once gnuplot is installed.",
             f->error, f->name, f->name, f->name);
    doc_p(d, p);
  }
}

/* The pictures of plot_mesh.c, per case: each method's mesh beside the zoom on its worst
 * element. */
static void mesh_pictures(doc *d, const pm_cmp_study *st, const pm_cmp_figures *figs) {
  if (!figs->npic) return;
  doc_h(d, 2, "Meshes");
  double mesh_s = 0;
  for (int i = 0; i < st->nrow; ++i)
    if (st->rows[i].status == PM_CMP_OK) mesh_s += st->rows[i].wall_s;
  char p[1024];
  snprintf(p, sizeof p,
           "The first successful run of each method, on one camera per case; triangles (the "
           "surface's, for volume meshes) coloured by R/l_min on one log scale for the whole "
           "study, from 0.577 (equilateral, blue) to %.3g (red; larger values are red too). "
           "Beside each, a zoom on its worst element. The %d pictures took %.2f s to draw "
           "(%.2f s of processor time; the runs: %.1f s).",
           figs->colour_max, figs->npic, figs->picture_s, figs->picture_cpu_s, mesh_s);
  doc_p(d, p);
  for (int c = 0; c < st->suite.ncase; ++c) {
    int any = 0;
    /* Method by method, each mesh beside its zoom. */
    for (int k = 0; k < figs->npic * st->suite.nmethod; ++k) {
      const pm_cmp_picture *pic = &figs->pic[k % figs->npic];
      if (pic->icase != c || pic->imethod != k / figs->npic) continue;
      if (!any++) {
        doc_h(d, 3, st->suite.cases[c].name);
        SB(&d->html, "<div class=\"meshes\">\n");
      }
      if (!pic->drawn) {
        char q[800];
        snprintf(q, sizeof q, "%s: not drawn (%s).", pic->name, pic->error);
        doc_p(d, q);
        continue;
      }
      SB(&d->md, "![%s](plots/%s.png)\n\n%s [SVG](plots/%s.svg)\n\n", pic->caption, pic->name,
         pic->caption, pic->name);
      SB(&d->html, "<figure class=\"%s\"><a href=\"plots/%s.svg\"><img src=\"plots/%s.png\" alt=\"",
         pic->worst ? "worst" : "mesh", pic->name, pic->name);
      html_esc(&d->html, pic->caption);
      SB(&d->html, "\"></a><figcaption>");
      html_esc(&d->html, pic->caption);
      SB(&d->html, "</figcaption></figure>\n");
    }
    if (any) SB(&d->html, "</div>\n");
  }
}

/* The 3D viewer (viewer.c writes its folder): a place for viewer.js, three.js, the cases' data
 * and viewer.js itself, in that order; or why there is none. */
static void viewer_section(doc *d, const pm_cmp_study *st, const pm_cmp_viewer *v) {
  doc_h(d, 2, "3D viewer");
  if (!v->available) {
    doc_p(d, v->note);
    return;
  }
  SB(&d->md, "The 3D viewer is in report.html (it needs a browser with WebGL). ");
  doc_p(d, "Drag to rotate, wheel to zoom, shift-drag to pan; choose the case, the measure the "
           "triangles are coloured by, and the methods shown side by side; click a triangle to "
           "see its values. It shows the first successful run of each method, the surface "
           "triangles of volume meshes. Everything it needs is in viewer/, so the study folder "
           "works offline.");
  SB(&d->html, "<div id=\"pm-viewer\"></div>\n<script src=\"viewer/three.min.js\"></script>\n");
  for (int c = 0; c < st->suite.ncase; ++c) {
    if (!v->case_written[c]) continue;
    char rel[400];
    pm_cmp_viewer_case_file(st, c, rel, sizeof rel);
    SB(&d->html, "<script src=\"%s\"></script>\n", rel);
  }
  SB(&d->html, "<script src=\"viewer/viewer.js\"></script>\n");
  doc_p(d, v->note);
}

static void environment(doc *d, const pm_cmp_figures *figs) {
  pm_cmp_sysinfo si;
  pm_cmp_sysinfo_get(&si);
  const pm_lib_versions *v = &si.lib;
  const char *h[2] = {"component", "version"};
  doc_table_head(d, 2, h);
  char rows[][2][CELL] = {
      {"packmesh", ""}, {"gmsh", ""}, {"OpenCASCADE (through gmsh)", ""}, {"CGAL", ""},
      {"TetGen", ""},   {"Embree", ""}, {"muparser", ""}, {"cJSON", ""},
      {"C compiler", ""}, {"C++ compiler", ""}, {"gnuplot", ""},
  };
  snprintf(rows[0][1], CELL, "%s", v->packmesh);
  snprintf(rows[1][1], CELL, "%s (API headers %s)", v->gmsh, v->gmsh_api);
  snprintf(rows[2][1], CELL, "%s", v->occ);
  snprintf(rows[3][1], CELL, "%s", v->cgal);
  snprintf(rows[4][1], CELL, "%s", v->tetgen);
  snprintf(rows[5][1], CELL, "%s", v->embree);
  snprintf(rows[6][1], CELL, "%s", v->muparser);
  snprintf(rows[7][1], CELL, "%s", v->cjson);
  snprintf(rows[8][1], CELL, "%s", v->c_compiler);
  snprintf(rows[9][1], CELL, "%s", v->cxx_compiler);
  snprintf(rows[10][1], CELL, "%s",
           figs->have_gnuplot ? figs->gnuplot_version : "not installed (figures not drawn)");
  for (size_t i = 0; i < sizeof rows / sizeof rows[0]; ++i) doc_table_row(d, 2, rows[i]);
  doc_table_end(d);
  if (si.packages[0]) {
    char p[2200];
    snprintf(p, sizeof p, "Debian packages: %s.", si.packages);
    doc_p(d, p);
  }
  char p[1024];
  snprintf(p, sizeof p, "Machine: %s; CPU %s, %d cores online; %.1f GiB of memory.", si.os,
           si.cpu, si.cores, si.mem_gib);
  doc_p(d, p);
}

static void inputs(doc *d, const pm_cmp_study *st) {
  const pm_cmp_suite *su = &st->suite;
  const char *hc[4] = {"case", "input", "size", "volume"};
  doc_table_head(d, 4, hc);
  for (int c = 0; c < su->ncase; ++c) {
    char cells[4][CELL];
    snprintf(cells[0], CELL, "%s", su->cases[c].name);
    snprintf(cells[1], CELL, "%s", su->cases[c].input);
    snprintf(cells[2], CELL, "%s",
             su->cases[c].size ? su->cases[c].size : "the input's own, else the method's default");
    snprintf(cells[3], CELL, "%s", su->cases[c].volume ? "yes" : "no");
    doc_table_row(d, 4, cells);
  }
  doc_table_end(d);
  const char *hm[4] = {"label", "method", "--set", "cases"};
  doc_table_head(d, 4, hm);
  for (int m = 0; m < su->nmethod; ++m) {
    const pm_cmp_method *me = &su->methods[m];
    char cells[4][CELL];
    snprintf(cells[0], CELL, "%s", me->label);
    snprintf(cells[1], CELL, "%s", me->name);
    cells[2][0] = cells[3][0] = '\0';
    for (int k = 0; k < me->nset; ++k) {
      strncat(cells[2], k ? " " : "", CELL - 1 - strlen(cells[2]));
      strncat(cells[2], me->sets[k], CELL - 1 - strlen(cells[2]));
    }
    for (int k = 0; k < me->nonly; ++k) {
      strncat(cells[3], k ? ", " : "", CELL - 1 - strlen(cells[3]));
      strncat(cells[3], me->only[k], CELL - 1 - strlen(cells[3]));
    }
    if (!me->nonly) snprintf(cells[3], CELL, "all");
    doc_table_row(d, 4, cells);
  }
  doc_table_end(d);
  char p[2048];
  int k = snprintf(p, sizeof p, "Seeds:");
  for (int i = 0; i < su->nseed && k < (int)sizeof p - 32; ++i)
    k += snprintf(p + k, sizeof p - (size_t)k, "%s %ld", i ? "," : "", su->seeds[i]);
  k += snprintf(p + k, sizeof p - (size_t)k,
                ". Node counts %s. Time limit per run: %g s. Threads per run: %s. Traces: %s.",
                !su->match_nodes ? "not matched"
                : su->match_surface
                    ? "matched on the surface nodes (the nodes of the triangles; a volume mesh's "
                      "interior nodes are not counted) to the reference method's (packmesh mesh "
                      "--target-surface-nodes: within 3%)"
                    : "matched on all nodes to the reference method's (packmesh mesh "
                      "--target-nodes: within 3%)",
                su->timeout_s, su->threads ? "as set" : "cores / jobs",
                su->trace ? "recorded" : "off");
  if (su->match_nodes && k < (int)sizeof p - 128)
    k += snprintf(p + k, sizeof p - (size_t)k, " Reference method: %s.",
                  su->methods[su->reference].label);
  if (su->nsweep && k < (int)sizeof p - 256) {
    k += snprintf(p + k, sizeof p - (size_t)k, " Sweep of %s over", su->sweep_key);
    for (int w = 0; w < su->nsweep && k < (int)sizeof p - 32; ++w)
      k += snprintf(p + k, sizeof p - (size_t)k, "%s %s", w ? "," : "", su->sweep_values[w]);
    if (k < (int)sizeof p - 2) snprintf(p + k, sizeof p - (size_t)k, ".");
  }
  doc_p(d, p);
  doc_p(d, su->path[0] ? "The suite file, verbatim:" : "The suite (built in), verbatim:");
  doc_code(d, su->text, "json");
}

/* The papers the report has cited so far (papers/NNN in its Markdown text: the summary, the
 * figure captions, the suite's description), in full. */
static void references(doc *d) {
  int any = 0;
  for (int i = 0; i < pm_cmp_reference_count(); ++i) {
    const pm_cmp_reference *r = pm_cmp_reference_at(i);
    char key[32];
    snprintf(key, sizeof key, "papers/%s", r->key);
    if (!d->md.s || !strstr(d->md.s, key)) continue;
    if (!any++) doc_h(d, 2, "References");
    char p[1200];
    snprintf(p, sizeof p, "%s: %s", key, r->citation);
    doc_p(d, p);
  }
}

/* "Runs ran on: HOST (N runs), ...": the machines (Slurm's nodes) of the runs that ran, in the
 * order they first appear in the study. */
static void hosts(doc *d, const pm_cmp_study *st) {
  sbuf b = {0};
  SB(&b, "Runs ran on:");
  int listed = 0, unknown = 0;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (r->status == PM_CMP_PENDING || r->status == PM_CMP_SKIPPED) continue;
    if (!r->host[0]) {
      unknown++;
      continue;
    }
    int seen = 0;
    for (int k = 0; k < i && !seen; ++k)
      seen = st->rows[k].status != PM_CMP_PENDING && st->rows[k].status != PM_CMP_SKIPPED &&
             strcmp(st->rows[k].host, r->host) == 0;
    if (seen) continue;
    int n = 0;
    for (int k = i; k < st->nrow; ++k)
      n += st->rows[k].status != PM_CMP_PENDING && st->rows[k].status != PM_CMP_SKIPPED &&
           strcmp(st->rows[k].host, r->host) == 0;
    SB(&b, "%s %s (%d run%s)", listed++ ? "," : "", r->host, n, n == 1 ? "" : "s");
  }
  if (unknown) SB(&b, "%s not recorded (%d run%s)", listed++ ? "," : "", unknown,
                  unknown == 1 ? "" : "s");
  if (!listed) SB(&b, " none");
  SB(&b, ".");
  if (!b.bad) doc_p(d, b.s);
  d->md.bad |= b.bad;
  free(b.s);
}

pm_status pm_cmp_report(const pm_cmp_study *st, const pm_cmp_figures *figs,
                        const char *invocation, pm_error *err) {
  const pm_cmp_suite *su = &st->suite;
  doc D;
  memset(&D, 0, sizeof D);
  doc *d = &D;
  SB(&d->html,
     "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>packmesh "
     "comparison: ");
  html_esc(&d->html, su->name);
  SB(&d->html,
     "</title>\n<style>\n"
     "body{font-family:Helvetica,Arial,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;"
     "color:#222;line-height:1.4}\n"
     "table{border-collapse:collapse;margin:0.5em 0 1.2em;font-size:0.9em}\n"
     "th,td{border:1px solid #ccc;padding:0.25em 0.6em}th{background:#f2f2f2}\n"
     "td.n{text-align:right;font-variant-numeric:tabular-nums}\n"
     "pre{background:#f7f7f7;padding:0.8em;overflow-x:auto;font-size:0.85em}\n"
     "figure{margin:1em 0}figure img{max-width:100%%;border:1px solid #eee}\n"
     "figcaption{font-size:0.9em;color:#444}\n"
     "#pm-viewer select,#pm-viewer label{margin-right:0.6em}#pm-viewer-info{font-size:0.9em;"
     "min-height:1.4em}#pm-viewer-legend{font-size:0.85em;color:#444}\n"
     ".meshes{display:flex;flex-wrap:wrap;gap:0.5em 1em;align-items:flex-start}\n"
     ".meshes figure{margin:0.3em 0}.meshes figure.mesh img{width:520px}"
     ".meshes figure.worst img{width:260px}\n"
     "</style>\n</head>\n<body>\n");
  char title[512];
  snprintf(title, sizeof title, "packmesh comparison: %s", su->name);
  SB(&d->md, "# %s\n\n", title);
  SB(&d->html, "<h1>");
  html_esc(&d->html, title);
  SB(&d->html, "</h1>\n");
  if (su->description[0]) doc_p(d, su->description);

  int nok = 0, nbad = 0, npend = 0;
  for (int i = 0; i < st->nrow; ++i) {
    nok += st->rows[i].status == PM_CMP_OK;
    npend += st->rows[i].status == PM_CMP_PENDING;
  }
  nbad = st->nrow - nok - npend;
  char when[64];
  time_t now = time(NULL);
  struct tm tmv;
  localtime_r(&now, &tmv);
  strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S %Z", &tmv);
  char p[4096];
  char pend[96] = "";
  if (npend) snprintf(pend, sizeof pend, ", %d not finished (listed below)", npend);
  snprintf(p, sizeof p,
           "%d runs: %d succeeded, %d did not%s%s. Made on %s by the command below in %.1f s; "
           "runs made now: %d, kept from an earlier invocation: %d.",
           st->nrow, nok, nbad, nbad ? " (listed below)" : "", pend, when, st->wall_s, st->nrun,
           st->nreused);
  doc_p(d, p);
  doc_code(d, invocation, "sh");
  hosts(d, st);
  doc_p(d, "Every run is one `packmesh mesh` command, listed at the end; results.csv holds one "
           "row per run with every statistic, elements.csv the per-element measures behind the "
           "box plots, runs/ID/ each run's mesh, stats, trace and log.");

  doc_h(d, 2, "Summary");
  doc_p(d, "Mean ± standard deviation over the distinct results of each method (seeds and "
           "repeats; runs whose meshes are byte-identical are one result, counted once here and "
           "in the box plots' element pools: 'distinct' counts them; times are over every "
           "successful run). Radius "
           "ratio: 2r/R for triangles, 3r/R for tets (1 is ideal). R/l_min: circumradius over "
           "shortest edge (0.577 for an equilateral triangle, 0.612 for a regular tet). Angles in "
           "degrees. eps_t, eps_g: Shimada's irregularities (papers/003 eq. 8-9). valid: the mesh "
           "checker's verdict.");
  if (su->match_nodes) {
    char m[600];
    snprintf(m, sizeof m,
             "Node counts are matched to %s's %s (within 3%%).", su->methods[su->reference].label,
             su->match_surface ? "on the surface nodes, the nodes of the triangles: a volume "
                                 "mesh's interior nodes are not counted, so that surfaces are "
                                 "compared like for like"
                               : "on all nodes: a volume mesh's interior nodes count too, so its "
                                 "surface may be finer or coarser than the reference's");
    doc_p(d, m);
  }
  for (int c = 0; c < su->ncase; ++c) {
    char h[300];
    snprintf(h, sizeof h, "%s (%s)", su->cases[c].name, su->cases[c].input);
    doc_h(d, 3, h);
    if (any_value(st, c, "tri.radius_ratio.mean") || !any_value(st, c, "tet.radius_ratio.mean")) {
      if (any_value(st, c, "tet.radius_ratio.mean")) doc_p(d, "Surface triangles:");
      summary_table(d, st, c, tri_cols, COLS(tri_cols));
      if (any_value(st, c, "tri.by_site.boundary.count")) {
        doc_p(d, "Triangles by site: with a corner on a curve or vertex (boundary), around an "
                 "interior node of degree other than 6 (irregular), the rest (regular); their "
                 "mean counts and median R/l_min.");
        summary_table(d, st, c, site_cols, COLS(site_cols));
      }
    }
    if (any_value(st, c, "tet.radius_ratio.mean")) {
      doc_p(d, "Tetrahedra:");
      summary_table(d, st, c, tet_cols, COLS(tet_cols));
    }
    reference_table(d, st, c);
  }

  mesh_pictures(d, st, figs);
  pm_cmp_viewer viewer;
  pm_status vs = pm_cmp_viewer_write(st, figs->colour_max > 0 ? figs->colour_max : 1.5, &viewer, err);
  if (vs) {
    free(d->md.s);
    free(d->html.s);
    return vs;
  }
  viewer_section(d, st, &viewer);
  pm_cmp_viewer_clear(&viewer);

  doc_h(d, 2, "Figures");
  if (!figs->have_gnuplot)
    doc_p(d, "gnuplot is not installed, so no figure was drawn; the scripts and their data are "
             "in plots/ (install gnuplot and run `gnuplot NAME.gp` there).");
  if (figs->n == 0) doc_p(d, "No figure: no run succeeded.");
  for (int i = 0; i < figs->n; ++i) figure(d, &figs->fig[i]);

  if (nbad) {
    doc_h(d, 2, "Runs that did not succeed");
    const char *h[3] = {"run", "status", "error"};
    doc_table_head(d, 3, h);
    for (int i = 0; i < st->nrow; ++i) {
      const pm_cmp_row *r = &st->rows[i];
      if (r->status == PM_CMP_OK || r->status == PM_CMP_PENDING) continue;
      char cells[3][CELL];
      snprintf(cells[0], CELL, "%s", r->id);
      snprintf(cells[1], CELL, "%s", pm_cmp_status_name(r->status));
      snprintf(cells[2], CELL, "%s", r->error);
      doc_table_row(d, 3, cells);
    }
    doc_table_end(d);
  }

  if (npend) {
    doc_h(d, 2, "Runs not finished");
    doc_p(d, "These runs have no record yet: the tables leave them out. Running the study's "
             "command again runs them (or, with the Slurm engine, submits them).");
    const char *h[2] = {"run", "state"};
    doc_table_head(d, 2, h);
    for (int i = 0; i < st->nrow; ++i) {
      const pm_cmp_row *r = &st->rows[i];
      if (r->status != PM_CMP_PENDING) continue;
      char cells[2][CELL];
      snprintf(cells[0], CELL, "%s", r->id);
      snprintf(cells[1], CELL, "%s", r->error[0] ? r->error : "not run");
      doc_table_row(d, 2, cells);
    }
    doc_table_end(d);
  }

  doc_h(d, 2, "Runs and how to reproduce them");
  snprintf(p, sizeof p,
           "Each command re-creates its run exactly when run in the study folder (%s); write "
           "`packmesh` as the path of the binary if it is not on your PATH.",
           st->dir);
  doc_p(d, p);
  {
    const char *h[6] = {"run", "status", "nodes", "wall time (s)", "iterations", "same mesh as"};
    doc_table_head(d, 6, h);
    for (int i = 0; i < st->nrow; ++i) {
      const pm_cmp_row *r = &st->rows[i];
      char cells[6][CELL];
      snprintf(cells[0], CELL, "%s", r->id);
      snprintf(cells[1], CELL, "%s", pm_cmp_status_name(r->status));
      if (r->status == PM_CMP_OK)
        snprintf(cells[2], CELL, "%ld", r->nodes);
      else
        snprintf(cells[2], CELL, "-");
      fmt_num(cells[3], CELL, r->status == PM_CMP_SKIPPED ? NAN : r->wall_s, 3);
      fmt_num(cells[4], CELL, pm_cmp_row_value(r, "iterations"), 7);
      snprintf(cells[5], CELL, "%s", r->same_mesh_as >= 0 ? st->rows[r->same_mesh_as].id : "");
      doc_table_row(d, 6, cells);
    }
    doc_table_end(d);
    sbuf cmds = {0};
    for (int i = 0; i < st->nrow; ++i) {
      const pm_cmp_row *r = &st->rows[i];
      if (!r->command[0]) continue;
      SB(&cmds, "# %s\n%s\n", r->id, r->command);
    }
    doc_code(d, cmds.s ? cmds.s : "", "sh");
    d->md.bad |= cmds.bad;
    free(cmds.s);
  }

  doc_h(d, 2, "Inputs");
  inputs(d, st);
  doc_h(d, 2, "Environment");
  environment(d, figs);
  references(d);
  SB(&d->html, "</body>\n</html>\n");

  pm_status s = PM_OK;
  if (d->md.bad || d->html.bad) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  } else {
    char path[4400];
    snprintf(path, sizeof path, "%s/report.md", st->dir);
    s = pm_atomic_write(path, d->md.s, d->md.n, err);
    if (!s) {
      snprintf(path, sizeof path, "%s/report.html", st->dir);
      s = pm_atomic_write(path, d->html.s, d->html.n, err);
    }
  }
  free(d->md.s);
  free(d->html.s);
  return s;
}
