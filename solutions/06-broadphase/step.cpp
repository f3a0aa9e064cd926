/// \file solutions/06-broadphase/step.cpp
/// \brief Stage 06, broad phase (CPU, OpenMP): a space-time grid finds every pair that can meet
/// in the step, model.md's pair time is computed for those alone, and the events are chosen by a
/// greedy pass over the sparse candidates. Same bits as stages 01-05.
//
// =================================================================================================
//  GOAL   Stage 03 tests N^2/2 pairs a step; at N = 10^4 in the report's box only about 2000 can
//         meet. Find them, and few others, with plab::sweep (read sweep.hpp first):
//         1. broad phase: for each time slab k (in parallel), sort the particles that take part
//            into the grid's cells by their positions at the slab's midpoint (a counting sort),
//            then test each against the same and the next cells (half of the 3 x 3
//            neighbourhood; a fast particle: every cell within its search radius) with
//            sweep::close_in_slab();
//         2. narrow phase: model.md's pair time for each pair that passed;
//         3. model.md's greedy selection over the sparse candidates (a pair at or after either
//            wall time is never accepted), then apply.
//         Memory O(N + candidates + cells): no N x N anything.
//  READ   handouts/06-broadphase.md     TEST   ./plab test --impl student --stage 06
// =================================================================================================
#include <omp.h>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
/// 1 where the pair test has AVX2 and AVX-512 paths (x86-64, chosen at run time), else 0.
#define PLAB_AVX2 1
#else
/// 0: no vector paths here; the portable pair test only.
#define PLAB_AVX2 0
#endif

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "plab/stage.hpp"
#include "plab/sweep.hpp"

namespace plab {
namespace {

constexpr int kLanes = 8;          //!< close_in_slab() is evaluated for this many entries at a time
constexpr double kQuantile = 0.9;  //!< the fastest 10% search wider (sweep::choose())
constexpr double kAlpha = 0.3;     //!< slabs per sqrt(N) v_cut / L, measured best on the report's scene

/// One thread's slab: the particles that take part, in cell order, one array per field.
struct Slab {
  std::vector<int> start;             //!< cell c holds entries [start[c], start[c + 1])
  std::vector<int> cell;              //!< per particle: its cell in this slab
  std::vector<double> mx, my;         //!< per particle: its midpoint position
  std::vector<int> id;                //!< per entry: the particle
  std::vector<double> x, y, vx, vy;   //!< per entry: midpoint position and velocity (padded)
  std::vector<std::pair<int, int>> hits;  //!< entry pairs that passed close_in_slab()
  std::vector<model::Event> found;    //!< this thread's pair candidates
};

/// Slab k's counting sort: the particles that take part (last[i] >= k), by the cell of their
/// midpoint positions.
template <class Real>
void bin(Slab& s, const ParticlesOf<Real>& p, const std::vector<int>& last, int k,
         const sweep::Grid& g) {
  const int n = static_cast<int>(p.size());
  const double tm = sweep::slab_mid(k, g);
  s.start.assign(g.cells() + 1, 0);
  for (int i = 0; i < n; ++i) {  // count
    if (last[i] < k) continue;
    s.mx[i] = p.x[i] + tm * p.vx[i];
    s.my[i] = p.y[i] + tm * p.vy[i];
    s.cell[i] = sweep::cell_of(s.mx[i], s.my[i], g);
    ++s.start[s.cell[i] + 1];
  }
  for (int c = 0; c < g.cells(); ++c) s.start[c + 1] += s.start[c];
  for (int i = 0; i < n; ++i) {  // scatter: start[c] moves on to where cell c + 1 starts
    if (last[i] < k) continue;
    const int e = s.start[s.cell[i]]++;
    s.id[e] = i;
    s.x[e] = s.mx[i];
    s.y[e] = s.my[i];
    s.vx[e] = p.vx[i];
    s.vy[e] = p.vy[i];
  }
  for (int c = g.cells(); c > 0; --c) s.start[c] = s.start[c - 1];
  s.start[0] = 0;
}

/// Bit u of the result: whether entry `a` and entry `b0 + u` pass close_in_slab(), u < kLanes.
inline unsigned close_lanes(const Slab& s, int a, int b0, const sweep::Grid& g) {
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
__attribute__((target("avx2"))) inline unsigned close_lanes_avx2(const Slab& s, int a, int b0,
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
__attribute__((target("avx512f"))) inline unsigned close_lanes_avx512(const Slab& s, int a, int b0,
                                                                     const sweep::Grid& g) {
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

/// Files entry `a` with every entry of [from, to) but itself that passes close_in_slab(),
/// kLanes entries at a time (the arrays are padded: lanes past `to` are masked off).
/// The instruction sets the pair test has a path for, chosen once at run time.
enum class Isa { kPortable, kAvx2, kAvx512 };

template <Isa kIsa>
inline void test_range(Slab& s, int a, int from, int to, const sweep::Grid& g) {
  for (int b0 = from; b0 < to; b0 += kLanes) {
#if PLAB_AVX2
    unsigned lanes = kIsa == Isa::kAvx512 ? close_lanes_avx512(s, a, b0, g)
                     : kIsa == Isa::kAvx2 ? close_lanes_avx2(s, a, b0, g)
                                          : close_lanes(s, a, b0, g);
#else
    unsigned lanes = close_lanes(s, a, b0, g);
#endif
    if (to - b0 < kLanes) lanes &= (1u << (to - b0)) - 1;
    for (; lanes != 0; lanes &= lanes - 1) {
      const int b = b0 + __builtin_ctz(lanes);
      if (b != a) s.hits.emplace_back(a, b);
    }
  }
}

/// Slab k's search, entry by entry (sweep::search_of()): a slow entry against the later entries of
/// its row up to the last column within its reach, then the columns within reach of the row
/// above, two runs of entries in row-major order; a fast entry against every entry within its
/// reach, one run per row.
template <Isa kIsa>
inline void search_cells(Slab& s, const std::vector<sweep::Search>& reach, const sweep::Grid& g) {
  s.hits.clear();
  const int columns = g.columns;
  for (int row = 0, a = 0; row < g.rows; ++row) {
    for (const int end = s.start[(row + 1) * columns]; a < end; ++a) {
      const sweep::Search q = reach[s.id[a]];
      int x0, x1;
      sweep::columns_within(s.x[a], q.d, g, x0, x1);
      if (!q.fast) {
        test_range<kIsa>(s, a, a + 1, s.start[row * columns + x1 + 1], g);
        if (row + 1 < g.rows)
          test_range<kIsa>(s, a, s.start[(row + 1) * columns + x0],
                           s.start[(row + 1) * columns + x1 + 1], g);
      } else {  // a pair found twice is harmless
        int y0, y1;
        sweep::rows_within(s.y[a], q.d, g, y0, y1);
        for (int y = y0; y <= y1; ++y)
          test_range<kIsa>(s, a, s.start[y * columns + x0], s.start[y * columns + x1 + 1], g);
      }
    }
  }
}

#if PLAB_AVX2
__attribute__((target("avx512f"), flatten)) void search_avx512(
    Slab& s, const std::vector<sweep::Search>& reach, const sweep::Grid& g) {
  search_cells<Isa::kAvx512>(s, reach, g);
}

__attribute__((target("avx2"), flatten)) void search_avx2(
    Slab& s, const std::vector<sweep::Search>& reach, const sweep::Grid& g) {
  search_cells<Isa::kAvx2>(s, reach, g);
}
#endif

/// The vectors the pair test uses in this run: the widest the CPU has, or narrower ones when
/// the run asks (StageOptions::simd `portable` or `avx2`: the tests run every path the machine has
/// and compare their bits). Set once by make_stepper(), before any step.
Isa isa_in_use = Isa::kPortable;

/// The widest vectors the CPU has, or narrower ones if `asked` says so.
Isa choose_isa(const std::string& asked) {
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

/// Slab k's search, with the chosen vectors.
void search(Slab& s, const std::vector<sweep::Search>& reach, const sweep::Grid& g) {
#if PLAB_AVX2
  if (isa_in_use == Isa::kAvx512) return search_avx512(s, reach, g);
  if (isa_in_use == Isa::kAvx2) return search_avx2(s, reach, g);
#endif
  search_cells<Isa::kPortable>(s, reach, g);
}

}  // namespace

/// One step in reals of type `Real`: `double` is model.md's step, `float` the variant that
/// `plab accuracy` measures (the broad phase always works in double).
template <class Real>
void step_in(const Box& box, ParticlesOf<Real>& p) {
  const int n = static_cast<int>(p.size());
  static std::vector<double> wall, end, scratch;  // working memory, kept between steps
  static std::vector<int> last;
  static std::vector<sweep::Search> reach;
  static std::vector<Slab> slabs;
  wall.resize(n);
  end.resize(n);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) {
    wall[i] = wall_candidate(box, p, i).t;
    end[i] = sweep::path_end(wall[i]);
  }
  const sweep::Grid g = sweep::choose(box, p, end, scratch, kQuantile, kAlpha);
  last.resize(n);
  reach.resize(n);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) {
    last[i] = sweep::last_slab(end[i], g);
    reach[i] = sweep::search_of(p.vx[i], p.vy[i], g);
  }
  slabs.resize(omp_get_max_threads());

#pragma omp parallel
  {
    Slab& s = slabs[omp_get_thread_num()];
    s.found.clear();
    for (auto* v : {&s.cell, &s.id}) v->resize(n + kLanes);
    for (auto* v : {&s.mx, &s.my, &s.x, &s.y, &s.vx, &s.vy}) v->resize(n + kLanes);
#pragma omp for schedule(dynamic, 1)
    for (int k = 0; k < g.slabs; ++k) {
      bin(s, p, last, k, g);
      search(s, reach, g);
      for (const auto& [a, b] : s.hits) {  // the narrow phase (the plan drops pairs after walls)
        const model::Event e =
            pair_candidate(box, p, std::min(s.id[a], s.id[b]), std::max(s.id[a], s.id[b]));
        if (model::in_step(e.t)) s.found.push_back(e);
      }
    }
  }

  std::vector<model::Event> events;
  for (const Slab& s : slabs) events.insert(events.end(), s.found.begin(), s.found.end());
  const Plan plan = sparse_greedy_plan(events, wall);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

void step(const Box& box, Particles& p) { step_in(box, p); }

void step_float(const Box& box, ParticlesOf<float>& p) { step_in(box, p); }

/// Stage 06's entry point (stage.hpp): the GPU path (step.cu) when the run and the machine allow
/// it, otherwise step() on the CPU with the vectors `options.simd` asks for (or step_float()).
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  isa_in_use = choose_isa(options.simd);
  return cpu_stage(box, p, options, {step, step_float, make_gpu_stepper});
}

}  // namespace plab
