/// \file stages/05-cuda-streams/kernels.cuh
/// \brief Stage 05's kernels (device code only): the pair search split over a 2D grid with tiles in
/// shared memory, every round of a step in one block, and the branchless wall event.
#pragma once

#include "plab/cuda/particles.hpp"
#include "plab/cuda/rounds.cuh"
#include "plab/cuda/slots.cuh"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

using cuda::accept_one;
using cuda::choose_one;
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

// EXERCISE 1: find_pairs on a 2D grid: block (x, y) pairs x's 128 particles i with y's tile of 256
// particles j (in shared memory), j > i only; each pair found goes to both particles' slots.
// Hints: start from stage 04's find_pairs. Load the tile (x, y, vx, vy of j0 .. j0 + kTile - 1)
// into __shared__ arrays with all the block's threads, then __syncthreads(). A block with no j > i
// returns before the barrier (every thread of it alike). File a pair under both particles with
// a.slots.add() (the kit's plab::cuda::SlotsView: atomicAdd on the particle's count, then its
// slot if there is one); the order of slots does not matter, as the event key orders them.

// EXERCISE 2: resolve, every round of a step in one block of kResolveThreads threads.
// Hints: a particle's part of a round (stage 04's choose and accept, per particle) is the kit's
// choose_one(i, a, none) and accept_one(i, a) (plab/cuda/rounds.cuh; "none" is
// model::pair_event_key(model::never(), n, n)): write the block's loop around them, with a block
// barrier (__syncthreads) between choose and accept and __syncthreads_or(open) to decide on
// another round. First decide at once the particles with no pair event (their wall, or nothing)
// and list the others (contested) with a __shared__ counter; the rounds run over those only.
// When a count exceeds a.slots.cap, raise flags->overflow (atomicMax) and return without counting
// the step; when flags->overflow is already set on entry, return at once. Thread 0 adds 1 to
// flags->steps_done at the end.

/// Applies the plan (plab::apply_one()'s own code, on the device); `Branchless` picks model.md's
/// branchless wall event (flip each axis whose time equals the earlier one) over the branchy
/// one: the same bits, less divergence.
template <bool Branchless>
__global__ void apply(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n || a.flags->overflow) return;
  apply_planned<Branchless>(p, a.partner, a.ptime, i, box.L, box.r);
}

}  // namespace plab::kernels
