/// \file 05-cuda-streams.cpp
/// \brief Stage 05's idea as a spec: the second stream and the branchless wall event (the
/// exercises), like the given one-block rounds and replayed CUDA graph, change the speed, never
/// the bits: the hand-built cases of stages 01-03 give the same state with each change turned off
/// (StageOptions::off). Skips without a GPU.
#include <vector>

#include "cases.hpp"

namespace {

using namespace plab::spec;

/// Runs `c` with every change on, each one off, and all off.
void expect_with_each_switch_off(const Case& c) {
  std::vector<std::vector<std::string>> variants{{}};
  for (const std::string& s : plab::stage_info().switches) variants.push_back({s});
  variants.push_back(plab::stage_info().switches);
  for (const auto& off : variants) {
    plab::StageOptions options;
    options.off = off;
    std::string named;
    for (const std::string& s : off) named += " " + s;
    SCOPED_TRACE("off:" + (named.empty() ? std::string(" none") : named));
    expect_case(c, options);
  }
}

// The branchless wall event gives the bits of the branchy one: one wall, a corner, and a stop at
// the second wall, each of the two forms.
TEST(Stage05Spec, BranchlessWallsGiveTheSameBits) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  expect_with_each_switch_off(walls());
}

// Every round in one block still chooses the greedy set: the chain of four needs two rounds.
TEST(Stage05Spec, RoundsInOneBlockGiveTheGreedySet) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  expect_with_each_switch_off(chain_of_four());
}

// A replayed graph steps like launched kernels: three steps of a head-on pair (it touches at
// t = 1, collides at time 0 of step 2, then both move freely: 3 -> 2 and 7 -> 8).
TEST(Stage05Spec, AReplayedGraphStepsLikeLaunchedKernels) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  Case c = head_on_at_one();
  c.steps = 3;
  c.expected = state({{2, 5, -1, 0}, {8, 5, 1, 0}}, {1, 1}, {0, 0});
  expect_with_each_switch_off(c);
}

// Every hand-built case of stages 01-03, with each change on and off.
TEST(Stage05Spec, EveryHandBuiltCaseWithEachSwitchOff) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  for (const Case& c : all_cases()) expect_with_each_switch_off(c);
}

}  // namespace
