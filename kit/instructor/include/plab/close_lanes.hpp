/// \file kit/instructor/include/plab/close_lanes.hpp
/// \brief The broad phase's pair test in single precision, sweep::close_in_slab_single(), for
/// sixteen entries at a time: a portable loop the compiler may vectorise, and an AVX-512 path
/// chosen at run time with the scalar test's operations in the same order (no FMA), so every lane
/// gives the scalar test's bits. Instructor-only (the CPU engines of stages 06 and 08: stage 06's
/// exercise is the broad phase itself).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
/// 1 where the pair test has AVX2 and AVX-512 paths (x86-64, chosen at run time), else 0.
#define PLAB_AVX2 1
#else
/// 0: no vector paths here; the portable pair test only.
#define PLAB_AVX2 0
#endif

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
/// A loop's function compiled three times, for x86-64-v4 (AVX-512), v3 (AVX2) and the baseline,
/// the widest the CPU has chosen when the program loads (GCC's target_clones): scalar code gains
/// the newer instructions (a floor in one instruction instead of the baseline's five, among
/// others). No FMA is formed in any of them (-ffp-contract=off), so every clone gives the same
/// bits.
#define PLAB_CPU_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
/// One compilation for the baseline (not x86-64 with GCC).
#define PLAB_CPU_CLONES
#endif

#include <cmath>
#include <string>

#include "plab/sweep.hpp"

namespace plab::lanes {

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

/// The single-precision test (sweep::close_in_slab_within()) on entries rounded to float: the CPU
/// engines of stages 06 and 08, sixteen entries at a time: a portable loop and an AVX-512 path
/// that does the scalar test's operations in the same order. Entry `a` is tested against many, so
/// its allowance's constant part is computed once, for any partner: Single::base() of its own
/// \f$|v_x| + |v_y|\f$ plus Single::s_most (base_of()), at least the pair's, so the test passes
/// every pair close_in_slab_single() passes (and, at the report's scales, hardly any more: the
/// part that grows with `s` is a few parts in 10^4 of the reach).
constexpr int kLanesSingle = 16;  //!< entries tested at a time: float arrays are padded by this

/// The entries' fields the single-precision test reads, one float array per field, each padded
/// by kLanesSingle.
struct SingleFields {
  const float* x;   //!< position x at the slab's midpoint, rounded to float
  const float* y;   //!< position y at the slab's midpoint, rounded to float
  const float* vx;  //!< velocity x, rounded to float
  const float* vy;  //!< velocity y, rounded to float
};

/// The allowance's constant part for entry `a` against any partner (Single::base()).
inline float base_of(const SingleFields& s, int a, const sweep::Single& c) {
  return c.base((std::fabs(s.vx[a]) + std::fabs(s.vy[a])) + c.s_most);
}

/// Bit u of the result: whether entry `a` (its allowance's constant part `base`, base_of()) and
/// entry `b0 + u` pass sweep::close_in_slab_within(), u < kLanesSingle (portable: a loop the
/// compiler may vectorise).
inline unsigned close_lanes_single(const SingleFields& s, int a, float base, int b0,
                                   const sweep::Single& c) {
  unsigned lanes = 0;
#pragma omp simd reduction(| : lanes)
  for (int u = 0; u < kLanesSingle; ++u) {
    const int b = b0 + u;
    lanes |= unsigned{sweep::close_in_slab_within(s.x[a] - s.x[b], s.y[a] - s.y[b],
                                                  s.vx[a] - s.vx[b], s.vy[a] - s.vy[b], base, c)}
             << u;
  }
  return lanes;
}

#if PLAB_AVX2
/// close_lanes_single() with AVX-512, all sixteen lanes in one register.
__attribute__((target("avx512f"))) inline unsigned close_lanes_single_avx512(
    const SingleFields& s, int a, float base, int b0, const sweep::Single& c) {
  const __m512 dx = _mm512_sub_ps(_mm512_set1_ps(s.x[a]), _mm512_loadu_ps(&s.x[b0]));
  const __m512 dy = _mm512_sub_ps(_mm512_set1_ps(s.y[a]), _mm512_loadu_ps(&s.y[b0]));
  const __m512 wx = _mm512_sub_ps(_mm512_set1_ps(s.vx[a]), _mm512_loadu_ps(&s.vx[b0]));
  const __m512 wy = _mm512_sub_ps(_mm512_set1_ps(s.vy[a]), _mm512_loadu_ps(&s.vy[b0]));
  const __m512 dd = _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy));
  const __m512 ww = _mm512_add_ps(_mm512_mul_ps(wx, wx), _mm512_mul_ps(wy, wy));
  const __m512 q = _mm512_abs_ps(_mm512_add_ps(_mm512_mul_ps(dx, wx), _mm512_mul_ps(dy, wy)));
  const __m512 hw = _mm512_mul_ps(_mm512_set1_ps(c.half2), ww);
  const __m512 allow = _mm512_add_ps(
      _mm512_set1_ps(base), _mm512_mul_ps(_mm512_set1_ps(c.slack), _mm512_add_ps(dd, hw)));
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
/// Without the vector paths (not x86-64), every Isa takes the portable loop: close_lanes_single().
inline unsigned close_lanes_single_avx512(const SingleFields& s, int a, float base, int b0,
                                          const sweep::Single& c) {
  return close_lanes_single(s, a, base, b0, c);
}
#endif

/// The lanes of entry `a` against entries b0 .. b0 + kLanesSingle - 1 (bit u: b0 + u passes
/// close_in_slab_within()), with kIsa's vectors. AVX2 takes the portable loop: on this kit's
/// 2-core machine (AVX-512) the portable float loop ran as fast as the double test's AVX-512 path
/// (since removed), and only the explicit AVX-512 path made the float search faster.
template <Isa kIsa>
inline unsigned lanes_at(const SingleFields& s, int a, float base, int b0, const sweep::Single& c) {
  return kIsa == Isa::kAvx512 ? close_lanes_single_avx512(s, a, base, b0, c)
                              : close_lanes_single(s, a, base, b0, c);
}

/// Calls `hit(b)` for every entry b of [from, to) that passes close_in_slab_within() with entry
/// `a` (`a` itself included, if it is in the range), kLanesSingle entries at a time with kIsa's
/// vectors (lanes past `to` are read from the padding and masked off). Call it from a function
/// compiled for kIsa (`__attribute__((target(...), flatten))`) so that the vector path is inlined.
template <Isa kIsa, class Hit>
inline void for_each_close_single(const SingleFields& s, int a, int from, int to,
                                  const sweep::Single& c, Hit&& hit) {
  const float base = base_of(s, a, c);
  for (int b0 = from; b0 < to; b0 += kLanesSingle) {
    unsigned lanes = lanes_at<kIsa>(s, a, base, b0, c);
    if (to - b0 < kLanesSingle) lanes &= (1u << (to - b0)) - 1;
    for (; lanes != 0; lanes &= lanes - 1) hit(b0 + __builtin_ctz(lanes));
  }
}

}  // namespace plab::lanes
