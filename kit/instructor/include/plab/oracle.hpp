/// \file oracle.hpp
/// \brief The kit's greedy oracle: the events of one step by model.md's rule, computed the
/// plainest way, to explain a divergence (`--explain`) and to audit collisions (`--audit`).
///
/// It is a whole step, so a stage must not call it: it lives in its own library (plab::oracle,
/// kit/instructor/src/oracle.cpp), which the kit's own builds link into the runner, and which a graded build
/// of a submission does not have (the grader's sandbox gets the kit without kit/instructor/, and the
/// runner is built there with PLAB_HAVE_ORACLE=0).
#pragma once

#include <string>
#include <vector>

#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab {

/// The events of one step by model.md's rule, computed the plainest way: every candidate (walls,
/// pairs with t < 1) sorted by key, each accepted when its particles are still free. O(N^2 log N):
/// an independent oracle for diagnosis and tests, not a stage.
Plan plan_step(const Box& box, const Particles& p);

/// The step of plan_step() as stage 03 selects it: "mutual earliest" rounds (each unresolved
/// particle picks its earliest event among unresolved partners; a wall, no event, or a pair both
/// picked is accepted). Returns the plan (the greedy one, as model.md proves) and sets `rounds`
/// to the number of rounds, the last included: what the grader's idea test of stage 03 expects
/// a submission's work-sharing loops to follow (`plab-rounds`). Its comparisons are made with
/// plab::EventOrder, on the calling thread: `plab-rounds` reports their count and later-event sum
/// for the grader to compare with a stage 03's.
Plan plan_in_rounds(const Box& box, const Particles& p, int& rounds);

/// One line per particle of `which` saying its event in the step that starts from `p`, e.g.
/// `particle 17: pair collision with 42 at t = 0.31270000`, `particle 3: wall at t = 0.5`,
/// `particle 8: moves freely`.
std::string describe_events(const Box& box, const Particles& p, const std::vector<int>& which);

/// The same events as JSON, what the grader reads (`--explain K:i,... --json`):
/// `{"particles": [{"i": 17, "event": "pair", "partner": 42, "t": 0.3127}, {"i": 3, "event":
/// "wall", "t": 0.5}, {"i": 8, "event": "free"}]}`, each time the double itself (`%.17g`).
std::string describe_events_json(const Box& box, const Particles& p,
                                 const std::vector<int>& which);

}  // namespace plab
