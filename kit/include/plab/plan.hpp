/// \file plan.hpp
/// \brief The events chosen for one step (at most one per particle), and applying them.
#pragma once

#include <algorithm>
#include <vector>

#include "plab/model.hpp"
#include "plab/scene.hpp"

namespace plab {

/// Each particle's event for this step, one array per field.
struct Plan {
  static constexpr int kFree = -1;  //!< `partner[i]`: no event, particle `i` moves freely
  static constexpr int kWall = -2;  //!< `partner[i]`: particle `i` hits a wall
  std::vector<int> partner;   //!< kFree, kWall, or the index of the other particle of a pair
  std::vector<double> time;   //!< the event time (pairs; unused otherwise)

  /// Clears the plan for `n` particles: every particle free.
  void reset(std::size_t n) {
    partner.assign(n, kFree);
    time.assign(n, 0.0);
  }
  /// Whether particle `i` already has an event.
  [[nodiscard]] bool taken(int i) const { return partner[i] != kFree; }
  /// Records an accepted event for particle `i` only (the other particle of a pair records it
  /// itself): parallel loops where each iteration writes only its own particle use this.
  void accept_for(int i, const model::Event& e) {
    if (e.kind == model::kWall) {
      partner[i] = kWall;
    } else {
      partner[i] = (e.lo == i) ? e.hi : e.lo;
      time[i] = e.t;
    }
  }
  /// Records an accepted event (wall or pair) for its particles.
  void accept(const model::Event& e) {
    if (e.kind == model::kWall) {
      partner[e.lo] = kWall;
    } else {
      partner[e.lo] = e.hi;
      partner[e.hi] = e.lo;
      time[e.lo] = e.t;
      time[e.hi] = e.t;
    }
  }
};

/// Applies particle `i`'s planned event. A pair is applied by its lower index only, so calling
/// this for every `i` in any order, or in parallel, writes each particle exactly once.
template <class Real>
inline void apply_one(const Box& box, ParticlesOf<Real>& p, const Plan& plan, int i) {
  const int j = plan.partner[i];
  const Real L = static_cast<Real>(box.L), r = static_cast<Real>(box.r);
  if (j == Plan::kFree) {
    model::free_move(p.x[i], p.y[i], p.vx[i], p.vy[i]);
  } else if (j == Plan::kWall) {
    model::wall_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.wc[i], L, r);
  } else if (i < j) {
    model::pair_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.pc[i], p.x[j], p.y[j], p.vx[j], p.vy[j],
                      p.pc[j], static_cast<Real>(plan.time[i]), L, r);
  }
}

/// Applies every planned event (sequentially).
template <class Real>
inline void apply(const Box& box, ParticlesOf<Real>& p, const Plan& plan) {
  const int n = static_cast<int>(p.size());
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

/// MODEL.md's selection over a list of candidate events (walls and pairs with t < 1): in key
/// order, each event is accepted when its particles are still free. Sorts `events`.
inline Plan greedy_plan(std::vector<model::Event>& events, std::size_t n) {
  std::sort(events.begin(), events.end(),
            [](const model::Event& a, const model::Event& b) { return model::key_less(a, b); });
  Plan plan;
  plan.reset(n);
  for (const model::Event& e : events)
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
  return plan;
}

/// greedy_plan() when most particles meet nothing but, perhaps, a wall: `pairs` holds the pair
/// candidates (t < 1, in any order, repeats allowed) and `wall[i]` each particle's wall time.
/// A particle in no pair candidate competes with nothing, so its wall (if `wall[i] < 1`) is
/// accepted outright; only the pairs and the walls of their particles are sorted, which gives
/// the same plan as sorting every candidate. Sorts `pairs` and appends those walls to it.
inline Plan sparse_greedy_plan(std::vector<model::Event>& pairs, const std::vector<double>& wall) {
  const int n = static_cast<int>(wall.size());
  Plan plan;
  plan.partner.resize(n);
  plan.time.assign(n, 0.0);
  for (int i = 0; i < n; ++i) plan.partner[i] = model::in_step(wall[i]) ? Plan::kWall : Plan::kFree;
  const std::size_t m = pairs.size();
  for (std::size_t e = 0; e < m; ++e)  // contested: clear, and list its wall once
    for (const int i : {pairs[e].lo, pairs[e].hi}) {
      if (plan.partner[i] == Plan::kWall) pairs.push_back(model::wall_event_key(wall[i], i));
      plan.partner[i] = Plan::kFree;
    }
  std::sort(pairs.begin(), pairs.end(),
            [](const model::Event& a, const model::Event& b) { return model::key_less(a, b); });
  for (const model::Event& e : pairs)
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
  return plan;
}

/// The wall event of particle `i` as a candidate, from its start-of-step state (the time of a
/// `float` run is kept exactly in the event's double).
template <class Real>
inline model::Event wall_candidate(const Box& box, const ParticlesOf<Real>& p, int i) {
  return model::wall_event_key(model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i],
                                                static_cast<Real>(box.L), static_cast<Real>(box.r)),
                               i);
}

/// The pair event of particles `i < j` as a candidate, from their start-of-step state.
template <class Real>
inline model::Event pair_candidate(const Box& box, const ParticlesOf<Real>& p, int i, int j) {
  return model::pair_event_key(model::pair_time(p.x[i], p.y[i], p.vx[i], p.vy[i], p.x[j], p.y[j],
                                                p.vx[j], p.vy[j], static_cast<Real>(box.r)),
                               i, j);
}

}  // namespace plab
