// Stage 03 by "bo": helpers for each phase, rounds until nobody changes.
#include <omp.h>

#include <vector>

#include "plab/candidates.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

struct Choice {
  model::Event ev;
};

// phase 1: every pair event in the step, each thread into its own list
CandidateLists collect_candidates(const Box& box, const Particles& p, std::vector<double>& walls) {
  const int count = static_cast<int>(p.size());
  std::vector<std::vector<FoundPair>> per_thread(omp_get_max_threads());
#pragma omp parallel
  {
    auto& out = per_thread[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 16)
    for (int a = 0; a < count; ++a) {
      walls[a] = model::wall_time(p.x[a], p.y[a], p.vx[a], p.vy[a], box.L, box.r);
      for (int b = a + 1; b < count; ++b) {
        const model::Event cand = pair_candidate(box, p, a, b);
        if (model::in_step(cand.t)) out.push_back(FoundPair{cand.t, a, b});
      }
    }
  }
  CandidateLists lists;
  lists.build(count, per_thread);
  return lists;
}

// phase 2a: the earliest event of each particle still in play
void choose_all(const CandidateLists& lists, const std::vector<double>& walls,
                const std::vector<char>& done, std::vector<Choice>& pick, int count) {
  const model::Event nothing = model::pair_event_key(model::never(), count, count);
#pragma omp parallel for
  for (int a = 0; a < count; ++a) {
    if (done[a]) continue;
    model::Event mine = nothing;
    if (model::in_step(walls[a])) mine = model::wall_event_key(walls[a], a);
    for (int k = lists.start[a]; k < lists.start[a + 1]; ++k) {
      const int b = lists.other[k];
      if (done[b]) continue;
      const model::Event e = a < b ? model::pair_event_key(lists.time[k], a, b)
                                   : model::pair_event_key(lists.time[k], b, a);
      if (model::key_less(e, mine)) mine = e;
    }
    pick[a].ev = mine;
  }
}

// phase 2b: keep the mutual choices; returns how many particles are still open
int accept_all(const std::vector<Choice>& pick, std::vector<char>& done, Plan& plan, int count) {
  int still_open = 0;
#pragma omp parallel for reduction(+ : still_open)
  for (int a = 0; a < count; ++a) {
    if (done[a]) continue;
    const model::Event& e = pick[a].ev;
    bool ok = !model::in_step(e.t) || e.kind == model::kWall;
    if (!ok) {
      const model::Event& theirs = pick[e.lo == a ? e.hi : e.lo].ev;
      ok = theirs.kind == model::kPair && theirs.lo == e.lo && theirs.hi == e.hi;
    }
    if (ok) {
      if (model::in_step(e.t)) plan.accept_for(a, e);
      done[a] = 1;
    } else {
      ++still_open;
    }
  }
  return still_open;
}

}  // namespace

void step(const Box& box, Particles& p) {
  const int count = static_cast<int>(p.size());
  std::vector<double> walls(count);
  const CandidateLists lists = collect_candidates(box, p, walls);
  Plan plan;
  plan.reset(count);
  std::vector<char> done(count, 0);
  std::vector<Choice> pick(count);
  while (true) {
    choose_all(lists, walls, done, pick, count);
    if (accept_all(pick, done, plan, count) == 0) break;
  }
#pragma omp parallel for
  for (int a = 0; a < count; ++a) apply_one(box, p, plan, a);
}

std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
