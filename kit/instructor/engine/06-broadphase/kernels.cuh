/// \file kit/instructor/engine/06-broadphase/kernels.cuh
/// \brief Stage 06's kernels (device code only): the space-time grid built by a counting sort on
/// the GPU (atomics, a CUB scan), a few slabs at a time, the pair search over neighbouring
/// buckets filing compact candidates (cuda/candidates.cuh), then stage 05's rounds and branchless
/// apply over them.
#pragma once

#include <cooperative_groups.h>
#include <cub/block/block_scan.cuh>

#include "plab/cuda/particles.hpp"
#include "plab/cuda/rounds.cuh"
#include "plab/cuda/candidates.cuh"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"
#include "plab/sweep.hpp"

namespace plab::kernels {

using cuda::accept_one;
using cuda::choose_one;
using cuda::start_one;
using cuda::ParticlesView;
using model::Event;

constexpr int kResolveThreads = 1024;  //!< the one block of resolve

/// What the host reads after a batch of steps.
struct Flags {
  int overflow;          //!< pairs a step needed, when they did not fit the list (else 0)
  long long steps_done;  //!< steps applied so far
  int pairs;             //!< pairs filed this step (CompactView::file())
  int contested;         //!< particles with pair events this step (listed by start_rounds; not
                         //!< by finish_small, whose threads hold their own particles)
  int open[3];           //!< resolve_grid: someone left unresolved in round r (at r % 3)
  int fast;              //!< fast entries the pass's search listed for a team search (the solution's
                         //!< find_fast_pairs)
  int rows;              //!< finish_small: events given a row so far this step
  int spilled;           //!< a particle had more pair events than its slots this step
                         //!< (CompactView::slot): finish_small lays the rows
  int crowded;           //!< kCrowdedBands: find_pairs_banded's entries did not fit a block's
                         //!< shared memory (the host goes back to the counting sort);
                         //!< kCrowdedFinish: finish_block's pairs did not fit (the host goes
                         //!< back to finish_small or the separate kernels); the step is redone
  /// The largest squared speed of step s's state (start_step() of step s writes slot s % 2 and
  /// clears the other), as the bits of a double (non-negative doubles order as their bits):
  /// how far find_pairs_banded()'s fastest entry reaches.
  unsigned long long vmax2[2];
};

constexpr int kCrowdedBands = 1;   //!< Flags::crowded: the bands' search did not fit
constexpr int kCrowdedFinish = 2;  //!< Flags::crowded: finish_block() did not fit

/// Whether the steps are stopped until the host looks: the list had no room for a step's pairs
/// (`overflow`) or a small scene's kernel did not fit its block's shared memory (`crowded`).
__device__ inline bool stopped(const Flags* f) { return f->overflow || f->crowded; }

/// The grid of the batch and the slabs of one pass of the counting sort, as the kernels see it.
/// A pass sorts and searches slabs [first, first + slabs) together: slab k's cells are buckets
/// [(k - first) * cells, (k - first + 1) * cells), and its entries are counted at
/// [(k - first) * n + i]. Large scenes take a few slabs a pass, so that the entries of one pass
/// (not of the whole step) are what the memory holds.
struct DeviceGrid {
  sweep::Grid g;         //!< slabs, cells, v_cut
  sweep::Single single;  //!< the pass search's slab test on float entries (Entry)
  int cells;             //!< g.cells()
  int first;      //!< the pass's first slab
  int slabs;      //!< the pass's number of slabs
};

/// What the pass search reads of an entry: its midpoint position and velocity rounded to float,
/// 16 bytes (the scatter writes it at a random place; the search reads some 190 a particle a
/// step at the report's density). The entry is sorted by its rounded midpoint, and the search
/// tests it in single precision (sweep::close_in_slab_single()): every pair the double test
/// passes still passes (sweep::Single says why), the pair time stays the model's, in double.
struct alignas(16) Entry {
  float x, y;    //!< midpoint position
  float vx, vy;  //!< velocity
};

/// An entry's \f$|v_x| + |v_y|\f$ (sweep::close_in_slab_single()'s `s` is two of them).
__device__ inline float speed_sum(const Entry& e) { return fabsf(e.vx) + fabsf(e.vy); }

/// The single-precision slab test of entries `me` and `o` (sweep::close_in_slab_single()).
__device__ inline bool close_entries(const Entry& me, float me_s, const Entry& o,
                                     const DeviceGrid& d) {
  return sweep::close_in_slab_single(me.x - o.x, me.y - o.y, me.vx - o.vx, me.vy - o.vy,
                                     me_s + speed_sum(o), d.single);
}

/// Each particle's pair events of the step, compact (cuda/candidates.cuh).
using Slots = cuda::CompactView;

/// One step's working arrays (pointers into memory the host class owns).
struct StepArrays {
  double* wall;      //!< wall time of each particle
  int* last;         //!< the last slab each particle takes part in (sweep::last_slab())
  Slots slots;       //!< each particle's pair events of the step (count, list, rows)
  Event* best;       //!< each unresolved particle's earliest event in the current round
  char* resolved;    //!< 1 once a particle's event (or none) is decided
  int* contested;    //!< the particles with at least one pair event (start_rounds(),
                     //!< finish_block(); finish_small() leaves it, and with the slots also the
                     //!< rows and their ends, unwritten)
  int* partner;      //!< the plan: Plan::kFree, Plan::kWall, or the other particle of its pair
  double* ptime;     //!< the plan's pair time
  int* start;        //!< a pass's slabs * cells + 1: entries counted into each bucket, then (an
                     //!< exclusive scan in place) bucket b holds entries [start[b], start[b + 1])
  int* rank;         //!< per (slab of the pass, particle) at [(k - first) * n + i]: its place in
                     //!< its bucket
  int* entry_at;     //!< per entry (at most slabs of a pass * N): (k - first) * n + i, its slab k
                     //!< and particle i in one int (particle_of(), slab_of())
  Entry* entry;      //!< ... its midpoint position and velocity
  int* band_cell;    //!< find_pairs_banded()'s steps only (else null): per (slab k, particle i),
                     //!< at [k * n + i], band_cell_of() (start_step() writes it)
  Flags* flags;      //!< see Flags
};

/// Particle `i`'s cell in slab k, for find_pairs_banded(): its midpoint's row and column
/// (bucket_of()'s arithmetic, on the midpoint rounded to float) as row << 16 | column (the bands
/// take N < 2^15: at most 181 rows and 724 columns), or -1 when it takes no part in slab k (its
/// last slab is before k). The midpoint is sweep::rounded_midpoint(), as in find_pairs_banded()'s
/// scatter (no contraction: --fmad=false), so an entry is sorted into the cell of the midpoint its
/// search reads.
__device__ inline int band_cell_of(double x, double y, double vx, double vy, int last, int k,
                                   const sweep::Grid& g) {
  if (last < k) return -1;
  const double tm = sweep::slab_mid(k, g);
  const float mx = sweep::rounded_midpoint(x, vx, tm), my = sweep::rounded_midpoint(y, vy, tm);
  return sweep::row_of(my, g) << 16 | sweep::column_of(mx, g);
}

/// Threads a particle of start_step(): with the bands' cells to write (every slab's), several.
__host__ __device__ inline int start_step_groups(const StepArrays& a) {
  return a.band_cell ? 4 : 1;
}

/// Programmatic dependent launch (sm_90 and later; nothing before): a kernel launched with it
/// (launch::find_pairs_banded()) may start while the kernel before it ends, and waits here, first
/// thing, for that kernel to finish and its writes to be seen. So nothing is read or written
/// early: what is saved is the launch's latency between the two kernels.
__device__ inline void wait_for_kernel_before() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.wait;" ::: "memory");
#endif
}

/// Lets the kernel after this one (when launched programmatically dependent) be launched now:
/// its blocks start and wait in wait_for_kernel_before() until this kernel has finished.
__device__ inline void let_kernel_after_launch() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.launch_dependents;" ::: "memory");
#endif
}

/// Wall times, the last slab of each particle, counters cleared; with `buckets` > 0 (a step of
/// one pass) also the pass's first `buckets` bucket counts and the fast entries' counter, which
/// the pass would otherwise clear with two memsets of its own.
__global__ void start_step(ParticlesView p, Box box, StepArrays a, DeviceGrid d, int buckets) {
  let_kernel_after_launch();  // (the bands' kernel: its blocks wait for this one's end)
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  for (int b = t; b < buckets; b += gridDim.x * blockDim.x) a.start[b] = 0;
  if (t == 0 && buckets > 0) a.flags->fast = 0;
  // Thread t: particle i of group `group` (start_step_groups() groups; group 0 does all but
  // the band cells, which the groups share: slab k to group k % groups). Each group computes
  // the particle's wall time and last slab again: no barrier between the groups.
  const int group = p.n > 0 ? t / p.n : 0, i = t - group * p.n;
  // The largest squared speed, a warp's at a time (find_pairs_banded()'s reach).
  const long long s = a.flags->steps_done;
  if (t == 0) a.flags->vmax2[(s + 1) % 2] = 0;
  unsigned long long v2 = 0;
  if (group == 0 && i < p.n) v2 = __double_as_longlong(p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i]);
  for (int step = 16; step > 0; step >>= 1) {
    const unsigned long long o = __shfl_down_sync(0xffffffffu, v2, step);
    v2 = o > v2 ? o : v2;
  }
  if (threadIdx.x % 32 == 0 && v2 != 0) atomicMax(&a.flags->vmax2[s % 2], v2);
  const int groups = start_step_groups(a);
  if (group >= groups) return;
  const double x = p.x[i], y = p.y[i], vx = p.vx[i], vy = p.vy[i];
  const double wall = model::wall_time(x, y, vx, vy, box.L, box.r);
  const int last = sweep::last_slab(sweep::path_end(wall), d.g);
  if (a.band_cell)  // the cells of slabs group, group + groups, ...: 4 bytes a band reads, not 40
    for (int k = group; k < d.g.slabs; k += groups)
      a.band_cell[static_cast<long long>(k) * p.n + i] = band_cell_of(x, y, vx, vy, last, k, d.g);
  if (group > 0) return;
  a.wall[i] = wall;
  a.last[i] = last;
  a.slots.count[i] = 0;
  if (i == 0) {
    a.flags->pairs = 0;
    a.flags->contested = 0;
    a.flags->open[0] = a.flags->open[1] = a.flags->open[2] = 0;
    a.flags->rows = 0;
    a.flags->spilled = 0;
  }
}

/// Particle i's midpoint position in slab k.
__device__ inline void midpoint(const ParticlesView& p, int i, int k, const DeviceGrid& d,
                                double& mx, double& my) {
  const double tm = sweep::slab_mid(k, d.g);
  mx = p.x[i] + tm * p.vx[i];
  my = p.y[i] + tm * p.vy[i];
}

/// Particle i's entry in slab k (its midpoint and velocity rounded to float), and its bucket in
/// the pass: the cell of the rounded midpoint, which the search reads back.
__device__ inline int bucket_of(const ParticlesView& p, int i, int k, const DeviceGrid& d,
                                Entry& e) {
  const double tm = sweep::slab_mid(k, d.g);
  e = Entry{sweep::rounded_midpoint(p.x[i], p.vx[i], tm),
            sweep::rounded_midpoint(p.y[i], p.vy[i], tm), static_cast<float>(p.vx[i]),
            static_cast<float>(p.vy[i])};
  return (k - d.first) * d.cells + sweep::cell_of(e.x, e.y, d.g);
}

/// Counting sort, pass 1 (grid: particles x the pass's slabs): each particle that takes part in
/// slab k counts itself into its bucket, and keeps its place there.
__global__ void bin_count(ParticlesView p, StepArrays a, DeviceGrid d) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int k = d.first + blockIdx.y;
  if (i >= p.n || a.last[i] < k) return;
  Entry entry;
  const int b = bucket_of(p, i, k, d, entry);
  a.rank[static_cast<long long>(blockIdx.y) * p.n + i] = atomicAdd(&a.start[b], 1);
}

/// Counting sort, pass 2 (after the exclusive scan of `start`'s counts, in place): each entry to
/// its place (its bucket found again, the same arithmetic), with what the search reads.
__global__ void bin_scatter(ParticlesView p, StepArrays a, DeviceGrid d) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int k = d.first + blockIdx.y;
  if (i >= p.n || a.last[i] < k) return;
  Entry entry;
  const int b = bucket_of(p, i, k, d, entry);
  const int e = a.start[b] + a.rank[static_cast<long long>(blockIdx.y) * p.n + i];
  a.entry_at[e] = static_cast<int>(blockIdx.y) * p.n + i;  // below max(N, 2^20) + N: an int
  a.entry[e] = entry;
}

/// The particle of entry `e` (bin_scatter() packs it with its slab: StepArrays::entry_at).
__device__ inline int particle_of(const StepArrays& a, int n, int e) { return a.entry_at[e] % n; }

/// The slab of entry `e` (StepArrays::entry_at).
__device__ inline int slab_of(const StepArrays& a, const DeviceGrid& d, int n, int e) {
  return d.first + a.entry_at[e] / n;
}

/// Whether particles i and j pass the slab test in slab k (then slab k's search finds them).
__device__ inline bool close_in_slab_at(const ParticlesView& p, int i, int j, int k,
                                        const DeviceGrid& d) {
  double xi, yi, xj, yj;
  midpoint(p, i, k, d, xi, yi);
  midpoint(p, j, k, d, xj, yj);
  return sweep::close_in_slab(xi - xj, yi - yj, p.vx[i] - p.vx[j], p.vy[i] - p.vy[j], d.g);
}

/// The pair of entries e and f that passed sweep::close_in_slab() in slab k (e's particle i):
/// model.md's pair time, unless slab k - 1 found them already (a pair filed twice is harmless to
/// the rounds, but it takes room), filed when the pair comes before both particles' walls.
__device__ inline void file_pair_of(const ParticlesView& p, const Box& box, const StepArrays& a,
                                    const DeviceGrid& d, int i, int k, int j) {
  if (k > 0 && close_in_slab_at(p, i, j, k - 1, d)) return;  // found in slab k - 1
  // Scales outside float's range: the single test passed everything, the double one decides.
  if (!(d.single.rr < HUGE_VALF) && !close_in_slab_at(p, i, j, k, d)) return;
  const int lo = i < j ? i : j, hi = i < j ? j : i;
  const double t = model::pair_time(p.x[lo], p.y[lo], p.vx[lo], p.vy[lo], p.x[hi], p.y[hi],
                                    p.vx[hi], p.vy[hi], box.r);
  if (model::in_step(t) && model::before_walls(t, a.wall[lo], a.wall[hi]) &&
      !a.slots.file(lo, hi, t, &a.flags->pairs))
    a.flags->spilled = 1;
}

/// file_pair_of() for the particle of entry `f` of the pass.
__device__ inline void file_pair(const ParticlesView& p, const Box& box, const StepArrays& a,
                                 const DeviceGrid& d, int i, int k, int f) {
  file_pair_of(p, box, a, d, i, k, particle_of(a, p.n, f));
}

/// Entry e against entries [from, to) of its slab: the pairs that pass sweep::close_in_slab() go
/// to file_pair(). `kBatch` entries are loaded (their loads in flight together), then tested,
/// then the ones that passed filed. A team of `lanes` threads can share the run: this one takes
/// every lanes-th entry from from + lane.
template <int kBatch>
__device__ inline void test_entries(const ParticlesView& p, const Box& box, const StepArrays& a,
                                    const DeviceGrid& d, int e, int from, int to, int lane = 0,
                                    int lanes = 1) {
  const int i = particle_of(a, p.n, e), k = slab_of(a, d, p.n, e);
  const Entry me = a.entry[e];
  const float me_s = speed_sum(me);
  for (int f0 = from + lane; f0 < to; f0 += kBatch * lanes) {
    Entry o[kBatch];
#pragma unroll
    for (int u = 0; u < kBatch; ++u) {
      const int f = f0 + u * lanes;
      if (f < to) o[u] = a.entry[f];
    }
    unsigned passed = 0;
#pragma unroll
    for (int u = 0; u < kBatch; ++u) {
      const int f = f0 + u * lanes;
      if (f < to && f != e && close_entries(me, me_s, o[u], d)) passed |= 1u << u;
    }
    for (; passed != 0; passed &= passed - 1)
      file_pair(p, box, a, d, i, k, f0 + (__ffs(passed) - 1) * lanes);
  }
}

constexpr int kSearchThreads = 256;  //!< threads per block of find_pairs and find_fast_pairs
constexpr int kFastTeam = 8;         //!< threads that search together for one fast entry

/// How the pair search runs (measured on an H100, 2026-11-27, handouts/engine-gpu.md): a small
/// scene's search is short of threads, and each thread's loads in flight at once decide its
/// time; a large scene has threads enough, and more of them resident decide it.
enum class Search {
  kBatched,  //!< four entries loaded at a time, up to 128 registers a thread (two blocks an SM)
  kLean,     //!< one entry at a time, at most 64 registers a thread (four blocks an SM)
  kBalanced, //!< the slow entries: a warp's tests shared evenly by its lanes
             //!< (find_pairs_balanced()); the fast ones: lean
};
/// Entries test_entries() loads at a time with search shape `S`.
template <Search S>
constexpr int kBatchOf = S == Search::kBatched ? 4 : 1;
/// Blocks of kSearchThreads an SM holds at least (the register bound) with search shape `S`.
template <Search S>
constexpr int kBlocksOf = S == Search::kBatched ? 2 : 4;

/// The pair search, one thread per entry (as step.cpp, but for the fast entries): a slow entry
/// against the later entries of its row up to the last column within its reach, then the
/// columns within reach of the row above (two runs of entries of its slab). A fast entry
/// searches about twice as many entries (every row within its reach): it is listed in `a.rank`
/// (free once bin_scatter ran) for find_fast_pairs, so that the threads of a warp run loops of
/// like length (`list_fast`; otherwise find_fast_pairs finds the fast entries itself, running
/// beside this kernel). Search shape `S` (Search).
template <Search S>
__global__ void __launch_bounds__(kSearchThreads, kBlocksOf<S>)
    find_pairs(ParticlesView p, Box box, StepArrays a, DeviceGrid d, bool list_fast) {
  namespace cg = cooperative_groups;
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= a.start[d.slabs * d.cells] || stopped(a.flags)) return;
  const Entry me = a.entry[e];
  const sweep::Search q = sweep::search_of(me.vx, me.vy, d.g);
  if (q.fast) {  // one atomic for the fast threads of the warp
    if (!list_fast) return;
    const cg::coalesced_group fast = cg::coalesced_threads();
    int first = 0;
    if (fast.thread_rank() == 0) first = atomicAdd(&a.flags->fast, static_cast<int>(fast.size()));
    a.rank[fast.shfl(first, 0) + static_cast<int>(fast.thread_rank())] = e;
    return;
  }
  const int columns = d.g.columns;
  const int* row = a.start + (slab_of(a, d, p.n, e) - d.first) * d.cells;  // this slab's cells
  int x0, x1;
  sweep::columns_within(me.x, q.d, d.g, x0, x1);
  const int y = sweep::row_of(me.y, d.g);
  test_entries<kBatchOf<S>>(p, box, a, d, e, e + 1, row[y * columns + x1 + 1]);
  if (y + 1 < d.g.rows)
    test_entries<kBatchOf<S>>(p, box, a, d, e, row[(y + 1) * columns + x0],
                              row[(y + 1) * columns + x1 + 1]);
}

/// What a lane of find_pairs_balanced() tells the rest of its warp: its entry and the two runs
/// it searches, as a span of the warp's tests.
struct LaneRuns {
  Entry me;             //!< the entry's midpoint position and velocity
  float s;              //!< speed_sum() of it
  int e;                //!< the entry
  int first;            //!< the first of its row's later entries it searches (e + 1)
  int next_row;         //!< where its run in the next row starts
  int row_tests;        //!< entries of the run in its own row (the rest are in the next row)
  int from, to;         //!< its tests are the warp's tests [from, to)
};

/// find_pairs() with a warp's tests shared evenly by its 32 lanes. Each lane takes an entry, as
/// in find_pairs(), and finds its two runs (a fast entry is listed for find_fast_pairs() and has
/// none); the warp lays the runs end to end (a prefix sum of their lengths), and lane l takes the
/// warp's tests l, l + 32, l + 64, ...: every lane tests as many entries as the next, where
/// find_pairs() keeps a warp until its longest run ends, and the lanes read neighbouring entries
/// of two or three overlapping runs together. The same entries are tested with the same
/// arithmetic, so the same pairs are filed. (The warp's sum of run lengths is an int: it would
/// overflow only past 2^31 tests for 32 entries, a grid no search could finish.)
__global__ void __launch_bounds__(kSearchThreads, 4)
    find_pairs_balanced(ParticlesView p, Box box, StepArrays a, DeviceGrid d, bool list_fast) {
  namespace cg = cooperative_groups;
  __shared__ LaneRuns lanes[kSearchThreads];
  if (stopped(a.flags)) return;  // the same for every thread: written before this kernel
  const int lane = static_cast<int>(threadIdx.x % 32);
  LaneRuns* warp = lanes + (threadIdx.x - lane);  // this warp's lanes
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  int count = 0;  // this lane's tests
  LaneRuns mine{};
  if (e < a.start[d.slabs * d.cells]) {
    const Entry me = a.entry[e];
    const sweep::Search q = sweep::search_of(me.vx, me.vy, d.g);
    if (q.fast) {  // one atomic for the fast threads of the warp (find_pairs()' `list_fast`)
      if (list_fast) {
        const cg::coalesced_group fast = cg::coalesced_threads();
        int first = 0;
        if (fast.thread_rank() == 0)
          first = atomicAdd(&a.flags->fast, static_cast<int>(fast.size()));
        a.rank[fast.shfl(first, 0) + static_cast<int>(fast.thread_rank())] = e;
      }
    } else {
      const int columns = d.g.columns;
      const int* row = a.start + (slab_of(a, d, p.n, e) - d.first) * d.cells;  // its slab's cells
      int x0, x1;
      sweep::columns_within(me.x, q.d, d.g, x0, x1);
      const int y = sweep::row_of(me.y, d.g);
      mine = LaneRuns{me, speed_sum(me), e, e + 1, 0, 0, 0, 0};
      mine.row_tests = max(0, row[y * columns + x1 + 1] - (e + 1));
      count = mine.row_tests;
      if (y + 1 < d.g.rows) {
        mine.next_row = row[(y + 1) * columns + x0];
        count += max(0, row[(y + 1) * columns + x1 + 1] - mine.next_row);
      }
    }
  }
  int end = count;  // the warp's prefix sum of the counts, this lane included
  for (int step = 1; step < 32; step <<= 1) {
    const int before = __shfl_up_sync(0xffffffffu, end, step);
    if (lane >= step) end += before;
  }
  const int total = __shfl_sync(0xffffffffu, end, 31);
  mine.from = end - count;
  mine.to = end;
  warp[lane] = mine;
  __syncwarp();
  int owner = 0;  // the lane whose entry test t belongs to: the warp's tests go in lane order
  for (int t = lane; t < total; t += 32) {
    while (t >= warp[owner].to) ++owner;
    const LaneRuns& r = warp[owner];
    const int j = t - r.from;
    const int f = j < r.row_tests ? r.first + j : r.next_row + (j - r.row_tests);
    if (close_entries(r.me, r.s, a.entry[f], d))
      file_pair(p, box, a, d, particle_of(a, p.n, r.e), slab_of(a, d, p.n, r.e), f);
  }
}

/// The search of the fast entries: a team of kFastTeam threads for each, sharing every run of
/// entries within its reach, one run per row (a pair found twice is harmless); any grid, the
/// teams stride over the entries. `listed`: those find_pairs or find_pairs_balanced listed
/// (`flags->fast` of them in `a.rank`); otherwise every entry of the pass, each team keeping
/// its entry only if it is fast, so that this kernel can run beside the slow entries' search
/// instead of after it (small scenes, which leave most of the GPU idle). Search shape `S`.
template <Search S>
__global__ void __launch_bounds__(kSearchThreads, kBlocksOf<S>)
    find_fast_pairs(ParticlesView p, Box box, StepArrays a, DeviceGrid d, bool listed) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int lane = t % kFastTeam, teams = gridDim.x * blockDim.x / kFastTeam;
  if (stopped(a.flags)) return;
  const int m = listed ? a.flags->fast : a.start[d.slabs * d.cells], columns = d.g.columns;
  for (int q = t / kFastTeam; q < m; q += teams) {
    const int e = listed ? a.rank[q] : q;
    const Entry me = a.entry[e];
    const sweep::Search search = sweep::search_of(me.vx, me.vy, d.g);
    if (!search.fast) continue;  // (a listed entry is fast)
    const int* row = a.start + (slab_of(a, d, p.n, e) - d.first) * d.cells;
    const double reach = search.d;
    int x0, x1, y0, y1;
    sweep::columns_within(me.x, reach, d.g, x0, x1);
    sweep::rows_within(me.y, reach, d.g, y0, y1);
    for (int y = y0; y <= y1; ++y)
      test_entries<kBatchOf<S>>(p, box, a, d, e, row[y * columns + x0],
                                row[y * columns + x1 + 1], lane, kFastTeam);
  }
}

constexpr int kBandThreads = 1024;  //!< threads per block of find_pairs_banded()
constexpr int kWideMost = 128;      //!< entries a band may search over the whole slab
constexpr int kBandLoads = 8;       //!< particles a thread of find_pairs_banded() reads at a time
constexpr int kHitMost = 2048;      //!< pairs a block of find_pairs_banded() lists to file at once
/// Shared memory find_pairs_banded() takes a kept entry: its midpoint position and velocity in
/// float (16: Entry), its particle (4), while it is sorted its particle and cell again (8), and
/// its first test and its runs, packed (4 + 8).
constexpr int kBandEntryBytes = 40;

/// The runs of entries an entry of find_pairs_banded() tests (those of find_pairs() or
/// find_fast_pairs()): a slow one, run 0 its row after it and run 1 the next row; a fast one, a
/// run for each row y, y + 1, ..., y + count - 1; columns x0 to x1 in each.
struct BandRuns {
  int e;       //!< the entry
  int y;       //!< its first run's row (of the rows the block keeps)
  int x0, x1;  //!< the columns within its reach
  int count;   //!< runs (0 when `wide`)
  bool fast;   //!< a fast entry
  bool wide;   //!< a fast entry whose reach leaves the rows kept: it searches the whole slab
};

/// What find_pairs_banded() keeps in shared memory: its entries in cell order, one array per
/// field, and where each kept cell starts.
struct BandEntries {
  const float2* pos;   //!< midpoint position, rounded to float
  const float2* vel;   //!< velocity, rounded to float
  const int* start;    //!< kept cell c holds entries [start[c], start[c + 1])
  int columns;         //!< the grid's columns
  int lo, hi;          //!< the rows kept, [lo, hi)
};

/// The runs entry `e` searches.
__device__ inline BandRuns band_runs(const BandEntries& s, const sweep::Grid& g, int e) {
  BandRuns b{};
  b.e = e;
  const sweep::Search q = sweep::search_of(s.vel[e].x, s.vel[e].y, g);
  sweep::columns_within(s.pos[e].x, q.d, g, b.x0, b.x1);
  b.fast = q.fast;
  if (!q.fast) {  // its row after it, then the next row
    b.y = sweep::row_of(s.pos[e].y, g) - s.lo;
    b.count = b.y + s.lo + 1 < g.rows ? 2 : 1;
    return b;
  }
  int y0, y1;
  sweep::rows_within(s.pos[e].y, q.d, g, y0, y1);
  b.wide = y0 < s.lo || y1 >= s.hi;
  b.y = y0 - s.lo;
  b.count = b.wide ? 0 : y1 - y0 + 1;
  return b;
}

/// `b` in two ints, for shared memory: columns in 16 bits, the first row in 16 (signed), the runs
/// in 13 (sweep::choose_for() gives at most sqrt(N) rows and 4 sqrt(N) columns, and the bands
/// take N < 2^15: 181 rows, 724 columns).
__device__ inline int2 pack_runs(const BandRuns& b) {
  return make_int2(b.x0 | (b.x1 << 16), (b.y & 0xffff) | (b.count << 16) |
                                            (b.fast ? 1 << 30 : 0) | (b.wide ? 1 << 29 : 0));
}

/// The runs of entry `e`, packed by pack_runs().
__device__ inline BandRuns unpack_runs(int2 v, int e) {
  BandRuns b;
  b.e = e;
  b.x0 = v.x & 0xffff;
  b.x1 = (v.x >> 16) & 0xffff;
  b.y = static_cast<short>(v.y & 0xffff);  // (a fast entry's first row may lie below lo)
  b.count = (v.y >> 16) & 0x1fff;
  b.fast = (v.y >> 30) & 1;
  b.wide = (v.y >> 29) & 1;
  return b;
}

/// Run `r` of `b`: entries [from, to).
__device__ inline void band_run(const BandEntries& s, const BandRuns& b, int r, int& from,
                                int& to) {
  const int y = b.y + r;  // (a slow entry's run 1 is the next row)
  from = (!b.fast && r == 0) ? b.e + 1 : s.start[y * s.columns + b.x0];
  to = max(from, s.start[y * s.columns + b.x1 + 1]);
}

/// An exclusive scan of `value[0 .. size)` (shared memory) by a block of kThreads threads, a
/// stretch of consecutive items a thread: `put(k, first)` for each item k, with the sum of the
/// items before it, once its own value is read (so `put` may write it over). Returns the sum of
/// all. One barrier inside (cub's); the caller puts one between two scans with the same `temp`.
template <int kThreads, class Put>
__device__ inline int scan_stretches(const int* value, int size,
                                     typename cub::BlockScan<int, kThreads>::TempStorage& temp,
                                     Put&& put) {
  const int per = (size + kThreads - 1) / kThreads;
  const int lo = min(size, static_cast<int>(threadIdx.x) * per), hi = min(size, lo + per);
  int sum = 0;
  for (int k = lo; k < hi; ++k) sum += value[k];
  int at = 0, total = 0;
  cub::BlockScan<int, kThreads>(temp).ExclusiveSum(sum, at, total);
  for (int k = lo; k < hi; ++k) {
    const int v = value[k];
    put(k, at);
    at += v;
  }
  return total;
}

/// Rows a fast particle of speed `vmax` reaches beyond its own (sweep::search_of()'s reach in
/// row heights, rounded up, and one for rounding): find_pairs_banded()'s halo, and what the host
/// expects of it. Not a number when `vmax` is not.
__host__ __device__ inline double halo_rows(const sweep::Grid& g, double vmax) {
  return ceil((g.reach + g.margin + g.half * (2 * vmax)) * (1 + 1e-6) * g.inv_cell) + 1;
}

/// The rows [lo, hi) a band of rows [r0, r1) keeps in its block: its own, `halo` rows below,
/// and `halo` (at least one, the next row of a slow entry's search) above.
__device__ inline void band_rows_kept(int r0, int r1, int halo, int rows, int& lo, int& hi) {
  lo = max(0, r0 - halo);
  hi = min(rows, r1 + max(halo, 1));
}

/// The pair search of a small scene without the counting sort over the grid: a block for each
/// (band of `band` rows, slab k) (grid: bands x slabs) reads every particle's cell in slab k
/// (start_step()'s `band_cell`, 4 bytes a particle), keeps those whose midpoint in slab k lies
/// in its rows or within the fastest particle's reach of them (the halo: start_step()'s
/// `vmax2`), sorts them by cell in shared memory (a counting sort: shared
/// atomics, a block scan), and searches its own rows' entries exactly as find_pairs() and
/// find_fast_pairs() search the same entries of the pass's sort (the same runs: the cells are
/// the grid's, restricted to the rows kept), so the same pairs are filed. A fast entry whose
/// reach leaves the rows kept (a speed past `vmax2`'s, or not a number) is tested by the whole
/// block against every particle of the slab (a pair filed twice is harmless). The block's tests
/// are shared evenly by its threads (each entry's runs and test count, a block scan, then each
/// thread a stretch of consecutive tests), and the pairs that pass are filed together at the
/// end (filing waits on device memory: one wait for all). When the kept entries outgrow
/// `shared_bytes`, more than kWideMost entries reach past the rows kept, or more than kHitMost
/// pairs pass, the block stops the steps (`crowded`); the host then sorts over the grid again.
/// One kernel where the pass has five (bin_count, the scan, bin_scatter, the two searches), and
/// no array of entries in device memory. `halo_most` caps the halo (the grid's rows; fewer only
/// to test the whole-slab search).
__global__ void __launch_bounds__(kBandThreads, 1)
    find_pairs_banded(ParticlesView p, Box box, StepArrays a, DeviceGrid d, int band,
                      int shared_bytes, int halo_most) {
  using Scan = cub::BlockScan<int, kBandThreads>;
  extern __shared__ __align__(16) unsigned char pool[];
  __shared__ typename Scan::TempStorage temp;
  __shared__ int kept, wides, hits;
  __shared__ int wide[kWideMost];
  __shared__ int2 hit[kHitMost];
  wait_for_kernel_before();  // start_step()
  Flags* f = a.flags;
  // Every thread of the block alike (other blocks of this kernel may raise `crowded` while this
  // one starts: a thread that returned alone would leave the others at the barriers).
  if (__syncthreads_or(stopped(f))) return;
  const sweep::Grid& g = d.g;
  const int k = blockIdx.y, columns = g.columns;
  const int r0 = blockIdx.x * band, r1 = min(g.rows, r0 + band);
  // The halo: rows within the fastest particle's reach (sweep::search_of() of a fast one).
  const double vmax = sqrt(__longlong_as_double(f->vmax2[f->steps_done % 2]));
  const double rows_out = halo_rows(g, vmax);
  const int most = min(g.rows, halo_most);
  const int halo = rows_out < most ? static_cast<int>(rows_out) : most;  // (not a number too)
  int lo, hi;
  band_rows_kept(r0, r1, halo, g.rows, lo, hi);
  const int cells = (hi - lo) * columns;
  // Shared memory: each kept cell's start and cursor, then the entries.
  int* start = reinterpret_cast<int*>(pool);
  int* cursor = start + cells + 1;
  const long long used = (2LL * cells + 1) * 4 / 16 * 16 + 16;
  const long long room = (shared_bytes - used - 4) / kBandEntryBytes;
  if (room < 1) {
    if (threadIdx.x == 0) atomicOr(&f->crowded, kCrowdedBands);
    return;
  }
  const int cap = static_cast<int>(room);
  // Midpoint positions and velocities as float pairs (Entry's rounding: the single-precision
  // test, sweep::close_in_slab_single()): a test reads two 8-byte words.
  float2* pos = reinterpret_cast<float2*>(pool + used);
  float2* vel = pos + cap;
  int2* packed = reinterpret_cast<int2*>(vel + cap);  // each own entry's runs (pack_runs())
  int* id = reinterpret_cast<int*>(packed + cap);
  int* kept_id = id + cap;
  int* kept_cell = kept_id + cap;
  int* before = kept_cell + cap;  // cap + 1: each own entry's first test in the block's tests

  for (int c = threadIdx.x; c < cells; c += blockDim.x) start[c] = 0;
  if (threadIdx.x == 0) kept = wides = hits = 0;
  __syncthreads();
  // Count: the particles of slab k whose midpoint row is kept (start_step()'s band_cell_of()),
  // kBandLoads particles a thread at a time (their loads in flight together: the block reads
  // every particle, and one at a time would wait for each).
  const double tm = sweep::slab_mid(k, g);
  const int* cell_of = a.band_cell + static_cast<long long>(k) * p.n;
  for (int i0 = threadIdx.x; i0 < p.n; i0 += kBandLoads * kBandThreads) {
    int cell[kBandLoads];
#pragma unroll
    for (int u = 0; u < kBandLoads; ++u) {
      const int i = i0 + u * kBandThreads;
      cell[u] = i < p.n ? cell_of[i] : -1;
    }
#pragma unroll
    for (int u = 0; u < kBandLoads; ++u) {
      const int row = cell[u] >> 16;  // (-1 for -1: no part)
      if (row < lo || row >= hi) continue;
      const int c = (row - lo) * columns + (cell[u] & 0xffff);
      atomicAdd(&start[c], 1);
      const int q = atomicAdd(&kept, 1);
      if (q < cap) {
        kept_id[q] = i0 + u * kBandThreads;
        kept_cell[q] = c;
      }
    }
  }
  __syncthreads();
  const int m = kept;
  if (m > cap) {
    if (threadIdx.x == 0) atomicOr(&f->crowded, kCrowdedBands);
    return;
  }
  // Each cell's start (its count scanned in place), and the scatter's cursor.
  scan_stretches<kBandThreads>(start, cells, temp,
                               [&](int c, int at) { start[c] = cursor[c] = at; });
  if (threadIdx.x == 0) start[cells] = m;
  __syncthreads();
  // Scatter: each kept particle to its cell, with what the search reads.
  for (int q = threadIdx.x; q < m; q += blockDim.x) {
    const int i = kept_id[q], e = atomicAdd(&cursor[kept_cell[q]], 1);
    pos[e] = make_float2(sweep::rounded_midpoint(p.x[i], p.vx[i], tm),
                         sweep::rounded_midpoint(p.y[i], p.vy[i], tm));
    vel[e] = make_float2(static_cast<float>(p.vx[i]), static_cast<float>(p.vy[i]));
    id[e] = i;
  }
  __syncthreads();
  // Search: each entry of the band's own rows over the same runs as find_pairs() (slow) and
  // find_fast_pairs() (fast), the block's tests shared evenly by its threads: each entry's test
  // count, a block scan of them, then each thread a run of consecutive tests (as
  // find_pairs_balanced() shares a warp's). A pair that passes is listed, and the block files
  // the list together afterwards (filing waits on device memory: one wait for all, not one each).
  const int own0 = start[(r0 - lo) * columns], owned = start[(r1 - lo) * columns] - own0;
  const BandEntries kept_entries{pos, vel, start, columns, lo, hi};
  const int per_thread = (owned + kBandThreads - 1) / kBandThreads;
  const int j0 = min(owned, static_cast<int>(threadIdx.x) * per_thread);
  const int j1 = min(owned, j0 + per_thread);
  for (int j = j0; j < j1; ++j) {  // each entry's tests, kept in `before` for now
    const BandRuns b = band_runs(kept_entries, g, own0 + j);
    if (b.wide) {  // reaches past the rows kept: the whole slab, below
      const int w = atomicAdd(&wides, 1);
      if (w < kWideMost) wide[w] = b.e;
    }
    packed[j] = pack_runs(b);
    int count = 0;
    for (int r = 0; r < b.count; ++r) {
      int from, to;
      band_run(kept_entries, b, r, from, to);
      count += to - from;
    }
    before[j] = count;
  }
  // Each entry's first test (its count scanned in place), and the block's tests in all.
  const int total =
      scan_stretches<kBandThreads>(before, owned, temp, [&](int j, int at) { before[j] = at; });
  if (threadIdx.x == 0) before[owned] = total;
  __syncthreads();
  const int share = (total + kBandThreads - 1) / kBandThreads;
  const int t0 = min(total, static_cast<int>(threadIdx.x) * share), t1 = min(total, t0 + share);
  if (t0 < t1) {
    int j = 0, above = owned;  // the entry of test t0: the last j with before[j] <= t0
    while (above - j > 1) {
      const int mid = (j + above) / 2;
      if (before[mid] <= t0) j = mid; else above = mid;
    }
    BandRuns b = unpack_runs(packed[j], own0 + j);
    int r = 0, from = 0, to = 0, skip = t0 - before[j];
    band_run(kept_entries, b, r, from, to);
    while (skip >= to - from) {  // the run of test t0 (the entry has tests past it)
      skip -= to - from;
      band_run(kept_entries, b, ++r, from, to);
    }
    int o = from + skip;
    float2 me = pos[b.e], mv = vel[b.e];
    float ms = fabsf(mv.x) + fabsf(mv.y);
    for (int t = t0; t < t1; ++t) {
      while (o >= to) {  // the next run, or the next entry's first
        if (++r < b.count) {
          band_run(kept_entries, b, r, from, to);
        } else {
          do ++j; while (before[j + 1] == before[j]);  // (entries without tests)
          b = unpack_runs(packed[j], own0 + j);
          r = 0;
          band_run(kept_entries, b, r, from, to);
          me = pos[b.e], mv = vel[b.e];
          ms = fabsf(mv.x) + fabsf(mv.y);
        }
        o = from;
      }
      const float2 op = pos[o], ov = vel[o];
      if (o != b.e &&
          sweep::close_in_slab_single(me.x - op.x, me.y - op.y, mv.x - ov.x, mv.y - ov.y,
                                      ms + (fabsf(ov.x) + fabsf(ov.y)), d.single)) {
        const int h = atomicAdd(&hits, 1);
        if (h < kHitMost) hit[h] = make_int2(b.e, o);
      }
      ++o;
    }
  }
  __syncthreads();
  if (hits > kHitMost) {  // (the pairs of a band are a few dozen)
    if (threadIdx.x == 0) atomicOr(&f->crowded, kCrowdedBands);
    return;
  }
  for (int h = threadIdx.x; h < hits; h += kBandThreads)
    file_pair_of(p, box, a, d, id[hit[h].x], k, id[hit[h].y]);
  __syncthreads();
  const int w = wides;
  if (w > kWideMost) {
    if (threadIdx.x == 0) atomicOr(&f->crowded, kCrowdedBands);
    return;
  }
  for (int u = 0; u < w; ++u) {  // every particle of slab k, the block's threads together
    const int e = wide[u], i = id[e];
    // (in double, from the particle: the whole slab is read from device memory anyway)
    const double2 me = make_double2(p.x[i] + tm * p.vx[i], p.y[i] + tm * p.vy[i]);
    const double2 mv = make_double2(p.vx[i], p.vy[i]);
    for (int j = threadIdx.x; j < p.n; j += blockDim.x) {
      if (j == i || a.last[j] < k) continue;
      if (sweep::close_in_slab(me.x - (p.x[j] + tm * p.vx[j]), me.y - (p.y[j] + tm * p.vy[j]),
                               mv.x - p.vx[j], mv.y - p.vy[j], g))
        file_pair_of(p, box, a, d, i, k, j);
    }
  }
}

/// After the passes: lays the filed pairs into each particle's row (CompactView::place(), once
/// `end` is the exclusive scan of the counts); when the list had no room for them all, stops
/// the batch instead (`overflow` = the pairs the step needs; the host grows the list).
__global__ void place_pairs(StepArrays a) {
  const int q = blockIdx.x * blockDim.x + threadIdx.x;
  const int filed = a.flags->pairs;
  if (filed > a.slots.capacity) {
    if (q == 0) atomicMax(&a.flags->overflow, filed);
    return;
  }
  if (q < filed && !stopped(a.flags)) a.slots.place(q);
}

/// Before the rounds, on the whole GPU: each particle's start (cuda::start_one(): decided at once
/// when it has no pair event) and the list of those with pair events, `a.contested` (as many as
/// `flags->contested`).
__global__ void start_rounds(int n, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || stopped(a.flags)) return;
  if (start_one(i, a) > 0) a.contested[atomicAdd(&a.flags->contested, 1)] = i;
}

/// Every round of the step in one block over the particles start_rounds listed (stage 05's
/// rounds, from the kit: cuda::rounds_block()); nothing when the step was stopped.
__global__ void __launch_bounds__(kResolveThreads) resolve(int n, StepArrays a) {
  if (stopped(a.flags)) return;
  cuda::rounds_block(n, a.flags->contested, a);
}

constexpr int kFinishThreads = 256;  //!< threads per block of finish_small()

/// Pair events a thread of finish_small() keeps in registers: as many as the search files in
/// each particle's slots (CompactView::slot).
constexpr int kHeld = Slots::kSlotted;

/// A particle's pair events held by its thread of finish_small() (in registers) from one round
/// to the next, so that a round reads only its partners' flags and choices, not its row and the
/// list again: the rounds wait on the loads of each round, one after the other, not on their
/// arithmetic. A particle with more than kHeld events goes through cuda::choose_one() instead.
struct HeldEvents {
  int count = 0;         //!< its pair events (held when at most kHeld)
  double wall = 0;       //!< its wall time
  int other[kHeld]{};    //!< each event's other particle
  double time[kHeld]{};  //!< each event's pair time
  /// Reads particle `i`'s events, when there are at most kHeld: from its slots when `slotted`
  /// (the search filed them there), else from its row (after place_pairs()).
  __device__ void read(int i, const StepArrays& a, bool slotted) {
    if (count > kHeld) return;
    const int* at = slotted ? a.slots.slot + static_cast<long long>(i) * kHeld
                            : a.slots.row + (a.slots.end[i] - count);
    int q[kHeld];
#pragma unroll
    for (int u = 0; u < kHeld; ++u) q[u] = u < count ? at[u] : 0;
#pragma unroll
    for (int u = 0; u < kHeld; ++u) {
      if (u >= count) continue;
      const cuda::Pair& pair = a.slots.list[q[u]];
      other[u] = pair.lo ^ pair.hi ^ i;
      time[u] = pair.t;
    }
  }
  /// cuda::choose_one() over the held events: the same choice, written to `a.best[i]` and
  /// returned (the events compared in another order: key_less() orders them completely). In
  /// the first round every partner is undecided (it has a pair event), so no flag is read.
  __device__ Event choose(int i, const StepArrays& a, const Event& none, bool first) const {
    if (count > kHeld) return choose_one(i, a, none);
    Event b = cuda::wall_or_none(i, wall, none);
    bool open[kHeld];
#pragma unroll
    for (int u = 0; u < kHeld; ++u) open[u] = u < count && (first || !a.resolved[other[u]]);
#pragma unroll
    for (int u = 0; u < kHeld; ++u)
      if (open[u]) cuda::fold_pair(b, i, other[u], time[u]);
    a.best[i] = b;
    return b;
  }
};

/// Everything of a small scene's step after the pair search, in one cooperative kernel of
/// ceil(n / kFinishThreads) blocks (all resident; one thread a particle), with grid-wide
/// barriers where the multi-kernel path has kernel boundaries: start_rounds(), the rounds of
/// resolve_grid(), and apply(). Each thread keeps its particle's count, wall time, events
/// (HeldEvents) and choice in registers over the rounds, so a round's choose reads only the
/// partners' `resolved` flags and its accept only the chosen partner's `best`. The events come
/// from the slots the search filed them in (CompactView::slot); when a particle had more than
/// kHeld (`spilled`), from rows laid as the multi-kernel path lays them (each particle's row: a
/// block's rows side by side, at a place one atomic a block takes: rows need not be in the
/// particles' order, only apart, so no scan over the grid; then place_pairs()). The rounds take
/// a particle's events in any order (the event key orders them completely) and every
/// particle's arithmetic is that of those kernels, so the same bits; one kernel where the
/// multi-kernel path has five, and 2 x rounds grid barriers (2 more to lay rows). Nothing when
/// the step was stopped; stops it (as place_pairs()) when the list had no room.
__global__ void __launch_bounds__(kFinishThreads)
    finish_small(ParticlesView p, Box box, StepArrays a) {
  namespace cg = cooperative_groups;
  using Scan = cub::BlockScan<int, kFinishThreads>;
  __shared__ typename Scan::TempStorage temp;
  cg::grid_group grid = cg::this_grid();
  Flags* f = a.flags;
  const int n = p.n;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;  // this thread's particle, if i < n
  // Every block decides alike: `overflow` only ever rises, and the list's length is final.
  const int filed = f->pairs;
  if (stopped(f) || filed > a.slots.capacity) {
    if (i == 0 && filed > a.slots.capacity) atomicMax(&f->overflow, filed);
    return;
  }
  HeldEvents held;
  if (i < n) {
    held.count = a.slots.count[i];
    held.wall = a.wall[i];
    cuda::start_from(i, held.count, held.wall, a);  // start_rounds()
  }
  const bool slotted = a.slots.slot != nullptr && !f->spilled;  // (final: the search is done)
  if (!slotted) {  // each particle's row, then place_pairs()
    int mine = 0, total = 0;
    Scan(temp).ExclusiveSum(held.count, mine, total);
    __shared__ int base;
    if (threadIdx.x == 0) base = atomicAdd(&f->rows, total);
    __syncthreads();
    if (i < n) a.slots.end[i] = base + mine;
    grid.sync();
    for (int q = i; q < filed; q += gridDim.x * blockDim.x) a.slots.place(q);
    grid.sync();
  }
  bool open = i < n && held.count > 0;  // undecided
  if (open) held.read(i, a, slotted);
  const Event none = model::pair_event_key(model::never(), n, n);
  for (int round = 0;; ++round) {  // resolve_grid()'s rounds
    if (i == 0) f->open[(round + 1) % 3] = 0;
    Event b = none;
    if (open) b = held.choose(i, a, none, round == 0);
    grid.sync();
    if (open) {
      open = !cuda::accept_choice(i, b, a);
      if (open) f->open[round % 3] = 1;
    }
    grid.sync();
    if (!f->open[round % 3]) break;
  }
  if (i == 0) f->steps_done += 1;
  if (i < n) apply_planned<true>(p, a.partner, a.ptime, i, box.L, box.r);  // apply()
}

constexpr int kBlockFinishThreads = 1024;  //!< threads of finish_block()'s one block

/// The step's arrays as finish_block() gives them to the rounds (cuda/rounds.cuh reads them by
/// name): the candidates (counts, rows, the list) and the resolved flags in shared memory, the
/// rest in device memory.
struct BlockArrays {
  double* wall;    //!< StepArrays::wall
  Slots slots;     //!< the candidates, in shared memory
  Event* best;     //!< StepArrays::best
  char* resolved;  //!< in shared memory
  int* contested;  //!< StepArrays::contested
  int* partner;    //!< StepArrays::partner
  double* ptime;   //!< StepArrays::ptime
  Flags* flags;    //!< StepArrays::flags
};

/// Shared memory finish_block() needs for `n` particles and `pairs` filed pairs: each
/// particle's count, row end and flag (9 bytes), each pair (16) and its two events' rows (8).
__host__ __device__ inline long long finish_block_bytes(int n, int pairs) {
  return 9LL * n + 24LL * pairs + 64;
}

/// Everything of a small scene's step after the pair search but apply, in one block, with the
/// candidates in shared memory: each particle's row of events (a block scan of the counts) and
/// start_rounds(), place_pairs(), and the rounds (cuda::rounds_block(): block barriers instead of
/// finish_small()'s grid barriers, and the candidates read from shared memory instead of device
/// memory). The same rounds over the same candidates: the same plan. apply() follows on the
/// whole GPU. Nothing when the step was stopped; stops it as place_pairs() does when the list
/// had no room, and (`crowded`, kCrowdedFinish) when the filed pairs do not fit `shared_bytes`.
__global__ void __launch_bounds__(kBlockFinishThreads, 1)
    finish_block(int n, StepArrays a, int shared_bytes) {
  using Scan = cub::BlockScan<int, kBlockFinishThreads>;
  extern __shared__ __align__(16) unsigned char pool[];
  __shared__ typename Scan::TempStorage temp;
  __shared__ int contested;
  Flags* f = a.flags;
  const int filed = f->pairs;
  if (stopped(f) || filed > a.slots.capacity) {
    if (threadIdx.x == 0 && filed > a.slots.capacity) atomicMax(&f->overflow, filed);
    return;
  }
  if (finish_block_bytes(n, filed) > shared_bytes) {
    if (threadIdx.x == 0) atomicOr(&f->crowded, kCrowdedFinish);
    return;
  }
  cuda::Pair* list = reinterpret_cast<cuda::Pair*>(pool);
  int* count = reinterpret_cast<int*>(list + filed);
  int* end = count + n;
  int* row = end + n;
  char* resolved = reinterpret_cast<char*>(row + 2LL * filed);
  const BlockArrays s{a.wall,      Slots{count, end, list, filed, row}, a.best, resolved,
                      a.contested, a.partner, a.ptime, f};
  if (threadIdx.x == 0) contested = 0;
  for (int i = threadIdx.x; i < n; i += kBlockFinishThreads) count[i] = a.slots.count[i];
  for (int q = threadIdx.x; q < filed; q += kBlockFinishThreads) list[q] = a.slots.list[q];
  __syncthreads();
  // Each particle's row (an exclusive scan of the counts), and start_rounds().
  scan_stretches<kBlockFinishThreads>(count, n, temp, [&](int i, int at) {
    end[i] = at;
    if (start_one(i, s) > 0) a.contested[atomicAdd(&contested, 1)] = i;
  });
  __syncthreads();
  for (int q = threadIdx.x; q < filed; q += kBlockFinishThreads) s.slots.place(q);
  __syncthreads();
  cuda::rounds_block(n, contested, s);
}

/// resolve() for large N: the same rounds over the whole grid (a cooperative launch, every block
/// resident), with grid-wide barriers between the phases instead of block barriers.
__global__ void resolve_grid(int n, StepArrays a) {
  namespace cg = cooperative_groups;
  cg::grid_group grid = cg::this_grid();
  Flags* f = a.flags;
  const int stride = gridDim.x * blockDim.x;
  const int me = blockIdx.x * blockDim.x + threadIdx.x;
  if (stopped(f)) return;  // written before this kernel: every block returns alike
  const int m = f->contested;
  const Event none = model::pair_event_key(model::never(), n, n);
  for (int round = 0;; ++round) {
    // Three flags: round r writes r % 3 and everyone reads it after the last barrier of round r;
    // clearing (r + 1) % 3 now cannot meet a slow reader of round r - 1's flag.
    if (me == 0) f->open[(round + 1) % 3] = 0;
    for (int q = me; q < m; q += stride)  // choose
      if (!a.resolved[a.contested[q]]) choose_one(a.contested[q], a, none);
    grid.sync();
    for (int q = me; q < m; q += stride)  // accept
      if (!a.resolved[a.contested[q]] && !accept_one(a.contested[q], a)) f->open[round % 3] = 1;
    grid.sync();
    if (!f->open[round % 3]) break;
  }
  if (me == 0) f->steps_done += 1;
}

/// Applies the plan (plab::apply_one()'s own code, on the device, with branchless walls);
/// nothing when the step was skipped.
__global__ void apply(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n || stopped(a.flags)) return;
  apply_planned<true>(p, a.partner, a.ptime, i, box.L, box.r);
}

}  // namespace plab::kernels
