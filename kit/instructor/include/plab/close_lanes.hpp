/// \file kit/instructor/include/plab/close_lanes.hpp
/// \brief The broad phase's pair test, sweep::close_in_slab(), for eight entries at a time: a
/// portable loop the compiler vectorises, and AVX2 and AVX-512 paths chosen at run time, each
/// with the scalar test's operations in the same order (no FMA), so every lane gives the scalar
/// test's bits. Instructor-only (the engines of stages 06 and 08: stage 06's exercise is the
/// broad phase itself).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
/// 1 where the pair test has AVX2 and AVX-512 paths (x86-64, chosen at run time), else 0.
#define PLAB_AVX2 1
#else
/// 0: no vector paths here; the portable pair test only.
#define PLAB_AVX2 0
#endif

#include <cmath>
#include <string>

#include "plab/sweep.hpp"

namespace plab::lanes {

constexpr int kLanes = 8;  //!< entries tested at a time: arrays read by the test are padded by this

/// The instruction sets the pair test has a path for.
enum class Isa { kPortable, kAvx2, kAvx512 };

/// The widest vectors this CPU has, or narrower ones if `asked` says so (`portable`, `avx2`: the
/// tests run every path the machine has and compare their bits; "" or anything else: the widest).
inline Isa choose_isa(const std::string& asked) {
  Isa best = Isa::kPortable;
#if PLAB_AVX2
  best = __builtin_cpu_supports("avx512f") ? Isa::kAvx512
         : __builtin_cpu_supports("avx2")  ? Isa::kAvx2
                                           : Isa::kPortable;
#endif
  if (asked == "portable") return Isa::kPortable;
  if (asked == "avx2" && best == Isa::kAvx512) return Isa::kAvx2;
  return best;
}

/// The entries' fields the test reads, one array per field, each padded by kLanes.
struct Fields {
  const double* x;   //!< position x at the slab's midpoint
  const double* y;   //!< position y at the slab's midpoint
  const double* vx;  //!< velocity x
  const double* vy;  //!< velocity y
};

/// Bit u of the result: whether entry `a` and entry `b0 + u` pass sweep::close_in_slab(),
/// u < kLanes (portable: a loop the compiler may vectorise).
inline unsigned close_lanes(const Fields& s, int a, int b0, const sweep::Grid& g) {
  unsigned lanes = 0;
#pragma omp simd reduction(| : lanes)
  for (int u = 0; u < kLanes; ++u)
    lanes |= unsigned{sweep::close_in_slab(s.x[a] - s.x[b0 + u], s.y[a] - s.y[b0 + u],
                                           s.vx[a] - s.vx[b0 + u], s.vy[a] - s.vy[b0 + u], g)}
             << u;
  return lanes;
}

#if PLAB_AVX2
/// close_lanes() with AVX2, four lanes a register: the operations of close_in_slab() in the
/// same order (no FMA), so every lane gives the bits of the scalar test.
__attribute__((target("avx2"))) inline unsigned close_lanes_avx2(const Fields& s, int a, int b0,
                                                                 const sweep::Grid& g) {
  const __m256d xa = _mm256_set1_pd(s.x[a]), ya = _mm256_set1_pd(s.y[a]);
  const __m256d vxa = _mm256_set1_pd(s.vx[a]), vya = _mm256_set1_pd(s.vy[a]);
  const __m256d h = _mm256_set1_pd(g.half), two_h = _mm256_set1_pd(2 * g.half);
  const __m256d hh = _mm256_set1_pd(g.half * g.half), rr = _mm256_set1_pd(g.reach * g.reach);
  const __m256d sign = _mm256_set1_pd(-0.0);
  unsigned lanes = 0;
  for (int u = 0; u < kLanes; u += 4) {
    const __m256d dx = _mm256_sub_pd(xa, _mm256_loadu_pd(&s.x[b0 + u]));
    const __m256d dy = _mm256_sub_pd(ya, _mm256_loadu_pd(&s.y[b0 + u]));
    const __m256d wx = _mm256_sub_pd(vxa, _mm256_loadu_pd(&s.vx[b0 + u]));
    const __m256d wy = _mm256_sub_pd(vya, _mm256_loadu_pd(&s.vy[b0 + u]));
    const __m256d dd = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
    const __m256d ww = _mm256_add_pd(_mm256_mul_pd(wx, wx), _mm256_mul_pd(wy, wy));
    const __m256d q =
        _mm256_andnot_pd(sign, _mm256_add_pd(_mm256_mul_pd(dx, wx), _mm256_mul_pd(dy, wy)));
    const __m256d inside = _mm256_cmp_pd(q, _mm256_mul_pd(h, ww), _CMP_LE_OQ);
    const __m256d far_inside = _mm256_cmp_pd(
        _mm256_sub_pd(_mm256_mul_pd(dd, ww), _mm256_mul_pd(q, q)), _mm256_mul_pd(rr, ww),
        _CMP_GT_OQ);
    const __m256d far_end = _mm256_cmp_pd(
        _mm256_add_pd(_mm256_sub_pd(dd, _mm256_mul_pd(two_h, q)), _mm256_mul_pd(hh, ww)), rr,
        _CMP_GT_OQ);
    // close = (inside & !far_inside) | (!inside & !far_end)
    const __m256d far = _mm256_or_pd(_mm256_and_pd(inside, far_inside),
                                     _mm256_andnot_pd(inside, far_end));
    lanes |= static_cast<unsigned>(~_mm256_movemask_pd(far) & 0xF) << u;
  }
  return lanes;
}

/// close_lanes() with AVX-512, all eight lanes in one register: the same operations again.
__attribute__((target("avx512f"))) inline unsigned close_lanes_avx512(const Fields& s, int a,
                                                                     int b0, const sweep::Grid& g) {
  const __m512d dx = _mm512_sub_pd(_mm512_set1_pd(s.x[a]), _mm512_loadu_pd(&s.x[b0]));
  const __m512d dy = _mm512_sub_pd(_mm512_set1_pd(s.y[a]), _mm512_loadu_pd(&s.y[b0]));
  const __m512d wx = _mm512_sub_pd(_mm512_set1_pd(s.vx[a]), _mm512_loadu_pd(&s.vx[b0]));
  const __m512d wy = _mm512_sub_pd(_mm512_set1_pd(s.vy[a]), _mm512_loadu_pd(&s.vy[b0]));
  const __m512d dd = _mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy));
  const __m512d ww = _mm512_add_pd(_mm512_mul_pd(wx, wx), _mm512_mul_pd(wy, wy));
  const __m512d q = _mm512_abs_pd(_mm512_add_pd(_mm512_mul_pd(dx, wx), _mm512_mul_pd(dy, wy)));
  const __mmask8 inside =
      _mm512_cmp_pd_mask(q, _mm512_mul_pd(_mm512_set1_pd(g.half), ww), _CMP_LE_OQ);
  const __mmask8 far_inside = _mm512_cmp_pd_mask(
      _mm512_sub_pd(_mm512_mul_pd(dd, ww), _mm512_mul_pd(q, q)),
      _mm512_mul_pd(_mm512_set1_pd(g.reach * g.reach), ww), _CMP_GT_OQ);
  const __mmask8 far_end = _mm512_cmp_pd_mask(
      _mm512_add_pd(_mm512_sub_pd(dd, _mm512_mul_pd(_mm512_set1_pd(2 * g.half), q)),
                    _mm512_mul_pd(_mm512_set1_pd(g.half * g.half), ww)),
      _mm512_set1_pd(g.reach * g.reach), _CMP_GT_OQ);
  // close = (inside & !far_inside) | (!inside & !far_end)
  return static_cast<unsigned>(~((inside & far_inside) | (~inside & far_end)) & 0xFF);
}
#endif

/// The single-precision test (sweep::close_in_slab_single()) on entries rounded to float: stage
/// 06's engine on the CPU, sixteen entries at a time: a portable loop and an AVX-512 path that
/// does the scalar test's operations in the same order.
constexpr int kLanesSingle = 16;  //!< entries tested at a time: float arrays are padded by this

/// The entries' fields the single-precision test reads, one float array per field, each padded
/// by kLanesSingle.
struct SingleFields {
  const float* x;   //!< position x at the slab's midpoint, rounded to float
  const float* y;   //!< position y at the slab's midpoint, rounded to float
  const float* vx;  //!< velocity x, rounded to float
  const float* vy;  //!< velocity y, rounded to float
};

/// Bit u of the result: whether entry `a` and entry `b0 + u` pass sweep::close_in_slab_single(),
/// u < kLanesSingle (portable: a loop the compiler may vectorise).
inline unsigned close_lanes_single(const SingleFields& s, int a, int b0, const sweep::Single& c) {
  const float sa = std::fabs(s.vx[a]) + std::fabs(s.vy[a]);
  unsigned lanes = 0;
#pragma omp simd reduction(| : lanes)
  for (int u = 0; u < kLanesSingle; ++u) {
    const int b = b0 + u;
    lanes |= unsigned{sweep::close_in_slab_single(
                 s.x[a] - s.x[b], s.y[a] - s.y[b], s.vx[a] - s.vx[b], s.vy[a] - s.vy[b],
                 sa + (std::fabs(s.vx[b]) + std::fabs(s.vy[b])), c)}
             << u;
  }
  return lanes;
}

#if PLAB_AVX2
/// close_lanes_single() with AVX-512, all sixteen lanes in one register.
__attribute__((target("avx512f"))) inline unsigned close_lanes_single_avx512(
    const SingleFields& s, int a, int b0, const sweep::Single& c) {
  const __m512 vxb = _mm512_loadu_ps(&s.vx[b0]), vyb = _mm512_loadu_ps(&s.vy[b0]);
  const __m512 dx = _mm512_sub_ps(_mm512_set1_ps(s.x[a]), _mm512_loadu_ps(&s.x[b0]));
  const __m512 dy = _mm512_sub_ps(_mm512_set1_ps(s.y[a]), _mm512_loadu_ps(&s.y[b0]));
  const __m512 wx = _mm512_sub_ps(_mm512_set1_ps(s.vx[a]), vxb);
  const __m512 wy = _mm512_sub_ps(_mm512_set1_ps(s.vy[a]), vyb);
  const __m512 sab = _mm512_add_ps(_mm512_set1_ps(std::fabs(s.vx[a]) + std::fabs(s.vy[a])),
                                   _mm512_add_ps(_mm512_abs_ps(vxb), _mm512_abs_ps(vyb)));
  const __m512 dd = _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy));
  const __m512 ww = _mm512_add_ps(_mm512_mul_ps(wx, wx), _mm512_mul_ps(wy, wy));
  const __m512 q = _mm512_abs_ps(_mm512_add_ps(_mm512_mul_ps(dx, wx), _mm512_mul_ps(dy, wy)));
  const __m512 hw = _mm512_mul_ps(_mm512_set1_ps(c.half2), ww);
  const __m512 allow = _mm512_add_ps(
      _mm512_add_ps(_mm512_set1_ps(c.rr),
                    _mm512_mul_ps(sab, _mm512_add_ps(_mm512_set1_ps(c.k1),
                                                     _mm512_mul_ps(_mm512_set1_ps(c.k2), sab)))),
      _mm512_mul_ps(_mm512_set1_ps(c.slack), _mm512_add_ps(dd, hw)));
  const __mmask16 tiny = _mm512_cmp_ps_mask(ww, _mm512_set1_ps(0x1p-60f), _CMP_LT_OQ);
  const __mmask16 inside =
      _mm512_cmp_ps_mask(q, _mm512_mul_ps(_mm512_set1_ps(c.half), ww), _CMP_LE_OQ);
  const __mmask16 far_inside = _mm512_cmp_ps_mask(
      _mm512_sub_ps(_mm512_mul_ps(dd, ww), _mm512_mul_ps(q, q)), _mm512_mul_ps(allow, ww),
      _CMP_GT_OQ);
  const __mmask16 far_end = _mm512_cmp_ps_mask(
      _mm512_add_ps(_mm512_sub_ps(dd, _mm512_mul_ps(_mm512_set1_ps(2 * c.half), q)), hw), allow,
      _CMP_GT_OQ);
  return static_cast<unsigned>((tiny | ~((inside & far_inside) | (~inside & far_end))) & 0xFFFF);
}
#endif

#if !PLAB_AVX2
/// Without the vector paths (not x86-64), every Isa takes the portable loop: close_lanes().
inline unsigned close_lanes_avx2(const Fields& s, int a, int b0, const sweep::Grid& g) {
  return close_lanes(s, a, b0, g);
}
/// Without the vector paths: close_lanes().
inline unsigned close_lanes_avx512(const Fields& s, int a, int b0, const sweep::Grid& g) {
  return close_lanes(s, a, b0, g);
}
/// Without the vector paths: close_lanes_single().
inline unsigned close_lanes_single_avx512(const SingleFields& s, int a, int b0,
                                          const sweep::Single& c) {
  return close_lanes_single(s, a, b0, c);
}
#endif

/// The lanes of entry `a` against entries b0 .. b0 + kLanes - 1 (bit u: b0 + u passes
/// close_in_slab()), with kIsa's vectors.
template <Isa kIsa>
inline unsigned lanes_at(const Fields& s, int a, int b0, const sweep::Grid& g) {
  return kIsa == Isa::kAvx512 ? close_lanes_avx512(s, a, b0, g)
         : kIsa == Isa::kAvx2 ? close_lanes_avx2(s, a, b0, g) : close_lanes(s, a, b0, g);
}

/// The same for the single-precision test, entries b0 .. b0 + kLanesSingle - 1. AVX2 takes the
/// portable loop: on this kit's 2-core machine (AVX-512) the portable float loop ran as fast as
/// the double AVX-512 path, and only the explicit AVX-512 path made the float search faster.
template <Isa kIsa>
inline unsigned lanes_at(const SingleFields& s, int a, int b0, const sweep::Single& c) {
  return kIsa == Isa::kAvx512 ? close_lanes_single_avx512(s, a, b0, c)
                              : close_lanes_single(s, a, b0, c);
}

/// Calls `hit(b)` for every entry b of [from, to) that passes the test (`Test`: sweep::Grid for
/// close_in_slab() on Fields, sweep::Single for close_in_slab_single() on SingleFields) with entry
/// `a` (`a` itself included, if it is in the range), kWidth entries at a time with kIsa's vectors
/// (lanes past `to` are read from the padding and masked off). Call it from a function compiled
/// for kIsa (`__attribute__((target(...), flatten))`) so that the vector path is inlined.
template <Isa kIsa, int kWidth, class F, class Test, class Hit>
inline void for_each_passing(const F& s, int a, int from, int to, const Test& test, Hit&& hit) {
  for (int b0 = from; b0 < to; b0 += kWidth) {
    unsigned lanes = lanes_at<kIsa>(s, a, b0, test);
    if (to - b0 < kWidth) lanes &= (1u << (to - b0)) - 1;
    for (; lanes != 0; lanes &= lanes - 1) hit(b0 + __builtin_ctz(lanes));
  }
}

/// for_each_passing() with close_in_slab(), kLanes entries at a time.
template <Isa kIsa, class Hit>
inline void for_each_close(const Fields& s, int a, int from, int to, const sweep::Grid& g,
                           Hit&& hit) {
  for_each_passing<kIsa, kLanes>(s, a, from, to, g, hit);
}

/// for_each_passing() with close_in_slab_single(), kLanesSingle entries at a time.
template <Isa kIsa, class Hit>
inline void for_each_close_single(const SingleFields& s, int a, int from, int to,
                                  const sweep::Single& c, Hit&& hit) {
  for_each_passing<kIsa, kLanesSingle>(s, a, from, to, c, hit);
}

}  // namespace plab::lanes
