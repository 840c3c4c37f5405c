/* Volume bubbles (bub_volume.c) and the shared volume tests (volume_inside.c): the inside test and
 * segment test against a sphere's surface mesh; the overlap ratio of a volume bubble in a relaxed
 * packing (standard value 12); a bubble pushed into a relaxed packing removed, a hole refilled;
 * volume bubbles never outside their volume, even when thrown at the wall; the non-manifold
 * built-in case as one conforming hybrid mesh (the dangling face's triangles between two tets,
 * the dangling curve's segments tet edges, pm_mesh_check valid). */
#include "bub_test_util.h"

#include <math.h>

#include "common/report/run_report.h"
#include "common/geom/geom_cad.h"
#include "common/input/cases.h"
#include "common/mesh/mesh_check.h"
#include "common/mesh/mesh_topo.h"
#include "common/backends/predicates.h"
#include "common/measure/quality.h"
#include "common/report/stats.h"
#include "common/sizing/sizing.h"
#include "common/mesh/volume_inside.h"

/* A run's state up to a relaxed packing of volume bubbles: the built-in solid `name` at uniform
 * size d. *model, *size, *surf are the caller's. */
typedef struct vrun {
  pm_model *m;
  pm_sizing *size;
  pm_mesh *surf;
  bub_state *s;
} vrun;

static void vrun_free(vrun *r) {
  bub_state_destroy(r->s);
  pm_mesh_destroy(r->surf);
  pm_sizing_destroy(r->size);
  pm_model_destroy(r->m);
}

static vrun relaxed(const char *name, double d, int relax_volume) {
  vrun r = {0};
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open(name, &r.m, NULL, &e), e);
  PM_ASSERT_OK(pm_sizing_constant(d, &r.size, &e), e);
  bub_params p;
  bub_params_init(&p);
  PM_ASSERT_OK(bub_state_create(r.m, r.size, &p, 1, 3, &r.s, &e), e);
  PM_ASSERT_OK(bub_place(r.s, &e), e);
  pm_run_input in = {r.m, r.size, 3, 1, 1, 0, NULL};
  char reason[128];
  PM_ASSERT_OK(bub_relax(r.s, &in, 1000000, 0, reason, &e), e);
  int32_t dropped = 0;
  PM_ASSERT_OK(bub_border_cleanup(r.s, &dropped, &e), e);
  PM_ASSERT_OK(bub_connect_nodes(r.s, &in, 1, &r.surf, &e), e);
  PM_ASSERT_OK(bub_volume_begin(r.s, r.surf, &e), e);
  PM_ASSERT_OK(bub_place_volumes(r.s, &e), e);
  assert_true(r.s->nw > r.s->nf);
  if (relax_volume) PM_ASSERT_OK(bub_relax(r.s, &in, 1000000, 0, reason, &e), e);
  return r;
}

/* ---- the shared tests against a sphere's surface mesh ---------------------------------------- */

static void inside_and_segments(void **state) {
  (void)state;
  vrun r = relaxed("sphere", 0.2, 0);
  const pm_volume_shell *sh = r.s->shell[0];
  assert_true(pm_volume_shell_ntri(sh) == r.surf->ntri);
  pm_rng g;
  pm_rng_init(&g, 11, 0);
  /* The mesh lies within the chord error d^2 / 8 = 0.005 of the unit sphere: points farther
   * than 0.02 from it are inside exactly when |x| < 1. */
  int tested = 0;
  for (int k = 0; k < 3000; ++k) {
    double x[3] = {pm_rng_range(&g, -1.3, 1.3), pm_rng_range(&g, -1.3, 1.3), pm_rng_range(&g, -1.3, 1.3)};
    double rad = pm_v3_norm(x);
    if (fabs(rad - 1) < 0.02) continue;
    assert_int_equal(pm_volume_shell_inside(sh, x), rad < 1);
    ++tested;
  }
  assert_true(tested > 2000);
  /* Exactly on a node and on a triangle's centroid: not strictly inside. */
  assert_int_equal(pm_volume_shell_inside(sh, &r.surf->xyz[3 * r.surf->tri[0]]), 0);
  /* Segments: from the centre region to outside meet the wall; within |x| < 0.9 they do not. */
  for (int k = 0; k < 500; ++k) {
    double a[3] = {pm_rng_range(&g, -0.5, 0.5), pm_rng_range(&g, -0.5, 0.5), pm_rng_range(&g, -0.5, 0.5)};
    double dir[3] = {pm_rng_range(&g, -1, 1), pm_rng_range(&g, -1, 1), pm_rng_range(&g, -1, 1)};
    pm_v3_normalize(dir);
    double out[3], in[3];
    pm_v3_axpy(out, a, 2.0, dir);
    pm_v3_axpy(in, a, 0.9 - pm_v3_norm(a), dir);
    assert_int_equal(pm_volume_shell_segment_meets(sh, a, out), 1);
    if (pm_v3_norm(in) < 0.9) assert_int_equal(pm_volume_shell_segment_meets(sh, a, in), 0);
  }
  /* Distance: the nodes lie on the unit sphere, so each triangle lies in the cap cut off by the
   * plane of its circumcircle (radius R), at sqrt(1 - R^2) from the centre: the centre's
   * distance to the wall is between that for the largest R and 1. */
  double o[3] = {0, 0, 0}, rmax = 0;
  for (int32_t t = 0; t < r.surf->ntri; ++t) {
    const int32_t *v = &r.surf->tri[3 * t];
    const double *A = &r.surf->xyz[3 * v[0]], *B = &r.surf->xyz[3 * v[1]], *C = &r.surf->xyz[3 * v[2]];
    double ab[3], ac[3], n[3];
    pm_v3_sub(ab, B, A), pm_v3_sub(ac, C, A), pm_v3_cross(n, ab, ac);
    const double a = pm_v3_dist(B, C), b = pm_v3_norm(ac), c = pm_v3_norm(ab);
    rmax = fmax(rmax, a * b * c / (2 * pm_v3_norm(n))); /* R = abc / (4 area) */
  }
  const double dist = pm_volume_shell_distance(sh, o, 2), low = sqrt(1 - rmax * rmax);
  assert_true(rmax < 0.2); /* d = 0.2: no triangle wider than a bubble's reach */
  assert_true(dist >= low - 1e-9 && dist <= 1.0);
  assert_true(dist < low + 0.01);
  assert_true(isinf(pm_volume_shell_distance(sh, o, 0.5)));
  vrun_free(&r);
}

/* ---- overlap ratio in a relaxed packing ------------------------------------------------------ */

static int cmp_d(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void alpha_close_packing(void **state) {
  (void)state;
  vrun r = relaxed("sphere", 0.2, 1);
  bub_state *s = r.s;
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_grid_rebuild(s, &e), e);
  double *a = malloc(sizeof(double) * (size_t)s->n);
  int32_t n = 0, within = 0;
  for (int32_t i = s->nf; i < s->nw; ++i) {
    /* Interior bubbles: a full shell of volume neighbours around them. */
    if (pm_volume_shell_distance(s->shell[0], &s->x[3 * i], 2 * s->d[i]) < 1.5 * s->d[i]) continue;
    a[n] = bub_alpha(s, i);
    within += fabs(a[n] - 12) <= 1.2;
    ++n;
  }
  assert_true(n >= 30);
  qsort(a, (size_t)n, sizeof(double), cmp_d);
  double med = a[n / 2];
  print_message("interior volume bubbles %d, alpha median %.3f, min %.3f, p10 %.3f, p90 %.3f, max "
                "%.3f, within 10%%: %d\n",
                (int)n, med, a[0], a[n / 10], a[9 * n / 10], a[n - 1], (int)within);
  assert_true(fabs(med - 12) <= 1.2);
  assert_true(within >= 0.6 * n);
  /* Every interior bubble between the cut-offs: the packing is settled. */
  assert_true(a[0] >= s->p.volume_open - 1 && a[n - 1] <= s->p.volume_excess);
  free(a);
  vrun_free(&r);
}

/* ---- population control in a volume ---------------------------------------------------------- */

static int32_t count_volume(const bub_state *s) { return s->nw - s->nf; }

/* The smallest distance / l0 between two volume bubbles within 1.5 d of c. */
static double min_spacing(const bub_state *s, const double c[3]) {
  double best = INFINITY;
  for (int32_t i = s->nf; i < s->nw; ++i) {
    if (pm_v3_dist(&s->x[3 * i], c) > 1.5 * s->d[i]) continue;
    for (int32_t j = s->nf; j < s->nw; ++j) {
      if (j == i) continue;
      double l = pm_v3_dist(&s->x[3 * i], &s->x[3 * j]) / (0.5 * (s->d[i] + s->d[j]));
      if (l < best) best = l;
    }
  }
  return best;
}

/* The interior volume bubble nearest to the centre point c. */
static int32_t nearest_volume(const bub_state *s, const double c[3]) {
  int32_t best = -1;
  double bd = INFINITY;
  for (int32_t i = s->nf; i < s->nw; ++i) {
    double dd = pm_v3_dist(&s->x[3 * i], c);
    if (dd < bd) bd = dd, best = i;
  }
  return best;
}

static void pushed_removed_hole_refilled(void **state) {
  (void)state;
  vrun r = relaxed("sphere", 0.2, 1);
  bub_state *s = r.s;
  pm_error e = {0};
  const int32_t N = count_volume(s);
  /* Push a bubble into the packing: towards the centroid of the tetrahedron of an interior bubble
   * and three mutual neighbours (a tetrahedral hole; the most compact triple within 1.3 d). The
   * bubble: the one nearest the centre among the interior bubbles (a full shell of neighbours)
   * whose own ratio is at least the interior median, a typically packed spot (the packing is
   * amorphous: at a loose spot, 10 against the median 11.5, an intruder reads no more than 13). */
  double o[3] = {0, 0, 0};
  PM_ASSERT_OK(bub_state_grid_rebuild(s, &e), e);
  double *al = malloc(sizeof(double) * (size_t)s->n), med;
  int32_t nal = 0;
  for (int32_t i = s->nf; i < s->nw; ++i)
    if (pm_volume_shell_distance(s->shell[0], &s->x[3 * i], 2 * s->d[i]) >= 1.5 * s->d[i]) al[nal++] = bub_alpha(s, i);
  assert_true(nal >= 30);
  qsort(al, (size_t)nal, sizeof(double), cmp_d);
  med = al[nal / 2];
  free(al);
  int32_t c = -1;
  for (int32_t i = s->nf; i < s->nw; ++i)
    if (pm_volume_shell_distance(s->shell[0], &s->x[3 * i], 2 * s->d[i]) >= 1.5 * s->d[i] &&
        bub_alpha(s, i) >= med && (c < 0 || pm_v3_norm(&s->x[3 * i]) < pm_v3_norm(&s->x[3 * c])))
      c = i;
  assert_true(c >= 0);
  int32_t nbs[64], nn = 0;
  for (int32_t i = s->nf; i < s->nw && nn < 64; ++i)
    if (i != c && pm_v3_dist(&s->x[3 * i], &s->x[3 * c]) < 1.3 * s->d[c]) nbs[nn++] = i;
  double best = INFINITY, mid[3] = {0, 0, 0};
  for (int32_t p = 0; p < nn; ++p)
    for (int32_t q = p + 1; q < nn; ++q)
      for (int32_t t = q + 1; t < nn; ++t) {
        const double *X[4] = {&s->x[3 * c], &s->x[3 * nbs[p]], &s->x[3 * nbs[q]], &s->x[3 * nbs[t]]};
        double perim = 0;
        for (int u = 0; u < 4; ++u)
          for (int w = u + 1; w < 4; ++w) perim += pm_v3_dist(X[u], X[w]);
        if (perim < best) {
          best = perim;
          for (int k = 0; k < 3; ++k) mid[k] = 0.25 * (X[0][k] + X[1][k] + X[2][k] + X[3][k]);
        }
      }
  assert_true(isfinite(best));
  /* The intruder sits 0.15 d from the centre bubble, towards that hole: an intruder right in the
   * hole of an amorphous packing reads about as much as its neighbours (12.4-14 against the cut-off
   * 14: the ratio alone cannot tell it apart, relaxation spreads it), one pushed onto a bubble is
   * the excess the control must catch. */
  {
    double dir[3];
    pm_v3_sub(dir, mid, &s->x[3 * c]);
    pm_v3_normalize(dir);
    pm_v3_axpy(mid, &s->x[3 * c], 0.15 * s->d[c], dir);
  }
  const double sp0 = min_spacing(s, mid);
  assert_true(sp0 > 0.7);
  int32_t id;
  PM_ASSERT_OK(bub_state_add(s, BUB_KVOLUME, 0, NULL, mid, 0, &id, &e), e);
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  assert_int_equal(count_volume(s), N + 1);
  const double sp1 = min_spacing(s, mid);
  assert_true(sp1 < 0.2);
  PM_ASSERT_OK(bub_state_grid_rebuild(s, &e), e);
  double amax = 0;
  for (int32_t i = s->nf; i < s->nw; ++i) amax = fmax(amax, bub_alpha(s, i));
  print_message("pushed: its overlap ratio %.2f, the largest %.2f\n", bub_alpha(s, nearest_volume(s, mid)), amax);
  assert_true(bub_alpha(s, nearest_volume(s, mid)) > s->p.volume_excess);
  bub_control_info ci;
  PM_ASSERT_OK(bub_population_control(s, 1000000, &ci, &e), e);
  print_message("control: removed %d inserted %d\n", (int)ci.removed, (int)ci.inserted);
  assert_true(ci.removed >= 1);
  /* The intruder and its nearest neighbours read nearly the same ratio (13.99 against up to 14.5
   * here): the control removes the highest first, which may be a neighbour instead of the
   * intruder; relaxation then restores the packing with one bubble less either way. */
  pm_run_input in0 = {r.m, r.size, 3, 1, 1, 0, NULL};
  char reason0[128];
  PM_ASSERT_OK(bub_relax(s, &in0, 1000000, 0, reason0, &e), e);
  print_message("local spacing / l0: relaxed %.3f, pushed %.3f, after control and relaxation %.3f; "
                "%d -> %d volume bubbles\n",
                sp0, sp1, min_spacing(s, mid), (int)N + 1, (int)count_volume(s));
  assert_true(min_spacing(s, mid) > 0.95 * sp0); /* the packing's spacing is back */
  assert_true(abs(count_volume(s) - N) <= 3);

  /* A hole: the centre bubble and every volume bubble within 1.2 d of it removed. */
  c = nearest_volume(s, o);
  double hc[3];
  pm_v3_copy(hc, &s->x[3 * c]);
  int32_t removed = 0;
  for (int32_t i = s->nf; i < s->nw; ++i)
    if (pm_v3_dist(&s->x[3 * i], hc) < 1.2 * s->d[i]) s->flags[i] |= BUB_FDEAD, ++removed;
  assert_true(removed >= 8);
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  const int32_t before = count_volume(s);
  double hole = pm_v3_dist(&s->x[3 * nearest_volume(s, hc)], hc);
  assert_true(hole > 0.9 * 0.2);
  pm_run_input in = {r.m, r.size, 3, 1, 1, 0, NULL};
  char reason[128];
  PM_ASSERT_OK(bub_relax(s, &in, 1000000, 0, reason, &e), e);
  print_message("hole of %d bubbles: %d -> %d volume bubbles (%d before the hole), nearest to its "
                "centre %.3f -> %.3f\n",
                (int)removed, (int)before, (int)count_volume(s), (int)N, hole,
                pm_v3_dist(&s->x[3 * nearest_volume(s, hc)], hc));
  /* Refilled: most of the bubbles back, and the hole's centre no farther from a bubble than the
   * deepest point of a close packing (d / sqrt2, an octahedral hole) with a margin. */
  assert_true(count_volume(s) >= before + (3 * removed) / 4);
  assert_true(pm_v3_dist(&s->x[3 * nearest_volume(s, hc)], hc) < 0.75 * 0.2);
  vrun_free(&r);
}

/* ---- never outside ------------------------------------------------------------------------------ */

static void never_outside(void **state) {
  (void)state;
  /* The torus: a non-convex volume whose walls curve both ways. */
  vrun r = relaxed("torus", 0.15, 1);
  bub_state *s = r.s;
  const pm_volume_shell *sh = s->shell[0];
  for (int32_t i = s->nf; i < s->nw; ++i) {
    assert_int_equal(pm_volume_shell_inside(sh, &s->x[3 * i]), 1);
    assert_true(pm_volume_shell_distance(sh, &s->x[3 * i], 1) >= BUB_VMARGIN * s->d[i] * (1 - 1e-9));
  }
  /* Thrown at the wall: every volume bubble gets a velocity of 3 diameters per time step straight
   * away from the torus's core circle, population control off. */
  s->p.population = 0;
  const double h = bub_time_step(&s->p);
  for (int k = 0; k < 10; ++k) {
    for (int32_t i = s->nf; i < s->nw; ++i) {
      const double *x = &s->x[3 * i];
      double rho = hypot(x[0], x[1]), core[3] = {x[0] / rho, x[1] / rho, 0}, dir[3];
      pm_v3_sub(dir, x, core);
      pm_v3_normalize(dir);
      pm_v3_scale(&s->v[3 * i], dir, 3 * s->d[i] / h);
    }
    bt_steps(s, 1);
    for (int32_t i = s->nf; i < s->nw; ++i) {
      assert_int_equal(pm_volume_shell_inside(sh, &s->x[3 * i]), 1);
      assert_true(pm_volume_shell_distance(sh, &s->x[3 * i], 1) >= BUB_VMARGIN * s->d[i] * (1 - 1e-9));
    }
  }
  vrun_free(&r);
}

/* ---- the non-manifold case -------------------------------------------------------------------- */

static void nonmanifold_hybrid(void **state) {
  (void)state;
  pm_error e = {0};
  pm_model *m = NULL;
  PM_ASSERT_OK(pm_case_open("nonmanifold", &m, NULL, &e), e);
  assert_int_equal(m->count[PM_VOLUME], 1);
  const pm_cell *vol = pm_model_cell(m, PM_VOLUME, 0);
  int32_t face = -1, curve = -1;
  for (int32_t k = 0; k < vol->nembed; ++k) {
    if (vol->embed[k].dim == PM_FACE) face = vol->embed[k].index;
    if (vol->embed[k].dim == PM_CURVE && pm_model_cell(m, PM_CURVE, vol->embed[k].index)->nup == 0)
      curve = vol->embed[k].index;
  }
  assert_true(face >= 0 && curve >= 0);
  bub_params p;
  bub_params_init(&p);
  pm_run_input in = {m, NULL, 1, 1, 1, 0, NULL};
  pm_run_output out = {0};
  PM_ASSERT_OK(bub_run(&in, &p, &out, &e), e);
  pm_mesh *mesh = out.mesh;
  assert_true(mesh->ntet > 0);
  int32_t nvolnode = 0;
  for (int32_t i = 0; i < mesh->nnode; ++i) nvolnode += mesh->node_dim[i] == PM_VOLUME;
  assert_true(nvolnode > 100);
  /* The dangling face's triangles: faces of exactly two tets, one on each side. */
  pm_faces fc = {0};
  PM_ASSERT_OK(pm_faces_build(mesh->nnode, mesh->tet, mesh->ntet, &fc, &e), e);
  int32_t nft = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    if (mesh->tri_cell[t] != face) continue;
    ++nft;
    const int32_t *v = &mesh->tri[3 * t];
    int64_t f = pm_faces_find(&fc, v[0], v[1], v[2], NULL);
    assert_true(f >= 0);
    assert_int_equal(fc.off[f + 1] - fc.off[f], 2);
    int sides[2];
    for (int k = 0; k < 2; ++k) {
      const int32_t *tt = &mesh->tet[4 * fc.tet[fc.off[f] + k]];
      int32_t opp = -1;
      for (int q = 0; q < 4; ++q)
        if (tt[q] != v[0] && tt[q] != v[1] && tt[q] != v[2]) opp = tt[q];
      sides[k] = pm_orient3d(&mesh->xyz[3 * v[0]], &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[2]], &mesh->xyz[3 * opp]);
    }
    assert_int_equal(sides[0] * sides[1], -1);
  }
  assert_true(nft > 10);
  /* The dangling curve's segments: edges of tets. */
  int32_t nseg = 0;
  for (int32_t sg = 0; sg < mesh->nseg; ++sg) {
    if (mesh->seg_cell[sg] != curve) continue;
    ++nseg;
    int found = 0;
    for (int32_t t = 0; t < mesh->ntet && !found; ++t) {
      int hits = 0;
      for (int q = 0; q < 4; ++q) hits += mesh->tet[4 * t + q] == mesh->seg[2 * sg] || mesh->tet[4 * t + q] == mesh->seg[2 * sg + 1];
      found = hits == 2;
    }
    assert_true(found);
  }
  assert_true(nseg >= 2);
  pm_check_report rep = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &rep, &e), e);
  if (!rep.valid) fail_msg("mesh check: %s", rep.nproblem ? rep.problem[0] : "?");
  pm_check_report_clear(&rep);
  pm_faces_free(&fc);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* The sliver step: with it, no tet of the built-in boxhole and non-manifold solids is flatter than
 * 5 degrees of dihedral angle (without it, measured: one all-surface sliver of 1.5 degrees where
 * the box's faces meet, and 2.0 degrees in the non-manifold cube); with it switched off
 * (sliver_angle = 0) they are there. */
static double min_dihedral_of(const char *name, double sliver_angle, int32_t *added) {
  pm_error e = {0};
  pm_model *m = NULL;
  PM_ASSERT_OK(pm_case_open(name, &m, NULL, &e), e);
  bub_params p;
  bub_params_init(&p);
  p.sliver_angle = sliver_angle;
  pm_stats st;
  pm_stats_init(&st);
  pm_run_input in = {m, NULL, 1, 1, 1, 0, NULL};
  pm_run_output out = {0};
  pm_run_report report = {&st, NULL, NULL};
  pm_run_observer observer;
  pm_run_report_observer(&report, &observer);
  in.observer = &observer;
  PM_ASSERT_OK(bub_run(&in, &p, &out, &e), e);
  double worst = 180;
  const pm_mesh *mesh = out.mesh;
  for (int32_t t = 0; t < mesh->ntet; ++t) {
    const int32_t *v = &mesh->tet[4 * t];
    pm_tet_measure tm;
    pm_tet_measure_eval(&mesh->xyz[3 * v[0]], &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[2]],
                        &mesh->xyz[3 * v[3]], &tm);
    worst = fmin(worst, tm.min_dihedral);
  }
  pm_stats_flat fl = {0};
  PM_ASSERT_OK(pm_stats_flatten(&st, &fl, &e), e);
  const pm_stats_item *it = pm_stats_flat_find(&fl, "bubble.sliver_added");
  *added = it ? (int32_t)it->num : -1;
  pm_stats_flat_clear(&fl);
  pm_check_report rep = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &rep, &e), e);
  assert_true(rep.valid);
  pm_check_report_clear(&rep);
  pm_mesh_destroy(out.mesh);
  pm_stats_clear(&st);
  pm_model_destroy(m);
  return worst;
}

static void no_flat_tets(void **state) {
  (void)state;
  const char *cases[] = {"boxhole", "nonmanifold"};
  for (int k = 0; k < 2; ++k) {
    int32_t added_off = 0, added_on = 0;
    double off = min_dihedral_of(cases[k], 0, &added_off);
    double on = min_dihedral_of(cases[k], 10, &added_on);
    print_message("%s: min dihedral %.2f without the sliver step, %.2f with it (%d nodes added)\n",
                  cases[k], off, on, (int)added_on);
    assert_true(off < 5);
    assert_true(on >= 5);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(inside_and_segments),
      cmocka_unit_test(alpha_close_packing),
      cmocka_unit_test(pushed_removed_hole_refilled),
      cmocka_unit_test(never_outside),
      cmocka_unit_test(nonmanifold_hybrid),
      cmocka_unit_test(no_flat_tets),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
