/// \file stages/01-naive/step.cpp
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

void step([[maybe_unused]] const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  [[maybe_unused]] const auto at = [n](int i, int j) { return static_cast<std::size_t>(i) * n + j; };
  std::vector<double> wall(n, model::never());
  std::vector<double> pair(static_cast<std::size_t>(n) * n, model::never());

  // EXERCISE 1: compute every wall time, and the pair time of every i < j into pair[at(i, j)].
  // Use model::wall_time() and plab::pair_candidate() (or model::pair_time()); never retype a formula.
  PLAB_EXERCISE(1, "compute every wall and pair time");

  // EXERCISE 2: select the earliest event (by model::key_less) among free particles, accept it
  // into the plan, and repeat until the earliest is not in this step (model::in_step()).
  Plan plan;
  plan.reset(n);
  PLAB_EXERCISE(2, "select the earliest event");

  // EXERCISE 3: apply the chosen events: plab::apply_one() for every particle.
  PLAB_EXERCISE(3, "apply the chosen events");
}

/// Stage 01's entry point (stage.hpp): the kit runs step() on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
