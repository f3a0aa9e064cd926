/// \file solutions/01-naive/step.cpp
/// \brief Stage 01, naive (the 2019 report's V1): every event time in arrays, then the global
/// minimum picked again and again. O(N^2) memory and O(N^3) time per step, by design.
//
// =================================================================================================
//  GOAL   Advance every particle by one step, exactly as model.md says, the simplest way:
//         1. compute every wall time and every pair time (an N x N matrix) from the start state;
//         2. pick the earliest event among particles still free, accept it, repeat until no event
//            before t = 1 is left;
//         3. apply the chosen events (the rest move freely).
//  READ   handouts/01-naive.md          TEST   ./plab test --impl student --stage 01
// =================================================================================================
#include <vector>

#include "plab/stage.hpp"

namespace plab {

void step(const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  const auto at = [n](int i, int j) { return static_cast<std::size_t>(i) * n + j; };
  std::vector<double> wall(n, model::never());
  std::vector<double> pair(static_cast<std::size_t>(n) * n, model::never());

  // EXERCISE 1: compute every wall time, and the pair time of every i < j into pair[at(i, j)].
  for (int i = 0; i < n; ++i) {
    wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
    for (int j = i + 1; j < n; ++j) pair[at(i, j)] = pair_candidate(box, p, i, j).t;
  }

  // EXERCISE 2: select the earliest event (by model::key_less) among free particles, accept it
  // into the plan, and repeat until the earliest is not in this step.
  Plan plan;
  plan.reset(n);
  while (true) {
    model::Event best = model::pair_event_key(model::never(), n, n);
    for (int i = 0; i < n; ++i) {
      if (plan.taken(i)) continue;
      const model::Event w = model::wall_event_key(wall[i], i);
      if (model::key_less(w, best)) best = w;
      for (int j = i + 1; j < n; ++j) {
        if (plan.taken(j)) continue;
        const model::Event e = model::pair_event_key(pair[at(i, j)], i, j);
        if (model::key_less(e, best)) best = e;
      }
    }
    if (!model::in_step(best.t)) break;
    plan.accept(best);
  }

  // EXERCISE 3: apply the chosen events: plab::apply_one() for every particle.
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

/// Stage 01's entry point (stage.hpp): the kit runs step() on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
