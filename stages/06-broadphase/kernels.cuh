/// \file stages/06-broadphase/kernels.cuh
/// \brief Stage 06's kernels (device code only): the space-time grid built by a counting sort on
/// the GPU (atomics, a CUB scan), the pair search over neighbouring buckets, then stage 05's
/// one-block rounds and branchless apply over the sparse candidates.
#pragma once

#include <cooperative_groups.h>

#include "plab/cuda/particles.hpp"
#include "plab/cuda/rounds.cuh"
#include "plab/cuda/slots.cuh"
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
  int overflow;          //!< largest slot count needed, when a step ran out of slots (else 0)
  long long steps_done;  //!< steps applied so far
  int contested;         //!< resolve_grid: particles with pair events this step
  int open[3];           //!< resolve_grid: someone left unresolved in round r (at r % 3)
};

/// The grid of the batch, as the kernels see it.
struct DeviceGrid {
  sweep::Grid g;  //!< slabs, cells, v_cut
  int cells;      //!< g.cells(): slab k's cells are buckets [k * cells, (k + 1) * cells)
};

/// What the pair search reads of an entry, in one 32-byte sector (the scatter writes it at a
/// random place: one sector, not four).
struct alignas(32) Entry {
  double x, y;    //!< midpoint position
  double vx, vy;  //!< velocity
};

/// Each particle's pair events of the step: slot `s` of particle `i` at `[s * n + i]` (as
/// stage 05).
using Slots = cuda::SlotsView<cuda::SlotLayout::kBySlot>;

/// One step's working arrays (pointers into memory the host class owns).
struct StepArrays {
  double* wall;      //!< wall time of each particle
  int* last;         //!< the last slab each particle takes part in (sweep::last_slab())
  Slots slots;       //!< each particle's pair events of the step (count, other, time, cap)
  Event* best;       //!< each unresolved particle's earliest event in the current round
  char* resolved;    //!< 1 once a particle's event (or none) is decided
  int* contested;    //!< the particles with at least one pair event
  int* partner;      //!< the plan: Plan::kFree, Plan::kWall, or the other particle of its pair
  double* ptime;     //!< the plan's pair time
  int* filled;       //!< K * cells + 1: entries counted into each bucket
  int* start;        //!< K * cells + 1: bucket b holds entries [start[b], start[b + 1])
  int* bucket;       //!< per (slab, particle) at [k * n + i]: its bucket
  int* rank;         //!< ... and its place in the bucket
  int* entry_id;     //!< per entry (at most K * N): the particle
  int* entry_k;      //!< ... its slab
  Entry* entry;      //!< ... its midpoint position and velocity
  Flags* flags;      //!< see Flags
};

/// Wall times, the last slab of each particle, counters cleared.
__global__ void start_step(ParticlesView p, Box box, StepArrays a, DeviceGrid d) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  a.wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
  a.last[i] = sweep::last_slab(sweep::path_end(a.wall[i]), d.g);
  a.slots.count[i] = 0;
  if (i == 0) {
    a.flags->contested = 0;
    a.flags->open[0] = a.flags->open[1] = a.flags->open[2] = 0;
  }
}

/// Particle i's midpoint position in slab k.
__device__ inline void midpoint(const ParticlesView& p, int i, int k, const DeviceGrid& d,
                                double& mx, double& my) {
  const double tm = sweep::slab_mid(k, d.g);
  mx = p.x[i] + tm * p.vx[i];
  my = p.y[i] + tm * p.vy[i];
}

// EXERCISE 4: the broad phase on the GPU, as step.cpp's EXERCISE 1 with one thread per
// (particle, slab), blockIdx.y the slab: bin_count (a particle with a.last[i] >= k finds its bucket
// k * d.cells + cell from its midpoint(), keeps it in a.bucket[k * n + i] and its place,
// atomicAdd(&a.filled[bucket], 1), in a.rank[k * n + i]); after the host's exclusive scan of
// `filled` into `start`, bin_scatter (entry start[bucket] + rank gets the particle, its slab,
// midpoint position and velocity).

/// Whether particles i and j pass the slab test in slab k (then slab k's search finds them).
__device__ inline bool close_in_slab_at(const ParticlesView& p, int i, int j, int k,
                                        const DeviceGrid& d) {
  double xi, yi, xj, yj;
  midpoint(p, i, k, d, xi, yi);
  midpoint(p, j, k, d, xj, yj);
  return sweep::close_in_slab(xi - xj, yi - yj, p.vx[i] - p.vx[j], p.vy[i] - p.vy[j], d.g);
}

/// Entry e against entries [from, to) of its slab: the pairs that pass sweep::close_in_slab()
/// get model.md's pair time, unless slab k - 1 found them already (a pair listed twice is
/// harmless to the rounds, but it fills slots), and are filed when the pair comes before both
/// particles' walls.
__device__ inline void test_entries(const ParticlesView& p, const Box& box, const StepArrays& a,
                                    const DeviceGrid& d, int e, int from, int to) {
  const int i = a.entry_id[e], k = a.entry_k[e];
  const Entry me = a.entry[e];
  for (int f = from; f < to; ++f) {
    const Entry o = a.entry[f];
    if (f == e || !sweep::close_in_slab(me.x - o.x, me.y - o.y, me.vx - o.vx, me.vy - o.vy, d.g))
      continue;
    const int j = a.entry_id[f];
    if (k > 0 && close_in_slab_at(p, i, j, k - 1, d)) continue;  // found in slab k - 1
    const int lo = i < j ? i : j, hi = i < j ? j : i;
    const double t = model::pair_time(p.x[lo], p.y[lo], p.vx[lo], p.vy[lo], p.x[hi], p.y[hi],
                                      p.vx[hi], p.vy[hi], box.r);
    if (model::in_step(t) && model::before_walls(t, a.wall[lo], a.wall[hi])) {
      a.slots.add(lo, hi, t);
      a.slots.add(hi, lo, t);
    }
  }
}

// EXERCISE 4: find_pairs, one thread per entry e < a.start[slabs * cells] (the entries of this
// step): as step.cpp's search (slab k's cells start at a.start + k * d.cells), with
// sweep::search_of(), sweep::columns_within(), sweep::rows_within() and test_entries(): a slow
// entry over the later entries of its row up to the last column within reach, then the columns
// within reach of the next row; a fast entry over every row within reach.

/// Every round of the step in one block (stage 05's resolve over the sparse candidates, from the
/// kit: cuda::resolve_block()); skips the step when slots ran out.
__global__ void __launch_bounds__(kResolveThreads) resolve(int n, StepArrays a) {
  cuda::resolve_block(n, a);
}

/// resolve() for large N: the same rounds over the whole grid (a cooperative launch, every block
/// resident), with grid-wide barriers between the phases instead of block barriers.
__global__ void resolve_grid(int n, StepArrays a) {
  namespace cg = cooperative_groups;
  cg::grid_group grid = cg::this_grid();
  Flags* f = a.flags;
  const int stride = gridDim.x * blockDim.x;
  const int me = blockIdx.x * blockDim.x + threadIdx.x;
  const bool skipped = f->overflow;  // read before anyone writes them below
  grid.sync();
  if (skipped) return;
  for (int i = me; i < n; i += stride) {
    const int c = start_one(i, a);
    if (c > a.slots.cap) atomicMax(&f->overflow, c);
    if (c > 0) a.contested[atomicAdd(&f->contested, 1)] = i;
  }
  grid.sync();
  if (f->overflow) return;
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
  if (i >= p.n || a.flags->overflow) return;
  apply_planned<true>(p, a.partner, a.ptime, i, box.L, box.r);
}

}  // namespace plab::kernels
