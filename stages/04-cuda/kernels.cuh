/// \file stages/04-cuda/kernels.cuh
/// \brief Stage 04's kernels (device code only): one thread per particle for every phase of V3.
#pragma once

#include "plab/cuda/particles.hpp"
#include "plab/cuda/slots.cuh"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

using cuda::ParticlesView;
using model::Event;

/// Each particle's pair events of the step: slot `s` of particle `i` at `[i * cap + s]`.
using Slots = cuda::SlotsView<cuda::SlotLayout::kByParticle>;

/// What the host reads after find_pairs and after each round.
struct Flags {
  int unresolved;  //!< a round left a particle unresolved
  int overflow;    //!< largest count above the slots' cap (else 0)
};

/// One step's working arrays on the device (pointers into memory the host class owns).
struct StepArrays {
  double* wall;    //!< wall time of each particle
  Slots slots;     //!< each particle's pair events of the step (count, other, time, cap)
  Event* best;     //!< each unresolved particle's earliest event in the current round
  char* resolved;  //!< 1 once a particle's event (or none) is decided
  int* partner;    //!< the plan: Plan::kFree, Plan::kWall, or the other particle of its pair
  double* ptime;   //!< the plan's pair time
  Flags* flags;    //!< see Flags
};

/// Starts a step: wall times, nothing resolved, no plan.
__global__ void start_step(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  a.wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
  a.resolved[i] = 0;
  a.partner[i] = Plan::kFree;
}

// EXERCISE 2: find_pairs, one thread per particle i: every j != i whose pair event with i falls in
// this step goes to i's slots (count them all; store the first cap; report a larger count).
// Hints: compute every pair as pair_time(lower index, higher index) so that both particles get the
// same bits; a.slots.put(i, c, j, t) stores the c-th event of particle i when c < cap (slot c of
// particle i); count them all into a.slots.count[i], and raise a.flags->overflow to the count with
// atomicMax when it exceeds a.slots.cap (the host then grows the slots and runs it again).

// EXERCISE 3: a round in two kernels: choose (each unresolved particle's earliest event among its
// wall and its unresolved partners) and accept (a wall, no event, or a pair both chose).
// Hints: "none" is model::pair_event_key(model::never(), n, n); slot s of particle i is
// a.slots.other_at(i, s) and a.slots.time_at(i, s), s < a.slots.count[i]; compare events with
// model::key_less(); accept writes only particle i (partner: Plan::kWall or the other particle;
// ptime, resolved) and sets a.flags->unresolved to 1 when i is left for the next round. Stage 03's
// rounds are the same algorithm.

// EXERCISE 4: apply, one thread per particle; a pair is applied by its lower index.
// Hints: plab::apply_planned() (plan.hpp) is plab::apply_one() on plain arrays, for host and
// device: give it the particles' view, the plan's partner and ptime arrays, i, box.L and box.r.

}  // namespace plab::kernels
