/// \file solutions/05-cuda-streams/kernels.cuh
/// \brief Stage 05's kernels (device code only): the branchless wall event (exercise 2), and,
/// given, the pair search split over a 2D grid with tiles in shared memory and every round of a
/// step in one block.
#pragma once

#include <type_traits>

#include "plab/cuda/particles.hpp"
#include "plab/cuda/slots.cuh"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

using cuda::ParticlesView;
using model::Event;

constexpr int kPairThreads = 128;  //!< threads per block of find_pairs (one per particle `i`)
constexpr int kTile = 256;         //!< particles `j` per block of find_pairs (in shared memory)
constexpr int kResolveThreads = 1024;  //!< the one block of resolve

/// What the host reads after a batch of steps.
struct Flags {
  int overflow;          //!< largest slot count needed, when a step ran out of slots (else 0)
  int unused;            //!< (padding)
  long long steps_done;  //!< steps applied so far
};

/// Each particle's pair events of the step: slot `s` of particle `i` at `[s * n + i]`, so that
/// neighbouring threads read neighbouring addresses (coalesced).
using Slots = cuda::SlotsView<cuda::SlotLayout::kBySlot>;

/// One step's working arrays on the device (pointers into memory the host class owns).
struct StepArrays {
  double* wall;    //!< wall time of each particle
  Slots slots;     //!< each particle's pair events of the step (count, other, time, cap)
  Event* best;     //!< each unresolved particle's earliest event in the current round
  char* resolved;  //!< 1 once a particle's event (or none) is decided
  int* contested;  //!< the particles with at least one pair event (they need rounds)
  int* partner;    //!< the plan: Plan::kFree, Plan::kWall, or the other particle of its pair
  double* ptime;   //!< the plan's pair time
  Flags* flags;    //!< see Flags
};

/// Wall times (on one stream, while find_pairs runs on another).
__global__ void wall_times(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  a.wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
}

/// The pair search on a 2D grid: block (x, y) pairs particles `i` of x's 128 with particles `j`
/// of y's tile of 256, held in shared memory, and computes only `j > i` (blocks wholly below the
/// diagonal return at once). A pair found goes to both particles' slots. Many more threads than
/// particles: at N = 10^4 one thread per particle would leave most of an H100 idle.
__global__ void find_pairs(ParticlesView p, Box box, StepArrays a) {
  __shared__ double sx[kTile], sy[kTile], svx[kTile], svy[kTile];
  const int i0 = blockIdx.x * blockDim.x;
  const int j0 = blockIdx.y * kTile;
  if (j0 + kTile <= i0 + 1) return;  // no j > i in this block
  for (int k = threadIdx.x; k < kTile; k += blockDim.x) {
    const int j = j0 + k;
    if (j < p.n) {
      sx[k] = p.x[j];
      sy[k] = p.y[j];
      svx[k] = p.vx[j];
      svy[k] = p.vy[j];
    }
  }
  __syncthreads();
  const int i = i0 + threadIdx.x;
  if (i >= p.n) return;
  const double xi = p.x[i], yi = p.y[i], vxi = p.vx[i], vyi = p.vy[i];
  const int end = min(j0 + kTile, p.n);
  for (int j = max(j0, i + 1); j < end; ++j) {
    const int k = j - j0;
    const double t = model::pair_time(xi, yi, vxi, vyi, sx[k], sy[k], svx[k], svy[k], box.r);
    if (model::in_step(t)) {
      a.slots.add(i, j, t);
      a.slots.add(j, i, t);
    }
  }
}

/// A round's first half for unresolved particle `i` (stage 04's choose): its earliest event
/// among its wall and its pairs with unresolved partners, or `none`.
__device__ inline void choose_one(int i, const StepArrays& a, const Event& none) {
  Event b = model::in_step(a.wall[i]) ? model::wall_event_key(a.wall[i], i) : none;
  for (int s = 0; s < a.slots.count[i]; ++s) {
    const int o = a.slots.other_at(i, s);
    if (a.resolved[o]) continue;
    const Event e = model::pair_event_key(a.slots.time_at(i, s), i < o ? i : o, i < o ? o : i);
    if (model::key_less(e, b)) b = e;
  }
  a.best[i] = b;
}

/// A round's second half for unresolved particle `i` (stage 04's accept): takes a wall, no
/// event, or a pair both particles chose. Returns false when `i` is left for the next round.
__device__ inline bool accept_one(int i, const StepArrays& a) {
  const Event e = a.best[i];
  const int o = (e.lo == i) ? e.hi : e.lo;
  if (!model::in_step(e.t)) {
    a.resolved[i] = 1;
  } else if (e.kind == model::kWall) {
    a.partner[i] = Plan::kWall;
    a.resolved[i] = 1;
  } else if (a.best[o].kind == model::kPair && a.best[o].lo == e.lo && a.best[o].hi == e.hi) {
    a.partner[i] = o;
    a.ptime[i] = e.t;
    a.resolved[i] = 1;
  } else {
    return false;
  }
  return true;
}

/// Every round of the step in one block, so that the host never waits: particles without pair
/// events are decided at once (their wall, or nothing); the others go through rounds of
/// choose_one() / accept_one() separated by block barriers. Skips the step (and counts nothing)
/// when a particle has more pair events than slots; the host then grows the slots and runs the
/// step again.
__global__ void __launch_bounds__(kResolveThreads) resolve(int n, StepArrays a) {
  __shared__ int contested;
  if (a.flags->overflow) return;  // an earlier step is waiting for more slots
  if (threadIdx.x == 0) contested = 0;
  __syncthreads();
  int over = 0;
  for (int i = threadIdx.x; i < n; i += blockDim.x) {
    const int c = a.slots.count[i];
    a.partner[i] = (c == 0 && model::in_step(a.wall[i])) ? Plan::kWall : Plan::kFree;
    a.resolved[i] = (c == 0);
    if (c > a.slots.cap) over = max(over, c);
    if (c > 0) a.contested[atomicAdd(&contested, 1)] = i;
  }
  if (__syncthreads_or(over)) {
    if (over) atomicMax(&a.flags->overflow, over);
    return;
  }
  const int m = contested;
  const Event none = model::pair_event_key(model::never(), n, n);
  for (;;) {
    for (int k = threadIdx.x; k < m; k += blockDim.x)  // choose
      if (!a.resolved[a.contested[k]]) choose_one(a.contested[k], a, none);
    __syncthreads();
    int open = 0;
    for (int k = threadIdx.x; k < m; k += blockDim.x)  // accept
      if (!a.resolved[a.contested[k]] && !accept_one(a.contested[k], a)) open = 1;
    if (!__syncthreads_or(open)) break;
  }
  if (threadIdx.x == 0) a.flags->steps_done += 1;
}

/// The branchless wall event (model.md): \f$ e = \min(t_x, t_y) \f$, reflect every axis whose
/// time equals \f$e\f$, then move \f$ \min(1, t_{later}) - e \f$, with \f$ t_{later} = 1 \f$ at a
/// corner. The same operations on every path, so a warp does not split; the same bits as
/// model::wall_event() (the tests compare them).
struct BranchlessWall {
  /// The wall event of particle `(x, y, vx, vy, wc)`, from its start-of-step state.
  template <class Real>
  PLAB_HD void operator()(Real& x, Real& y, Real& vx, Real& vy, long long& wc, Real L,
                          Real r) const {
    const model::WallTimesOf<Real> w = model::wall_times(x, y, vx, vy, L, r);
    const Real e = model::wall_time(w);
    const bool flip_x = (w.tx == e);
    const bool flip_y = (w.ty == e);
    const Real later = (flip_x && flip_y) ? Real(1) : (flip_x ? w.ty : w.tx);
    const Real m = ((later < 1) ? later : Real(1)) - e;
    x = x + e * vx;
    y = y + e * vy;
    model::reflect(vx, vy, flip_x, flip_y);
    x = x + m * vx;
    y = y + m * vy;
    wc = wc + 1;
  }
};

/// Applies the plan (plab::apply_one()'s own code, on the device); `Branchless` picks
/// BranchlessWall over the kit's branchy model::wall_event() (BranchyWall): the same bits, less
/// divergence.
template <bool Branchless>
__global__ void apply(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n || a.flags->overflow) return;
  using Wall = std::conditional_t<Branchless, BranchlessWall, BranchyWall>;
  apply_planned<Wall>(p, a.partner, a.ptime, i, box.L, box.r);
}

}  // namespace plab::kernels
