/// \file stages/02-heap/step.cpp
/// \brief Stage 02, heap (the 2019 report's V2): the candidate events in a binary heap (your
/// heap.hpp), popped in key order and accepted while their particles are free. O(N^2 log N) time
/// per step at worst.
//
// =================================================================================================
//  GOAL   The same step as stage 01, bit for bit, without rescanning N^2 times per accepted event:
//         the candidates (given: stage 01's pair and wall events in this step) go into your
//         MinHeap (heap.hpp, exercises 1 and 2), ordered by model::key_less (plab::EventOrder);
//         3. pop events in order; accept one when none of its particles has an event yet.
//         The chosen events are applied as in stage 01 (given).
//  READ   handouts/02-heap.md           TEST   ./plab test --impl student --stage 02
// =================================================================================================
#include "heap.hpp"
#include "plab/event_order.hpp"
#include "plab/stage.hpp"

namespace plab {

void step(const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  MinHeap<model::Event, EventOrder> heap;  // the earliest by model.md's key on top

  // Every wall event and every pair event (i < j) that happens in this step (stage 01's).
  for (int i = 0; i < n; ++i) {
    const model::Event w = wall_candidate(box, p, i);
    if (model::in_step(w.t)) heap.push(w);
    for (int j = i + 1; j < n; ++j) {
      const model::Event e = pair_candidate(box, p, i, j);
      if (model::in_step(e.t)) heap.push(e);
    }
  }

  Plan plan;
  plan.reset(n);
  // EXERCISE 3: pop events in key order; accept an event when all its particles are still free
  // (plab::Plan's taken() and accept()).
  PLAB_EXERCISE(3, "pop events in order and accept those whose particles are free");

  // The chosen events, applied (stage 01's).
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

/// Stage 02's entry point (stage.hpp): the kit runs step() on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
