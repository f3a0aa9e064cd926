/// \file solutions/03-openmp/step.cpp
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

void step(const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  std::vector<double> wall(n);
  std::vector<std::vector<FoundPair>> found(omp_get_max_threads());

  // EXERCISE 1: in parallel over particles, compute wall[i] and every pair event of i with j > i
  // that happens in this step, into the calling thread's own list (no two threads share one).
#pragma omp parallel
  {
    std::vector<FoundPair>& mine = found[omp_get_thread_num()];
#pragma omp for schedule(runtime)
    for (int i = 0; i < n; ++i) {
      wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
      for (int j = i + 1; j < n; ++j) {
        const double t = pair_candidate(box, p, i, j).t;
        if (model::in_step(t)) mine.push_back(FoundPair{t, i, j});
      }
    }
  }
  CandidateLists cand;
  cand.build(n, found);

  // EXERCISE 2: rounds until every particle is resolved. (a) In parallel, each unresolved
  // particle finds its earliest event: its wall, or a candidate pair with an unresolved partner.
  // Compare two events with earlier(a, b): model.md's order, counted by the kit on each thread.
  // (b) In parallel, each unresolved particle accepts its choice when it is a wall, no event, or
  // a pair its partner chose too; each iteration writes only its own particle, and a reduction
  // over the particles says whether another round is needed.
  Plan plan;
  plan.reset(n);
  std::vector<char> resolved(n, 0);
  std::vector<model::Event> best(n);
  const EventOrder earlier;  // earlier(a, b): whether event a comes before b (model::key_less())
  const model::Event none = model::pair_event_key(model::never(), n, n);
  for (bool open = true; open;) {
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      if (resolved[i]) continue;
      model::Event b = model::in_step(wall[i]) ? model::wall_event_key(wall[i], i) : none;
      for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) {
        const int o = cand.other[k];
        if (resolved[o]) continue;
        const model::Event e = model::pair_event_key(cand.time[k], i < o ? i : o, i < o ? o : i);
        if (earlier(e, b)) b = e;
      }
      best[i] = b;
    }
    open = false;
#pragma omp parallel for schedule(static) reduction(|| : open)
    for (int i = 0; i < n; ++i) {
      if (resolved[i]) continue;
      const model::Event& e = best[i];
      const int o = (e.lo == i) ? e.hi : e.lo;
      if (!model::in_step(e.t) || e.kind == model::kWall ||
          (best[o].lo == e.lo && best[o].hi == e.hi && best[o].kind == model::kPair)) {
        if (model::in_step(e.t)) plan.accept_for(i, e);
        resolved[i] = 1;
      } else {
        open = true;
      }
    }
  }

  // EXERCISE 3: apply the chosen events in parallel (plab::apply_one() writes each particle once).
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

/// Stage 03's entry point (stage.hpp): the kit runs step() on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
