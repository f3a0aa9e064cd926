/// \file greedy_test.cpp
/// \brief The instructor's greedy.hpp (the oracle's selection, left out of a student release) as a
/// specification: model.md's greedy rule on small hand-built candidate sets (earliest first, a
/// wall beats a pair at the same time, the lower index wins), and its sparse form.
#include <gtest/gtest.h>

#include <vector>

#include "plab/greedy.hpp"

namespace {

using plab::Plan;
using plab::model::pair_event_key;
using plab::model::wall_event_key;

TEST(GreedyPlan, TheEarliestEventWinsAndBlocksItsParticles) {
  // 0-1 at 0.5 and 1-2 at 0.25: 1-2 comes first, so 0 stays free.
  std::vector<plab::model::Event> events{pair_event_key(0.5, 0, 1), pair_event_key(0.25, 1, 2)};
  const Plan plan = plab::greedy_plan(events, 3);
  EXPECT_EQ(plan.partner[1], 2);
  EXPECT_EQ(plan.partner[2], 1);
  EXPECT_FALSE(plan.taken(0));
}

TEST(GreedyPlan, AWallBeatsAPairAtTheSameTime) {
  std::vector<plab::model::Event> events{pair_event_key(0.5, 0, 1), wall_event_key(0.5, 1)};
  const Plan plan = plab::greedy_plan(events, 2);
  EXPECT_EQ(plan.partner[1], Plan::kWall);
  EXPECT_FALSE(plan.taken(0));  // its only event lost its partner
}

TEST(GreedyPlan, TheLowerIndicesWinATie) {
  std::vector<plab::model::Event> events{pair_event_key(0.5, 1, 2), pair_event_key(0.5, 0, 1)};
  const Plan plan = plab::greedy_plan(events, 3);
  EXPECT_EQ(plan.partner[0], 1);
  EXPECT_FALSE(plan.taken(2));
}

TEST(SparseGreedyPlan, APairAtOrAfterAWallIsDropped) {
  // Particle 1's wall at 0.5 comes before its pair with 0 at 0.75; particle 0 then takes its
  // own wall at 0.9; particle 2's wall is after the step, so it stays free.
  std::vector<plab::model::Event> pairs{pair_event_key(0.75, 0, 1)};
  const Plan plan = plab::sparse_greedy_plan(pairs, {0.9, 0.5, 1.5});
  EXPECT_EQ(plan.partner[0], Plan::kWall);
  EXPECT_EQ(plan.partner[1], Plan::kWall);
  EXPECT_FALSE(plan.taken(2));
  EXPECT_TRUE(pairs.empty());  // the dominated pair is gone from the list
}

TEST(SparseGreedyPlan, AnIsolatedPairFoundTwiceKeepsItsEarliestTime) {
  std::vector<plab::model::Event> pairs{pair_event_key(0.5, 0, 1), pair_event_key(0.25, 0, 1)};
  const Plan plan = plab::sparse_greedy_plan(pairs, {2.0, 2.0});
  EXPECT_EQ(plan.partner[0], 1);
  EXPECT_EQ(plan.time[0], 0.25);
}

}  // namespace
