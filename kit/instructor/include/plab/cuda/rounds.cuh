/// \file cuda/rounds.cuh
/// \brief Instructor only (stage 04's exercise 2 and stage 05's one-block rounds, done): the
/// "mutual earliest" rounds on the device, for the kit's own GPU engine and stage 06's GPU path.
/// One particle's part of a round (choose_one(), accept_one(), and start_one() before the first
/// round), every round of a step in one block over a list of contested particles
/// (rounds_block()), or with the start in the same block (resolve_block()).
///
/// A round, for every unresolved particle \f$i\f$ at once:
/// - **choose**: \f$b_i = \min_{\prec} \big(\{w_i\} \cup \{(t_{ik}, \min(i,o_k), \max(i,o_k)) :
///   o_k \text{ unresolved}\}\big)\f$ over its wall event \f$w_i\f$ (if its wall time is in the
///   step, else "none", which sorts after every real event) and its slots \f$k\f$, where
///   \f$\prec\f$ is plab::model::key_less();
/// - **accept** (after a barrier): \f$i\f$ is resolved when \f$b_i\f$ is none (it moves freely),
///   a wall (it hits it), or a pair whose other particle \f$o\f$ chose the same pair,
///   \f$b_o = b_i\f$ (both take it); otherwise \f$i\f$ is left for the next round.
///
/// Each call writes only particle \f$i\f$'s entries, so one thread per particle needs no atomics;
/// the caller separates the two halves by a barrier (a kernel boundary, `__syncthreads()`, a grid
/// sync). The comparisons are stage 04's, in the same order: the same plan, bit for bit.
///
/// `Arrays` is the stage's struct of step arrays (passed to kernels by value); these functions
/// read and write its members by name:
/// - `double* wall`: each particle's wall time (steps);
/// - `SlotsView<Layout> slots`: each particle's pair events of the step (slots.cuh);
/// - `model::Event* best`: each unresolved particle's choice in the current round;
/// - `char* resolved`: 1 once a particle's event (or none) is decided;
/// - `int* partner`, `double* ptime`: the plan (Plan::kFree, Plan::kWall or the other particle,
///   and the pair time);
/// - rounds_block() and resolve_block() only: `int* contested` (room for every particle: the
///   particles the rounds still have to decide), and `flags`, a pointer to the stage's flags with
///   `int overflow` and `long long steps_done`.
#pragma once

#include "plab/branchless.hpp"  // the engine applies its plans with apply_planned<true>
#include "plab/cuda/slots.cuh"
#include "plab/model.hpp"
#include "plab/plan.hpp"

namespace plab::cuda {

/// start_one() from particle `i`'s count of pair events and its wall time, already read (the
/// wall time is read only when the count is 0).
template <class Arrays>
__device__ inline void start_from(int i, int count, double wall, const Arrays& a) {
  a.partner[i] = (count == 0 && model::in_step(wall)) ? Plan::kWall : Plan::kFree;
  a.resolved[i] = (count == 0);
}

/// Before the first round, for every particle `i`: one with no pair event is decided at once
/// (resolved, with its wall when the wall time is in the step, else nothing); one with pair
/// events is left unresolved, with no plan yet. Returns its count of pair events (it takes part
/// in the rounds when the count is above 0; a count above `a.slots.cap` means the slots ran out).
template <class Arrays>
__device__ inline int start_one(int i, const Arrays& a) {
  const int c = a.slots.count[i];
  start_from(i, c, c == 0 ? a.wall[i] : 0, a);
  return c;
}

/// Events choose_one() reads at a time: their loads (the event, then its partner's flag) are in
/// flight together instead of one event after another.
constexpr int kChooseBatch = 4;

/// Folds particle `i`'s pair event with `o` at time `t` into its choice so far `b`: the earlier
/// of the two by model::key_less().
__device__ inline void fold_pair(model::Event& b, int i, int o, double t) {
  const model::Event e = model::pair_event_key(t, i < o ? i : o, i < o ? o : i);
  if (model::key_less(e, b)) b = e;
}

/// Particle `i`'s choice before its pairs: its wall event when the wall time `wall` is in the
/// step, else `none`.
__device__ inline model::Event wall_or_none(int i, double wall, const model::Event& none) {
  return model::in_step(wall) ? model::wall_event_key(wall, i) : none;
}

/// A round's first half for unresolved particle `i`: `a.best[i]` = its earliest event among its
/// wall (when in the step) and its pairs with unresolved partners, or `none`
/// (`model::pair_event_key(model::never(), n, n)`) when it has neither; returns it too. The
/// events are read kChooseBatch at a time; the order in which they are compared does not matter
/// (key_less() is a strict total order, and a pair filed twice gives the same key twice).
template <class Arrays>
__device__ inline model::Event choose_one(int i, const Arrays& a, const model::Event& none) {
  model::Event b = wall_or_none(i, a.wall[i], none);
  const int count = a.slots.count[i];
  for (int s0 = 0; s0 < count; s0 += kChooseBatch) {
    int o[kChooseBatch];
    double t[kChooseBatch];
    bool open[kChooseBatch];
#pragma unroll
    for (int u = 0; u < kChooseBatch; ++u) {
      o[u] = s0 + u < count ? a.slots.other_at(i, s0 + u) : i;
      t[u] = s0 + u < count ? a.slots.time_at(i, s0 + u) : 0;
    }
#pragma unroll
    for (int u = 0; u < kChooseBatch; ++u) open[u] = s0 + u < count && !a.resolved[o[u]];
#pragma unroll
    for (int u = 0; u < kChooseBatch; ++u)
      if (open[u]) fold_pair(b, i, o[u], t[u]);
  }
  a.best[i] = b;
  return b;
}

/// A round's second half for unresolved particle `i` whose choice this round is `e` (every
/// choose_one() of the round done): accepts it when it is none, a wall, or a pair the other
/// particle chose too, writing only particle `i`'s plan entry and `resolved[i]`. Returns false
/// when `i` is left for the next round.
template <class Arrays>
__device__ inline bool accept_choice(int i, const model::Event& e, const Arrays& a) {
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

/// accept_choice() with the choice read from `a.best[i]`.
template <class Arrays>
__device__ inline bool accept_one(int i, const Arrays& a) {
  return accept_choice(i, a.best[i], a);
}

/// Every round of a step in the calling block over the `m` particles listed in `a.contested`
/// (each with pair events and none decided yet; launch one block): rounds of choose_one() and
/// accept_one() separated by block barriers, until a round leaves no one open; then adds 1 to
/// `a.flags->steps_done`.
template <class Arrays>
__device__ inline void rounds_block(int n, int m, const Arrays& a) {
  const model::Event none = model::pair_event_key(model::never(), n, n);
  for (;;) {
    for (int q = threadIdx.x; q < m; q += blockDim.x)  // choose
      if (!a.resolved[a.contested[q]]) choose_one(a.contested[q], a, none);
    __syncthreads();
    int open = 0;
    for (int q = threadIdx.x; q < m; q += blockDim.x)  // accept
      if (!a.resolved[a.contested[q]] && !accept_one(a.contested[q], a)) open = 1;
    if (!__syncthreads_or(open)) break;
  }
  if (threadIdx.x == 0) a.flags->steps_done += 1;
}

/// Every round of a step in the calling block (stage 05's resolve; launch one block): the
/// particles with pair events are listed in `a.contested` (through a `__shared__` counter) and go
/// through rounds_block(). Does nothing when `a.flags->overflow` is set on entry (an earlier step
/// waits for more slots); skips the step (raising `overflow` to the largest count) when a
/// particle has more pair events than slots.
template <class Arrays>
__device__ inline void resolve_block(int n, const Arrays& a) {
  __shared__ int contested;
  if (a.flags->overflow) return;
  if (threadIdx.x == 0) contested = 0;
  __syncthreads();
  int over = 0;
  for (int i = threadIdx.x; i < n; i += blockDim.x) {
    const int c = start_one(i, a);
    if (c > a.slots.cap) over = max(over, c);
    if (c > 0) a.contested[atomicAdd(&contested, 1)] = i;
  }
  if (__syncthreads_or(over)) {
    if (over) atomicMax(&a.flags->overflow, over);
    return;
  }
  rounds_block(n, contested, a);
}

}  // namespace plab::cuda
