/// \file grading.hpp
/// \brief What the autograder asks of a stage's program: the events model.md's greedy rule picks in
/// a step (to explain a divergence), and one step from every printed state (to score steps).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "plab/driver.hpp"
#include "plab/io.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab {

/// The events of one step by model.md's rule, computed the plainest way: every candidate (walls,
/// pairs with t < 1) sorted by key, each accepted when its particles are still free. O(N^2 log N):
/// an independent oracle for diagnosis and tests, not a stage.
Plan plan_step(const Box& box, const Particles& p);

/// One line per particle of `which` saying its event in the step that starts from `p`, e.g.
/// `particle 17: pair collision with 42 at t = 0.31270000`, `particle 3: wall at t = 0.5`,
/// `particle 8: moves freely`.
std::string describe_events(const Box& box, const Particles& p, const std::vector<int>& which);

/// For every block `k` of `blocks` but the last, starts a run from that state, advances it one step
/// with the stage and writes the result as block `k + 1` (without counters).
/// (`blocks` is an output read by parse_output(), io.hpp.)
void step_from_each(const Box& box, const std::vector<OutputBlock>& blocks,
                    const MakeStepper& make, std::FILE* out);

}  // namespace plab
