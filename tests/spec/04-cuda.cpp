/// \file 04-cuda.cpp
/// \brief Stage 04's idea as a spec: stage 03's mutual-earliest rounds on the GPU, one thread per
/// particle, give the same bits as the hand-built cases of stages 01-03. Skips without a GPU.
#include "cases.hpp"

namespace {

using namespace plab::spec;

// The rounds on the GPU choose the greedy set for four disks in a row: (2,3) in round 1, then
// (0,1) in round 2, once 2 and 3 are resolved.
TEST(Stage04Spec, ChainOfFourDisksChoosesTheGreedySetOnTheGpu) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  expect_case(chain_of_four());
}

// On the GPU too, a wall at the same time beats a pair, and the lower index wins a tie.
TEST(Stage04Spec, KeyOrderTiesOnTheGpu) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  expect_case(wall_beats_pair());
  expect_case(lower_index_wins_a_tie());
}

// The state stays on the GPU between steps: two steps of a pair that touches at t = 1 exactly.
TEST(Stage04Spec, StateStaysOnTheGpuBetweenSteps) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  expect_case(head_on_at_one());
}

// Every hand-built case of stages 01-03, to the bit (the same physics, model.hpp, on the device).
TEST(Stage04Spec, EveryHandBuiltCaseOnTheGpu) {
  PLAB_SPEC_SKIP_WITHOUT_DEVICE();
  for (const Case& c : all_cases()) expect_case(c);
}

}  // namespace
