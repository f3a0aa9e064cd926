/// \file stages/04-cuda/kernels.cuh
/// \brief Stage 04's kernels (device code only): one thread per particle for every phase of V3.
#pragma once

#include "plab/cuda/particles.hpp"
#include "plab/model.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

using cuda::ParticlesView;
using model::Event;

constexpr int kFree = -1;  //!< `partner[i]`: particle `i` moves freely (as plab::Plan)
constexpr int kWall = -2;  //!< `partner[i]`: particle `i` hits a wall

/// One step's working arrays on the device (pointers into memory the host class owns).
struct StepArrays {
  double* wall;    //!< wall time of each particle
  int* count;      //!< pair events found for each particle (can exceed `cap`)
  int* other;      //!< the other particle of slot `s` of particle `i`, at `[i * cap + s]`
  double* time;    //!< the pair time of that slot
  int cap;         //!< slots per particle
  Event* best;     //!< each unresolved particle's earliest event in the current round
  char* resolved;  //!< 1 once a particle's event (or none) is decided
  int* partner;    //!< the plan: kFree, kWall, or the other particle of its pair
  double* ptime;   //!< the plan's pair time
  int* flags;      //!< [0]: a round left a particle unresolved; [1]: largest count above cap
};

/// Starts a step: wall times, nothing resolved, no plan.
__global__ void start_step(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  a.wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
  a.resolved[i] = 0;
  a.partner[i] = kFree;
}

// EXERCISE 1: find_pairs, one thread per particle i: every j != i whose pair event with i falls in
// this step goes to i's slots (count them all; store the first cap; report a larger count).
// Hints: compute every pair as pair_time(lower index, higher index) so that both particles get the
// same bits; slot s of particle i is other[i * cap + s] and time[i * cap + s]; raise flags[1] to
// the count with atomicMax when it exceeds cap (the host then grows the slots and runs it again).

// EXERCISE 2: a round in two kernels: choose (each unresolved particle's earliest event among its
// wall and its unresolved partners) and accept (a wall, no event, or a pair both chose).
// Hints: "none" is model::pair_event_key(model::never(), n, n); compare events with
// model::key_less(); accept writes only particle i (partner, ptime, resolved) and sets flags[0] to
// 1 when i is left for the next round. Stage 03's rounds are the same algorithm.

// EXERCISE 3: apply, one thread per particle; a pair is applied by its lower index.
// Hints: partner[i] is kFree, kWall or the other particle; the model header has free_move(),
// wall_event() and pair_event().

}  // namespace plab::kernels
