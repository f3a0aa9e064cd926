/// \file solutions/04-cuda/kernels.cuh
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
/// Particle `i`'s row of V3's matrix, kept sparse: every `j` whose pair event with `i` falls in
/// this step goes to `i`'s slots. Each pair is computed by both of its particles, always as
/// pair_time(lower, higher) so that both get the same bits.
__global__ void find_pairs(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  const double xi = p.x[i], yi = p.y[i], vxi = p.vx[i], vyi = p.vy[i];
  int c = 0;
  for (int j = 0; j < p.n; ++j) {
    if (j == i) continue;
    const double t = (i < j)
        ? model::pair_time(xi, yi, vxi, vyi, p.x[j], p.y[j], p.vx[j], p.vy[j], box.r)
        : model::pair_time(p.x[j], p.y[j], p.vx[j], p.vy[j], xi, yi, vxi, vyi, box.r);
    if (!model::in_step(t)) continue;
    a.slots.put(i, c, j, t);
    ++c;
  }
  a.slots.count[i] = c;
  if (c > a.slots.cap) atomicMax(&a.flags->overflow, c);
}

// EXERCISE 3: a round in two kernels: choose (each unresolved particle's earliest event among its
// wall and its unresolved partners) and accept (a wall, no event, or a pair both chose).
/// A round, first half: each unresolved particle's earliest event among its wall and its pairs
/// with unresolved partners (or "none", which sorts after every real event).
__global__ void choose(int n, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || a.resolved[i]) return;
  Event b = model::in_step(a.wall[i]) ? model::wall_event_key(a.wall[i], i)
                                      : model::pair_event_key(model::never(), n, n);
  for (int s = 0; s < a.slots.count[i]; ++s) {
    const int o = a.slots.other_at(i, s);
    if (a.resolved[o]) continue;
    const Event e = model::pair_event_key(a.slots.time_at(i, s), i < o ? i : o, i < o ? o : i);
    if (model::key_less(e, b)) b = e;
  }
  a.best[i] = b;
}

/// A round, second half: accept a wall, no event, or a pair both particles chose; each thread
/// writes only its own particle. Raises flags->unresolved when someone is left for the next round.
__global__ void accept(int n, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || a.resolved[i]) return;
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
    a.flags->unresolved = 1;
  }
}

// EXERCISE 4: apply, one thread per particle; a pair is applied by its lower index.
/// Applies the plan: a free move, a wall event, or a pair event (by its lower index, which
/// writes both particles): plab::apply_one()'s own code, on the device.
__global__ void apply(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  apply_planned(p, a.partner, a.ptime, i, box.L, box.r);
}

}  // namespace plab::kernels
