/* The convergence figure of a case, convergence_CASE, from the runs' traces (--trace): how a
 * particle method gets to its mesh, drawn so that a reader can follow it.
 *
 * One panel per measure a trace has -- energy (psys's energy, bubble's potential), the node count,
 * the mean displacement per step, eps_t and eps_g (papers/003 eq. 8-9, Table 1) -- in one column
 * per method, since bubble's steps and psys's iterations are different units and must not share
 * an axis. Every seed of the method is a thin line; the mean over the seeds that reached a step
 * is bold. Phases (the trace's `phase` column: bubble 2 surface, 3 volume; psys 1
 * curves, 2 gap sizes, 3 faces) are named where they start, after the first with a dashed
 * vertical line, taken from the first seed. Legends sit above each column's first panel, outside the
 * data.
 *
 * The node count: rows whose `event` is not 0 are the population changes between steps
 * (population control, bubble's border cleanup) and the mesh (event 3: the node count after the
 * connection). The node panel draws them, so each seed's line ends on its mesh's node count,
 * marked by a point; the caption gives the largest difference between the last step and the
 * mesh (nodes the connection step added: repairs, and with --volume TetGen's refinement in psys).
 * Traces without `nodes` (studies made before it) fall back to `particles` / `bubbles`, which
 * leave out vertex bubbles and, in bubble's volume phase, the surface, and the caption says so.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "compare/src/plot_gnuplot.h"

#define MAX_TRACE_POINTS 2000 /* a curve keeps at most this many points (every k-th row) */
#define NMEASURE 5

/* ---- reading a trace ----------------------------------------------------------------------- */

typedef struct trace {
  int ncol;
  char **name;
  double *v; /* [nrow * ncol]; an empty or unreadable field is NaN */
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

/* The first column named exactly one of the names, in order of the names; -1 when none. */
static int trace_col(const trace *t, const char *const *names) {
  for (int p = 0; names[p]; ++p)
    for (int c = 0; c < t->ncol; ++c)
      if (t->name[c] && strcmp(t->name[c], names[p]) == 0) return c;
  return -1;
}

static const char *const col_step[] = {"step", "iteration", NULL};
static const char *const col_phase[] = {"phase", NULL};
static const char *const col_event[] = {"event", NULL};
static const char *const col_nodes_old[] = {"particles", "bubbles", NULL};

/* The measures, one panel each, in this order. */
static const struct {
  const char *const names[3]; /* trace columns, the first present wins */
  const char *ylabel;
  int log;                    /* a log axis when every value is > 0 */
} measure[NMEASURE] = {
    {{"energy", "potential", NULL}, "energy", 1},
    {{"nodes", NULL, NULL}, "nodes", 0},
    {{"mean_disp", "mean_move", NULL}, "mean displacement per step", 1},
    {{"eps_t", NULL, NULL}, "eps_t (topological irregularity)", 0},
    {{"eps_g", NULL, NULL}, "eps_g (geometric irregularity)", 0},
};
enum { M_NODES = 1 };

/* ---- one method's runs --------------------------------------------------------------------- */

/* Sums over the seeds per step (steps are whole numbers from step0), for the bold mean. */
typedef struct means {
  long step0, nstep;
  double *sum; /* [nstep * NMEASURE] */
  int *cnt;    /* [nstep * NMEASURE] */
} means;

static int means_add(means *M, long step, int q, double v) {
  long k = step - M->step0;
  if (k < 0) return 0;
  if (k >= M->nstep) {
    long n = 2 * (k + 1);
    double *s = realloc(M->sum, (size_t)n * NMEASURE * sizeof *s);
    if (s) M->sum = s;
    int *c = realloc(M->cnt, (size_t)n * NMEASURE * sizeof *c);
    if (c) M->cnt = c;
    if (!s || !c) return -1;
    memset(M->sum + M->nstep * NMEASURE, 0, (size_t)(n - M->nstep) * NMEASURE * sizeof *s);
    memset(M->cnt + M->nstep * NMEASURE, 0, (size_t)(n - M->nstep) * NMEASURE * sizeof *c);
    M->nstep = n;
  }
  M->sum[k * NMEASURE + q] += v;
  M->cnt[k * NMEASURE + q]++;
  return 0;
}

/* What one method column holds. */
typedef struct column {
  int seeds;                 /* traced runs drawn */
  int block0;                /* data index of its first seed block; the mean block follows */
  int have[NMEASURE];        /* a value in some row */
  int positive[NMEASURE];    /* every value > 0 */
  int old_nodes;             /* a trace without `nodes` */
  double phase_x[8];         /* the first seed's phase starts, its first phase's included */
  int phase_of[8], nphase;
  unsigned long long mesh_rows; /* seeds (the first 64) whose trace has the mesh's row */
  long mesh_gap;             /* largest |mesh nodes - last step's nodes| over the seeds */
  char xlabel[32];
  char sweep[128];           /* the sweep value drawn, "" without a sweep */
} column;

/* Append the runs of method m on case c to the data: one block per seed (every row: steps and
 * events), then the mean block. */
static pm_status method_blocks(const pm_cmp_study *st, int c, int m, sbuf *d, int *block,
                               column *col, pm_error *err) {
  const pm_cmp_suite *su = &st->suite;
  means M = {0, 0, NULL, NULL};
  int w = -2; /* the sweep value drawn: that of the first traced run */
  for (int q = 0; q < NMEASURE; ++q) col->positive[q] = 1;
  for (int i = 0; i < st->nrow; ++i) {
    const pm_cmp_row *r = &st->rows[i];
    if (!pm_cmp_row_in(r, c, m, -1) || r->status != PM_CMP_OK || (w != -2 && r->isweep != w))
      continue;
    char path[4400];
    snprintf(path, sizeof path, "%s/runs/%s/trace.csv", st->dir, r->id);
    trace t;
    if (!trace_read(path, &t)) {
      trace_free(&t);
      continue;
    }
    int cs = trace_col(&t, col_step), cp = trace_col(&t, col_phase), ce = trace_col(&t, col_event);
    int cq[NMEASURE], any = 0;
    for (int q = 0; q < NMEASURE; ++q) any |= (cq[q] = trace_col(&t, measure[q].names)) >= 0;
    if (cq[M_NODES] < 0 && (cq[M_NODES] = trace_col(&t, col_nodes_old)) >= 0) col->old_nodes = 1;
    if (!any && cq[M_NODES] < 0) {
      trace_free(&t);
      continue;
    }
    if (w == -2) {
      w = r->isweep;
      snprintf(col->xlabel, sizeof col->xlabel, "%s", cs >= 0 ? t.name[cs] : "row");
      if (w >= 0) snprintf(col->sweep, sizeof col->sweep, "%s=%s", su->sweep_key, su->sweep_values[w]);
    }
    SB(d, "# method %s, seed %ld, run %s\n# %s event energy nodes displacement eps_t eps_g\n",
       su->methods[m].label, r->seed, r->id, col->xlabel);
    long stride = t.nrow > MAX_TRACE_POINTS ? (t.nrow + MAX_TRACE_POINTS - 1) / MAX_TRACE_POINTS : 1;
    double last_phase = NAN, last_step_nodes = NAN, mesh_nodes = NAN;
    sbuf events = {0}; /* the seed's event rows, its second block */
    for (long k = 0; k < t.nrow; ++k) {
      const double *row = t.v + k * t.ncol;
      double x = cs >= 0 ? row[cs] : (double)k;
      double ev = ce >= 0 ? row[ce] : 0;
      if (ev == 0 && cp >= 0 && isfinite(row[cp])) {
        /* the first seed's phases: where each starts, the first one included */
        if (col->seeds == 0 && row[cp] != last_phase && col->nphase < 8) {
          col->phase_x[col->nphase] = x;
          col->phase_of[col->nphase++] = (int)row[cp];
        }
        last_phase = row[cp];
      }
      for (int q = 0; q < NMEASURE; ++q) {
        double v = cq[q] >= 0 ? row[cq[q]] : NAN;
        if (!isfinite(v)) continue;
        col->have[q] = 1;
        if (!(v > 0)) col->positive[q] = 0;
        if (ev == 0 && isfinite(x) && means_add(&M, (long)llround(x), q, v))
          return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      }
      if (cq[M_NODES] >= 0) {
        if (ev == 0) last_step_nodes = row[cq[M_NODES]];
        if (ev == 3) mesh_nodes = row[cq[M_NODES]];
      }
      /* Steps in the first block (lines, every k-th), events whole in the second (points). */
      sbuf *to = ev == 0 ? d : &events;
      if (ev == 0 && k % stride && k != t.nrow - 1) continue;
      SB(to, "%.9g %.0f", x, isfinite(ev) ? ev : 0);
      for (int q = 0; q < NMEASURE; ++q) {
        double v = cq[q] >= 0 ? row[cq[q]] : NAN;
        if (isfinite(v))
          SB(to, " %.9g", v);
        else
          SB(to, " ?");
      }
      SB(to, "\n");
    }
    if (col->seeds < 64 && isfinite(mesh_nodes)) col->mesh_rows |= 1ull << col->seeds;
    SB(d, "\n\n# its events: population changes between steps, the mesh (event 3)\n");
    if (events.bad) d->bad = 1;
    if (events.s)
      SB(d, "%s", events.s);
    else /* a block needs a row to be counted: a placeholder no plot selects */
      SB(d, "0 -1 ? ? ? ? ?\n");
    free(events.s);
    if (isfinite(mesh_nodes) && isfinite(last_step_nodes)) {
      long gap = labs((long)llround(mesh_nodes - last_step_nodes));
      if (gap > col->mesh_gap) col->mesh_gap = gap;
    }
    SB(d, "\n\n");
    if (!col->seeds) col->block0 = *block;
    *block += 2;
    col->seeds++;
    trace_free(&t);
  }
  if (col->seeds) {
    SB(d, "# method %s, mean over its %d seeds at each %s (those that reached it)\n",
       su->methods[m].label, col->seeds, col->xlabel);
    long stride = M.nstep > MAX_TRACE_POINTS ? (M.nstep + MAX_TRACE_POINTS - 1) / MAX_TRACE_POINTS : 1;
    for (long k = 0; k < M.nstep; ++k) {
      int anyv = 0;
      for (int q = 0; q < NMEASURE; ++q) anyv |= M.cnt[k * NMEASURE + q] > 0;
      if (!anyv || k % stride) continue;
      SB(d, "%ld 0", M.step0 + k);
      for (int q = 0; q < NMEASURE; ++q) {
        int n = M.cnt[k * NMEASURE + q];
        if (n)
          SB(d, " %.9g", M.sum[k * NMEASURE + q] / n);
        else
          SB(d, " ?");
      }
      SB(d, "\n");
    }
    SB(d, "\n\n");
    ++*block;
  }
  free(M.sum);
  free(M.cnt);
  return PM_OK;
}

/* ---- the figure ---------------------------------------------------------------------------- */

/* What a phase does, for its label: the trace's step column tells the two methods apart (bubble
 * counts steps, psys iterations); "" for another trace. */
static const char *phase_name(const char *xlabel, int phase) {
  static const char *const bubble[4] = {"", "", "surface", "volume"};
  static const char *const psys[4] = {"", "curves", "gap sizes", "faces"};
  if (phase < 0 || phase > 3) return "";
  if (strcmp(xlabel, "step") == 0) return bubble[phase];
  if (strcmp(xlabel, "iteration") == 0) return psys[phase];
  return "";
}

pm_status pm_cmp_plot_convergence(pm_cmp_plotctx *P, int c, pm_error *err) {
  const pm_cmp_study *st = P->st;
  const pm_cmp_suite *su = &st->suite;
  const int nm = su->nmethod;
  sbuf d = {0}, g = {0};
  int block = 0, ncol = 0;
  column *col = calloc((size_t)nm + 1, sizeof *col);
  if (!col) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status s = PM_OK;
  SB(&d, "# convergence of the runs on %s: per method, two blocks per seed (its steps, every "
         "k-th; its events), then the mean over the seeds (steps only)\n# columns: step or "
         "iteration, event, energy, nodes, mean displacement, eps_t, eps_g (? = not traced)\n",
     su->cases[c].name);
  int have[NMEASURE] = {0};
  for (int m = 0; m < nm && !s; ++m) {
    s = method_blocks(st, c, m, &d, &block, &col[m], err);
    if (col[m].seeds) {
      ++ncol;
      for (int q = 0; q < NMEASURE; ++q) have[q] |= col[m].have[q];
    }
  }
  int nrow = 0;
  for (int q = 0; q < NMEASURE; ++q) nrow += have[q];
  if (s || !ncol || !nrow) goto done;
  char name[160], title[300], q[512];
  snprintf(name, sizeof name, "convergence_%s", su->cases[c].name);
  pm_cmp_plot_stem(name);
  snprintf(title, sizeof title, "convergence on %s", su->cases[c].name);
  pm_cmp_gp_head(&g, name, title,
                 "per method: one block per seed (step, event, energy, nodes, displacement, "
                 "eps_t, eps_g), then the mean over the seeds",
                 180 + 470 * ncol, 90 + 230 * nrow);
  pm_cmp_gp_quote(title, q, sizeof q);
  SB(&g, "  set multiplot layout %d,%d columnsfirst title \"%s\"\n", nrow, ncol, q);
  SB(&g, "  set lmargin 12\n  set rmargin 3\n");
  for (int m = 0; m < nm; ++m) {
    const column *k = &col[m];
    if (!k->seeds) continue;
    char lab[256];
    pm_cmp_gp_quote(su->methods[m].label, lab, sizeof lab);
    const char *colour = pm_cmp_palette[m % PM_CMP_NPALETTE];
    int row = 0;
    for (int p = 0; p < NMEASURE; ++p) {
      if (!have[p]) continue;
      SB(&g, "  unset logscale y\n  set format y \"%%g\"\n  unset arrow\n  unset label\n");
      if (measure[p].log && k->positive[p] && k->have[p]) SB(&g, "  set logscale y\n");
      /* Phases: each named where it starts, a dashed line at the first step of each after the
       * first. */
      for (int b = 0; b < k->nphase && k->have[p]; ++b) {
        if (b > 0)
          SB(&g, "  set arrow from %.9g, graph 0 to %.9g, graph 1 nohead dt 2 lc rgb "
                 "\"#777777\"\n",
             k->phase_x[b], k->phase_x[b]);
        const char *what = phase_name(k->xlabel, k->phase_of[b]);
        SB(&g, "  set label \"phase %d%s%s\" at %.9g, graph 0.93 offset 0.4,0 font \",10\" tc "
               "rgb \"#555555\"\n",
           k->phase_of[b], what[0] ? ": " : "", what, k->phase_x[b]);
      }
      SB(&g, "  set ylabel \"%s\"\n", measure[p].ylabel);
      if (row == 0) {
        SB(&g, "  set title \"%s%s%s\" font \",13\"\n", lab, k->sweep[0] ? ", " : "", k->sweep);
        SB(&g, "  set key outside top center horizontal font \",10\"\n");
      } else {
        SB(&g, "  unset title\n  unset key\n");
      }
      /* The x label on the bottom panel of the column only. */
      if (row == nrow - 1)
        SB(&g, "  set xlabel \"%s\"\n", k->xlabel);
      else
        SB(&g, "  unset xlabel\n");
      if (!k->have[p]) { /* this method has no such column: an empty, labelled panel */
        SB(&g, "  set label \"not traced by %s\" at graph 0.5, graph 0.5 center\n", lab);
        SB(&g, "  plot [0:1] [0:1] NaN notitle\n");
        ++row;
        continue;
      }
      SB(&g, "  plot \\\n");
      /* The key is drawn once, above the column: the mesh's dots get their entry there. */
      if (row == 0 && k->mesh_rows)
        SB(&g, "    NaN with points pt 7 ps 0.8 lc rgb \"black\" title \"the mesh (node "
               "count)\", \\\n");
      const int ycol = 3 + p;
      for (int sd = 0; sd < k->seeds; ++sd) {
        SB(&g, "    data index %d using 1:%d with lines lw 0.9 lc rgb \"#80%s\" %s, \\\n",
           k->block0 + 2 * sd, ycol, colour + 1, sd == 0 ? "title \"each seed\"" : "notitle");
        if (p == M_NODES && sd < 64 && (k->mesh_rows >> sd & 1))
          SB(&g, "    data index %d using 1:($2 == 3 ? $%d : NaN) with points pt 7 ps 0.8 lc rgb "
                 "\"black\" notitle, \\\n",
             k->block0 + 2 * sd + 1, ycol);
      }
      SB(&g, "    data index %d using 1:%d with lines lw 2.6 lc rgb \"%s\" title \"mean of %d "
             "seed%s\"\n",
         k->block0 + 2 * k->seeds, ycol, colour, k->seeds, k->seeds == 1 ? "" : "s");
      ++row;
    }
  }
  SB(&g, "  unset multiplot\n");
  pm_cmp_gp_tail(&g);
  char cap[1024];
  int n = snprintf(cap, sizeof cap,
                   "Each column is one method against its own steps (bubble) or iterations "
                   "(psys); thin lines are the seeds, the bold line their mean. Dashed lines start "
                   "a phase (bubble: 2 surface, 3 volume; psys: 1 curves, 2 gap sizes, 3 faces). "
                   "The node count includes population control between steps and ends on the "
                   "mesh's node count (the dots).");
  for (int m = 0; m < nm && n < (int)sizeof cap; ++m) {
    if (!col[m].seeds) continue;
    if (col[m].old_nodes)
      n += snprintf(cap + n, sizeof cap - (size_t)n,
                    " %s's trace has no nodes column: its count leaves out vertex bubbles and, in "
                    "a volume phase, the surface.",
                    su->methods[m].label);
    else if (col[m].mesh_gap > 0)
      n += snprintf(cap + n, sizeof cap - (size_t)n,
                    " %s's mesh has up to %ld nodes more than its last step: added by the "
                    "connection step (repairs%s).",
                    su->methods[m].label, col[m].mesh_gap,
                    su->cases[c].volume ? "; with tets, the volume step's nodes" : "");
  }
  s = pm_cmp_plot_emit(P, name, title, cap, &d, &g, err);
done:
  free(col);
  free(d.s);
  free(g.s);
  return s;
}
