/// \file 01-naive.cpp
/// \brief Stage 01's idea as a spec: the global minimum over every wall and pair time, taken
/// again and again among the free particles, gives model.md's events (cases.hpp works each out).
#include "cases.hpp"

namespace {

using namespace plab::spec;

// The global minimum is taken again and again: of three disks in a row, the earliest pair (1,2)
// wins and its partner's later events, (0,1) and (0,2), are dropped; 0 moves freely.
TEST(Stage01Spec, EarliestPairWinsAndDropsItsPartnersLaterEvents) { expect_case(three_in_a_row()); }

// Only events before t = 1 are taken: two disks that touch at t = 1 exactly move freely in the
// first step and collide at time 0 of the second.
TEST(Stage01Spec, AnEventAtExactlyOneBelongsToTheNextStep) { expect_case(head_on_at_one()); }

// A wall event reflects the axis that reaches the wall first and stops at a second wall; at an
// exact corner both axes reflect.
TEST(Stage01Spec, WallEventsReflectAndStopAtASecondWall) { expect_case(walls()); }

// Minimum after minimum: a chain of four, where the earliest pair (2,3) blocks (1,2) and (1,3),
// and the next minimum among the free particles is (0,1).
TEST(Stage01Spec, TheNextMinimumIsTakenAmongTheFreeParticles) { expect_case(chain_of_four()); }

// A particle without an event moves the whole step (x + vx, y + vy), even at rest.
TEST(Stage01Spec, ParticlesWithoutEventsMoveFreely) {
  // 0: walls at ((20 - 3) - 1)/2 = 8 and ((20 - 4) - 1)/1 = 15; 1 at rest: no wall. The pair:
  // 0 heads straight for 1 (d = -5 dv): c = 121, b = -50, a = 5, t1 = (50 - sqrt(80))/10 > 1.
  EXPECT_STATE(state({{5, 5, 2, 1}, {13, 9, 0, 0}}, {0, 0}, {0, 0}),
               run({20, 1}, disks({{3, 4, 2, 1}, {13, 9, 0, 0}})));
}

}  // namespace
