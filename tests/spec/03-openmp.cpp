/// \file 03-openmp.cpp
/// \brief Stage 03's idea as a spec: "mutual earliest" rounds, every phase a parallel loop,
/// choose model.md's greedy set, whatever the number of threads (1, 2 and 3: an odd count
/// splits the particles unevenly).
#include "cases.hpp"
#include "plab/runtime.hpp"

namespace {

using namespace plab::spec;

/// Runs `c` with 1, 2 and 3 threads (plab::set_threads), then restores the thread count.
void expect_with_threads(const Case& c) {
  const int before = plab::get_threads();
  for (int threads : {1, 2, 3}) {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    plab::set_threads(threads);
    expect_case(c);
  }
  plab::set_threads(before);
}

// The rounds choose the greedy set for four disks in a row whatever the thread count: round 1
// accepts the mutual choice (2,3); round 2, with 2 and 3 resolved, accepts (0,1). Like every
// spec, it checks the output only: that the step works in rounds of parallel loops is the
// grader's idea test, measured outside the stage's code.
TEST(Stage03Spec, ChainOfFourDisksChoosesTheGreedySetAnyThreads) {
  expect_with_threads(chain_of_four());
}

// The rounds choose the greedy set for three disks in a row: 1 and 2 choose each other, 0's
// choice (0,1) is never mutual, and once 1 and 2 are resolved 0 has no event left.
TEST(Stage03Spec, ThreeInARowAnyThreads) { expect_with_threads(three_in_a_row()); }

// A wall is accepted at once in the first round, so the pair that ties with it never is.
TEST(Stage03Spec, AWallBeatsAPairAnyThreads) { expect_with_threads(wall_beats_pair()); }

// A tie between pairs is broken by the key's indices, in every thread's copy of the rule.
TEST(Stage03Spec, TheLowerIndexWinsATieAnyThreads) {
  expect_with_threads(lower_index_wins_a_tie());
}

// Every hand-built case of stages 01 and 02, with 1, 2 and 3 threads.
TEST(Stage03Spec, EveryHandBuiltCaseAnyThreads) {
  for (const Case& c : all_cases()) expect_with_threads(c);
}

}  // namespace
