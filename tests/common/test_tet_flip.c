/* Edge removal (tet_flip.h): a flat tet in the ring around an interior edge is flipped away, the
 * new tets tile exactly the space of the old ones (the total volume is kept and every tet is
 * positive), and a ring with a reflex corner never gets a triangle folded over its neighbours. */
#include "test_support.h"

#include "common/backends/predicates.h"
#include "common/connect/tet_flip.h"

#include <stdlib.h>
#include <string.h>

enum { RING = 4 };

static double tet_volume6(const double *xyz, const int32_t *t) {
  const double *a = &xyz[3 * t[0]], *b = &xyz[3 * t[1]], *c = &xyz[3 * t[2]], *d = &xyz[3 * t[3]];
  double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  double e3[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return e3[0] * (e1[1] * e2[2] - e1[2] * e2[1]) + e3[1] * (e1[2] * e2[0] - e1[0] * e2[2]) +
         e3[2] * (e1[0] * e2[1] - e1[1] * e2[0]);
}

/* The RING tets around the edge p = node 0 (z = -1), q = node 1 (z = +1), whose other corners
 * are the ring nodes 2.. in the plane z = 0, each tet positively oriented. */
static void ring_tets(double *xyz, const double ring[RING][2], int32_t **tet, int32_t **tag) {
  xyz[0] = 0, xyz[1] = 0, xyz[2] = -1;
  xyz[3] = 0, xyz[4] = 0, xyz[5] = 1;
  for (int i = 0; i < RING; ++i)
    xyz[3 * (2 + i)] = ring[i][0], xyz[3 * (2 + i) + 1] = ring[i][1], xyz[3 * (2 + i) + 2] = 0;
  *tet = malloc(sizeof(int32_t) * 4 * RING);
  *tag = malloc(sizeof(int32_t) * RING);
  for (int i = 0; i < RING; ++i) {
    int32_t *t = &(*tet)[4 * i];
    t[0] = 2 + i, t[1] = 2 + (i + 1) % RING, t[2] = 0, t[3] = 1;
    if (pm_orient3d(&xyz[3 * t[0]], &xyz[3 * t[1]], &xyz[3 * t[2]], &xyz[3 * t[3]]) < 0) {
      int32_t x = t[0];
      t[0] = t[1], t[1] = x;
    }
    (*tag)[i] = 7;
  }
}

typedef struct flip_result {
  int32_t ntet, remaining, flips, negative, duplicates;
  double volume6;
} flip_result;

static flip_result remove_flat(const double ring[RING][2]) {
  double xyz[3 * (2 + RING)];
  int32_t *tet, *tag;
  ring_tets(xyz, ring, &tet, &tag);
  double before = 0;
  for (int i = 0; i < RING; ++i) before += fabs(tet_volume6(xyz, &tet[4 * i]));
  pm_tet_flip_input in = {xyz, 2 + RING, 0, NULL, 0, NULL, 1e-10, 100};
  flip_result r = {RING, 0, 0, 0, 0, 0};
  pm_error err = {0};
  PM_ASSERT_OK(pm_tet_remove_flat(&in, &tet, &tag, &r.ntet, &r.remaining, &r.flips, &err), err);
  for (int32_t t = 0; t < r.ntet; ++t) {
    const int32_t *v = &tet[4 * t];
    r.negative += pm_orient3d(&xyz[3 * v[0]], &xyz[3 * v[1]], &xyz[3 * v[2]], &xyz[3 * v[3]]) <= 0;
    r.volume6 += fabs(tet_volume6(xyz, v));
    assert_int_equal(tag[t], 7);
    for (int32_t u = 0; u < t; ++u) {
      int same = 0;
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) same += tet[4 * u + a] == v[b];
      r.duplicates += same == 4;
    }
  }
  PM_ASSERT_NEAR(r.volume6, before, 1e-12 * before);
  free(tet), free(tag);
  return r;
}

/* Ring nodes 2 and 3 (angles 90 and 270 degrees, up to 1e-12) are coplanar with the edge: the tet
 * between them is flat. Node 1 at 45 degrees makes the ring convex: a 4-4 flip removes it. */
static void convex_ring_flat_tet_removed(void **state) {
  (void)state;
  const double ring[RING][2] = {{1, 0}, {0.7, 0.7}, {0, 1}, {-1e-12, -1}};
  flip_result r = remove_flat(ring);
  assert_int_equal(r.flips, 1);
  assert_int_equal(r.remaining, 0);
  assert_int_equal(r.ntet, 4);
  assert_int_equal(r.negative, 0);
  assert_int_equal(r.duplicates, 0);
}

/* The same ring with node 1 pulled in to (0.1, 0.1): a reflex corner. The triangulation (0, 1, 2)
 * + (0, 2, 3) separates p from q with each triangle, but (0, 1, 2) is folded over (0, 2, 3); its
 * tets made positive would cover space twice (volume check in remove_flat). Only (0, 1, 3) +
 * (1, 2, 3) tiles the ring. */
static void reflex_ring_never_folds(void **state) {
  (void)state;
  const double ring[RING][2] = {{1, 0}, {0.1, 0.1}, {0, 1}, {-1e-12, -1}};
  flip_result r = remove_flat(ring);
  assert_int_equal(r.flips, 1);
  assert_int_equal(r.remaining, 0);
  assert_int_equal(r.negative, 0);
  assert_int_equal(r.duplicates, 0);
}

/* The tiling check: two tets glued on a face tile; the same tet twice, or a third tet on the face,
 * does not, and the check names the face. */
static void overlap_is_found(void **state) {
  (void)state;
  const double xyz[3 * 5] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1};
  /* (0 1 2 3) above the face 0 1 2, (0 2 1 4) below it: both positive */
  int32_t tet[4 * 3] = {0, 1, 2, 3, 0, 2, 1, 4, 0, 1, 2, 3};
  for (int k = 0; k < 2; ++k)
    assert_true(pm_orient3d(&xyz[3 * tet[4 * k]], &xyz[3 * tet[4 * k + 1]],
                            &xyz[3 * tet[4 * k + 2]], &xyz[3 * tet[4 * k + 3]]) > 0);
  int found = -1;
  int32_t t = -1, node = -1, count = 0;
  pm_error e = {0};
  PM_ASSERT_OK(pm_tet_find_overlap(5, tet, NULL, 2, &found, &t, &node, &count, &e), e);
  assert_int_equal(found, 0);
  /* the third tet repeats the first: every face of it is in two tets on one side */
  PM_ASSERT_OK(pm_tet_find_overlap(5, tet, NULL, 3, &found, &t, &node, &count, &e), e);
  assert_int_equal(found, 1);
  assert_true(t == 0 || t == 2);
  assert_true(count >= 2);
  /* not kept, it does not count */
  const uint8_t keep[3] = {1, 1, 0};
  PM_ASSERT_OK(pm_tet_find_overlap(5, tet, keep, 3, &found, &t, &node, &count, &e), e);
  assert_int_equal(found, 0);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(convex_ring_flat_tet_removed),
      cmocka_unit_test(reflex_ring_never_folds),
      cmocka_unit_test(overlap_is_found),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
