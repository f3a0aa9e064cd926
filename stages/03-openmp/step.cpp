/// \file stages/03-openmp/step.cpp
/// \brief Stage 03, OpenMP (the 2019 report's V3): event times in parallel, then "mutual
/// earliest" rounds, then the events applied in parallel. Same bits as stages 01 and 02 for
/// every thread count.
//
// =================================================================================================
//  GOAL   The step of stages 01-02, with every phase a parallel loop and no locks or atomics:
//         1. wall times and each particle's candidate pair events (time < 1), rows in parallel;
//         2. rounds: every unresolved particle finds its earliest event among partners still
//            unresolved; a wall (or no event) is accepted at once, a pair when both chose it;
//         3. apply the chosen events, every particle in parallel.
//  READ   handouts/03-openmp.md         TEST   ./plab test --impl student --stage 03
// =================================================================================================
#include <omp.h>

#include <vector>

#include "plab/candidates.hpp"
#include "plab/event_order.hpp"
#include "plab/stage.hpp"

namespace plab {

void step([[maybe_unused]] const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  std::vector<double> wall(n);
  std::vector<std::vector<FoundPair>> found(omp_get_max_threads());

  // EXERCISE 1: in parallel over particles, compute wall[i] and every pair event of i with j > i
  // that happens in this step, into the calling thread's own list (no two threads share one).
  // Think about the schedule: row i has n - i - 1 pairs. Use schedule(runtime) so that
  // `plab run --schedule` and `plab bench --schedule` can compare them.
  PLAB_EXERCISE(1, "compute the event times in parallel");
  CandidateLists cand;
  cand.build(n, found);

  // EXERCISE 2: rounds until every particle is resolved. (a) In parallel, each unresolved
  // particle finds its earliest event: its wall, or a candidate pair with an unresolved partner.
  // Compare two events with earlier(a, b): model.md's order, counted by the kit on each thread.
  // (b) In parallel, each unresolved particle accepts its choice when it is a wall, no event, or
  // a pair its partner chose too; each iteration writes only its own particle
  // (plab::Plan::accept_for()), and a reduction over the particles says whether another round is
  // needed.
  Plan plan;
  plan.reset(n);
  std::vector<char> resolved(n, 0);
  std::vector<model::Event> best(n);
  [[maybe_unused]] const EventOrder earlier;  // earlier(a, b): whether a comes before b
  PLAB_EXERCISE(2, "select events in mutual-earliest rounds");

  // EXERCISE 3: apply the chosen events in parallel (plab::apply_one() writes each particle once).
  PLAB_EXERCISE(3, "apply the events in parallel");
}

/// Stage 03's entry point (stage.hpp): the kit runs step() on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
