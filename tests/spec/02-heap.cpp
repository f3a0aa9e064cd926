/// \file 02-heap.cpp
/// \brief Stage 02's idea as a spec: the candidate events popped from a heap in key order
/// (t, kind, lo, hi), each accepted while its particles are free, give model.md's events.
#include "cases.hpp"

namespace {

using namespace plab::spec;

// The heap pops in key order: a wall (kind 0) at the same time beats a pair (kind 1).
TEST(Stage02Spec, AWallBeatsAPairAtTheSameTime) { expect_case(wall_beats_pair()); }

// The heap pops in key order: of two pairs at the same time, the lower index wins.
TEST(Stage02Spec, TheLowerIndexWinsATie) { expect_case(lower_index_wins_a_tie()); }

// Pair time 0 (an overlapping pair) is popped first, even for a pair moving apart.
TEST(Stage02Spec, AnOverlappingPairIsPoppedAtTimeZero) { expect_case(overlapping_pair()); }

// Only candidates with t < 1 are pushed: a pair that touches at t = 1 waits for the next step.
TEST(Stage02Spec, NothingAtOrAfterOneIsPushed) { expect_case(head_on_at_one()); }

// An event popped after its particle was taken is skipped: the earliest pair of three in a row.
TEST(Stage02Spec, AnEventWhoseParticleIsTakenIsSkipped) { expect_case(three_in_a_row()); }

}  // namespace
