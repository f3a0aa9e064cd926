/// \file grading.hpp
/// \brief What the autograder asks of a stage's program: one step from every printed state (to
/// score steps). The events model.md's greedy rule picks are the oracle's (oracle.hpp).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "plab/driver.hpp"
#include "plab/io.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab {

/// For every block of `blocks` (step `k`), starts a run from that state, advances it one step with
/// the stage and writes the result as a block of step `k + 1` (without counters). The grader gives
/// every other state of a run (steps 0, 2, 4, ...), so a step's answer is never in the input.
/// (`blocks` is an output read by parse_output(), io.hpp.)
void step_from_each(const Box& box, const std::vector<OutputBlock>& blocks,
                    const MakeStepper& make, std::FILE* out);

}  // namespace plab
