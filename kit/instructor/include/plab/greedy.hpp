/// \file greedy.hpp
/// \brief Instructor only: model.md's greedy selection as ready-made functions (greedy_plan() over
/// every candidate, sparse_greedy_plan() over a broad phase's sparse ones). Stages 01-03 and 06
/// ask the student to write this selection, so it lives in kit/instructor/ (the oracle, the tests
/// and the instructor's tools use it); a student release and a graded build leave it out.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include "plab/model.hpp"
#include "plab/plan.hpp"

namespace plab {

/// model.md's selection over a list of candidate events (walls and pairs with t < 1): in key
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

/// greedy_plan() for a broad phase's sparse candidates: `pairs` holds pair candidates (t < 1,
/// in any order, repeats allowed) and `wall[i]` is each particle's wall time. A pair at or after
/// either particle's wall time is dropped first: the wall comes first in key order and takes the
/// particle, or the particle is taken already. Every pair left comes before both its walls, so
/// the greedy pass over the pairs alone, in key order, decides every pair, and each particle it
/// leaves free takes its wall if `wall[i] < 1`: the same plan as sorting every candidate, with
/// only the pairs sorted; a pair whose particles meet no other is accepted without sorting.
/// Reorders `pairs` and keeps only the pairs it did not drop.
inline Plan sparse_greedy_plan(std::vector<model::Event>& pairs, const std::vector<double>& wall) {
  const auto dominated = [&](const model::Event& e) {
    return !model::before_walls(e.t, wall[e.lo], wall[e.hi]);
  };
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(), dominated), pairs.end());
  // A pair whose particles are in no other pair (found once or more) meets nothing earlier: it is
  // accepted without sorting. `only[i]`: particle i's one partner, or kMany.
  constexpr int kNone = -1, kMany = -2;
  std::vector<int> only(wall.size(), kNone);
  for (const model::Event& e : pairs)
    for (const auto& [i, o] : {std::pair{e.lo, e.hi}, std::pair{e.hi, e.lo}})
      only[i] = (only[i] == kNone || only[i] == o) ? o : kMany;
  const auto alone = [&](const model::Event& e) { return only[e.lo] == e.hi && only[e.hi] == e.lo; };
  std::vector<model::Event> isolated;
  for (const model::Event& e : pairs)
    if (alone(e)) isolated.push_back(e);
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(), alone), pairs.end());
  std::sort(pairs.begin(), pairs.end(),
            [](const model::Event& a, const model::Event& b) { return model::key_less(a, b); });
  Plan plan;
  plan.reset(wall.size());
  for (const model::Event& e : isolated)  // the earliest, should one pair come with two times
    if (!plan.taken(e.lo) || model::key_less(e, model::pair_event_key(plan.time[e.lo], e.lo, e.hi)))
      plan.accept(e);
  for (const model::Event& e : pairs)
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
  for (std::size_t i = 0; i < wall.size(); ++i)
    if (!plan.taken(static_cast<int>(i)) && model::in_step(wall[i])) plan.partner[i] = Plan::kWall;
  pairs.insert(pairs.end(), isolated.begin(), isolated.end());
  return plan;
}

}  // namespace plab
