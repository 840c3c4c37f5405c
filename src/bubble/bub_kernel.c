/* The force sums over the neighbour lists: the inner loop of the dynamics (papers/003 eq. 10-11,
 * papers/004 eq. 2.1), most of a step's cost.
 *
 * For each pair in bubble i's list (bub_neighbors.c) at the packed stage positions (x, y, z, d):
 *   r = x_i - x_j, l0 = (d_i + d_j) / 2 (003 eq. 10), r2 = |r|^2; the pair acts when r2 < (1.5 l0)^2
 *   (003 eq. 11); with l = sqrt(r2), q = 1 / (l l0) and lambda = l / l0 = r2 q,
 *   F / l = k0 l0^2 g(lambda) q, g = 5/4 lambda^3 - 19/8 lambda^2 + 9/8 (bub_force.c), and the force
 *   on i is the sum of (F / l) r: one square root and one division a pair.
 * Coincident pairs (r2 <= 1e-24 l0^2, where r has no direction) push along a direction drawn from
 * the run's seed and the pair (bub_dynamics.c's pair_direction), added after the others.
 * At the first RK stage the sum also gives the bubble's half of its pairs' potential energy and
 * its degree (pairs within 1.3 l0), for the trace.
 *
 * Two implementations with the same arithmetic: the list is taken four pairs at a time, pair k of
 * the list in lane k mod 4, every operation the same IEEE operation in the same order, the lanes
 * summed as (0 + 1) + (2 + 3). One is plain C, the other AVX2 (x86-64 processors that have it,
 * chosen at run time): four pairs per instruction, the four neighbours' packed records loaded and
 * transposed. Both give the same bits, so a mesh does not depend on the processor's vector
 * width any more than on the thread count (test_bub_dynamics checks them against each other).
 * AVX2 is compiled for this function only (the rest of the build targets baseline x86-64).
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define BUB_KERNEL_AVX2 1
#endif

/* The per-lane sums of a list. */
typedef struct lanes {
  double fx[4], fy[4], fz[4], u[4];
  int32_t deg[4];
  int coincident; /* some pair in range has r2 <= 1e-24 l0^2 */
} lanes;

/* Reference implementation, lane by lane. */
static void sum_lanes_c(const double *pos4, const int32_t *nb, int32_t cnt, const double pi[4],
                        double k0, int extras, lanes *L) {
  memset(L, 0, sizeof *L);
  for (int32_t k = 0; k < cnt; ++k) {
    const int lane = k & 3;
    const double *pj = &pos4[4 * nb[k]];
    const double rx = pi[0] - pj[0], ry = pi[1] - pj[1], rz = pi[2] - pj[2];
    const double l0 = 0.5 * (pi[3] + pj[3]), l02 = l0 * l0;
    const double r2 = (rx * rx + ry * ry) + rz * rz;
    if (!(r2 < 2.25 * l02)) continue; /* out of range */
    if (!(r2 > 1e-24 * l02)) { /* coincident: after the sum */
      L->coincident = 1;
      continue;
    }
    const double l = sqrt(r2), q = 1 / (l * l0), lambda = r2 * q;
    const double g = ((1.25 * lambda - 2.375) * lambda) * lambda + 1.125;
    const double gl = (k0 * l02) * g * q;
    L->fx[lane] += gl * rx, L->fy[lane] += gl * ry, L->fz[lane] += gl * rz;
    if (extras) {
      /* bub_potential: k0 l0^2 (G(1.5) - G(lambda)), G(mu) = (5/16 mu^3 - 19/24 mu^2 + 9/8) mu,
       * G(1.5) = 153 / 256. */
      const double G = ((0.3125 * lambda - 0.79166666666666667) * lambda * lambda + 1.125) * lambda;
      L->u[lane] += 0.5 * ((k0 * l02) * (0.59765625 - G));
      L->deg[lane] += r2 < 1.69 * l02;
    }
  }
}

#ifdef BUB_KERNEL_AVX2
__attribute__((target("avx2"))) static void sum_lanes_avx2(const double *pos4, const int32_t *nb,
                                                           int32_t cnt, const double pi[4],
                                                           double k0, int extras, lanes *L) {
  const __m256d xi = _mm256_set1_pd(pi[0]), yi = _mm256_set1_pd(pi[1]), zi = _mm256_set1_pd(pi[2]);
  const __m256d di = _mm256_set1_pd(pi[3]), half = _mm256_set1_pd(0.5), lim = _mm256_set1_pd(2.25);
  const __m256d tiny = _mm256_set1_pd(1e-24), one = _mm256_set1_pd(1.0), vk0 = _mm256_set1_pd(k0);
  const __m256d c125 = _mm256_set1_pd(1.25), c2375 = _mm256_set1_pd(2.375), c1125 = _mm256_set1_pd(1.125);
  const __m256d p3125 = _mm256_set1_pd(0.3125), p7916 = _mm256_set1_pd(0.79166666666666667);
  const __m256d g15 = _mm256_set1_pd(0.59765625), c169 = _mm256_set1_pd(1.69);
  __m256d fx = _mm256_setzero_pd(), fy = fx, fz = fx, u = fx, deg = fx;
  L->coincident = 0;
  const __m256d zero = _mm256_setzero_pd();
  const int32_t self = 0; /* padding lanes: any valid record, masked out */
  for (int32_t k = 0; k < cnt; k += 4) {
    const int32_t j0 = nb[k], j1 = k + 1 < cnt ? nb[k + 1] : self, j2 = k + 2 < cnt ? nb[k + 2] : self,
                  j3 = k + 3 < cnt ? nb[k + 3] : self;
    const __m256d a = _mm256_loadu_pd(&pos4[4 * j0]), b = _mm256_loadu_pd(&pos4[4 * j1]);
    const __m256d c = _mm256_loadu_pd(&pos4[4 * j2]), d = _mm256_loadu_pd(&pos4[4 * j3]);
    const __m256d t0 = _mm256_unpacklo_pd(a, b), t1 = _mm256_unpackhi_pd(a, b);
    const __m256d t2 = _mm256_unpacklo_pd(c, d), t3 = _mm256_unpackhi_pd(c, d);
    const __m256d X = _mm256_permute2f128_pd(t0, t2, 0x20), Z = _mm256_permute2f128_pd(t0, t2, 0x31);
    const __m256d Y = _mm256_permute2f128_pd(t1, t3, 0x20), D = _mm256_permute2f128_pd(t1, t3, 0x31);
    const __m256d rx = _mm256_sub_pd(xi, X), ry = _mm256_sub_pd(yi, Y), rz = _mm256_sub_pd(zi, Z);
    const __m256d l0 = _mm256_mul_pd(half, _mm256_add_pd(di, D)), l02 = _mm256_mul_pd(l0, l0);
    const __m256d r2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(rx, rx), _mm256_mul_pd(ry, ry)),
                                     _mm256_mul_pd(rz, rz));
    __m256d m = _mm256_cmp_pd(r2, _mm256_mul_pd(lim, l02), _CMP_LT_OQ);
    if (k + 4 > cnt) { /* the last group's padding */
      const __m256d lane = _mm256_set_pd(3, 2, 1, 0), have = _mm256_set1_pd((double)(cnt - k));
      m = _mm256_and_pd(m, _mm256_cmp_pd(lane, have, _CMP_LT_OQ));
    }
    const __m256d apart = _mm256_cmp_pd(r2, _mm256_mul_pd(tiny, l02), _CMP_GT_OQ);
    if (_mm256_movemask_pd(_mm256_andnot_pd(apart, m))) L->coincident = 1;
    m = _mm256_and_pd(m, apart);
    if (_mm256_movemask_pd(m) == 0) continue;
    const __m256d l = _mm256_sqrt_pd(r2), q = _mm256_div_pd(one, _mm256_mul_pd(l, l0));
    const __m256d lambda = _mm256_mul_pd(r2, q);
    const __m256d g = _mm256_add_pd(
        _mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(c125, lambda), c2375), lambda), lambda), c1125);
    const __m256d kl = _mm256_mul_pd(vk0, l02);
    const __m256d gl = _mm256_blendv_pd(zero, _mm256_mul_pd(_mm256_mul_pd(kl, g), q), m);
    fx = _mm256_add_pd(fx, _mm256_mul_pd(gl, rx));
    fy = _mm256_add_pd(fy, _mm256_mul_pd(gl, ry));
    fz = _mm256_add_pd(fz, _mm256_mul_pd(gl, rz));
    if (extras) {
      const __m256d G = _mm256_mul_pd(
          _mm256_add_pd(_mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(p3125, lambda), p7916), lambda), lambda), c1125),
          lambda);
      const __m256d du = _mm256_mul_pd(half, _mm256_mul_pd(kl, _mm256_sub_pd(g15, G)));
      u = _mm256_add_pd(u, _mm256_blendv_pd(zero, du, m));
      const __m256d near = _mm256_and_pd(m, _mm256_cmp_pd(r2, _mm256_mul_pd(c169, l02), _CMP_LT_OQ));
      deg = _mm256_add_pd(deg, _mm256_blendv_pd(zero, one, near));
    }
  }
  _mm256_storeu_pd(L->fx, fx), _mm256_storeu_pd(L->fy, fy), _mm256_storeu_pd(L->fz, fz);
  _mm256_storeu_pd(L->u, u);
  double dg[4];
  _mm256_storeu_pd(dg, deg);
  for (int k = 0; k < 4; ++k) L->deg[k] = (int32_t)dg[k];
}
#endif

/* The implementation in use: AVX2 where the processor has it, unless the environment variable
 * PM_BUB_KERNEL=c asks for the reference (for tests and measurements). */
static int use_avx2(void) {
#ifdef BUB_KERNEL_AVX2
  static int chosen = -1;
  int c = __atomic_load_n(&chosen, __ATOMIC_RELAXED);
  if (c < 0) {
    const char *env = getenv("PM_BUB_KERNEL");
    c = (env && strcmp(env, "c") == 0) ? 0 : (__builtin_cpu_supports("avx2") ? 1 : 0);
    __atomic_store_n(&chosen, c, __ATOMIC_RELAXED);
  }
  return c;
#else
  return 0;
#endif
}

int bub_kernel_simd(void) { return use_avx2(); }

void bub_force_sum(const bub_state *s, const double *pos4, int32_t i, int simd, double f[3],
                   double *pot, int32_t *deg) {
  const double *pi = &pos4[4 * i];
  const int32_t *nb = &s->nb[s->nb_off[i]], cnt = s->nb_cnt[i];
  const int extras = pot != NULL || deg != NULL;
  lanes L;
#ifdef BUB_KERNEL_AVX2
  if (simd)
    sum_lanes_avx2(pos4, nb, cnt, pi, s->p.k0, extras, &L);
  else
#endif
    sum_lanes_c(pos4, nb, cnt, pi, s->p.k0, extras, &L);
  (void)simd;
  f[0] = (L.fx[0] + L.fx[1]) + (L.fx[2] + L.fx[3]);
  f[1] = (L.fy[0] + L.fy[1]) + (L.fy[2] + L.fy[3]);
  f[2] = (L.fz[0] + L.fz[1]) + (L.fz[2] + L.fz[3]);
  double u = (L.u[0] + L.u[1]) + (L.u[2] + L.u[3]);
  int32_t nd = L.deg[0] + L.deg[1] + L.deg[2] + L.deg[3];
  /* Coincident pairs, in list order (rare: only a start or an insertion puts two bubbles on one
   * point). */
  for (int32_t k = 0; k < cnt && L.coincident; ++k) {
    const double *pj = &pos4[4 * nb[k]];
    const double rx = pi[0] - pj[0], ry = pi[1] - pj[1], rz = pi[2] - pj[2];
    const double l0 = 0.5 * (pi[3] + pj[3]), l02 = l0 * l0;
    const double r2 = (rx * rx + ry * ry) + rz * rz;
    if (!(r2 <= 1e-24 * l02)) continue;
    /* F(0) = 9/8 k0 l0 (bub_force.c), saturated. */
    double dir[3], F = 1.125 * s->p.k0 * l0;
    bub_pair_direction(s->seed, i, nb[k], dir);
    f[0] += F * dir[0], f[1] += F * dir[1], f[2] += F * dir[2];
    if (extras) u += 0.5 * bub_potential(s->p.k0, 0, l0), ++nd;
  }
  if (pot) *pot = u;
  if (deg) *deg = nd;
}
