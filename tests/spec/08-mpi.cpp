/// \file 08-mpi.cpp
/// \brief Stage 08's idea as a spec, on the one rank a test program has: the halo, the rounds
/// and the migration change nothing when one rank owns every particle, so the hand-built cases
/// of stages 01-03 hold as they are. The same cases on 2-4 ranks, where pairs straddle the cut,
/// are the Ranks tests (stage_test.cpp, under mpirun).
#include "cases.hpp"

namespace {

using namespace plab::spec;

// The rounds across ranks are stage 03's rounds: four disks in a row take two rounds.
TEST(Stage08Spec, ChainOfFourDisksChoosesTheGreedySet) { expect_case(chain_of_four()); }

// Three in a row: the middle pair chooses each other; the first disk is left free.
TEST(Stage08Spec, ThreeInARow) { expect_case(three_in_a_row()); }

// A wall beats a pair at the same time, and the lower scene index wins a tie: the keys use
// the particles' scene indices, whatever rank holds them.
TEST(Stage08Spec, KeysUseSceneIndices) {
  expect_case(wall_beats_pair());
  expect_case(lower_index_wins_a_tie());
}

// Every hand-built case of stages 01 and 02.
TEST(Stage08Spec, EveryHandBuiltCase) {
  for (const Case& c : all_cases()) expect_case(c);
}

}  // namespace
