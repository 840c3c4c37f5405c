/* Real-CAD robustness, on shapes built in-process with gmsh's OpenCASCADE kernel and written
 * to BREP, then loaded and meshed as a user's file would be (pm_cad_load, `packmesh mesh`):
 *   - a cylinder whose inner loop crosses the seam twice;
 *   - a torus patch trimmed across both seams (one trimmed face, and the four faces a boolean
 *     cuts it into, whose pcurves on the seam lines come in two copies a period apart);
 *   - two faces that share an edge without being sewn come out conforming;
 *   - two solids that touch without sharing their face are fragmented;
 *   - a shell that lists one face twice under two tags keeps it once (the corpus's dlr_f6.brep,
 *     read when the shared models are there);
 *   - a sliver face narrower than the default size gives no needle;
 *   - a cone whose apex has a single face node near it (a pole fan of two triangles, the same
 *     triangle twice) is connected into a valid mesh by a repair node;
 *   - boundary chords of two curves leaving a vertex tangent to each other that cross in the
 *     face's parameter plane are split on their curves (a crescent);
 *   - curve nodes given twice, or at their curve's end, are dropped (the same crescent);
 *   - face nodes beyond the chord of a boundary segment too coarse for its arc are dropped (a
 *     quarter cone frustum);
 *   - a corner where the surface's derivatives are nearly parallel (a twisted bilinear patch
 *     whose boundary curves meet at 173 degrees) gets no needle;
 *   - a cylinder far taller than wide in its parameters connects without wrapping round;
 *   - a cone meshed by psys (fine at the apex, coarse at the base) connects without wrapping,
 *     and without a needle at the apex (a copy of robust/statreport__Cone_1.brep).
 */
#include "cli/cli_stats.h"

#include <cjson/cJSON.h>
#include <gmshc.h>
#include <math.h>
#include <unistd.h>

#include "common/connect/connect.h"
#include "common/geom/geom_cad.h"
#include "common/mesh/element_measure.h"
#include "common/mesh/mesh_check.h"
#include "common/backends/gmsh_session.h"
#include "common/geom/trim.h"
#include "common/base/vec3.h"

/* Stop with the gmsh lock released (a failed assertion leaves by longjmp). */
#define LOCKED_CHECK(cond)                                     \
  do {                                                         \
    if (!(cond)) {                                             \
      pm_gmsh_unlock();                                        \
      fail_msg("%s:%d: %s failed", __FILE__, __LINE__, #cond); \
    }                                                          \
  } while (0)

static char tmpdir[] = "/tmp/pm_test_cad_heal_XXXXXX";

static int setup(void **state) {
  (void)state;
  return mkdtemp(tmpdir) ? 0 : -1;
}

static int teardown(void **state) {
  (void)state;
  char cmd[200];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
  return system(cmd) == 0 ? 0 : -1;
}

typedef int (*shape_fn)(void); /* adds OCC shapes to the current model; returns gmsh's ierr */

/* Build a shape in a fresh gmsh model and write it to tmpdir/NAME.brep; the path is returned. */
static const char *write_shape(const char *name, shape_fn fn) {
  static char path[600];
  snprintf(path, sizeof path, "%s/%s.brep", tmpdir, name);
  pm_error e = {0};
  PM_ASSERT_OK(pm_gmsh_begin(&e), e);
  pm_gmsh_lock();
  pm_gmsh_scope sc;
  LOCKED_CHECK(pm_gmsh_scope_enter(&sc, name, 1, &e) == PM_OK);
  int ierr = fn();
  if (!ierr) gmshModelOccSynchronize(&ierr);
  if (!ierr) gmshWrite(path, &ierr);
  pm_gmsh_scope_leave(&sc, 1);
  pm_gmsh_unlock();
  assert_int_equal(ierr, 0);
  return path;
}

static void free_bool(int *out, int **map, size_t *nmap, size_t nnmap) {
  if (out) gmshFree(out);
  for (size_t i = 0; i < nnmap; ++i) gmshFree(map[i]);
  if (map) gmshFree(map);
  if (nmap) gmshFree(nmap);
}

/* Mesh `path` with `method` through the command; the stats document (cJSON_Delete it). */
static cJSON *mesh_stats(const char *path, const char *method, const char *extra) {
  char args[2048], stats[700];
  snprintf(stats, sizeof stats, "%s/stats.json", tmpdir);
  snprintf(args, sizeof args, "mesh '%s' --method %s --threads 1 %s -o '%s/out.msh' --stats '%s'",
           path, method, extra ? extra : "", tmpdir, stats);
  char *err = NULL;
  int rc = pm_test_cli(tmpdir, args, NULL, &err);
  if (rc != 0) fail_msg("packmesh %s: exit %d: %s", args, rc, err);
  free(err);
  return pm_test_read_json(stats);
}

/* Valid, and no needle the geometry does not force. */
static void assert_valid_no_unforced(const cJSON *o, const char *what) {
  if (!cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(o, "valid"))) {
    char *p = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(o, "problems"));
    fail_msg("%s: the checker rejects the mesh: %s", what, p);
  }
  double unforced = pm_test_stat(o, "tri", "needles", "unforced");
  if (unforced != 0)
    fail_msg("%s: %g unforced needles (smallest angle %g)", what, unforced,
             pm_test_stat(o, "tri", "min_angle_deg", "min"));
}

/* ---- a cylinder whose inner loop crosses the seam twice ------------------------------------ */

/* A solid cylinder (radius 1, z from 0 to 2, seam at +x) drilled along x at z = 1: the hole
 * (radius 0.3) goes through the seam, so the lateral face's hole loop crosses it twice. */
static int drilled_cylinder(void) {
  int ierr = 0;
  int c = gmshModelOccAddCylinder(0, 0, 0, 0, 0, 2, 1, -1, 2 * M_PI, &ierr);
  int h = gmshModelOccAddCylinder(-2, 0, 1, 4, 0, 0, 0.3, -1, 2 * M_PI, &ierr);
  int a[2] = {3, c}, b[2] = {3, h}, *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  if (!ierr) gmshModelOccCut(a, 2, b, 2, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  free_bool(out, map, nmap, nnmap);
  return ierr;
}

static void cylinder_hole_across_the_seam(void **state) {
  (void)state;
  const char *path = write_shape("drilled_cylinder", drilled_cylinder);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  /* The lateral face: the periodic cylinder. Points of the hole at the seam, on both sides of it
   * (u near 0 and near 2 pi), are outside; the material beside the hole is inside. */
  const pm_cell *lat = NULL;
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
    const pm_cell *f = &m->cells[PM_FACE][i];
    /* The drilled cylinder's side (the hole's own wall is periodic too, but has one loop). */
    if (f->periodic[0] && f->nloop == 2) lat = f;
  }
  assert_non_null(lat);
  const double P = lat->period[0];
  double probe[][2] = {{lat->lo[0] + 0.05, 1.0}, {lat->lo[0] + P - 0.05, 1.0},
                       {lat->lo[0] + 0.5 * P, 1.0}, {lat->lo[0] + 0.05, 0.3}, {lat->lo[0] + 0.05, 1.8}};
  const int want[] = {0, 0, 0, 1, 1};
  /* Which parameter is the height: the one spanning [0, 2]. */
  int hv = fabs(lat->hi[1] - lat->lo[1] - 2) < 1e-6 ? 1 : 0;
  assert_int_equal(hv, 1);
  for (int k = 0; k < 5; ++k) {
    int in = pm_face_inside(lat, probe[k]);
    if (in != want[k])
      fail_msg("(u, v) = (%g, %g): inside %d, want %d", probe[k][0], probe[k][1], in, want[k]);
  }
  pm_model_destroy(m);
  cJSON *o = mesh_stats(path, "bubble", NULL);
  assert_valid_no_unforced(o, "drilled cylinder, bubble");
  cJSON_Delete(o);
  o = mesh_stats(path, "gmsh-frontal", NULL);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(o, "valid")));
  cJSON_Delete(o);
}

/* ---- a torus patch across both seams --------------------------------------------------------- */

/* The torus (R = 1, r = 0.35) cut to the part inside a ball centred where its two seams cross,
 * (1.35, 0, 0): OpenCASCADE splits the patch at the seams into four faces, each bounded by
 * pieces of the seam lines whose pcurves come a period apart. */
static int torus_patch(void) {
  int ierr = 0;
  int t = gmshModelOccAddTorus(0, 0, 0, 1, 0.35, -1, 2 * M_PI, &ierr);
  int s = gmshModelOccAddSphere(1.35, 0, 0, 0.3, -1, -M_PI / 2, M_PI / 2, 2 * M_PI, &ierr);
  int a[2] = {3, t}, b[2] = {3, s}, *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  if (!ierr) gmshModelOccIntersect(a, 2, b, 2, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  free_bool(out, map, nmap, nnmap);
  return ierr;
}

/* One face of the torus trimmed by a circle of radius 0.5 round (u, v) = (0, 0) in its
 * parameter space: the loop runs through negative u and v, across both seams. */
static int torus_trimmed(void) {
  int ierr = 0;
  int t = gmshModelOccAddTorus(0, 0, 0, 1, 0.35, -1, 2 * M_PI, &ierr);
  /* The OpenCASCADE side's face, not the synchronized model's: a synchronization before the
   * removals below would keep the removed entities allocated (gmsh 4.8.4). */
  int *dt = NULL;
  size_t n = 0;
  gmshModelOccGetEntities(&dt, &n, 2, &ierr);
  int face = n >= 2 ? dt[1] : -1;
  if (dt) gmshFree(dt);
  /* The trimming circle, in (u, v) (wire3D = 0: x is u, y is v). */
  int c = gmshModelOccAddCircle(0, 0, 0, 0.5, -1, 0, 2 * M_PI, &ierr);
  int w = gmshModelOccAddWire(&c, 1, -1, 0, &ierr);
  if (!ierr) gmshModelOccAddTrimmedSurface(face, &w, 1, 0, -1, &ierr);
  int rm[4] = {3, t, 1, c};
  if (!ierr) gmshModelOccRemove(rm, 2, 1, &ierr);
  if (!ierr) gmshModelOccRemove(rm + 2, 2, 1, &ierr);
  return ierr;
}

static void torus_patch_across_both_seams(void **state) {
  (void)state;
  const char *names[2] = {"torus_patch", "torus_trimmed"};
  shape_fn fns[2] = {torus_patch, torus_trimmed};
  for (int k = 0; k < 2; ++k) {
    const char *path = write_shape(names[k], fns[k]);
    pm_model *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
    /* Every loop closes in (u, v) within the polyline tolerance and encloses area. */
    double area = 0;
    for (int32_t i = 0; i < m->count[PM_FACE]; ++i) {
      const pm_cell *f = pm_model_cell(m, PM_FACE, i);
      for (int32_t l = 0; l < f->nloop; ++l) area += fabs(pm_polyline_area(f->loop[l].uv, f->loop[l].npts));
    }
    assert_true(area > 0.1);
    if (k == 1) {
      /* The trimmed face: the disc of radius 0.5 about (0, 0), seen through the seams. */
      assert_int_equal(m->count[PM_FACE], 1);
      const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
      PM_ASSERT_NEAR(fabs(pm_polyline_area(f->loop[0].uv, f->loop[0].npts)), M_PI * 0.25, 2e-3);
      double in[2] = {-0.3, -0.3}, out[2] = {0.4, 0.4};
      assert_true(pm_face_inside(f, in));
      assert_false(pm_face_inside(f, out));
    } else {
      assert_int_equal(m->count[PM_FACE], 5); /* four torus pieces and the sphere cap */
    }
    pm_model_destroy(m);
    cJSON *o = mesh_stats(path, "bubble", NULL);
    assert_valid_no_unforced(o, names[k]);
    cJSON_Delete(o);
  }
}

/* ---- unsewn faces, touching solids, a face listed twice --------------------------------------- */

/* Two unit squares side by side at x = 1, each with its own edges: the edge x = 1 exists twice
 * and its end points are two pairs of coincident vertices. */
static int unsewn_squares(void) {
  int ierr = 0;
  gmshModelOccAddRectangle(0, 0, 0, 1, 1, -1, 0, &ierr);
  gmshModelOccAddRectangle(1, 0, 0, 1, 1, -1, 0, &ierr);
  return ierr;
}

static void unsewn_faces_come_out_conforming(void **state) {
  (void)state;
  const char *path = write_shape("unsewn", unsewn_squares);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  /* Sewn: 6 vertices and 7 curves instead of 8 and 8. */
  assert_int_equal(m->count[PM_VERTEX], 6);
  assert_int_equal(m->count[PM_CURVE], 7);
  assert_non_null(strstr(m->heal, "sewed"));
  pm_model_destroy(m);
  cJSON *o = mesh_stats(path, "bubble", NULL);
  assert_valid_no_unforced(o, "unsewn squares, bubble");
  const cJSON *heal = cJSON_GetObjectItemCaseSensitive(o, "heal");
  assert_true(cJSON_IsString(heal));
  cJSON_Delete(o);
  o = mesh_stats(path, "gmsh-frontal", NULL);
  assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(o, "valid")));
  cJSON_Delete(o);
}

/* Two unit cubes touching along x = 1, not fragmented. */
static int touching_boxes(void) {
  int ierr = 0;
  gmshModelOccAddBox(0, 0, 0, 1, 1, 1, -1, &ierr);
  gmshModelOccAddBox(1, 0, 0, 1, 1, 1, -1, &ierr);
  return ierr;
}

static void touching_solids_share_their_face(void **state) {
  (void)state;
  const char *path = write_shape("touching", touching_boxes);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  assert_int_equal(m->count[PM_VOLUME], 2);
  assert_int_equal(m->count[PM_FACE], 11); /* the face x = 1 once */
  assert_int_equal(m->count[PM_VERTEX], 12);
  assert_non_null(strstr(m->heal, "merged"));
  int shared = 0;
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i) shared += pm_model_cell(m, PM_FACE, i)->nup == 2;
  assert_int_equal(shared, 1);
  pm_model_destroy(m);
  cJSON *o = mesh_stats(path, "bubble", "--volume");
  assert_valid_no_unforced(o, "touching boxes, bubble --volume");
  cJSON_Delete(o);
}

/* The corpus file robust/NAME, loaded; the test is skipped when the shared models are not there
 * (real CAD, read from ../shared/cad). */
static pm_model *load_robust(const char *name) {
  if (!pm_test_have_cad()) skip();
  char path[1024];
  snprintf(path, sizeof path, "%s/robust/%s", PM_CAD_DIR, name);
  if (access(path, R_OK) != 0) skip();
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  return m;
}

static void faces_listed_twice_are_kept_once(void **state) {
  (void)state;
  /* bl/dlr_f6.brep of the corpus lists its symmetry plane twice (faces 124 and 131) */
  pm_model *m = load_robust("bl__dlr_f6.brep");
  assert_int_equal(m->count[PM_FACE], 129);
  assert_int_equal(m->count[PM_VOLUME], 1);
  assert_non_null(strstr(m->heal, "faces listed twice"));
  pm_model_destroy(m);
}

/* robust/step__mesh_T106_V3.step: an open shell of 8 B-spline faces exported unsewn. Sewing
 * leaves two faces that meet along part of an edge, so the sewn faces are fragmented too, and
 * the report names every step, the pcurves taken by projection last: a report that long was
 * once cut off at 320 characters. */
static void sewn_then_merged_report_is_whole(void **state) {
  (void)state;
  pm_model *m = load_robust("step__mesh_T106_V3.step");
  assert_int_equal(m->count[PM_VERTEX], 12);
  assert_int_equal(m->count[PM_CURVE], 18);
  assert_int_equal(m->count[PM_FACE], 8);
  assert_non_null(strstr(m->heal, "coincident vertex pairs (unsewn faces or touching solids): 28"));
  assert_non_null(strstr(m->heal, "merged what sewing left"));
  assert_non_null(strstr(m->heal, "32 / 34 / 8 / 0 -> 12 / 18 / 8 / 0"));
  const char *tail = "taken by projection onto the face: 12";
  size_t n = strlen(m->heal), k = strlen(tail);
  assert_true(n > k);
  assert_string_equal(m->heal + n - k, tail);
  pm_model_destroy(m);
}

/* ---- a sliver face ------------------------------------------------------------------------ */

/* A unit square and a strip 1 x 0.01 along its edge x = 1, fragmented so that they share it:
 * the strip is five times narrower than the default size (diagonal / 30 = 0.047). */
static int square_and_sliver(void) {
  int ierr = 0;
  int a = gmshModelOccAddRectangle(0, 0, 0, 1, 1, -1, 0, &ierr);
  int b = gmshModelOccAddRectangle(1, 0, 0, 0.01, 1, -1, 0, &ierr);
  int o[2] = {2, a}, t[2] = {2, b}, *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  if (!ierr) gmshModelOccFragment(o, 2, t, 2, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  free_bool(out, map, nmap, nnmap);
  return ierr;
}

static void sliver_face_gives_no_needle(void **state) {
  (void)state;
  const char *path = write_shape("sliver", square_and_sliver);
  cJSON *o = mesh_stats(path, "bubble", NULL);
  assert_valid_no_unforced(o, "square and sliver, bubble");
  /* No needle at all: the strip has no corner sharper than 10 degrees. */
  assert_true(pm_test_stat(o, "tri", "needles", "count") == 0);
  assert_true(pm_test_stat(o, "tri", "min_angle_deg", "min") >= 10);
  cJSON_Delete(o);
}

/* ---- a pole with two neighbours ---------------------------------------------------------- */

/* A cone (base radius 1 at z = 0, apex at z = 2). */
static int cone(void) {
  int ierr = 0;
  gmshModelOccAddCone(0, 0, 0, 0, 0, 2, 1, 0, -1, 2 * M_PI, &ierr);
  return ierr;
}

static void pole_with_two_neighbours(void **state) {
  (void)state;
  const char *path = write_shape("cone", cone);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  const pm_cell *f = NULL;
  for (int32_t i = 0; i < m->count[PM_FACE]; ++i)
    if (m->cells[PM_FACE][i].periodic[0]) f = &m->cells[PM_FACE][i];
  assert_non_null(f);
  /* The apex end of v: where S does not move with u. */
  pm_face_point a, b;
  double p0[2] = {f->lo[0], f->lo[1]}, p1[2] = {f->lo[0] + 1, f->lo[1]};
  pm_face_eval(f, p0, 0, &a), pm_face_eval(f, p1, 0, &b);
  const int apex_hi = pm_v3_dist(a.p, b.p) > 1e-6;
  const double vlen = f->hi[1] - f->lo[1];
  pm_mesh *mesh = pm_mesh_create();
  assert_non_null(mesh);
  /* Nodes on the curves: 12 on the base circle, 5 on the seam; on the face, one node only,
   * near the apex: the apex's neighbours are that node and the seam's last node, whose fan
   * closes with the same triangle on both sides of the seam. */
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    if (cv->degenerate) continue;
    int closed = cv->bound[0].cell == cv->bound[1].cell;
    int n = closed ? 12 : 5;
    for (int k = 1; k < n + (closed ? 0 : 1); ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / (closed ? n : n + 1), x[3];
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_CURVE, c, &t, NULL, &e), e);
    }
  }
  {
    double uv[2] = {0.5 * (f->lo[0] + f->hi[0]), apex_hi ? f->hi[1] - 0.1 * vlen : f->lo[1] + 0.1 * vlen};
    double x[3];
    pm_cell_point(f, uv, x);
    PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_FACE, f->index, uv, NULL, &e), e);
  }
  pm_connect_report rep;
  PM_ASSERT_OK(pm_connect(m, mesh, NULL, &rep, &e), e);
  pm_check_report chk = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &chk, &e), e);
  if (!chk.valid) fail_msg("%s", chk.nproblem ? chk.problem[0] : "invalid");
  assert_true(rep.repair_nodes >= 1);
  assert_int_equal(rep.chord_nodes, 0); /* no chords cross: the curve nodes are left as they are */
  pm_check_report_clear(&chk);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* ---- boundary chords that cross ----------------------------------------------------------- */

/* A crescent between two arcs that leave the vertex (0, 2.2) tangent to each other: arc A of the
 * circle of radius 2.2 about the origin, arc B of the circle of radius 2.4 about (0, -0.2), each a
 * quarter turn to the left, closed by a line between their ends; at arc length s from the vertex
 * the crescent is about 0.019 s^2 wide (0.0016 at s = 0.29), as robust/brep__test_11551.brep's
 * face 1 is. */
static int crescent(void) {
  int ierr = 0;
  int p0 = gmshModelOccAddPoint(0, 2.2, 0, 0, -1, &ierr);
  int ca = gmshModelOccAddPoint(0, 0, 0, 0, -1, &ierr);
  int ea = gmshModelOccAddPoint(-2.2, 0, 0, 0, -1, &ierr);
  int cb = gmshModelOccAddPoint(0, -0.2, 0, 0, -1, &ierr);
  int eb = gmshModelOccAddPoint(-2.4, -0.2, 0, 0, -1, &ierr);
  int a = gmshModelOccAddCircleArc(p0, ca, ea, -1, &ierr);
  int b = gmshModelOccAddCircleArc(p0, cb, eb, -1, &ierr);
  int l = gmshModelOccAddLine(ea, eb, -1, &ierr);
  int loop[3] = {a, l, -b};
  int w = gmshModelOccAddCurveLoop(loop, 3, -1, &ierr);
  gmshModelOccAddPlaneSurface(&w, 1, -1, &ierr);
  return ierr;
}

/* Nodes evenly spaced in arc length, 0.23 apart on arc A and 0.29 on arc B (none on the line): the
 * first chord of arc B, from the vertex, sags 0.0044 below its arc, deeper than the crescent is
 * wide, and crosses arc A's second chord. Connected, the crossing chords are split on their
 * curves (connect.c, step 1c) and the face is triangulated; without that the triangulation of the
 * face fails ("constraint edges ... cross away from any input point"), as psys's nodes of
 * brep__test_11551.brep did. */
static void crossing_chords_are_split(void **state) {
  (void)state;
  const char *path = write_shape("crescent", crescent);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  assert_int_equal(m->count[PM_FACE], 1);
  assert_int_equal(m->count[PM_CURVE], 3);
  pm_mesh *mesh = pm_mesh_create();
  assert_non_null(mesh);
  int arcs = 0;
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    double mid = 0.5 * (cv->lo[0] + cv->hi[0]), len = pm_curve_length(cv, cv->lo[0], cv->hi[0]);
    double k = pm_curve_curvature(cv, mid);
    if (k < 0.1) continue; /* the line */
    const double h = k > 1 / 2.3 ? 0.23 : 0.29;
    int n = (int)(len / h);
    for (int i = 1; i <= n; ++i) {
      /* arc length i h from the vertex (0, 2.2), whichever end of the curve it is */
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * (i * h / len), x[3], y[3];
      pm_cell_point(cv, &cv->lo[0], y);
      if (fabs(y[1] - 2.2) > 1e-6 || fabs(y[0]) > 1e-6) t = cv->hi[0] - (t - cv->lo[0]);
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_CURVE, c, &t, NULL, &e), e);
    }
    ++arcs;
  }
  assert_int_equal(arcs, 2);
  pm_connect_report rep;
  PM_ASSERT_OK(pm_connect(m, mesh, NULL, &rep, &e), e);
  pm_check_report chk = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &chk, &e), e);
  if (!chk.valid) fail_msg("%s", chk.nproblem ? chk.problem[0] : "invalid");
  print_message("crescent: %d curve nodes added, %d triangles\n", (int)rep.chord_nodes,
                (int)mesh->ntri);
  /* at least the two chords of the first crossing, and every segment where it was */
  assert_true(rep.chord_nodes >= 2);
  assert_true(mesh->ntri > 0);
  /* Every triangle is counter-clockwise or clockwise alike in the plane z = 0: none folded. */
  int pos = 0, neg = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    const double *a = &mesh->xyz[3 * mesh->tri[3 * t]], *b = &mesh->xyz[3 * mesh->tri[3 * t + 1]],
                 *c = &mesh->xyz[3 * mesh->tri[3 * t + 2]];
    double area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    pos += area2 > 0, neg += area2 < 0;
  }
  assert_true(pos == 0 || neg == 0);
  pm_check_report_clear(&chk);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* Curve nodes that repeat a node: the crescent's nodes as above, each arc's second node given
 * twice more (once at the same parameter, once 1e-13 of the range further), and a node at the
 * far end of each arc (its end vertex's point). Connected, the repeats are dropped (connect.c,
 * step 1a) and the mesh is the one of the nodes without them; kept, they would be duplicate
 * nodes and zero-length segments. */
static void repeated_curve_nodes_are_dropped(void **state) {
  (void)state;
  const char *path = write_shape("crescent", crescent);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  pm_mesh *plain = pm_mesh_create(), *repeated = pm_mesh_create();
  assert_non_null(plain);
  assert_non_null(repeated);
  int32_t extra = 0;
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    double len = pm_curve_length(cv, cv->lo[0], cv->hi[0]);
    if (pm_curve_curvature(cv, 0.5 * (cv->lo[0] + cv->hi[0])) < 0.1) continue; /* the line */
    const double range = cv->hi[0] - cv->lo[0];
    const int n = (int)(len / 0.1);
    for (int i = 1; i < n; ++i) {
      double t = cv->lo[0] + range * i / n, x[3];
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(plain, x, PM_CURVE, c, &t, NULL, &e), e);
      PM_ASSERT_OK(pm_mesh_add_node(repeated, x, PM_CURVE, c, &t, NULL, &e), e);
      if (i != 2) continue;
      double t2 = t + 1e-13 * range, x2[3];
      pm_cell_point(cv, &t2, x2);
      PM_ASSERT_OK(pm_mesh_add_node(repeated, x, PM_CURVE, c, &t, NULL, &e), e);
      PM_ASSERT_OK(pm_mesh_add_node(repeated, x2, PM_CURVE, c, &t2, NULL, &e), e);
      extra += 2;
    }
    double te = cv->hi[0], xe[3];
    pm_cell_point(cv, &te, xe);
    PM_ASSERT_OK(pm_mesh_add_node(repeated, xe, PM_CURVE, c, &te, NULL, &e), e);
    ++extra;
  }
  assert_int_equal(extra, 6);
  pm_connect_report ra, rb;
  PM_ASSERT_OK(pm_connect(m, plain, NULL, &ra, &e), e);
  PM_ASSERT_OK(pm_connect(m, repeated, NULL, &rb, &e), e);
  assert_int_equal(rb.dropped_nodes - ra.dropped_nodes, extra);
  assert_int_equal(repeated->nnode, plain->nnode);
  assert_int_equal(repeated->ntri, plain->ntri);
  assert_memory_equal(repeated->tri, plain->tri, sizeof(int32_t) * 3 * (size_t)plain->ntri);
  pm_check_report chk = {0};
  PM_ASSERT_OK(pm_mesh_check(repeated, m, &chk, &e), e);
  if (!chk.valid) fail_msg("%s", chk.nproblem ? chk.problem[0] : "invalid");
  pm_check_report_clear(&chk);
  pm_mesh_destroy(plain);
  pm_mesh_destroy(repeated);
  pm_model_destroy(m);
}

/* psys on the crescent: the paper's gap skips two curves that meet, so its field stays coarse
 * along the cusp, clamped at sigma_min where the crescent is narrower still, and triangles span
 * the crescent as needles; with feature_width (the default) sigma follows the crescent's width,
 * as bubble's default size does, and no needle is left that the cusp itself does not force. */
static void crescent_psys_follows_the_width(void **state) {
  (void)state;
  const char *path = write_shape("crescent", crescent);
  cJSON *paper = mesh_stats(path, "psys", "--set feature_width=0");
  cJSON *ours = mesh_stats(path, "psys", NULL);
  print_message("crescent, psys: feature_width=0: %g nodes, %g unforced needles; 1: %g nodes, %g\n",
                pm_test_stat(paper, "nodes", NULL, NULL), pm_test_stat(paper, "tri", "needles", "unforced"),
                pm_test_stat(ours, "nodes", NULL, NULL), pm_test_stat(ours, "tri", "needles", "unforced"));
  assert_true(pm_test_stat(paper, "tri", "needles", "unforced") > 0);
  assert_valid_no_unforced(ours, "crescent, psys");
  cJSON_Delete(paper);
  cJSON_Delete(ours);
}

/* ---- a boundary segment too coarse for its arc ------------------------------------------- */

/* A quarter of a cone frustum (radius 1 at the bottom, 0.5 at height 1): each quarter circle is
 * one segment, whose chord cuts 0.29 (0.15 at the top) inside the arc, and the curved face has
 * nodes 0.002 of the height from the circles -- beyond the chord in 3D, inside it in (u, v), as
 * psys left them on robust/occ_large__simple_plane.brep (face 3, a quarter frustum). Connected,
 * their triangles with the chord stand upright on the surface and, where it leans towards the
 * chord, fold over; step 1b (connect.c) drops them, and only them. */
static int quarter_frustum(void) {
  int ierr = 0;
  gmshModelOccAddCone(0, 0, 0, 0, 0, 1, 1, 0.5, -1, M_PI / 2, &ierr);
  return ierr;
}

static void coarse_arc_drops_nodes_beyond_its_chord(void **state) {
  (void)state;
  const char *path = write_shape("quarter_frustum", quarter_frustum);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  const pm_cell *f = NULL;
  for (int32_t i = 0; i < m->count[PM_FACE] && !f; ++i) {
    const pm_cell *c = &m->cells[PM_FACE][i];
    double k1 = 0, k2 = 0, mid[2] = {0.5 * (c->lo[0] + c->hi[0]), 0.5 * (c->lo[1] + c->hi[1])};
    pm_face_curvatures(c, mid, &k1, &k2, NULL);
    if (fabs(k1) > 0.5 || fabs(k2) > 0.5) f = c;
  }
  assert_non_null(f);
  int valid[2] = {0, 0};
  int32_t dropped[2] = {0, 0}, near = 0;
  for (int drop = 0; drop <= 1; ++drop) {
    pm_mesh *mesh = pm_mesh_create();
    assert_non_null(mesh);
    /* Straight curves get 4 nodes inside, arcs none. */
    for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
      const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
      if (pm_curve_curvature(cv, 0.5 * (cv->lo[0] + cv->hi[0])) > 0.5) continue;
      for (int k = 1; k <= 4; ++k) {
        double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / 5, x[3];
        pm_cell_point(cv, &t, x);
        PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_CURVE, c, &t, NULL, &e), e);
      }
    }
    /* Face nodes: three along each side of the parameter box, 0.002 of the box in, and one in
     * the middle. */
    near = 0;
    const double fr[3] = {0.25, 0.5, 0.75};
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < 3; ++k) {
        double a = side < 2 ? fr[k] : (side == 2 ? 0.002 : 0.998);
        double b = side < 2 ? (side == 0 ? 0.002 : 0.998) : fr[k];
        double uv[2] = {f->lo[0] + a * (f->hi[0] - f->lo[0]), f->lo[1] + b * (f->hi[1] - f->lo[1])}, x[3];
        pm_cell_point(f, uv, x);
        PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_FACE, f->index, uv, NULL, &e), e);
        ++near;
      }
    double uv[2] = {0.5 * (f->lo[0] + f->hi[0]), 0.5 * (f->lo[1] + f->hi[1])}, x[3];
    pm_cell_point(f, uv, x);
    PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_FACE, f->index, uv, NULL, &e), e);
    pm_connect_params p;
    pm_connect_params_init(&p);
    p.drop_crossed = drop;
    pm_connect_report rep;
    PM_ASSERT_OK(pm_connect(m, mesh, &p, &rep, &e), e);
    pm_check_report chk = {0};
    PM_ASSERT_OK(pm_mesh_check(mesh, m, &chk, &e), e);
    valid[drop] = chk.valid;
    dropped[drop] = rep.crossed_nodes;
    pm_check_report_clear(&chk);
    pm_mesh_destroy(mesh);
  }
  print_message("quarter frustum: %d face nodes near its sides; kept: valid %d; dropped %d: valid %d\n",
                (int)near, valid[0], (int)dropped[1], valid[1]);
  assert_false(valid[0]);       /* the fold is real */
  /* The three nodes along the bottom arc, whose triangles fold (the face leans 27 degrees back
   * from the chord); along the top arc the face leans over the chord and the triangles lie 63
   * degrees off the surface: kept, as are the nodes along the straight sides. */
  assert_int_equal(dropped[1], 3);
  assert_true(valid[1]);
  pm_model_destroy(m);
}

/* ---- a corner where the surface's derivatives are nearly parallel ------------------------- */

/* A bilinear patch twisted out of its plane: P00 = (0, 0, 0), P10 = (10, 0, 0), P11 = (20, 1.2, 0)
 * and P01 = (5, -8, 10). At the corner (u, v) = (1, 0), Su = P10 - P00 and Sv = P11 - P10 are 6.8
 * degrees apart, so the two boundary curves meet there at 173 degrees, and the surface's normal
 * there, +z, is 116 degrees off the normal at (0.85, 0.15) (a corner of the same kind, 84
 * degrees off, is on robust/statreport__A319.brep's face 5, where it was found). Nowhere else
 * are Su and Sv closer than 5 degrees. */
static int flat_corner_patch(void) {
  int ierr = 0, pt[4];
  const double P[4][3] = {{0, 0, 0}, {10, 0, 0}, {5, -8, 10}, {20, 1.2, 0}}; /* u fastest */
  for (int k = 0; k < 4 && !ierr; ++k) pt[k] = gmshModelOccAddPoint(P[k][0], P[k][1], P[k][2], 0, -1, &ierr);
  if (!ierr) gmshModelOccAddBezierSurface(pt, 4, 2, -1, NULL, 0, 0, &ierr);
  return ierr;
}

/* Curve nodes every tenth of each curve's parameter range and face nodes on an 8 x 8 grid of
 * (u, v) of the same step kept 1.5 steps from the sides: in (u, v) the corner is a right angle,
 * the circle through it and its two neighbours holds no face node, so the
 * triangulation there joins the corner to the first node along each curve, a triangle that
 * lifts to a 3-degree needle along the flat corner. The 3D flips must turn it to the face node
 * beside it: the corner's normal, taken from two nearly parallel derivatives, is no test of the
 * flipped triangles (face_smooth.h, PM_CONNECT_NORMAL_MIN_SIN). */
static void flat_corner_gets_no_needle(void **state) {
  (void)state;
  const char *path = write_shape("flat_corner", flat_corner_patch);
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  assert_int_equal(m->count[PM_FACE], 1);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  pm_mesh *mesh = pm_mesh_create();
  assert_non_null(mesh);
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    for (int k = 1; k < 10; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / 10, x[3];
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_CURVE, c, &t, NULL, &e), e);
    }
  }
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      double uv[2] = {f->lo[0] + (f->hi[0] - f->lo[0]) * (0.15 + 0.1 * i),
                      f->lo[1] + (f->hi[1] - f->lo[1]) * (0.15 + 0.1 * j)};
      double x[3];
      pm_cell_point(f, uv, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, PM_FACE, f->index, uv, NULL, &e), e);
    }
  /* The (u, v) triangulation as it comes, for the 3D flips alone to mend. */
  pm_connect_params p;
  pm_connect_params_init(&p);
  p.affine = 0, p.metric_flips = 0;
  pm_connect_report rep;
  PM_ASSERT_OK(pm_connect(m, mesh, &p, &rep, &e), e);
  pm_check_report chk = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, &chk, &e), e);
  if (!chk.valid) fail_msg("%s", chk.nproblem ? chk.problem[0] : "invalid");
  /* The corner: the vertex node at (10, 0, 0). */
  int32_t corner = -1;
  for (int32_t i = 0; i < mesh->nnode; ++i)
    if (mesh->node_dim[i] == PM_VERTEX && fabs(mesh->xyz[3 * i] - 10) < 1e-9 &&
        fabs(mesh->xyz[3 * i + 1]) < 1e-9)
      corner = i;
  assert_true(corner >= 0);
  int at_corner = 0;
  double worst = 180;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    const int32_t *v = &mesh->tri[3 * t];
    if (v[0] != corner && v[1] != corner && v[2] != corner) continue;
    pm_tri_measure q;
    pm_tri_measure_eval(&mesh->xyz[3 * v[0]], &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[2]], &q);
    worst = fmin(worst, q.min_angle);
    ++at_corner;
  }
  print_message("flat corner: %d triangles, smallest angle %.2f degrees\n", at_corner, worst);
  /* Measured: 3 triangles, 14.3 degrees (1 triangle of 3.4 degrees when the corner's normal
   * vetoed the flip). */
  assert_true(at_corner >= 2);
  assert_true(worst >= 10);
  pm_check_report_clear(&chk);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* ---- a tall cylinder ---------------------------------------------------------------------- */

/* Radius 100, height 300 (robust/statreport__Cylinder_1.brep's shape): its parameter plane is
 * 2 pi wide and 300 high, so the unscaled triangulation joins the two sides of the seam; the
 * affine map must not read those edges as neighbours (connect.c, affine_scale). */
static int tall_cylinder(void) {
  int ierr = 0;
  gmshModelOccAddCylinder(0, 0, 0, 0, 0, 300, 100, -1, 2 * M_PI, &ierr);
  return ierr;
}

static void tall_cylinder_does_not_wrap(void **state) {
  (void)state;
  const char *path = write_shape("tall_cylinder", tall_cylinder);
  const char *methods[2] = {"bubble", "psys"};
  for (int k = 0; k < 2; ++k) {
    cJSON *o = mesh_stats(path, methods[k], NULL);
    assert_valid_no_unforced(o, methods[k]);
    assert_true(pm_test_stat(o, "tri", "min_angle_deg", "min") >= 20);
    cJSON_Delete(o);
  }
}

/* ---- a cone with psys's grading ------------------------------------------------------------- */

/* robust/statreport__Cone_1.brep (a copy in tests/data/cad): base radius 100, apex 300 above.
 * psys's curvature sizing packs the apex a hundred times finer than the base, so the unscaled
 * parameter plane (2 pi by 316) joins the two copies of seam nodes near the base across the
 * whole period; the metric flips must flip those edges away (connect.c, metric_flips) rather
 * than leave them to a repair node on the far side of the cone (an edge of four triangles).
 * gmsh's addCone builds a cone that psys meshes without this fault, hence the file. */
static void graded_cone_does_not_wrap(void **state) {
  (void)state;
  cJSON *o = mesh_stats(PM_SOURCE_DIR "/tests/data/cad/Cone_1.brep", "psys", NULL);
  if (!cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(o, "valid"))) {
    char *p = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(o, "problems"));
    fail_msg("psys on Cone_1: the checker rejects the mesh: %s", p);
  }
  /* No triangle spans the cone: the mesh is within a hundredth of the diagonal of the surface
   * (64 with the repair node, 1.4 without it, of a diagonal of 412). */
  assert_true(pm_test_stat(o, "distance", "max", NULL) <
              0.01 * pm_test_stat(o, "distance", "bbox_diagonal", NULL));
  /* psys leaves no face node as close to the apex as the seam's last node (0.25 from it, the
   * nearest face node 0.47): the triangle of that node, the one before it and the apex lies flat
   * on the seam's ruling on each side of the seam; flipped away, the apex's fan holds no needle
   * (4 unforced ones, about 7 degrees, when a repair node split its edge into the apex). */
  assert_valid_no_unforced(o, "psys on Cone_1");
  assert_true(pm_test_stat(o, "tri", "min_angle_deg", "min") >= 10);
  cJSON_Delete(o);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(cylinder_hole_across_the_seam),
      cmocka_unit_test(torus_patch_across_both_seams),
      cmocka_unit_test(unsewn_faces_come_out_conforming),
      cmocka_unit_test(touching_solids_share_their_face),
      cmocka_unit_test(faces_listed_twice_are_kept_once),
      cmocka_unit_test(sewn_then_merged_report_is_whole),
      cmocka_unit_test(sliver_face_gives_no_needle),
      cmocka_unit_test(pole_with_two_neighbours),
      cmocka_unit_test(crossing_chords_are_split),
      cmocka_unit_test(repeated_curve_nodes_are_dropped),
      cmocka_unit_test(crescent_psys_follows_the_width),
      cmocka_unit_test(coarse_arc_drops_nodes_beyond_its_chord),
      cmocka_unit_test(flat_corner_gets_no_needle),
      cmocka_unit_test(tall_cylinder_does_not_wrap),
      cmocka_unit_test(graded_cone_does_not_wrap),
  };
  int rc = cmocka_run_group_tests(tests, setup, teardown);
  pm_gmsh_shutdown();
  return rc;
}
