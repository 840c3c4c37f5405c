/* geom_cad trimming loops: every boundary use present and the loops closed in (u, v); the
 * inside test against gmshModelIsInside; seams, poles and a hole across the seam
 * (cyl_loop_seam.brep); volume orientation across faces shared by two volumes. */
#include "test_geom_cad_util.h"

#include "common/base/rng.h"
#include "common/geom/trim.h"

/* Distance in (u, v) from p to the loop polylines of face f. */
static double dist_to_loops(const pm_cell *f, const double p[2]) {
  double best = 1e300;
  for (int32_t l = 0; l < f->nloop; ++l) {
    const pm_loop *lp = &f->loop[l];
    for (int32_t i = 0; i < lp->npts; ++i) {
      const double *a = &lp->uv[2 * i], *b = &lp->uv[2 * ((i + 1) % lp->npts)];
      double ab[2] = {b[0] - a[0], b[1] - a[1]}, ap[2] = {p[0] - a[0], p[1] - a[1]};
      double L = ab[0] * ab[0] + ab[1] * ab[1];
      double t = L > 0 ? (ab[0] * ap[0] + ab[1] * ap[1]) / L : 0;
      t = t < 0 ? 0 : (t > 1 ? 1 : t);
      double d = hypot(ap[0] - t * ab[0], ap[1] - t * ab[1]);
      if (d < best) best = d;
    }
  }
  return best;
}

/* Each face's loops use its boundary curves exactly as often as gmsh lists them (plus our
 * degenerate curves), seams once per side, consecutive uses join in (u, v), and the outer loops
 * run counter-clockwise, holes clockwise. */
static void check_loops(const pm_model *m) {
  pm_gmsh_scope sc;
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, i);
    cad_gmsh_begin(m, &sc);
    int in[2] = {2, f->tag}, *dt = NULL, ierr = 0;
    size_t n = 0;
    gmshModelGetBoundary(in, 2, &dt, &n, 0, 1, 0, &ierr);
    cad_gmsh_end(&sc);
    int32_t nuse = 0;
    for (int32_t l = 0; l < f->nloop; ++l) nuse += f->loop[l].nuse;
    int32_t synth = 0;
    for (int32_t k = 0; k < f->nbound; ++k) {
      const pm_cell *c = pm_model_cell(m, PM_CURVE, f->bound[k].cell);
      int mult = 0, listed = 0, side1 = 0;
      for (size_t q = 0; q < n / 2; ++q) listed += abs(dt[2 * q + 1]) == c->tag;
      for (int32_t r = 0; r < f->nbound; ++r)
        mult += f->bound[r].cell == c->index,
            side1 += f->bound[r].cell == c->index && f->bound[r].side == 1;
      if (listed == 0) {
        assert_true(c->degenerate); /* ours: a pole the file lacks */
        ++synth;
        continue;
      }
      assert_int_equal(mult, listed);
      if (f->bound[k].side) assert_int_equal(side1, 1);
    }
    assert_int_equal(nuse, (int32_t)(n / 2) + synth);
    if (dt) gmshFree(dt);
    for (int32_t l = 0; l < f->nloop; ++l) {
      const pm_loop *lp = &f->loop[l];
      double a = pm_polyline_area(lp->uv, lp->npts);
      assert_true(lp->outer ? a > 0 : a < 0);
      /* Consecutive uses join: the end of one pcurve is the start of the next. */
      for (int32_t k = 0; k < lp->nuse; ++k) {
        const pm_use *u = &lp->use[k], *w = &lp->use[(k + 1) % lp->nuse];
        const pm_cell *cu = pm_model_cell(m, PM_CURVE, u->cell),
                      *cw = pm_model_cell(m, PM_CURVE, w->cell);
        double e[2], s[2];
        pm_face_curve_uv(f, u, u->sense > 0 ? cu->hi[0] : cu->lo[0], e);
        pm_face_curve_uv(f, w, w->sense > 0 ? cw->lo[0] : cw->hi[0], s);
        double gap = hypot(e[0] - s[0], e[1] - s[1]);
        double box = hypot(f->hi[0] - f->lo[0], f->hi[1] - f->lo[1]);
        if (gap > 2e-3 * box)
          fail_msg("%s face %d loop %d: gap %.3g between curves %d and %d (box %.3g)", m->name,
                   f->tag, (int)l, gap, cu->tag, cw->tag, box);
      }
    }
  }
}

/* Test 4: loops of every face of the small models, and pm_face_inside against
 * gmshModelIsInside at random (u, v) of each face's box: they may disagree only within
 * 1e-3 of the box diagonal of a loop polyline (the polylines' chord error is 2e-4). */
static void loops_and_inside_agree_with_gmsh(void **state) {
  (void)state;
  CAD_REQUIRE();
  const char *files[] = {"synth_box_hole.brep", "synth_box_hole.step", "synth_sphere.brep",
                         "synth_torus.brep",    "synth_cone.brep",     "synth_bspline_patch.brep",
                         "planar_step.brep",    "crack.brep",          "cyl_loop_seam.brep",
                         "slender_face.brep",   "table.brep",          "screw.step",
                         "cube_fillet.stp",     "bspline_sphere.brep", "t20_component8.step",
                         "bottle.brep",         "base_interface.step", "solid56.step",
                         "bearing.iges"};
  pm_rng rng;
  pm_rng_init(&rng, 17, 0);
  for (size_t i = 0; i < sizeof files / sizeof files[0]; ++i) {
    pm_model *m = cad_load_file(files[i]);
    check_loops(m);
    long agree = 0, near = 0, checked = 0;
    const int npts = m->count[PM_FACE] > 100 ? 60 : 200;
    for (int32_t k = 0; k < m->count[PM_FACE]; ++k) {
      const pm_cell *f = pm_model_cell(m, PM_FACE, k);
      const double box = hypot(f->hi[0] - f->lo[0], f->hi[1] - f->lo[1]);
      for (int s = 0; s < npts; ++s) {
        double uv[2] = {pm_rng_range(&rng, f->lo[0], f->hi[0]),
                        pm_rng_range(&rng, f->lo[1], f->hi[1])};
        pm_gmsh_scope sc;
        cad_gmsh_begin(m, &sc);
        int ierr = 0;
        int g = gmshModelIsInside(2, f->tag, uv, 2, &ierr);
        cad_gmsh_end(&sc);
        assert_int_equal(ierr, 0);
        int ours = pm_face_inside(f, uv);
        ++checked;
        if ((g > 0) == ours) {
          ++agree;
          continue;
        }
        double d = dist_to_loops(f, uv);
        if (d > 1e-3 * box)
          fail_msg(
              "%s face %d: (%.9g, %.9g) inside %d for gmsh, %d for us, %.3g from the loops (box "
              "%.3g)",
              files[i], f->tag, uv[0], uv[1], g > 0, ours, d, box);
        ++near;
      }
    }
    print_message("  %-26s %ld points: %ld agree, %ld differ next to a loop\n", files[i], checked,
                  agree, near);
    pm_model_destroy(m);
  }
}

/* cyl_loop_seam.brep: a tube whose hole straddles the seam, split by the seam vertex into two
 * closed curves that touch the outer loop: three loops (the outer one with the two seam halves
 * on both sides, two holes of one curve each); periodic in u. */
static void hole_across_the_seam(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("cyl_loop_seam.brep");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  assert_string_equal(f->cls->name, "cylinder");
  assert_int_equal(f->periodic[0], 1);
  assert_int_equal(f->periodic[1], 0);
  PM_ASSERT_NEAR(f->period[0], 2 * M_PI, 1e-12);
  assert_int_equal(f->nloop, 3);
  assert_int_equal(f->loop[0].outer, 1);
  assert_int_equal(f->loop[0].nuse, 6);
  int sides[2] = {0, 0};
  for (int32_t k = 0; k < f->loop[0].nuse; ++k) {
    const pm_use *u = &f->loop[0].use[k];
    int tag = pm_model_cell(m, PM_CURVE, u->cell)->tag;
    if (tag == 2 || tag == 3) sides[u->side]++;
  }
  assert_int_equal(sides[0], 2);
  assert_int_equal(sides[1], 2);
  for (int l = 1; l < 3; ++l) {
    assert_int_equal(f->loop[l].outer, 0);
    assert_int_equal(f->loop[l].nuse, 1);
  }
  /* The hole is out from both sides of the seam, and wrapping does not change the answer. */
  int in = 0, out = 0;
  for (int a = 0; a < 64; ++a)
    for (int b = 0; b < 32; ++b) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (a + 0.5) / 64,
                      f->lo[1] + (f->hi[1] - f->lo[1]) * (b + 0.5) / 32};
      int r = pm_face_inside(f, uv);
      double w[2] = {uv[0] + f->period[0], uv[1]}, z[2] = {uv[0] - 3 * f->period[0], uv[1]};
      assert_int_equal(pm_face_inside(f, w), r);
      assert_int_equal(pm_face_inside(f, z), r);
      in += r, out += !r;
    }
  assert_true(in > 0 && out > 0);
  /* Area of the trimmed face by sampling against OCC's. */
  double area = 0, du = (f->hi[0] - f->lo[0]) / 400, dv = (f->hi[1] - f->lo[1]) / 400;
  for (int a = 0; a < 400; ++a)
    for (int b = 0; b < 400; ++b) {
      double uv[2] = {f->lo[0] + (a + 0.5) * du, f->lo[1] + (b + 0.5) * dv};
      if (!pm_face_inside(f, uv)) continue;
      pm_face_point p;
      pm_face_eval(f, uv, 1, &p);
      double x[3];
      pm_v3_cross(x, p.su, p.sv);
      area += pm_v3_norm(x) * du * dv;
    }
  PM_ASSERT_NEAR(area, 47.18, 0.005 * 47.18); /* CATALOG.md: face area 47.18 */
  pm_model_destroy(m);
}

/* Seams and poles: the box-with-hole cylinder has its seam once per side and is periodic in u
 * only; the sphere's loop runs through both pole curves; the torus is periodic both ways with
 * one loop of four seam uses. */
static void seams_and_poles(void **state) {
  (void)state;
  CAD_REQUIRE();
  pm_model *m = cad_load_file("synth_box_hole.brep");
  const pm_cell *cyl = cad_face_by_tag(m, 2, 7);
  assert_int_equal(cyl->periodic[0], 1);
  assert_int_equal(cyl->periodic[1], 0);
  assert_int_equal(cyl->nloop, 1);
  assert_int_equal(cyl->loop[0].nuse, 4);
  double a = pm_polyline_area(cyl->loop[0].uv, cyl->loop[0].npts);
  PM_ASSERT_NEAR(a, 2 * M_PI * 0.5, 1e-9); /* the full (u, v) rectangle 2 pi x 0.5 */
  double uvin[2] = {0.3, 0.35}, uvout[2] = {0.3, 0.65};
  assert_true(pm_face_inside(cyl, uvin));
  assert_false(pm_face_inside(cyl, uvout));
  /* The two plates with a hole: two loops, one hole each. */
  for (int tag = 3; tag <= 5; tag += 2) {
    const pm_cell *f = cad_face_by_tag(m, 2, tag);
    assert_int_equal(f->nloop, 2);
    assert_int_equal(f->loop[1].outer, 0);
    PM_ASSERT_NEAR(pm_polyline_area(f->loop[1].uv, f->loop[1].npts), -M_PI * 0.25 * 0.25,
                   2e-3 * M_PI * 0.0625);
  }
  pm_model_destroy(m);

  m = cad_load_file("synth_sphere.brep");
  const pm_cell *s = pm_model_cell(m, PM_FACE, 0);
  assert_int_equal(s->nloop, 1);
  assert_int_equal(s->loop[0].nuse, 4);
  int poles = 0;
  for (int32_t k = 0; k < s->loop[0].nuse; ++k)
    poles += pm_model_cell(m, PM_CURVE, s->loop[0].use[k].cell)->degenerate;
  assert_int_equal(poles, 2);
  PM_ASSERT_NEAR(pm_polyline_area(s->loop[0].uv, s->loop[0].npts), 2 * M_PI * M_PI, 1e-9);
  pm_model_destroy(m);

  m = cad_load_file("synth_torus.brep");
  const pm_cell *t = pm_model_cell(m, PM_FACE, 0);
  assert_true(t->periodic[0] && t->periodic[1]);
  assert_int_equal(t->nloop, 1);
  assert_int_equal(t->loop[0].nuse, 4);
  PM_ASSERT_NEAR(pm_polyline_area(t->loop[0].uv, t->loop[0].npts), 4 * M_PI * M_PI, 1e-9);
  double q[2] = {-10.0, 25.0};
  assert_true(pm_face_inside(t, q));
  pm_model_destroy(m);
}

/* Faces shared by two volumes: gmsh's normal is outward for one of them only; the senses come
 * from the neighbouring faces. Three solids fragmented together (a box, a box beside it sharing
 * the face x = 1, and a cylinder inside the first sharing its whole surface), written to BREP. */
static void shared_faces_orientation(void **state) {
  (void)state;
  pm_error e = {0};
  PM_ASSERT_OK(pm_gmsh_begin(&e), e);
  char path[] = "/tmp/pm_test_geom_cad_shared_XXXXXX.brep";
  int fd = mkstemps(path, 5);
  assert_true(fd >= 0);
  close(fd);
  pm_gmsh_lock();
  pm_gmsh_scope sc;
  CAD_LOCKED_CHECK(pm_gmsh_scope_enter(&sc, "test_shared_faces", 1, &e) == PM_OK);
  int ierr = 0;
  int b1 = gmshModelOccAddBox(0, 0, 0, 1, 1, 1, -1, &ierr);
  int b2 = gmshModelOccAddBox(1, 0, 0, 1, 1, 1, -1, &ierr);
  int cy = gmshModelOccAddCylinder(0.5, 0.5, 0.2, 0, 0, 0.6, 0.3, -1, 2 * M_PI, &ierr);
  int obj[2] = {3, b1}, tool[4] = {3, b2, 3, cy};
  int *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  gmshModelOccFragment(obj, 2, tool, 4, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  if (out) gmshFree(out);
  for (size_t i = 0; i < nnmap; ++i) gmshFree(map[i]);
  if (map) gmshFree(map);
  if (nmap) gmshFree(nmap);
  gmshModelOccSynchronize(&ierr);
  gmshWrite(path, &ierr);
  CAD_LOCKED_CHECK(ierr == 0);
  pm_gmsh_scope_leave(&sc, 1);
  pm_gmsh_unlock();

  pm_model *m = NULL;
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  remove(path);
  assert_int_equal(m->count[PM_VOLUME], 3);
  const double cyl = M_PI * 0.09 * 0.6;
  int shared = 0;
  for (int32_t k = 0; k < m->count[PM_VOLUME]; ++k) {
    const pm_cell *v = pm_model_cell(m, PM_VOLUME, k);
    double vol = cad_divergence_volume(m, v, 300);
    /* Which solid: by its box. */
    double want = v->box[3] - v->box[0] < 0.7 ? cyl : (v->box[0] > 0.5 ? 1.0 : 1.0 - cyl);
    print_message("  volume %d: divergence %.6f, exact %.6f\n", v->tag, vol, want);
    PM_ASSERT_NEAR(vol, want, 0.005);
    for (int32_t q = 0; q < v->nbound; ++q)
      shared += pm_model_cell(m, PM_FACE, v->bound[q].cell)->nup == 2;
  }
  /* x = 1 and the cylinder's three faces, each counted from both sides. */
  assert_int_equal(shared, 8);
  /* A shared face has opposite senses in its two volumes. */
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    const pm_cell *f = pm_model_cell(m, PM_FACE, i);
    if (f->nup != 2) continue;
    int s[2] = {0, 0};
    for (int j = 0; j < 2; ++j) {
      const pm_cell *v = pm_model_cell(m, PM_VOLUME, f->up[j]);
      for (int32_t q = 0; q < v->nbound; ++q)
        if (v->bound[q].cell == f->index) s[j] = v->bound[q].sense;
    }
    assert_int_equal(s[0], -s[1]);
  }
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(seams_and_poles),
      cmocka_unit_test(hole_across_the_seam),
      cmocka_unit_test(shared_faces_orientation),
      cmocka_unit_test(loops_and_inside_agree_with_gmsh),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  pm_gmsh_shutdown();
  return rc;
}
