/* geom_cad evaluation: derivatives against finite differences on planes, cylinders, cones,
 * spheres (poles), tori and B-spline faces and on line, circle, ellipse, B-spline and degenerate
 * curves; the closed forms against gmsh; batched against single evaluation; evaluation while
 * another gmsh model is current and from two threads; projection round trips. */
#include "test_geom_cad_util.h"

#include <pthread.h>

#include "common/base/rng.h"

/* Central differences with step h = FD_STEP x the parameter span: truncation ~ (1e-5)^2 and
 * rounding ~ 1e-16 / 1e-5 of the scale, so 1e-6 relative is a safe bar for first derivatives and
 * 1e-5 for second ones (a difference of exact first derivatives). */
#define FD_STEP 1e-5

static void expect_close3(const char *what, int tag, const double *a, const double *b, double tol) {
  double d = pm_v3_dist(a, b);
  if (!(d <= tol))
    fail_msg("%s of %d: (%.12g %.12g %.12g) vs (%.12g %.12g %.12g), |diff| %.3g > %.3g", what, tag,
             a[0], a[1], a[2], b[0], b[1], b[2], d, tol);
}

static void face_fd(const pm_model *m, const pm_cell *f, int npts, pm_rng *rng) {
  const double su = f->hi[0] - f->lo[0], sv = f->hi[1] - f->lo[1];
  const double hu = FD_STEP * su, hv = FD_STEP * sv, D = m->diagonal;
  for (int i = 0; i < npts; ++i) {
    double uv[2] = {pm_rng_range(rng, f->lo[0] + 2 * hu, f->hi[0] - 2 * hu),
                    pm_rng_range(rng, f->lo[1] + 2 * hv, f->hi[1] - 2 * hv)};
    pm_face_point p, a, b, c, d;
    pm_face_eval(f, uv, 2, &p);
    double q[2];
    q[0] = uv[0] + hu, q[1] = uv[1];
    pm_face_eval(f, q, 2, &a);
    q[0] = uv[0] - hu;
    pm_face_eval(f, q, 2, &b);
    q[0] = uv[0], q[1] = uv[1] + hv;
    pm_face_eval(f, q, 2, &c);
    q[1] = uv[1] - hv;
    pm_face_eval(f, q, 2, &d);
    double fu[3], fv[3], fuu[3], fvv[3], fuv1[3], fuv2[3];
    for (int k = 0; k < 3; ++k) {
      fu[k] = (a.p[k] - b.p[k]) / (2 * hu);
      fv[k] = (c.p[k] - d.p[k]) / (2 * hv);
      fuu[k] = (a.su[k] - b.su[k]) / (2 * hu);
      fvv[k] = (c.sv[k] - d.sv[k]) / (2 * hv);
      fuv1[k] = (a.sv[k] - b.sv[k]) / (2 * hu);
      fuv2[k] = (c.su[k] - d.su[k]) / (2 * hv);
    }
    expect_close3("Su", f->tag, p.su, fu, 1e-6 * (pm_v3_norm(p.su) + D / su));
    expect_close3("Sv", f->tag, p.sv, fv, 1e-6 * (pm_v3_norm(p.sv) + D / sv));
    expect_close3("Suu", f->tag, p.suu, fuu, 1e-5 * (pm_v3_norm(p.suu) + D / (su * su)));
    expect_close3("Svv", f->tag, p.svv, fvv, 1e-5 * (pm_v3_norm(p.svv) + D / (sv * sv)));
    expect_close3("Suv (from Sv)", f->tag, p.suv, fuv1, 1e-5 * (pm_v3_norm(p.suv) + D / (su * sv)));
    expect_close3("Suv (from Su)", f->tag, p.suv, fuv2, 1e-5 * (pm_v3_norm(p.suv) + D / (su * sv)));
  }
}

static void curve_fd(const pm_model *m, const pm_cell *c, int npts, pm_rng *rng) {
  const double s = c->hi[0] - c->lo[0], h = FD_STEP * s, D = m->diagonal;
  for (int i = 0; i < npts; ++i) {
    double t = pm_rng_range(rng, c->lo[0] + 2 * h, c->hi[0] - 2 * h);
    pm_curve_point p, a, b;
    pm_curve_eval(c, t, 2, &p);
    pm_curve_eval(c, t + h, 2, &a);
    pm_curve_eval(c, t - h, 2, &b);
    double f1[3], f2[3];
    for (int k = 0; k < 3; ++k)
      f1[k] = (a.p[k] - b.p[k]) / (2 * h), f2[k] = (a.d1[k] - b.d1[k]) / (2 * h);
    expect_close3("C'", c->tag, p.d1, f1, 1e-6 * (pm_v3_norm(p.d1) + D / s));
    expect_close3("C''", c->tag, p.d2, f2, 1e-5 * (pm_v3_norm(p.d2) + D / (s * s)));
  }
}

/* Test 2: derivatives by finite differences, per surface and curve type; `fast` says which path
 * the cell is expected to take. */
static void derivatives_match_finite_differences(void **state) {
  (void)state;
  CAD_REQUIRE();
  const struct {
    const char *file;
    int dim, tag;
    const char *cls;
    int fast;
  } cells[] = {
      {"synth_box_hole.brep", 2, 3, "plane", 1},        /* a plane with a hole */
      {"synth_box_hole.brep", 2, 7, "cylinder", 1},     /* periodic */
      {"synth_torus.brep", 2, 1, "torus", 1},           /* doubly periodic */
      {"synth_sphere.brep", 2, 1, "sphere", 1},         /* poles */
      {"synth_cone.brep", 2, 1, "cone", 1},             /* apex */
      {"cyl_loop_seam.brep", 2, 1, "cylinder", 1},      /* gmsh's "Unknown" surface */
      {"synth_bspline_patch.brep", 2, 1, "bspline", 0}, /* B-splines through gmsh */
      {"t20_component8.step", 2, 2, "bspline", 0},
      {"t20_component8.step", 2, 3, "plane", 1}, /* a B-spline that is a plane */
      {"bspline_sphere.brep", 2, 1, "bspline", 0},
      {"fusee.stp", 2, 40, "bspline", 0},
      {"synth_box_hole.brep", 1, 1, "line", 1},
      {"synth_box_hole.brep", 1, 10, "circle", 1},
      {"crack.brep", 1, 14, "ellipse", 1},
      {"table.brep", 1, 17, "ellipse", 1}, /* gmsh's "TrimmedCurve" of an ellipse */
      {"table.brep", 1, 31, "circle", 1},  /* a closed circle on [pi/2, 5 pi/2] */
      {"cyl_loop_seam.brep", 1, 5, "bspline", 0},
      {"t20_component8.step", 1, 7, "bspline", 0},
      {"screw.step", 1, 1, "bspline", 0},
  };
  pm_rng rng;
  pm_rng_init(&rng, 42, 0);
  for (size_t i = 0; i < sizeof cells / sizeof cells[0]; ++i) {
    pm_model *m = cad_load_file(cells[i].file);
    const pm_cell *c = cad_face_by_tag(m, cells[i].dim, cells[i].tag);
    if (strcmp(c->cls->name, cells[i].cls) != 0)
      fail_msg("%s %d:%d is a %s, expected %s", cells[i].file, cells[i].dim, cells[i].tag,
               c->cls->name, cells[i].cls);
    assert_int_equal(pm_cad_cell_is_fast(c), cells[i].fast);
    if (c->dim == PM_FACE)
      face_fd(m, c, 25, &rng);
    else
      curve_fd(m, c, 25, &rng);
    assert_int_equal(pm_cad_eval_failures(m), 0);
    pm_model_destroy(m);
  }
  /* A degenerate curve (the sphere's pole) is its point, with zero derivatives. */
  pm_model *m = cad_load_file("synth_sphere.brep");
  const pm_cell *pole = cad_face_by_tag(m, 1, 1);
  assert_true(pole->degenerate);
  assert_string_equal(pole->cls->name, "degenerate");
  pm_curve_point cp;
  pm_curve_eval(pole, 1.0, 2, &cp);
  PM_ASSERT_NEAR(pm_v3_dist(cp.p, pm_model_cell(m, 0, pole->bound[0].cell)->xyz), 0, 1e-15);
  PM_ASSERT_NEAR(pm_v3_norm(cp.d1) + pm_v3_norm(cp.d2), 0, 0);
  pm_model_destroy(m);
}

/* Direct gmsh evaluation of a face or curve of m (order 2; curves' second derivatives are not
 * compared: gmsh 4.8.4 computes them by a one-sided difference). */
static void gmsh_face(const pm_model *m, int tag, const double uv[2], pm_face_point *out) {
  pm_gmsh_scope sc;
  cad_gmsh_begin(m, &sc);
  double *x = NULL, *d = NULL, *dd = NULL;
  size_t nx, nd, ndd;
  int ierr = 0;
  gmshModelGetValue(2, tag, (double *)uv, 2, &x, &nx, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  gmshModelGetDerivative(2, tag, (double *)uv, 2, &d, &nd, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  gmshModelGetSecondDerivative(2, tag, (double *)uv, 2, &dd, &ndd, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  cad_gmsh_end(&sc);
  pm_v3_copy(out->p, x), pm_v3_copy(out->su, d), pm_v3_copy(out->sv, d + 3);
  pm_v3_copy(out->suu, dd), pm_v3_copy(out->svv, dd + 3), pm_v3_copy(out->suv, dd + 6);
  gmshFree(x), gmshFree(d), gmshFree(dd);
}

static void gmsh_curve(const pm_model *m, int tag, double t, pm_curve_point *out) {
  pm_gmsh_scope sc;
  cad_gmsh_begin(m, &sc);
  double *x = NULL, *d = NULL;
  size_t nx, nd;
  int ierr = 0;
  gmshModelGetValue(1, tag, &t, 1, &x, &nx, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  gmshModelGetDerivative(1, tag, &t, 1, &d, &nd, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  cad_gmsh_end(&sc);
  pm_v3_copy(out->p, x), pm_v3_copy(out->d1, d);
  gmshFree(x), gmshFree(d);
}

/* Every closed form of several models agrees with gmsh at random parameters; and the models
 * have the expected share of fast cells. */
static void fast_paths_agree_with_gmsh(void **state) {
  (void)state;
  CAD_REQUIRE();
  const struct {
    const char *file;
    int min_fast_faces, min_fast_curves; /* percent */
  } files[] = {{"screw.step", 100, 60},       {"table.brep", 100, 100},
               {"bottle.brep", 95, 95},       {"solid56.step", 70, 60},
               {"cube_fillet.stp", 100, 100}, {"engine_block.stp", 99, 80},
               {"synth_cone.brep", 100, 100}};
  pm_rng rng;
  pm_rng_init(&rng, 7, 0);
  for (size_t i = 0; i < sizeof files / sizeof files[0]; ++i) {
    pm_model *m = cad_load_file(files[i].file);
    const double D = m->diagonal;
    int nfast[2] = {0, 0};
    for (int dim = 1; dim <= 2; ++dim)
      for (int32_t k = 0; k < m->count[dim]; ++k) {
        const pm_cell *c = pm_model_cell(m, dim, k);
        if (pm_cad_cell_is_fast(c) != 1) continue;
        nfast[dim - 1]++;
        if (c->degenerate) continue;
        for (int s = 0; s < 3; ++s) {
          if (dim == PM_FACE) {
            double uv[2] = {pm_rng_range(&rng, c->lo[0], c->hi[0]),
                            pm_rng_range(&rng, c->lo[1], c->hi[1])};
            pm_face_point a, g;
            pm_face_eval(c, uv, 2, &a);
            gmsh_face(m, c->tag, uv, &g);
            double su = c->hi[0] - c->lo[0], sv = c->hi[1] - c->lo[1];
            expect_close3("S", c->tag, a.p, g.p, 1e-9 * D);
            expect_close3("Su", c->tag, a.su, g.su, 1e-9 * (pm_v3_norm(g.su) + D / su));
            expect_close3("Sv", c->tag, a.sv, g.sv, 1e-9 * (pm_v3_norm(g.sv) + D / sv));
            expect_close3("Suu", c->tag, a.suu, g.suu, 1e-6 * (pm_v3_norm(g.suu) + D / (su * su)));
            expect_close3("Suv", c->tag, a.suv, g.suv, 1e-6 * (pm_v3_norm(g.suv) + D / (su * sv)));
            expect_close3("Svv", c->tag, a.svv, g.svv, 1e-6 * (pm_v3_norm(g.svv) + D / (sv * sv)));
          } else {
            double t = pm_rng_range(&rng, c->lo[0], c->hi[0]);
            pm_curve_point a, g;
            pm_curve_eval(c, t, 1, &a);
            gmsh_curve(m, c->tag, t, &g);
            expect_close3("C", c->tag, a.p, g.p, 1e-9 * D);
            expect_close3("C'", c->tag, a.d1, g.d1,
                          1e-9 * (pm_v3_norm(g.d1) + D / (c->hi[0] - c->lo[0])));
          }
        }
      }
    print_message("  %-18s fast faces %d/%d, curves %d/%d\n", files[i].file, nfast[1], m->count[2],
                  nfast[0], m->count[1]);
    assert_true(100 * nfast[1] >= files[i].min_fast_faces * m->count[2]);
    assert_true(100 * nfast[0] >= files[i].min_fast_curves * m->count[1]);
    pm_model_destroy(m);
  }
}

/* Batched evaluation equals single evaluation (gmsh and closed forms), including parameters
 * outside the base period of a periodic face. */
static void batched_equals_single(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("t20_component8.step");
  pm_model *c = cad_load_file("synth_torus.brep");
  const pm_cell *faces[2] = {cad_face_by_tag(m, 2, 2), pm_model_cell(c, 2, 0)};
  pm_rng rng;
  pm_rng_init(&rng, 3, 0);
  enum { N = 700 }; /* more than one gmsh batch */
  static double uv[2 * N];
  static pm_face_point many[N];
  for (int k = 0; k < 2; ++k) {
    const pm_cell *f = faces[k];
    for (int i = 0; i < N; ++i) {
      uv[2 * i] = pm_rng_range(&rng, f->lo[0], f->hi[0]);
      uv[2 * i + 1] = pm_rng_range(&rng, f->lo[1], f->hi[1]);
      if (f->periodic[0] && i % 3 == 0) uv[2 * i] += 2 * f->period[0];
    }
    for (int order = 0; order <= 2; ++order) {
      pm_face_eval_many(f, N, uv, order, many);
      for (int i = 0; i < N; i += 7) {
        pm_face_point one;
        pm_face_eval(f, uv + 2 * i, order, &one);
        expect_close3("batched S", f->tag, many[i].p, one.p, 1e-12 * m->diagonal);
        if (order >= 1)
          expect_close3("batched Su", f->tag, many[i].su, one.su, 1e-12 * (1 + pm_v3_norm(one.su)));
        if (order >= 2)
          expect_close3("batched Svv", f->tag, many[i].svv, one.svv,
                        1e-12 * (1 + pm_v3_norm(one.svv)));
      }
    }
  }
  pm_model_destroy(c);
  pm_model_destroy(m);
}

/* gmsh's current model may be another one: evaluation still acts on the right model and leaves
 * the current model as it found it. */
static void evaluation_with_another_model_current(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *a = cad_load_file("t20_component8.step");
  const pm_cell *f = cad_face_by_tag(a, 2, 2);
  const pm_cell *cv = cad_face_by_tag(a, 1, 7);
  double uv[2] = {0.5 * (f->lo[0] + f->hi[0]), 0.5 * (f->lo[1] + f->hi[1])};
  pm_face_point ref, p;
  pm_curve_point cref, cp;
  pm_face_eval(f, uv, 2, &ref);
  pm_curve_eval(cv, 0.5 * (cv->lo[0] + cv->hi[0]), 2, &cref);
  /* Another CAD model (loaded later, so gmsh's list has both) and a foreign model current. */
  pm_model *b = cad_load_file("fusee.stp");
  pm_error e = {0};
  pm_gmsh_lock();
  pm_gmsh_scope sc;
  CAD_LOCKED_CHECK(pm_gmsh_scope_enter(&sc, "test_foreign_model", 1, &e) == PM_OK);
  pm_face_eval(f, uv, 2, &p);
  pm_curve_eval(cv, 0.5 * (cv->lo[0] + cv->hi[0]), 2, &cp);
  char *cur = NULL;
  int ierr = 0;
  gmshModelGetCurrent(&cur, &ierr);
  CAD_LOCKED_CHECK(cur && strcmp(cur, "test_foreign_model") == 0);
  gmshFree(cur);
  pm_gmsh_scope_leave(&sc, 1);
  pm_gmsh_unlock();
  assert_memory_equal(&p, &ref, sizeof p);
  assert_memory_equal(&cp, &cref, sizeof cp);
  /* b's faces evaluate too, alternating with a's. */
  const pm_cell *g = cad_face_by_tag(b, 2, 40);
  pm_face_point q;
  pm_face_eval(g, (double[2]){0.5 * (g->lo[0] + g->hi[0]), 0.5 * (g->lo[1] + g->hi[1])}, 1, &q);
  pm_face_eval(f, uv, 2, &p);
  assert_memory_equal(&p, &ref, sizeof p);
  assert_int_equal(pm_cad_eval_failures(a), 0);
  assert_int_equal(pm_cad_eval_failures(b), 0);
  pm_model_destroy(b);
  pm_face_eval(f, uv, 2, &p);
  assert_memory_equal(&p, &ref, sizeof p);
  pm_model_destroy(a);
}

/* A gmsh evaluation that fails (here: the gmsh model was removed behind the backend's back)
 * never aborts: the output is the cell's fallback point with zero derivatives, finite, and the
 * failure is counted; closed forms do not need gmsh; other gmsh models are not touched. */
static void evaluation_failure_is_finite(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("t20_component8.step");
  pm_model *other = cad_load_file("synth_torus.brep");
  const pm_cell *bs = cad_face_by_tag(m, 2, 2), *pl = cad_face_by_tag(m, 2, 3),
                *cv = cad_face_by_tag(m, 1, 7);
  double uv[2] = {0.5 * (bs->lo[0] + bs->hi[0]), 0.3 * bs->lo[1] + 0.7 * bs->hi[1]};
  double uvp[2] = {0.5 * (pl->lo[0] + pl->hi[0]), 0.5 * (pl->lo[1] + pl->hi[1])};
  pm_face_point before, after, plane_before, plane_after;
  pm_face_eval(bs, uv, 2, &before);
  pm_face_eval(pl, uvp, 2, &plane_before);
  pm_error e = {0};
  pm_gmsh_lock();
  pm_gmsh_scope sc;
  CAD_LOCKED_CHECK(pm_gmsh_scope_enter(&sc, pm_cad_gmsh_model(m), 0, &e) == PM_OK);
  pm_gmsh_scope_leave(&sc, 1);
  CAD_LOCKED_CHECK(pm_gmsh_scope_enter(&sc, pm_cad_gmsh_model(other), 0, &e) == PM_OK);
  pm_gmsh_unlock();
  assert_int_equal(pm_cad_eval_failures(m), 0);
  pm_face_eval(bs, uv, 2, &after);
  assert_int_equal(pm_cad_eval_failures(m), 1);
  const double *vals = after.p;
  for (int k = 0; k < 18; ++k) assert_true(isfinite(vals[k]));
  assert_true(pm_v3_norm(after.su) == 0 && pm_v3_norm(after.suu) == 0);
  assert_true(pm_v3_dist(after.p, before.p) < m->diagonal); /* a point of the face */
  pm_face_point many[3];
  double three[6] = {uv[0], uv[1], uv[0], uv[1], uv[0], uv[1]};
  pm_face_eval_many(bs, 3, three, 1, many);
  assert_int_equal(pm_cad_eval_failures(m), 4);
  assert_memory_equal(&many[2].p, &after.p, sizeof after.p);
  pm_curve_point cp;
  pm_curve_eval(cv, cv->lo[0], 2, &cp);
  assert_true(isfinite(cp.p[0]) && isfinite(cp.d2[2]));
  double fuv[2];
  pm_face_curve_uv(bs, &bs->loop[0].use[0], pm_model_cell(m, 1, bs->loop[0].use[0].cell)->lo[0],
                   fuv);
  assert_true(isfinite(fuv[0]) && isfinite(fuv[1]));
  /* Projection still returns (a finite answer from the fallback values). */
  double par[2], dist;
  PM_ASSERT_OK(pm_cell_project(bs, before.p, NULL, par, NULL, &dist, &e), e);
  assert_true(isfinite(par[0]) && isfinite(par[1]) && isfinite(dist));
  /* The closed form of the planar face is untouched. */
  pm_face_eval(pl, uvp, 2, &plane_after);
  assert_memory_equal(&plane_after, &plane_before, sizeof plane_after);
  /* The other model stayed current and evaluates normally. */
  pm_gmsh_lock();
  char *cur = NULL;
  int ierr = 0;
  gmshModelGetCurrent(&cur, &ierr);
  CAD_LOCKED_CHECK(cur && strcmp(cur, pm_cad_gmsh_model(other)) == 0);
  gmshFree(cur);
  pm_gmsh_scope_leave(&sc, 0);
  pm_gmsh_unlock();
  pm_model_destroy(m); /* its gmsh model is gone: destroying must not remove another one */
  pm_gmsh_lock();
  CAD_LOCKED_CHECK(pm_gmsh_scope_enter(&sc, pm_cad_gmsh_model(other), 0, &e) == PM_OK);
  pm_gmsh_scope_leave(&sc, 0);
  pm_gmsh_unlock();
  assert_int_equal(pm_cad_eval_failures(other), 0);
  pm_model_destroy(other);
}

typedef struct thread_arg {
  const pm_cell *f;
  int n;
  const double *uv;
  pm_face_point *out;
} thread_arg;

static void *eval_thread(void *p) {
  thread_arg *a = p;
  for (int i = 0; i < a->n; ++i) pm_face_eval(a->f, a->uv + 2 * i, 2, a->out + i);
  return NULL;
}

/* Two threads evaluating one B-spline face through gmsh give the serial results. */
static void concurrent_evaluation(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("t20_component8.step");
  const pm_cell *f = cad_face_by_tag(m, 2, 2);
  enum { N = 2000 };
  static double uv[2 * N];
  static pm_face_point serial[N], par[2][N];
  pm_rng rng;
  pm_rng_init(&rng, 11, 0);
  for (int i = 0; i < N; ++i)
    uv[2 * i] = pm_rng_range(&rng, f->lo[0], f->hi[0]),
           uv[2 * i + 1] = pm_rng_range(&rng, f->lo[1], f->hi[1]);
  for (int i = 0; i < N; ++i) pm_face_eval(f, uv + 2 * i, 2, serial + i);
  pthread_t th[2];
  thread_arg args[2] = {{f, N, uv, par[0]}, {f, N, uv, par[1]}};
  for (int k = 0; k < 2; ++k)
    assert_int_equal(pthread_create(&th[k], NULL, eval_thread, &args[k]), 0);
  for (int k = 0; k < 2; ++k) pthread_join(th[k], NULL);
  assert_memory_equal(par[0], serial, sizeof serial);
  assert_memory_equal(par[1], serial, sizeof serial);
  pm_model_destroy(m);
}

/* Test 3: projecting S(u, v) of random inside (u, v) returns the point (distance below 1e-7 of
 * the diagonal), on analytic and B-spline faces, a periodic face near its seam and a face with
 * a hole; points off the surface along the normal project back to their foot. */
static void projection_round_trips(void **state) {
  (void)state;
  CAD_REQUIRE();
  const struct {
    const char *file;
    int tag;
    int near_seam;
  } faces[] = {
      {"synth_box_hole.brep", 3, 0}, /* plane with a hole */
      {"synth_box_hole.brep", 7, 1}, /* cylinder, near its seam */
      {"synth_torus.brep", 1, 1},    {"synth_sphere.brep", 1, 1},
      {"synth_cone.brep", 1, 0},     {"synth_bspline_patch.brep", 1, 0},
      {"t20_component8.step", 4, 0}, {"fusee.stp", 153, 0}, /* B-spline with a hole */
      {"bspline_sphere.brep", 2, 0}, {"cyl_loop_seam.brep", 1, 1},
      {"screw.step", 7, 0},
  };
  pm_rng rng;
  pm_rng_init(&rng, 5, 0);
  for (size_t i = 0; i < sizeof faces / sizeof faces[0]; ++i) {
    pm_model *m = cad_load_file(faces[i].file);
    const pm_cell *f = cad_face_by_tag(m, 2, faces[i].tag);
    const double tol = 1e-7 * m->diagonal;
    int done = 0;
    for (int tries = 0; tries < 4000 && done < 30; ++tries) {
      double uv[2] = {pm_rng_range(&rng, f->lo[0], f->hi[0]),
                      pm_rng_range(&rng, f->lo[1], f->hi[1])};
      if (faces[i].near_seam && f->periodic[0]) {
        double w = 0.01 * f->period[0] * pm_rng_uniform(&rng);
        uv[0] = (tries & 1) ? f->lo[0] + w : f->lo[0] + f->period[0] - w;
      }
      if (!pm_face_inside(f, uv)) continue;
      pm_face_point p;
      pm_face_eval(f, uv, 1, &p);
      double par[2], closest[3], dist;
      pm_error e = {0};
      PM_ASSERT_OK(pm_cell_project(f, p.p, NULL, par, closest, &dist, &e), e);
      if (!(dist <= tol))
        fail_msg("%s face %d: S(%g, %g) projects at distance %g", faces[i].file, f->tag, uv[0],
                 uv[1], dist);
      pm_face_point q;
      pm_face_eval(f, par, 0, &q);
      assert_true(pm_v3_dist(q.p, p.p) <= tol);
      /* Off the surface along the normal, by 1e-3 of the diagonal: back to the foot point
       * (the surfaces' radii of curvature are larger than that offset). */
      double n[3];
      pm_v3_cross(n, p.su, p.sv);
      if (pm_v3_normalize(n) > 0) {
        double x[3];
        pm_v3_axpy(x, p.p, 1e-3 * m->diagonal, n);
        PM_ASSERT_OK(pm_cell_project(f, x, (done & 1) ? uv : NULL, par, closest, &dist, &e), e);
        if (!(fabs(dist - 1e-3 * m->diagonal) <= 1e-6 * m->diagonal &&
              pm_v3_dist(closest, p.p) <= 1e-6 * m->diagonal))
          fail_msg("%s face %d: S(%g, %g) + 1e-3 diag n projects at distance %g to (%g, %g)",
                   faces[i].file, f->tag, uv[0], uv[1], dist / m->diagonal, par[0], par[1]);
      }
      ++done;
    }
    assert_int_equal(done, 30);
    assert_int_equal(pm_cad_eval_failures(m), 0);
    pm_model_destroy(m);
  }
}

/* On B-spline faces (projected from a grid start, geom.c's Newton iteration refining) the
 * closest point is as close as gmshModelGetParametrization's, for points near the surface. */
static void bspline_projection_matches_gmsh(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("fusee.stp");
  pm_rng rng;
  pm_rng_init(&rng, 13, 0);
  int faces = 0;
  for (int32_t k = 0; k < m->count[PM_FACE] && faces < 40; ++k) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, k);
    if (pm_cad_cell_is_fast(f)) continue;
    ++faces;
    int done = 0;
    for (int tries = 0; tries < 2000 && done < 8; ++tries) {
      double uv[2] = {pm_rng_range(&rng, f->lo[0], f->hi[0]),
                      pm_rng_range(&rng, f->lo[1], f->hi[1])};
      if (!pm_face_inside(f, uv)) continue;
      ++done;
      pm_face_point p;
      pm_face_eval(f, uv, 1, &p);
      double n[3], x[3];
      pm_v3_cross(n, p.su, p.sv);
      if (!(pm_v3_normalize(n) > 0)) continue;
      /* Off by up to 1e-3 of the diagonal, to either side. */
      pm_v3_axpy(x, p.p, pm_rng_range(&rng, -1e-3, 1e-3) * m->diagonal, n);
      double par[2], dist;
      pm_error e = {0};
      PM_ASSERT_OK(pm_cell_project(f, x, NULL, par, NULL, &dist, &e), e);
      pm_gmsh_scope sc;
      cad_gmsh_begin(m, &sc);
      double *r = NULL, *q = NULL;
      size_t nr = 0, nq = 0;
      int ierr = 0;
      gmshModelGetParametrization(2, f->tag, x, 3, &r, &nr, &ierr);
      CAD_LOCKED_CHECK(ierr == 0);
      gmshModelGetValue(2, f->tag, r, 2, &q, &nq, &ierr);
      cad_gmsh_end(&sc);
      double dg = pm_v3_dist(q, x);
      gmshFree(r), gmshFree(q);
      if (!(dist <= dg + 1e-9 * m->diagonal))
        fail_msg("fusee face %d: our closest point at %.9g, gmsh's at %.9g", f->tag, dist, dg);
    }
  }
  assert_int_equal(faces, 40);
  pm_model_destroy(m);
}

/* A pcurve that strays from its curve: on fusee.stp, face 84's pcurve of curve 413 (indices) is a
 * straight line in (u, v) whose image passes up to 0.079 from the curve, which itself lies on the
 * surface within 4.2e-4. The use is taken by projection, so the face's trimming polyline follows
 * the curve; no other polyline point of the model strays much farther than its curve lies from
 * the surface (2.1 times its gap beyond twice the floor here; face 84's points are within 4.2e-4
 * of curve 413, 0.079 before the check). */
static void stray_pcurve_is_projected(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("fusee.stp");
  assert_non_null(strstr(pm_model_healed(m), "pcurve strays from the curve"));
  double worst413 = 0, worst = 0;
  int32_t on413 = 0;
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, i);
    for (int32_t l = 0; l < f->nloop; ++l) {
      const pm_loop *L = &f->loop[l];
      for (int32_t k = 0; k < L->npts; ++k) {
        const pm_use *u = &L->use[L->pt_use[k]];
        const pm_cell *c = pm_model_cell(m, PM_CURVE, u->cell);
        if (c->degenerate) continue;
        pm_curve_point cp;
        pm_face_point fp;
        pm_curve_eval(c, L->pt_t[k], 0, &cp);
        pm_face_eval(f, &L->uv[2 * k], 0, &fp);
        const double d = pm_v3_dist(cp.p, fp.p);
        /* beyond twice the floor (a use is checked at 31 points: a bump narrower than their
         * spacing may pass), a point strays no more than a few times the curve's own distance
         * from the surface (a CAD gap: the pcurve then maps to the nearest surface point) */
        double w[2];
        const double gap = sqrt(pm_face_project_from(f, cp.p, &L->uv[2 * k], w));
        worst = fmax(worst, (d - 2 * PM_FEATURE_FLOOR * m->diagonal) / fmax(gap, 1e-12));
        if (i == 84 && u->cell == 413) worst413 = fmax(worst413, d), ++on413;
      }
    }
  }
  assert_true(on413 >= 8);
  if (!(worst413 < 5e-4)) fail_msg("face 84, curve 413: the polyline strays %g from the curve", worst413);
  if (!(worst < 8)) fail_msg("a polyline point strays %g times its curve's gap from its curve", worst);
  printf("fusee.stp: polyline points stray at most twice the floor plus %.3g times their curves' "
         "gaps (face 84, curve 413: %.3g)\n", worst, worst413);
  pm_model_destroy(m);
}

/* Curves: C(t) projects back to t's point on lines, circles (across the closing point), ellipses
 * and B-splines. */
static void curve_projection_round_trips(void **state) {
  (void)state;
  CAD_REQUIRE();
  const struct {
    const char *file;
    int tag;
  } curves[] = {{"synth_box_hole.brep", 1}, {"synth_box_hole.brep", 10}, {"crack.brep", 14},
                {"t20_component8.step", 7}, {"cyl_loop_seam.brep", 5},   {"screw.step", 1},
                {"table.brep", 31}};
  pm_rng rng;
  pm_rng_init(&rng, 9, 0);
  for (size_t i = 0; i < sizeof curves / sizeof curves[0]; ++i) {
    pm_model *m = cad_load_file(curves[i].file);
    const pm_cell *c = cad_face_by_tag(m, 1, curves[i].tag);
    for (int k = 0; k < 20; ++k) {
      double t = k < 3 ? (k == 0 ? c->lo[0] : (k == 1 ? c->hi[0] : c->lo[0] + 1e-9))
                       : pm_rng_range(&rng, c->lo[0], c->hi[0]);
      pm_curve_point p;
      pm_curve_eval(c, t, 0, &p);
      double par, dist, closest[3];
      pm_error e = {0};
      PM_ASSERT_OK(pm_cell_project(c, p.p, NULL, &par, closest, &dist, &e), e);
      if (!(dist <= 1e-7 * m->diagonal))
        fail_msg("%s curve %d: C(%g) projects at distance %g", curves[i].file, c->tag, t, dist);
      assert_true(par >= c->lo[0] - 1e-12 && par <= c->hi[0] + 1e-12);
    }
    pm_model_destroy(m);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(derivatives_match_finite_differences),
      cmocka_unit_test(fast_paths_agree_with_gmsh),
      cmocka_unit_test(batched_equals_single),
      cmocka_unit_test(evaluation_with_another_model_current),
      cmocka_unit_test(evaluation_failure_is_finite),
      cmocka_unit_test(concurrent_evaluation),
      cmocka_unit_test(projection_round_trips),
      cmocka_unit_test(bspline_projection_matches_gmsh),
      cmocka_unit_test(curve_projection_round_trips),
      cmocka_unit_test(stray_pcurve_is_projected),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  return rc;
}
