/// \file kit/instructor/engine/06-broadphase/step.cpp
/// \brief Stage 06, broad phase (CPU, OpenMP): a space-time grid finds every pair that can meet
/// in the step, model.md's pair time is computed for those alone, and the events are chosen by a
/// greedy pass over the sparse candidates. Same bits as stages 01-05.
//
// =================================================================================================
//  GOAL   Stage 03 tests N^2/2 pairs a step; at N = 10^4 in the report's box only about 2000 can
//         meet. Find them, and few others, with plab::sweep (read sweep.hpp first):
//         1. broad phase: for each time slab k in turn, all threads together: sort the particles
//            that take part into the grid's cells by their positions at the slab's midpoint (a
//            counting sort by row, then by column within each row: sort_rows()), then test each
//            against the rest of its row and the next row within its reach (a fast particle:
//            every cell within its search radius) with sweep::close_in_slab() (search_cells());
//            slab k + 1 is sorted while slab k is searched, in two sets of arrays that take turns;
//            a small scene with at least two slabs a thread: each thread takes whole slabs
//            alone instead (slab_alone(), given: one counting sort by cell, then the same search);
//         2. narrow phase: model.md's pair time for each pair that passed;
//         3. model.md's greedy selection over the sparse candidates (a pair at or after either
//            wall time is never accepted), by the team (plan_team.hpp), then apply.
//         Memory O(N + candidates + cells), shared by the threads: no N x N anything, and no
//         copy per thread (but in small scenes). Slab k is sorted from slab k - 1's order, which is nearly right
//         already, so the sort's writes stay close together (handouts/engine.md, "Many cores").
//  READ   handouts/engine.md            TEST   ./plab test --impl engine --stage 06
// =================================================================================================
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "plab/close_lanes.hpp"
#include "plab/plan_team.hpp"
#include "plab/stage.hpp"
#include "plab/sweep.hpp"
#include "plab/unwritten.hpp"

namespace plab {
namespace {

using lanes::Isa;
using lanes::kLanesSingle;  // close_in_slab_single() is evaluated for this many entries at a time
constexpr double kQuantile = 0.9;  //!< the fastest 10% search wider (sweep::choose())
constexpr double kAlpha = 0.2;     //!< slabs per sqrt(N) v_cut / L, measured best from N = 10^4 to 10^6 (engine.md)
constexpr int kChunk = 256;        //!< entries a thread searches at a time (dynamic schedule)
constexpr int kSmall = 1 << 15;    //!< up to this many particles, a thread may take whole slabs
constexpr int kAhead = 24;         //!< loops that read particles out of order prefetch this far ahead

/// Resizes `v` to `size` elements of which the last `padding` are zero (a vector's lanes past
/// the entries read them).
template <class T>
void resize_padded(Buffer<T>& v, std::size_t size, std::size_t padding) {
  v.resize(size);
  std::fill(v.end() - static_cast<std::ptrdiff_t>(std::min(padding, size)), v.end(), T{});
}

/// A slab's entries, one array per field: the particles that take part, in cell order.
struct Entries {
  Buffer<int> id;               //!< the particle
  Buffer<int> last;             //!< its last slab (sweep::last_slab())
  Buffer<double> x0, y0;        //!< its start-of-step position
  Buffer<double> vx, vy;        //!< its velocity
  Buffer<sweep::PackedSearch> reach;  //!< what it searches (sweep::search_of())
  Buffer<int> row, column;      //!< its row (-1: takes no part) and column in the next slab
  /// Room for `n` entries.
  void reserve(int n) {
    for (auto* v : {&id, &last, &row, &column}) v->resize(n);
    for (auto* v : {&x0, &y0, &vx, &vy}) v->resize(n);
    reach.resize(n);
  }
};

/// What the search of a slab reads, written by its sort: per entry, in cell order, its midpoint
/// position (rounded to float: the entry's cell is the rounded one's) and its velocity rounded to
/// float (padded by kLanesSingle), and where each cell starts.
struct Sorted {
  Buffer<float> x, y;      //!< midpoint position
  Buffer<float> vx, vy;    //!< velocity
  std::vector<int> start;  //!< cell c holds entries [start[c], start[c + 1])
};

/// The slab that every thread works on, one at a time. Slab k's entries are sorted from slab
/// k - 1's (two sets that take turns), which are nearly in order already: a slow particle moves at
/// most a row from one slab to the next, so the sort's writes stay close together, and a thread
/// sorts, one slab after the other, about the same particles. What the threads share between two
/// barriers comes in two copies, one for even slabs and one for odd: slab k + 1 is sorted while
/// slab k is searched.
struct Slab {
  Entries set[2];                   //!< slab k's entries are set[(k + 1) % 2], its input set[k % 2]
  Sorted sorted[2];                 //!< slab k's search reads sorted[k % 2]
  std::vector<int> row_start[2];    //!< row r of slab k holds entries [row_start[k % 2][r], ... [r + 1])
  std::vector<int> counts[2];       //!< slab k's entries per thread and row (count_stride() a thread)
  Buffer<int> from;                 //!< per entry, grouped by row: the input entry it comes from
  Buffer<int> order;                //!< every particle, in the cell order of the last step's slab 0
  /// Room for `n` particles in grid `g` sorted by `threads` threads. A thread alone
  /// (slab_alone()) uses sorted[0] only; sorted[1]'s pages stay unwritten, so never mapped.
  void reserve(int n, const sweep::Grid& g, int threads);
};

/// What the search of a slab reads: its entries in cell order, one array per field, midpoints and
/// velocities rounded to float (sweep::close_in_slab_single() tests them: sixteen lanes a vector,
/// half the bytes a test).
struct View {
  const float* x;              //!< midpoint position x
  const float* y;              //!< midpoint position y
  const float* vx;             //!< velocity x
  const float* vy;             //!< velocity y
  sweep::Single single;        //!< the single-precision test's constants
  const sweep::PackedSearch* reach;  //!< what each entry searches
  const int* start;            //!< cell c holds entries [start[c], start[c + 1])
  const int* row_start;        //!< row r holds entries [row_start[r], row_start[r + 1])
};

/// One thread's own working memory and results (on cache lines of its own: the vectors' ends
/// move with every pair found).
struct alignas(128) Mine {
  std::vector<std::pair<int, int>> hits;  //!< entry pairs that passed close_in_slab()
  std::vector<model::Event> found;        //!< pair candidates
  std::vector<int> next;                  //!< per row: where this thread's next entry goes
  int lo = 0, hi = 0;                     //!< the input entries this thread groups by row
  int active = 0;                         //!< particles of its share that take part
  double max2 = 0;                        //!< the largest squared speed among them
  bool unordered = false;                 //!< whether one of them has a speed that is not a number
  std::vector<double> sample;             //!< its part of the sample of squared speeds
  Slab own;                               //!< its own slab, when it takes whole slabs alone
  bool first = false;                     //!< whether it sorted slab 0 alone (own.order is new)
};

/// Each thread's row of a table of counts per row (`rows + 1` of them), rounded up to whole cache
/// lines so that no two threads write the same line.
inline std::size_t count_stride(int rows) {
  return (static_cast<std::size_t>(rows) + 1 + 31) / 32 * 32;
}

void Slab::reserve(int n, const sweep::Grid& g, int threads) {
  for (Entries& e : set) e.reserve(n);
  for (Sorted& o : sorted) {
    for (auto* v : {&o.x, &o.y, &o.vx, &o.vy}) resize_padded(*v, n + kLanesSingle, kLanesSingle);
    o.start.resize(static_cast<std::size_t>(g.cells()) + 1);
  }
  from.resize(n);
  order.resize(n);
  for (int u = 0; u < 2; ++u) {
    row_start[u].resize(g.rows + 1);
    counts[u].resize(static_cast<std::size_t>(threads) * count_stride(g.rows));
  }
}

/// The first of `count` items that thread `t` of `threads` takes (a static split).
inline int share(int count, int t, int threads) {
  return static_cast<int>(static_cast<long long>(count) * t / threads);
}

/// Files entry `e` of `in` for slab k: its row and column by its midpoint position (row -1 when it
/// takes no part, last < k), counted in `count` (one per row, then one for those dropped).
inline void count_entry(Entries& in, int e, int k, const sweep::Grid& g, int* count) {
  if (in.last[e] < k) {
    in.row[e] = -1;
    ++count[g.rows];
    return;
  }
  const double tm = sweep::slab_mid(k, g);
  in.row[e] = sweep::row_of(sweep::rounded_midpoint(in.y0[e], in.vy[e], tm), g);
  in.column[e] = sweep::column_of(sweep::rounded_midpoint(in.x0[e], in.vx[e], tm), g);
  ++count[in.row[e]];
}

/// Between the counting and the grouping (each thread, from every thread's counts of slab k):
/// where this thread's entries of each row go, in `next`, rows in order and threads in order within
/// a row (so the result does not depend on the timing); thread 0 also writes the rows' first
/// entries. Returns how many entries take part.
inline int place_rows(Slab& s, std::vector<int>& next, int k, const sweep::Grid& g, int t,
                      int threads) {
  const std::vector<int>& counts = s.counts[k % 2];
  int at = 0, taking = 0;
  for (int row = 0; row <= g.rows; ++row) {
    if (row == g.rows) taking = at;
    if (t == 0) s.row_start[k % 2][row] = at;
    for (int u = 0; u < threads; ++u) {
      if (u == t) next[row] = at;
      at += counts[static_cast<std::size_t>(u) * count_stride(g.rows) + row];
    }
  }
  return taking;
}

/// Each of this thread's input entries to its place in its row's group (`from`); in slab 0, those
/// that take no part go straight to the end of the next step's order.
inline void group_rows(Slab& s, Mine& my, const Entries& in, int k, const sweep::Grid& g) {
  for (int j = my.lo; j < my.hi; ++j) {
    const int row = in.row[j];
    if (row >= 0)
      s.from[my.next[row]++] = j;
    else if (k == 0)
      s.order[my.next[g.rows]++] = in.id[j];
  }
}

/// Whether each thread takes whole slabs alone, as a team of one with its own buffers (no barrier
/// a slab), rather than every thread working on every slab: when there are at least two slabs a
/// thread and the scene is small (its slabs in cache: at N = 10^4 a slab is about 0.3 ms of work,
/// and two barriers a slab cost more than the sort they share, on a loaded machine most of all).
inline bool whole_slabs(int n, const sweep::Grid& g, int threads) {
  return n <= kSmall && g.slabs >= 2 * threads;
}

/// Prefetches particle `i`'s position and velocity (`kWrite`: to be written), for loops that
/// read the particles out of index order, kAhead places before they get there.
template <bool kWrite, class Real>
inline void prefetch_motion(const ParticlesOf<Real>& p, int i) {
  __builtin_prefetch(&p.x[i], kWrite);
  __builtin_prefetch(&p.y[i], kWrite);
  __builtin_prefetch(&p.vx[i], kWrite);
  __builtin_prefetch(&p.vy[i], kWrite);
}

/// Particle `i`'s squared speed, in double.
template <class Real>
inline double speed2_of(const ParticlesOf<Real>& p, int i) {
  return double(p.vx[i]) * double(p.vx[i]) + double(p.vy[i]) * double(p.vy[i]);
}

/// The wall time and path end of particles [my.lo, my.hi), and what the grid needs of them:
/// how many take part, the fastest and whether a speed is not a number (in `my`).
template <class Real>
PLAB_CPU_CLONES void walls_of(const Box& box, const ParticlesOf<Real>& p, Buffer<double>& wall,
                              Buffer<double>& end, Mine& my) {
  my.active = 0;
  my.max2 = 0;
  my.unordered = false;
  for (int i = my.lo; i < my.hi; ++i) {
    wall[i] = wall_candidate(box, p, i).t;
    end[i] = sweep::path_end(wall[i]);
    if (!(end[i] > 0)) continue;  // takes no part
    const double v2 = speed2_of(p, i);
    my.unordered |= (v2 != v2);
    my.max2 = std::max(my.max2, v2);
    ++my.active;
  }
}

/// Slab 0's input, entries [lo, hi): the particles in `order` (the last step's slab-0 order),
/// each with its last slab and its search; each filed for slab 0 when `count` is given.
template <class Real>
inline void gather(Entries& first, const ParticlesOf<Real>& p, const Buffer<double>& end,
                   const Buffer<int>& order, int lo, int hi, const sweep::Grid& g,
                   int* count) {
  for (int j = lo; j < hi; ++j) {
    if (j + kAhead < hi) {
      const int f = order[j + kAhead];
      prefetch_motion<false>(p, f);
      __builtin_prefetch(&end[f]);
    }
    const int i = order[j];
    first.id[j] = i;
    first.last[j] = sweep::last_slab(end[i], g);
    first.x0[j] = p.x[i];
    first.y0[j] = p.y[i];
    first.vx[j] = p.vx[i];
    first.vy[j] = p.vy[i];
    first.reach[j] = sweep::PackedSearch::of(sweep::search_of(p.vx[i], p.vy[i], g));
    if (count) count_entry(first, j, 0, g, count);
  }
}

/// Slab k's counting sort by column, one row at a time (this thread's rows, [r0, r1)): each row's
/// group into `out` in cell order, with each entry's midpoint position, and `start` of the row's
/// cells. Each entry is filed for slab k + 1 on the way (count_entry(), into `next_count`); in
/// slab 0, the particles in their new order also go to `order` (the next step's).
PLAB_CPU_CLONES void sort_rows(Slab& s, const Entries& in, Entries& out, int k, int r0, int r1,
                               const sweep::Grid& g, int* next_count) {
  const double tm = sweep::slab_mid(k, g);
  const std::vector<int>& row_start = s.row_start[k % 2];
  Sorted& o = s.sorted[k % 2];
  for (int row = r0; row < r1; ++row) {
    const int lo = row_start[row], hi = row_start[row + 1];
    int* start = &o.start[static_cast<std::size_t>(row) * g.columns];
    std::fill(start, start + g.columns, 0);
    for (int e = lo; e < hi; ++e) ++start[in.column[s.from[e]]];  // count
    for (int c = 0, at = lo; c < g.columns; ++c) {                 // prefix sums
      const int here = start[c];
      start[c] = at;
      at += here;
    }
    for (int e = lo; e < hi; ++e) {  // scatter: start[c] moves on to where column c + 1 starts
      const int j = s.from[e];
      const int to = start[in.column[j]]++;
      out.id[to] = in.id[j];
      out.last[to] = in.last[j];
      out.x0[to] = in.x0[j];
      out.y0[to] = in.y0[j];
      out.vx[to] = in.vx[j];
      out.vy[to] = in.vy[j];
      out.reach[to] = in.reach[j];
      o.x[to] = sweep::rounded_midpoint(in.x0[j], in.vx[j], tm);
      o.y[to] = sweep::rounded_midpoint(in.y0[j], in.vy[j], tm);
      o.vx[to] = static_cast<float>(in.vx[j]);
      o.vy[to] = static_cast<float>(in.vy[j]);
      if (k == 0) s.order[to] = in.id[j];
      if (next_count) count_entry(out, to, k + 1, g, next_count);
    }
    for (int c = g.columns - 1; c > 0; --c) start[c] = start[c - 1];
    start[0] = lo;
  }
  // Where the last cell ends: written by the one thread that sorted the last row (threads with
  // no rows may also have r1 == g.rows).
  if (r0 < r1 && r1 == g.rows) o.start[g.cells()] = row_start[g.rows];
}

/// Files entry `a` with every entry of [from, to) but itself that passes close_in_slab_single()
/// in `hits`, kLanesSingle entries at a time (the arrays are padded: lanes past `to` are masked
/// off). It passes every pair close_in_slab() passes on the unrounded values (sweep::Single).
template <Isa kIsa>
inline void test_range(const View& s, std::vector<std::pair<int, int>>& hits, int a, int from,
                       int to, const sweep::Grid&) {
  lanes::for_each_close_single<kIsa>({s.x, s.y, s.vx, s.vy}, a, from, to, s.single,
                                     [&hits, a](int b) {
                                       if (b != a) hits.emplace_back(a, b);
                                     });
}

/// The search of entries [from, to) of the slab, entry by entry (sweep::search_of()): a slow
/// entry against the later entries of its row up to the last column within its reach, then the
/// columns within reach of the row above, two runs of entries in row-major order; a fast entry
/// against every entry within its reach, one run per row. The entries that pass go to `hits`.
template <Isa kIsa>
inline void search_cells(const View& s, std::vector<std::pair<int, int>>& hits, int from, int to,
                         const sweep::Grid& g) {
  const int columns = g.columns;
  int row = static_cast<int>(std::upper_bound(s.row_start, s.row_start + g.rows, from) -
                             s.row_start) - 1;
  for (int a = from; a < to; ++a) {
    while (a >= s.row_start[row + 1]) ++row;
    const sweep::PackedSearch q = s.reach[a];
    const double d = q.d();
    int x0, x1;
    sweep::columns_within(s.x[a], d, g, x0, x1);
    if (!q.fast()) {
      test_range<kIsa>(s, hits, a, a + 1, s.start[row * columns + x1 + 1], g);
      if (row + 1 < g.rows)
        test_range<kIsa>(s, hits, a, s.start[(row + 1) * columns + x0],
                         s.start[(row + 1) * columns + x1 + 1], g);
    } else {  // a pair found twice is harmless
      int y0, y1;
      sweep::rows_within(s.y[a], d, g, y0, y1);
      for (int y = y0; y <= y1; ++y)
        test_range<kIsa>(s, hits, a, s.start[y * columns + x0], s.start[y * columns + x1 + 1], g);
    }
  }
}

#if PLAB_AVX2
/// search_cells() with AVX-512.
__attribute__((target("avx512f"), flatten)) void search_avx512(
    const View& s, std::vector<std::pair<int, int>>& hits, int from, int to, const sweep::Grid& g) {
  search_cells<Isa::kAvx512>(s, hits, from, to, g);
}

/// search_cells() with AVX2.
__attribute__((target("avx2"), flatten)) void search_avx2(
    const View& s, std::vector<std::pair<int, int>>& hits, int from, int to, const sweep::Grid& g) {
  search_cells<Isa::kAvx2>(s, hits, from, to, g);
}
#endif

/// The grid's slabs per sqrt(N) v_cut / L in this run: kAlpha, or StageOptions::sweep_alpha when
/// the run gives one (to measure; the grid changes, the bits do not). Set once by make_stepper().
double alpha_in_use = kAlpha;

/// The vectors the pair test uses in this run: the widest the CPU has, or narrower ones when
/// the run asks (StageOptions::simd `portable` or `avx2`: the tests run every path the machine has
/// and compare their bits). Set once by make_stepper(), before any step.
Isa isa_in_use = Isa::kPortable;

/// The search of entries [from, to), with the chosen vectors.
void search(const View& s, std::vector<std::pair<int, int>>& hits, int from, int to,
            const sweep::Grid& g) {
#if PLAB_AVX2
  if (isa_in_use == Isa::kAvx512) return search_avx512(s, hits, from, to, g);
  if (isa_in_use == Isa::kAvx2) return search_avx2(s, hits, from, to, g);
#endif
  search_cells<Isa::kPortable>(s, hits, from, to, g);
}

/// The narrow phase: model.md's pair time of each entry pair in `hits` (entries of `out`), kept in
/// `found` if it is in the step (the plan drops pairs after walls). It reads the particles' values
/// from the entries, which hold them exactly (Real's values widened to double), in cell order:
/// a pair's two entries are close together, where the particles' own arrays are in scene order,
/// which is random in space.
template <class Real>
inline void narrow(const Box& box, const Entries& out, const std::vector<std::pair<int, int>>& hits,
                   std::vector<model::Event>& found) {
  for (auto [a, b] : hits) {
    if (out.id[b] < out.id[a]) std::swap(a, b);  // the lower index first, as pair_candidate()
    const Real t = model::pair_time(
        static_cast<Real>(out.x0[a]), static_cast<Real>(out.y0[a]), static_cast<Real>(out.vx[a]),
        static_cast<Real>(out.vy[a]), static_cast<Real>(out.x0[b]), static_cast<Real>(out.y0[b]),
        static_cast<Real>(out.vx[b]), static_cast<Real>(out.vy[b]), static_cast<Real>(box.r));
    const model::Event e = model::pair_event_key(t, out.id[a], out.id[b]);
    if (model::in_step(e.t)) found.push_back(e);
  }
}

/// Slab k alone, by one thread in its own buffers `o` (whole_slabs()): a counting sort by cell
/// of slab 0's input `in` (the team's, read only) into `o`, the search, and the pairs' times (into
/// `my.found`). One level and one move an entry: the slab is small enough to stay in cache.
template <class Real>
PLAB_CPU_CLONES void slab_alone(const Box& box, Slab& o, Mine& my, const Entries& in, int n,
                                int k, const sweep::Grid& g, const sweep::Single& single) {
  const double tm = sweep::slab_mid(k, g);
  Buffer<int>& cell = o.from;  // per input entry: its cell, or -1
  Sorted& to_search = o.sorted[0];
  int* start = to_search.start.data();
  std::fill(start, start + g.cells() + 1, 0);
  for (int j = 0; j < n; ++j) {  // count
    cell[j] = in.last[j] < k ? -1
                             : sweep::cell_of(sweep::rounded_midpoint(in.x0[j], in.vx[j], tm),
                                              sweep::rounded_midpoint(in.y0[j], in.vy[j], tm), g);
    if (cell[j] >= 0) ++start[cell[j] + 1];
  }
  for (int c = 0; c < g.cells(); ++c) start[c + 1] += start[c];
  const int taking = start[g.cells()];
  Entries& out = o.set[1];
  for (int j = 0, rest = taking; j < n; ++j) {  // scatter: start[c] moves on to cell c + 1's
    if (cell[j] < 0) {
      if (k == 0) o.order[rest++] = in.id[j];  // no part in the step: the next step's order's end
      continue;
    }
    const int to = start[cell[j]]++;
    out.id[to] = in.id[j];
    out.x0[to] = in.x0[j];
    out.y0[to] = in.y0[j];
    out.vx[to] = in.vx[j];
    out.vy[to] = in.vy[j];
    out.reach[to] = in.reach[j];
    to_search.x[to] = sweep::rounded_midpoint(in.x0[j], in.vx[j], tm);
    to_search.y[to] = sweep::rounded_midpoint(in.y0[j], in.vy[j], tm);
    to_search.vx[to] = static_cast<float>(in.vx[j]);
    to_search.vy[to] = static_cast<float>(in.vy[j]);
    if (k == 0) o.order[to] = in.id[j];
  }
  for (int c = g.cells(); c > 0; --c) start[c] = start[c - 1];
  start[0] = 0;
  std::vector<int>& row_start = o.row_start[0];
  for (int r = 0; r <= g.rows; ++r) row_start[r] = start[static_cast<std::size_t>(r) * g.columns];
  const View v{to_search.x.data(), to_search.y.data(), to_search.vx.data(),
               to_search.vy.data(), single, out.reach.data(), start, row_start.data()};
  my.hits.clear();
  search(v, my.hits, 0, taking, g);
  narrow<Real>(box, out, my.hits, my.found);
}

}  // namespace

/// Where each thread's time goes, part by part (PLAB_ENGINE_PHASES=1 asks for it, as it does of
/// stage 08's engine): omp_get_wtime() laps of step_in()'s parts by every thread, summed over the
/// steps, written to stderr when the process ends (handouts/engine.md reads them). `wait` is the
/// time at the team's barriers (and, for the threads that do not run it, the grid's choice);
/// `select` holds the selection's own barriers (plan_team.hpp's rounds).
struct PhaseClock {
  enum Part { kWalls, kChoose, kGather, kSort, kSearch, kGroup, kSelect, kApply, kWait, kParts };
  static constexpr const char* kNames[kParts] = {"walls",  "choose", "gather", "sort", "search",
                                                 "group",  "select", "apply",  "wait"};
  /// One thread's laps (on cache lines of its own).
  struct alignas(128) Laps {
    double seconds[kParts] = {};
    double t0 = 0;
  };
  bool on = std::getenv("PLAB_ENGINE_PHASES") != nullptr;
  std::vector<Laps> laps;
  double region = 0;  //!< the parallel regions' time, summed
  long long steps = 0;
  int threads = 0;
  /// Before a step's parallel region of up to `most` threads: room for their laps; returns the
  /// region's start.
  double begin(std::size_t most) {
    if (!on) return 0;
    laps.resize(std::max(laps.size(), most));
    return omp_get_wtime();
  }
  /// After the region that began at `from`.
  void end(double from) {
    if (!on) return;
    region += omp_get_wtime() - from;
    threads = std::max(threads, omp_get_max_threads());
    ++steps;
  }
  /// Thread `t` starts its laps.
  void start(int t) {
    if (on) laps[t].t0 = omp_get_wtime();
  }
  /// Thread `t`'s time since its last lap goes to `part`.
  void lap(int t, Part part) {
    if (!on) return;
    const double now = omp_get_wtime();
    laps[t].seconds[part] += now - laps[t].t0;
    laps[t].t0 = now;
  }
  ~PhaseClock() {
    if (!on || steps == 0) return;
    std::string line = "stage 06 (engine, CPU) " + std::to_string(threads) +
                       " threads, ms a step (mean / slowest thread):";
    char part[96];
    for (int k = 0; k < kParts; ++k) {
      double sum = 0, most = 0;
      for (int t = 0; t < threads; ++t) {
        sum += laps[t].seconds[k];
        most = std::max(most, laps[t].seconds[k]);
      }
      std::snprintf(part, sizeof part, " %s %.2f / %.2f", kNames[k], 1e3 * sum / threads / steps,
                    1e3 * most / steps);
      line += part;
    }
    std::snprintf(part, sizeof part, "; the step %.2f\n", 1e3 * region / steps);
    std::fputs((line + part).c_str(), stderr);
  }
};
PhaseClock phases;

/// One step in reals of type `Real`: `double` is model.md's step, `float` the variant that
/// `plab accuracy` measures (the broad phase always works in double). One parallel region: every
/// thread works on every slab in turn (two barriers a slab; slab k + 1's sort in the phase of slab
/// k's search), or, in a small scene with at least two
/// slabs a thread (whole_slabs()), each thread on whole slabs alone; then all on the selection.
template <class Real>
void step_in(const Box& box, ParticlesOf<Real>& p) {
  const int n = static_cast<int>(p.size());
  static Buffer<double> wall, end;  // working memory, kept between steps (written by the team)
  static std::vector<double> scratch;
  static Slab s;  // the slab of the whole team
  static std::vector<Mine> mine;
  static TeamPlan plan;
  static SparseSelection selection;
  static sweep::Grid g;
  static sweep::Single single;  // the search's test in float, for g
  wall.resize(n);
  end.resize(n);
  const bool fresh = static_cast<int>(s.order.size()) != n;  // a new scene (any order will do)
  if (fresh) s.order.resize(n);
  mine.resize(omp_get_max_threads());
  plan.partner.resize(n);
  plan.time.resize(n);
  using Part = PhaseClock::Part;
  const double region_from = phases.begin(mine.size());

#pragma omp parallel
  {
    const int t = omp_get_thread_num(), threads = omp_get_num_threads();
    phases.start(t);
    Mine& my = mine[t];
    my.found.clear();
    if (fresh) {  // the arrays above grew unwritten: the team writes (and so maps) them
#pragma omp for schedule(static)
      for (int i = 0; i < n; ++i) s.order[i] = i;
    }
    // Wall times, and what the grid needs to know (sweep::choose(), by the team): how many take
    // part, the fastest, and a sample of the speeds (every stride-th of those that take part).
    const auto speed2 = [&](int i) { return speed2_of(p, i); };
    my.lo = share(n, t, threads);
    my.hi = share(n, t + 1, threads);
    walls_of(box, p, wall, end, my);
    phases.lap(t, Part::kWalls);
#pragma omp barrier
    phases.lap(t, Part::kWait);
    my.sample.clear();
    const int stride = static_cast<int>(sweep::sample_stride(n));
    if (n > kSmall) {  // a small scene's sample is taken by the single below: one barrier less
      for (int u = 0, at = 0; u <= t; ++u) {
        if (u < t) {
          at += mine[u].active;
          continue;
        }
        for (int i = my.lo; i < my.hi; ++i)
          if (end[i] > 0 && at++ % stride == 0) my.sample.push_back(speed2(i));
      }
      phases.lap(t, Part::kWalls);
#pragma omp barrier
      phases.lap(t, Part::kWait);
    }
#pragma omp single
    {
      int active = 0;
      double max2 = 0;
      bool unordered = false;
      scratch.clear();
      for (int i = 0, at = 0; i < n && n <= kSmall; ++i)
        if (end[i] > 0 && at++ % stride == 0) scratch.push_back(speed2(i));
      for (const Mine& m : mine) {
        if (&m - mine.data() >= threads) break;
        active += m.active;
        max2 = std::max(max2, m.max2);
        unordered |= m.unordered;
        scratch.insert(scratch.end(), m.sample.begin(), m.sample.end());
      }
      g = sweep::choose_from_sample(box, active, max2, unordered, scratch, kQuantile,
                                     alpha_in_use);
      // (this step's fastest bounds every speed the search's float entries round)
      single = sweep::single_of(g, box.L, std::sqrt(max2) * (1 + 1e-6));
      const bool alone = whole_slabs(n, g, threads);
      s.reserve(n, g, threads);
      for (Mine& m : mine) {
        m.next.resize(g.rows + 1);
        if (alone && &m - mine.data() < threads) m.own.reserve(n, g, 1);
      }
      phases.lap(t, Part::kChoose);
    }
    phases.lap(t, Part::kWait);
    if (whole_slabs(n, g, threads)) {
      // 1-2. Broad and narrow phase, each thread whole slabs alone, from slab 0's input (gathered
      // by the team); whoever sorts slab 0 hands its order on to the next step.
      Entries& in = s.set[0];
      gather(in, p, end, s.order, share(n, t, threads), share(n, t + 1, threads), g, nullptr);
      my.first = false;
      phases.lap(t, Part::kGather);
#pragma omp barrier
      phases.lap(t, Part::kWait);
#pragma omp for schedule(dynamic, 1) nowait
      for (int k = 0; k < g.slabs; ++k) {
        slab_alone<Real>(box, my.own, my, in, n, k, g, single);
        my.first |= (k == 0);
      }
      phases.lap(t, Part::kSearch);  // the slabs' sorts and searches
#pragma omp barrier
      phases.lap(t, Part::kWait);
      if (my.first) std::swap(s.order, my.own.order);  // no thread reads s.order until next step
    } else {
      // 1. Broad phase. Slab 0's input: every particle, in the order of the last step's slab 0
      // (close to this step's, so the sort's writes stay close together): the one pass that reads
      // the particles out of index order. Each thread takes a share and files it for slab 0.
      Entries& first = s.set[0];
      int* count = &s.counts[0][static_cast<std::size_t>(t) * count_stride(g.rows)];
      std::fill(count, count + g.rows + 1, 0);
      my.lo = share(n, t, threads);
      my.hi = share(n, t + 1, threads);
      gather(first, p, end, s.order, my.lo, my.hi, g, count);
      phases.lap(t, Part::kGather);
#pragma omp barrier
      phases.lap(t, Part::kWait);
      int taking = place_rows(s, my.next, 0, g, t, threads);
      group_rows(s, my, first, 0, g);
      phases.lap(t, Part::kGroup);
#pragma omp barrier
      phases.lap(t, Part::kWait);
      // Slab k's sort (sort_rows()) by this thread: the rows that start in its share of the
      // `entries` that take part; it files their entries for slab k + 1, which this thread then
      // groups by row (group_rows(), from my.lo to my.hi).
      const auto sort_slab = [&](int k, int entries) {
        const std::vector<int>& row_start = s.row_start[k % 2];
        const auto row_at = [&](int u) {
          return u == threads ? g.rows
                              : static_cast<int>(std::lower_bound(row_start.begin(),
                                                                  row_start.begin() + g.rows,
                                                                  share(entries, u, threads)) -
                                                 row_start.begin());
        };
        const int r0 = row_at(t), r1 = row_at(t + 1);
        int* next_count = nullptr;
        if (k + 1 < g.slabs) {
          next_count = &s.counts[(k + 1) % 2][static_cast<std::size_t>(t) * count_stride(g.rows)];
          std::fill(next_count, next_count + g.rows + 1, 0);
        }
        sort_rows(s, s.set[k % 2], s.set[(k + 1) % 2], k, r0, r1, g, next_count);
        my.lo = row_start[r0];
        my.hi = row_start[r1];
        phases.lap(t, Part::kSort);
      };
      sort_slab(0, taking);
#pragma omp barrier
      phases.lap(t, Part::kWait);
      for (int k = 0; k < g.slabs; ++k) {
        // Slab k + 1's rows (from the counts slab k's sort filed), then, in one phase, slab k + 1's
        // sort (a static share of rows a thread) and slab k's search (each pair that passes, then
        // the narrow phase at once; in chunks of entries taken as threads come free, so that a
        // thread whose sort took longer searches less). Two sets of arrays take turns: the sort
        // writes what the search of slab k does not read.
        int next_taking = 0;
        if (k + 1 < g.slabs) {
          next_taking = place_rows(s, my.next, k + 1, g, t, threads);
          group_rows(s, my, s.set[(k + 1) % 2], k + 1, g);
          phases.lap(t, Part::kGroup);
#pragma omp barrier
          phases.lap(t, Part::kWait);
          sort_slab(k + 1, next_taking);
        }
        const Entries& out = s.set[(k + 1) % 2];
        const Sorted& o = s.sorted[k % 2];
        const View v{o.x.data(),       o.y.data(),       o.vx.data(),
                     o.vy.data(),      single,           out.reach.data(),
                     o.start.data(),   s.row_start[k % 2].data()};
#pragma omp for schedule(dynamic, 1) nowait
        for (int from = 0; from < taking; from += kChunk) {
          my.hits.clear();
          search(v, my.hits, from, std::min(from + kChunk, taking), g);
          narrow<Real>(box, out, my.hits, my.found);  // the pairs' times, at once
        }
        phases.lap(t, Part::kSearch);
        taking = next_taking;
#pragma omp barrier
        phases.lap(t, Part::kWait);
      }
    }

    // 3. Selection (model.md's greedy rule over the sparse candidates) and apply, by the team.
    sparse_greedy_plan_in_team(my.found, wall, plan, selection);
    phases.lap(t, Part::kSelect);
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      if (i + kAhead < n) {  // a pair's other particle is anywhere in the arrays
        const int j = plan.partner[i + kAhead];
        if (j > i + kAhead) {
          prefetch_motion<true>(p, j);
          __builtin_prefetch(&p.pc[j], 1);
        }
      }
      apply_one(box, p, plan.partner.data(), plan.time.data(), i);
    }
    phases.lap(t, Part::kApply);
  }
  phases.end(region_from);
}

void step(const Box& box, Particles& p) { step_in(box, p); }

void step_float(const Box& box, ParticlesOf<float>& p) { step_in(box, p); }

/// Stage 06's entry point (stage.hpp): the GPU path (step.cu) when the run and the machine allow
/// it, otherwise step() on the CPU with the vectors `options.simd` asks for (or step_float()).
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  isa_in_use = lanes::choose_isa(options.simd);
  alpha_in_use = options.sweep_alpha > 0 ? options.sweep_alpha : kAlpha;
  return cpu_stage(box, p, options, {step, step_float, make_gpu_stepper});
}

}  // namespace plab
