/* Checking a planar domain's loops before it is built (see planar_check.h).
 *
 * Every piece becomes a line from a to b or an arc (centre c, radius R, start angle th0, signed
 * sweep: positive counter-clockwise, |sweep| in (0, 2 pi], 2 pi for a loop of one arc), with the
 * same conventions and tolerance as pm_planar_model. Then, in order, so that the first message is
 * the most telling one: piece lengths; loops of lines all on one line; contacts between pairs of
 * pieces (a sweep over bounding boxes sorted by x); each loop's area; holes inside the outer loop
 * and not inside each other.
 *
 * Contacts. Two lines: exact orientation tests decide crossing, touching and running along
 * (collinear with a common stretch); a gap of at most tol between them is a touch. A line and an
 * arc, two arcs: the circle intersections, kept when they lie on the arcs (within tol/R in
 * angle). Two consecutive pieces of a loop always meet at their shared vertex V; any other
 * contact is a fault. Their other intersection is computed from V rather than searched for near
 * it: a line meets a circle at V and at the mirror of V about the foot of the centre on the
 * line; two circles meet at V and at the mirror of V about the line of centres. So a tangent
 * continuation (a fillet arc after a line) has its second point on V itself, and is no fault,
 * while any genuine second contact is found wherever it is.
 *
 * Inside. Once no two loops meet, a hole is inside a loop exactly when one of its points is. The
 * winding number of a loop around a point p is that of the polygon of its vertices (exact
 * orientation tests, crossing rule of Sunday) plus, for each arc, +-1 when p lies in the
 * circular segment between the arc and its chord (+1 counter-clockwise): the arc followed by its
 * chord backwards is a closed curve that winds once around that segment.
 */
#include "common/geom/planar_check.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"
#include "common/backends/predicates.h"

typedef struct piece {
  int arc;
  double a[2], b[2];   /* start, end */
  double c[2], R;      /* arc: centre, radius */
  double th0, sweep;   /* arc: start angle, signed sweep */
  double box[4];       /* xmin, ymin, xmax, ymax */
  int32_t loop, k, n;  /* loop, index in it, pieces in the loop */
} piece;

typedef struct checker {
  piece *p;
  int32_t np;
  double tol, scale;
  pm_error *err;
} checker;

static double dist2(const double a[2], const double b[2]) {
  return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]);
}

static double wrap(double t) { /* to [0, 2 pi) */
  t = fmod(t, 2 * M_PI);
  return t < 0 ? t + 2 * M_PI : t;
}

/* p lies on arc q (its circle assumed): within tol / R of its angular range. */
static int on_arc(const piece *q, const double p[2], double tol) {
  if (fabs(q->sweep) >= 2 * M_PI) return 1;
  double phi = atan2(p[1] - q->c[1], p[0] - q->c[0]);
  double rel = wrap((q->sweep > 0 ? 1 : -1) * (phi - q->th0));
  double eps = tol / q->R;
  return rel <= fabs(q->sweep) + eps || rel >= 2 * M_PI - eps;
}

/* A point on piece q, at fraction t of the way. */
static void point_at(const piece *q, double t, double out[2]) {
  if (!q->arc) {
    out[0] = q->a[0] + t * (q->b[0] - q->a[0]);
    out[1] = q->a[1] + t * (q->b[1] - q->a[1]);
    return;
  }
  double th = q->th0 + t * q->sweep;
  out[0] = q->c[0] + q->R * cos(th);
  out[1] = q->c[1] + q->R * sin(th);
}

/* ---- contacts ------------------------------------------------------------------------------- */

enum { NONE = 0, TOUCH, CROSS, ALONG };

typedef struct contact {
  int kind;
  double at[2];
} contact;

static double seg_point_dist2(const double a[2], const double b[2], const double p[2], double q[2]) {
  double dx = b[0] - a[0], dy = b[1] - a[1], L2 = dx * dx + dy * dy;
  double t = L2 > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L2 : 0;
  t = t < 0 ? 0 : t > 1 ? 1 : t;
  q[0] = a[0] + t * dx, q[1] = a[1] + t * dy;
  return dist2(p, q);
}

static int near(const double a[2], const double b[2], double tol) { return dist2(a, b) <= tol * tol; }

/* Is x within tol of one of the vertices v[0..nv)? */
static int near_any(const double x[2], const double (*v)[2], int nv, double tol) {
  for (int i = 0; i < nv; ++i)
    if (near(x, v[i], tol)) return 1;
  return 0;
}

/* Two lines. The shared vertices of consecutive pieces need no special case: the exact tests
 * find them as a touch at an end point, which the caller discards. */
static void line_line(const checker *ck, const piece *p, const piece *q, contact *out, int *nout) {
  const double *a = p->a, *b = p->b, *c = q->a, *d = q->b;
  int o1 = pm_orient2d(a, b, c), o2 = pm_orient2d(a, b, d);
  int o3 = pm_orient2d(c, d, a), o4 = pm_orient2d(c, d, b);
  if (o1 == 0 && o2 == 0) {
    /* Collinear: the common stretch along the dominant axis. */
    int ax = fabs(b[0] - a[0]) >= fabs(b[1] - a[1]) ? 0 : 1;
    double p0 = fmin(a[ax], b[ax]), p1 = fmax(a[ax], b[ax]);
    double q0 = fmin(c[ax], d[ax]), q1 = fmax(c[ax], d[ax]);
    double lo = fmax(p0, q0), hi = fmin(p1, q1);
    double dir = fabs(b[ax] - a[ax]) > 0 ? hypot(b[0] - a[0], b[1] - a[1]) / fabs(b[ax] - a[ax]) : 1;
    if ((hi - lo) * dir > ck->tol) {
      out[(*nout)++] = (contact){ALONG, {0, 0}};
      point_at(p, fabs(b[ax] - a[ax]) > 0 ? (0.5 * (lo + hi) - a[ax]) / (b[ax] - a[ax]) : 0,
               out[*nout - 1].at);
    } else if ((hi - lo) * dir >= -ck->tol) {
      const double *e[4] = {a, b, c, d};
      for (int i = 0; i < 4; ++i)
        if (e[i][ax] >= lo - ck->tol && e[i][ax] <= hi + ck->tol) {
          out[(*nout)++] = (contact){TOUCH, {e[i][0], e[i][1]}};
          break;
        }
    }
    return;
  }
  if (o1 * o2 <= 0 && o3 * o4 <= 0) {
    contact r = {o1 && o2 && o3 && o4 ? CROSS : TOUCH, {0, 0}};
    if (o1 == 0) memcpy(r.at, c, sizeof r.at);
    else if (o2 == 0) memcpy(r.at, d, sizeof r.at);
    else if (o3 == 0) memcpy(r.at, a, sizeof r.at);
    else if (o4 == 0) memcpy(r.at, b, sizeof r.at);
    else {
      double den = (b[0] - a[0]) * (d[1] - c[1]) - (b[1] - a[1]) * (d[0] - c[0]);
      double t = ((c[0] - a[0]) * (d[1] - c[1]) - (c[1] - a[1]) * (d[0] - c[0])) / den;
      point_at(p, t, r.at);
    }
    out[(*nout)++] = r;
    return;
  }
  /* Apart: a gap of at most tol is a touch. */
  double best = INFINITY, at[2] = {0, 0}, f[2];
  const double *ends[4][3] = {{c, a, b}, {d, a, b}, {a, c, d}, {b, c, d}};
  for (int i = 0; i < 4; ++i) {
    double d2 = seg_point_dist2(ends[i][1], ends[i][2], ends[i][0], f);
    if (d2 < best) best = d2, at[0] = ends[i][0][0], at[1] = ends[i][0][1];
  }
  if (best <= ck->tol * ck->tol) out[(*nout)++] = (contact){TOUCH, {at[0], at[1]}};
}

/* A line p and an arc q. `shared` (nshared of them) are vertices the two pieces are known to
 * share (consecutive pieces); they are intersections already and are not reported. */
static void line_arc(const checker *ck, const piece *p, const piece *q, const double (*shared)[2],
                     int nshared, contact *out, int *nout) {
  double L = sqrt(dist2(p->a, p->b));
  double u[2] = {(p->b[0] - p->a[0]) / L, (p->b[1] - p->a[1]) / L};
  double w[2] = {q->c[0] - p->a[0], q->c[1] - p->a[1]};
  double tc = w[0] * u[0] + w[1] * u[1];             /* foot of the centre, along the line */
  double h = fabs(w[0] * u[1] - w[1] * u[0]);        /* the centre's distance to the line */
  if (h > q->R + ck->tol) return;
  double t[2];
  int nt = 0;
  if (nshared == 1) {
    /* The other root: the mirror of the shared vertex about the foot. */
    double ts = (shared[0][0] - p->a[0]) * u[0] + (shared[0][1] - p->a[1]) * u[1];
    t[nt++] = 2 * tc - ts;
  } else if (nshared == 0) {
    double k2 = q->R * q->R - h * h, k = k2 > 0 ? sqrt(k2) : 0;
    t[nt++] = tc - k;
    if (k > ck->tol) t[nt++] = tc + k;
  } else {
    return; /* both intersections of a line and a circle are the shared vertices */
  }
  for (int i = 0; i < nt; ++i) {
    if (t[i] < -ck->tol || t[i] > L + ck->tol) continue;
    double x[2] = {p->a[0] + t[i] * u[0], p->a[1] + t[i] * u[1]};
    if (near_any(x, shared, nshared, ck->tol) || !on_arc(q, x, ck->tol)) continue;
    const double ends[4][2] = {{p->a[0], p->a[1]}, {p->b[0], p->b[1]}, {q->a[0], q->a[1]}, {q->b[0], q->b[1]}};
    int tangent = nshared == 0 && nt == 1;
    out[(*nout)++] = (contact){tangent || near_any(x, ends, 4, 100 * ck->tol) ? TOUCH : CROSS, {x[0], x[1]}};
  }
}

/* Length (angle) of the common part of two arcs of one circle. */
static double common_angle(const piece *p, const piece *q) {
  /* As counter-clockwise intervals [s, s + w]. */
  double sp = p->sweep > 0 ? p->th0 : p->th0 + p->sweep, wp = fabs(p->sweep);
  double sq = q->sweep > 0 ? q->th0 : q->th0 + q->sweep, wq = fabs(q->sweep);
  double d = wrap(sq - sp), total = 0;
  for (int shift = -1; shift <= 1; ++shift) {
    double s = d + 2 * M_PI * shift, lo = fmax(0, s), hi = fmin(wp, s + wq);
    if (hi > lo) total += hi - lo;
  }
  return total;
}

static void arc_arc(const checker *ck, const piece *p, const piece *q, const double (*shared)[2],
                    int nshared, contact *out, int *nout) {
  double dx = q->c[0] - p->c[0], dy = q->c[1] - p->c[1], d = hypot(dx, dy);
  const double ends[4][2] = {{p->a[0], p->a[1]}, {p->b[0], p->b[1]}, {q->a[0], q->a[1]}, {q->b[0], q->b[1]}};
  if (d <= ck->tol && fabs(p->R - q->R) <= ck->tol) {
    /* One circle: a common stretch, or contacts at end points. */
    double common = common_angle(p, q) * p->R;
    if (common > ck->tol) {
      double mid[2];
      point_at(p, 0.5, mid);
      out[(*nout)++] = (contact){ALONG, {mid[0], mid[1]}};
      return;
    }
    for (int i = 0; i < 2; ++i)
      for (int j = 2; j < 4; ++j)
        if (near(ends[i], ends[j], ck->tol) && !near_any(ends[i], shared, nshared, ck->tol)) {
          out[(*nout)++] = (contact){TOUCH, {ends[i][0], ends[i][1]}};
          return;
        }
    return;
  }
  if (d > p->R + q->R + ck->tol || d < fabs(p->R - q->R) - ck->tol || d <= ck->tol) return;
  double e[2] = {dx / d, dy / d}, x[2][2];
  int nx = 0;
  if (nshared == 1) {
    /* The mirror of the shared vertex about the line of centres. */
    double v[2] = {shared[0][0] - p->c[0], shared[0][1] - p->c[1]};
    double along = v[0] * e[0] + v[1] * e[1];
    x[0][0] = p->c[0] + 2 * along * e[0] - v[0];
    x[0][1] = p->c[1] + 2 * along * e[1] - v[1];
    nx = 1;
  } else if (nshared == 0) {
    double m = (d * d + p->R * p->R - q->R * q->R) / (2 * d);
    double y2 = p->R * p->R - m * m, y = y2 > 0 ? sqrt(y2) : 0;
    for (int s = -1; s <= 1; s += 2) {
      x[nx][0] = p->c[0] + m * e[0] - s * y * e[1];
      x[nx][1] = p->c[1] + m * e[1] + s * y * e[0];
      ++nx;
      if (y <= ck->tol) break;
    }
  }
  for (int i = 0; i < nx; ++i) {
    if (near_any(x[i], shared, nshared, ck->tol) || !on_arc(p, x[i], ck->tol) ||
        !on_arc(q, x[i], ck->tol))
      continue;
    int tangent = nshared == 0 && nx == 1;
    out[(*nout)++] = (contact){tangent || near_any(x[i], ends, 4, 100 * ck->tol) ? TOUCH : CROSS,
                               {x[i][0], x[i][1]}};
  }
}

static const char *what_of(int kind) {
  return kind == CROSS ? "crosses" : kind == TOUCH ? "touches" : "runs along";
}

static pm_status pair(const checker *ck, const piece *p, const piece *q) {
  /* Vertices shared as consecutive pieces of one loop. */
  double shared[2][2];
  int nshared = 0;
  if (p->loop == q->loop) {
    if ((p->k + 1) % p->n == q->k) memcpy(shared[nshared++], p->b, sizeof shared[0]);
    if ((q->k + 1) % q->n == p->k) memcpy(shared[nshared++], q->b, sizeof shared[0]);
  }
  contact c[4];
  int nc = 0;
  if (!p->arc && !q->arc)
    line_line(ck, p, q, c, &nc);
  else if (!p->arc)
    line_arc(ck, p, q, (const double(*)[2])shared, nshared, c, &nc);
  else if (!q->arc)
    line_arc(ck, q, p, (const double(*)[2])shared, nshared, c, &nc);
  else
    arc_arc(ck, p, q, (const double(*)[2])shared, nshared, c, &nc);
  for (int i = 0; i < nc; ++i) {
    if (c[i].kind != ALONG && near_any(c[i].at, (const double(*)[2])shared, nshared, ck->tol)) continue;
    const piece *x = p->loop < q->loop || (p->loop == q->loop && p->k < q->k) ? p : q;
    const piece *y = x == p ? q : p;
    if (x->loop == y->loop)
      return pm_error_setf(ck->err, PM_ERR_ARG, "loop %d: piece %d %s piece %d at (%g, %g)%s",
                           (int)x->loop, (int)x->k, what_of(c[i].kind), (int)y->k, c[i].at[0],
                           c[i].at[1], " (a loop must not meet itself)");
    return pm_error_setf(ck->err, PM_ERR_ARG, "loop %d piece %d %s loop %d piece %d at (%g, %g)%s",
                         (int)x->loop, (int)x->k, what_of(c[i].kind), (int)y->loop, (int)y->k,
                         c[i].at[0], c[i].at[1], " (loops must not meet)");
  }
  return PM_OK;
}

static int cmp_xmin(const void *pa, const void *pb) {
  const piece *a = *(const piece *const *)pa, *b = *(const piece *const *)pb;
  if (a->box[0] != b->box[0]) return a->box[0] < b->box[0] ? -1 : 1;
  if (a->loop != b->loop) return a->loop - b->loop;
  return a->k - b->k;
}

static pm_status contacts(const checker *ck) {
  piece **order = malloc((size_t)ck->np * sizeof *order);
  if (!order) return pm_error_setf(ck->err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < ck->np; ++i) order[i] = &ck->p[i];
  qsort(order, (size_t)ck->np, sizeof *order, cmp_xmin);
  pm_status s = PM_OK;
  for (int32_t i = 0; i < ck->np && !s; ++i)
    for (int32_t j = i + 1; j < ck->np && !s; ++j) {
      const piece *p = order[i], *q = order[j];
      if (q->box[0] > p->box[2] + ck->tol) break;
      if (q->box[1] > p->box[3] + ck->tol || p->box[1] > q->box[3] + ck->tol) continue;
      if (p->loop == q->loop && p->k == q->k) continue;
      s = pair(ck, p, q);
    }
  free(order);
  return s;
}

/* ---- inside ---------------------------------------------------------------------------------- */

/* Winding number of loop l (pieces lp[0..n)) around x; *unsure when x lies on a chord. */
static int winding(const piece *lp, int32_t n, const double x[2], int *unsure) {
  int w = 0;
  for (int32_t k = 0; k < n; ++k) {
    const piece *q = &lp[k];
    const double *u = q->a, *v = q->b;
    if (!(q->arc && fabs(q->sweep) >= 2 * M_PI)) {
      int o = pm_orient2d(u, v, x);
      if (o == 0 && fmin(u[0], v[0]) <= x[0] && x[0] <= fmax(u[0], v[0]) &&
          fmin(u[1], v[1]) <= x[1] && x[1] <= fmax(u[1], v[1]))
        *unsure = 1;
      if (u[1] <= x[1]) {
        if (v[1] > x[1] && o > 0) ++w;
      } else if (v[1] <= x[1] && o < 0) {
        --w;
      }
    }
    if (!q->arc) continue;
    /* In the circular segment between the arc and its chord? */
    if (dist2(x, q->c) >= q->R * q->R) continue;
    int in;
    if (fabs(q->sweep) >= 2 * M_PI) {
      in = 1;
    } else {
      double mid[2];
      point_at(q, 0.5, mid);
      int om = pm_orient2d(u, v, mid), ox = pm_orient2d(u, v, x);
      in = ox != 0 && ox == om;
    }
    if (in) w += q->sweep > 0 ? 1 : -1;
  }
  return w;
}

/* A point of loop `l` that lies on no chord of loop `other`. */
static void probe(const piece *l, int32_t n, const piece *other, int32_t no, double x[2]) {
  for (int32_t k = 0; k < 2 * n; ++k) {
    point_at(&l[k / 2], k % 2 ? 0.5 : 0.0, x);
    int unsure = 0;
    winding(other, no, x, &unsure);
    if (!unsure) return;
  }
}

static pm_status holes_inside(const checker *ck, int32_t nloop, const int32_t *first) {
  for (int32_t h = 1; h < nloop; ++h) {
    const piece *hl = &ck->p[first[h]];
    int32_t hn = first[h + 1] - first[h];
    for (int32_t l = 0; l < nloop; ++l) {
      if (l == h) continue;
      const piece *ol = &ck->p[first[l]];
      int32_t on = first[l + 1] - first[l];
      double x[2];
      probe(hl, hn, ol, on, x);
      int unsure = 0, w = winding(ol, on, x, &unsure);
      if (l == 0 && w == 0)
        return pm_error_setf(ck->err, PM_ERR_ARG,
                             "loop %d (a hole) lies outside loop 0 (the outer boundary): it "
                             "would be meshed as material",
                             (int)h);
      if (l > 0 && w != 0)
        return pm_error_setf(ck->err, PM_ERR_ARG,
                             "loop %d (a hole) lies inside loop %d (another hole)", (int)h, (int)l);
    }
  }
  return PM_OK;
}

/* ---- pieces ---------------------------------------------------------------------------------- */

static pm_status build(checker *ck, int32_t nloop, const pm_planar_loop *loops, int32_t *first) {
  int32_t np = 0;
  double scale = 0;
  for (int32_t l = 0; l < nloop; ++l) {
    if (loops[l].n <= 0 || !loops[l].piece)
      return pm_error_setf(ck->err, PM_ERR_ARG, "loop %d has no pieces", (int)l);
    if (loops[l].n > PM_PLANAR_MAX_PIECES - np)
      return pm_error_setf(ck->err, PM_ERR_ARG, "more than %d pieces in all",
                           PM_PLANAR_MAX_PIECES);
    first[l] = np;
    np += loops[l].n;
    for (int32_t k = 0; k < loops[l].n; ++k) {
      const pm_planar_piece *q = &loops[l].piece[k];
      const double v[4] = {q->start[0], q->start[1], q->centre[0], q->centre[1]};
      for (int i = 0; i < (q->kind == PM_PIECE_ARC ? 4 : 2); ++i) {
        if (!isfinite(v[i]))
          return pm_error_setf(ck->err, PM_ERR_ARG, "loop %d piece %d: a non-finite coordinate",
                               (int)l, (int)k);
        if (fabs(v[i]) > PM_COORD_MAX)
          return pm_error_setf(ck->err, PM_ERR_ARG,
                               "loop %d piece %d: coordinate %g is beyond +-%g, the largest "
                               "packmesh takes",
                               (int)l, (int)k, v[i], PM_COORD_MAX);
      }
      scale = fmax(scale, fmax(fabs(q->start[0]), fabs(q->start[1])));
      if (q->kind == PM_PIECE_ARC)
        scale = fmax(scale, hypot(q->start[0] - q->centre[0], q->start[1] - q->centre[1]));
    }
  }
  first[nloop] = np;
  if (!(scale > 0)) scale = 1;
  ck->scale = scale;
  ck->tol = 1e-9 * scale; /* pm_planar_model's */
  ck->np = np;
  ck->p = calloc((size_t)np, sizeof *ck->p);
  if (!ck->p) return pm_error_setf(ck->err, PM_ERR_NOMEM, "out of memory");
  for (int32_t l = 0; l < nloop; ++l) {
    int32_t n = loops[l].n;
    for (int32_t k = 0; k < n; ++k) {
      const pm_planar_piece *q = &loops[l].piece[k];
      piece *p = &ck->p[first[l] + k];
      p->loop = l, p->k = k, p->n = n;
      p->arc = q->kind == PM_PIECE_ARC;
      memcpy(p->a, q->start, sizeof p->a);
      memcpy(p->b, loops[l].piece[(k + 1) % n].start, sizeof p->b);
      if (!p->arc) {
        if (!(sqrt(dist2(p->a, p->b)) > ck->tol))
          return pm_error_setf(ck->err, PM_ERR_ARG,
                               "loop %d piece %d: zero-length line (it starts at (%g, %g), where "
                               "the next piece starts)",
                               (int)l, (int)k, p->a[0], p->a[1]);
        p->box[0] = fmin(p->a[0], p->b[0]), p->box[1] = fmin(p->a[1], p->b[1]);
        p->box[2] = fmax(p->a[0], p->b[0]), p->box[3] = fmax(p->a[1], p->b[1]);
        continue;
      }
      memcpy(p->c, q->centre, sizeof p->c);
      p->R = sqrt(dist2(p->a, p->c));
      double Re = sqrt(dist2(p->b, p->c));
      if (!(p->R > ck->tol))
        return pm_error_setf(ck->err, PM_ERR_ARG,
                             "loop %d piece %d: arc of radius 0 (it starts at its centre)", (int)l,
                             (int)k);
      if (fabs(p->R - Re) > 1e-7 * scale)
        return pm_error_setf(ck->err, PM_ERR_ARG,
                             "loop %d piece %d: the arc's end is not on its circle (radius %g at "
                             "the start, %g at the end)",
                             (int)l, (int)k, p->R, Re);
      double s = q->ccw ? 1.0 : -1.0;
      p->th0 = atan2(p->a[1] - p->c[1], p->a[0] - p->c[0]);
      double span = wrap(s * (atan2(p->b[1] - p->c[1], p->b[0] - p->c[0]) - p->th0));
      if (n == 1 || span * p->R <= ck->tol) span = 2 * M_PI; /* closes on itself: a full circle */
      p->sweep = s * span;
      /* Box: the end points and the circle's extreme points the arc passes. */
      p->box[0] = fmin(p->a[0], p->b[0]), p->box[1] = fmin(p->a[1], p->b[1]);
      p->box[2] = fmax(p->a[0], p->b[0]), p->box[3] = fmax(p->a[1], p->b[1]);
      for (int e = 0; e < 4; ++e) {
        double x[2] = {p->c[0] + p->R * cos(e * M_PI / 2), p->c[1] + p->R * sin(e * M_PI / 2)};
        if (!on_arc(p, x, 0)) continue;
        p->box[0] = fmin(p->box[0], x[0]), p->box[1] = fmin(p->box[1], x[1]);
        p->box[2] = fmax(p->box[2], x[0]), p->box[3] = fmax(p->box[3], x[1]);
      }
    }
  }
  return PM_OK;
}

/* A loop of lines whose points all lie on one line encloses nothing (checked before contacts,
 * which would name one of its pieces running back along another). */
static pm_status collinear(const checker *ck, const piece *lp, int32_t n) {
  for (int32_t k = 0; k < n; ++k)
    if (lp[k].arc || (k >= 2 && pm_orient2d(lp[0].a, lp[1].a, lp[k].a) != 0)) return PM_OK;
  return pm_error_setf(ck->err, PM_ERR_ARG, "loop %d encloses no area: its %d points lie on one line",
                       (int)lp[0].loop, (int)n);
}

/* Once no loop meets itself, its area (chords by the shoelace formula, plus each arc's circular
 * segment R^2 (sweep - sin sweep) / 2, signed) is that of a simple curve: 0 only if degenerate. */
static pm_status area(const checker *ck, const piece *lp, int32_t n) {
  double A = 0;
  for (int32_t k = 0; k < n; ++k) {
    const piece *q = &lp[k];
    A += 0.5 * (q->a[0] * q->b[1] - q->b[0] * q->a[1]);
    if (q->arc) A += 0.5 * q->R * q->R * (q->sweep - sin(q->sweep));
  }
  if (!(fabs(A) > ck->tol * ck->tol))
    return pm_error_setf(ck->err, PM_ERR_ARG, "loop %d encloses no area", (int)lp[0].loop);
  return PM_OK;
}

pm_status pm_planar_check(int32_t nloop, const pm_planar_loop *loops, pm_error *err) {
  if (nloop <= 0) return pm_error_setf(err, PM_ERR_ARG, "a planar domain needs at least one loop");
  if (nloop > PM_PLANAR_MAX_PIECES)
    return pm_error_setf(err, PM_ERR_ARG, "more than %d loops", PM_PLANAR_MAX_PIECES);
  checker ck = {NULL, 0, 0, 0, err};
  int32_t *first = malloc(((size_t)nloop + 1) * sizeof *first);
  if (!first) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  pm_status s = build(&ck, nloop, loops, first);
  for (int32_t l = 0; l < nloop && !s; ++l)
    s = collinear(&ck, &ck.p[first[l]], first[l + 1] - first[l]);
  if (!s) s = contacts(&ck);
  for (int32_t l = 0; l < nloop && !s; ++l) s = area(&ck, &ck.p[first[l]], first[l + 1] - first[l]);
  if (!s) s = holes_inside(&ck, nloop, first);
  free(ck.p);
  free(first);
  return s;
}
