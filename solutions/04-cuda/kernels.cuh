/// \file solutions/04-cuda/kernels.cuh
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
    if (c < a.cap) {
      a.other[i * a.cap + c] = j;
      a.time[i * a.cap + c] = t;
    }
    ++c;
  }
  a.count[i] = c;
  if (c > a.cap) atomicMax(&a.flags[1], c);
}

// EXERCISE 2: a round in two kernels: choose (each unresolved particle's earliest event among its
// wall and its unresolved partners) and accept (a wall, no event, or a pair both chose).
/// A round, first half: each unresolved particle's earliest event among its wall and its pairs
/// with unresolved partners (or "none", which sorts after every real event).
__global__ void choose(int n, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || a.resolved[i]) return;
  Event b = model::in_step(a.wall[i]) ? model::wall_event_key(a.wall[i], i)
                                      : model::pair_event_key(model::never(), n, n);
  for (int s = 0; s < a.count[i]; ++s) {
    const int o = a.other[i * a.cap + s];
    if (a.resolved[o]) continue;
    const Event e = model::pair_event_key(a.time[i * a.cap + s], i < o ? i : o, i < o ? o : i);
    if (model::key_less(e, b)) b = e;
  }
  a.best[i] = b;
}

/// A round, second half: accept a wall, no event, or a pair both particles chose; each thread
/// writes only its own particle. Raises flags[0] when someone is left for the next round.
__global__ void accept(int n, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || a.resolved[i]) return;
  const Event e = a.best[i];
  const int o = (e.lo == i) ? e.hi : e.lo;
  if (!model::in_step(e.t)) {
    a.resolved[i] = 1;
  } else if (e.kind == model::kWall) {
    a.partner[i] = kWall;
    a.resolved[i] = 1;
  } else if (a.best[o].kind == model::kPair && a.best[o].lo == e.lo && a.best[o].hi == e.hi) {
    a.partner[i] = o;
    a.ptime[i] = e.t;
    a.resolved[i] = 1;
  } else {
    a.flags[0] = 1;
  }
}

// EXERCISE 3: apply, one thread per particle; a pair is applied by its lower index.
/// Applies the plan: a free move, a wall event, or a pair event (by its lower index, which
/// writes both particles).
__global__ void apply(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n) return;
  const int j = a.partner[i];
  if (j == kFree) {
    model::free_move(p.x[i], p.y[i], p.vx[i], p.vy[i]);
  } else if (j == kWall) {
    model::wall_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.wc[i], box.L, box.r);
  } else if (i < j) {
    model::pair_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.pc[i], p.x[j], p.y[j], p.vx[j], p.vy[j],
                      p.pc[j], a.ptime[i], box.L, box.r);
  }
}

}  // namespace plab::kernels
