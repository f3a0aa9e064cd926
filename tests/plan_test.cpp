/// \file plan_test.cpp
/// \brief plan.hpp as a specification: what a plan records, how it is applied (each particle
/// written once, a pair by its lower index), and the candidates' event keys. The greedy rule's
/// own cases (the instructor's greedy.hpp) are in greedy_test.cpp.
#include <gtest/gtest.h>

#include <vector>

#include "plab/plan.hpp"

namespace {

using plab::Plan;
using plab::model::pair_event_key;
using plab::model::wall_event_key;

/// Three disks of radius 1 in a 10 x 10 box: 0 and 1 head-on along y = 5, 2 alone near a wall.
plab::Particles three() {
  plab::Particles p;
  p.resize(3);
  const double state[3][4] = {{3, 5, 1, 0}, {7, 5, -1, 0}, {8.5, 2, 0.5, 0}};
  for (int i = 0; i < 3; ++i) {
    p.x[i] = state[i][0];
    p.y[i] = state[i][1];
    p.vx[i] = state[i][2];
    p.vy[i] = state[i][3];
  }
  return p;
}

TEST(Plan, ResetLeavesEveryParticleFree) {
  Plan plan;
  plan.reset(4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_FALSE(plan.taken(i));
    EXPECT_EQ(plan.partner[i], Plan::kFree);
  }
}

TEST(Plan, AcceptRecordsBothParticlesOfAPairAndOneOfAWall) {
  Plan plan;
  plan.reset(4);
  plan.accept(pair_event_key(0.25, 1, 3));
  plan.accept(wall_event_key(0.5, 0));
  EXPECT_EQ(plan.partner[1], 3);
  EXPECT_EQ(plan.partner[3], 1);
  EXPECT_EQ(plan.time[1], 0.25);
  EXPECT_EQ(plan.time[3], 0.25);
  EXPECT_EQ(plan.partner[0], Plan::kWall);
  EXPECT_FALSE(plan.taken(2));
}

TEST(Plan, AcceptForWritesOnlyItsOwnParticle) {
  Plan plan;
  plan.reset(3);
  plan.accept_for(2, pair_event_key(0.5, 0, 2));  // particle 2's side of the pair (0, 2)
  EXPECT_EQ(plan.partner[2], 0);
  EXPECT_EQ(plan.time[2], 0.5);
  EXPECT_FALSE(plan.taken(0));  // particle 0 records it itself, in its own iteration
}

TEST(Plan, ApplyOneWritesAPairOnceFromItsLowerIndex) {
  const plab::Box box{10, 1};
  plab::Particles p = three();
  Plan plan;
  plan.reset(3);
  plan.accept(pair_event_key(1.0, 0, 1));
  plab::Particles before = p;
  plab::apply_one(box, p, plan, 1);  // the higher index: nothing changes
  EXPECT_EQ(p.x, before.x);
  EXPECT_EQ(p.vx, before.vx);
  plab::apply_one(box, p, plan, 0);  // the lower index applies the pair to both
  EXPECT_EQ(p.pc[0], 1);
  EXPECT_EQ(p.pc[1], 1);
  EXPECT_EQ(p.vx[0], -1);  // equal masses, head-on: the velocities are exchanged
  EXPECT_EQ(p.vx[1], 1);
}

TEST(Plan, ApplyInAnyOrderGivesTheSameState) {
  const plab::Box box{10, 1};
  Plan plan;
  plan.reset(3);
  plan.accept(pair_event_key(1.0, 0, 1));
  plan.accept(wall_event_key(0.0, 2));
  plab::Particles forward = three(), backward = three();
  for (int i = 0; i < 3; ++i) plab::apply_one(box, forward, plan, i);
  for (int i = 2; i >= 0; --i) plab::apply_one(box, backward, plan, i);
  EXPECT_EQ(forward.x, backward.x);
  EXPECT_EQ(forward.y, backward.y);
  EXPECT_EQ(forward.vx, backward.vx);
  EXPECT_EQ(forward.vy, backward.vy);
  EXPECT_EQ(forward.wc[2], 1);
}

TEST(Candidates, WallAndPairCandidatesAreTheModelsTimes) {
  const plab::Box box{10, 1};
  const plab::Particles p = three();
  const plab::model::Event w = plab::wall_candidate(box, p, 2);
  EXPECT_EQ(w.kind, plab::model::kWall);
  EXPECT_EQ(w.t, plab::model::wall_time(p.x[2], p.y[2], p.vx[2], p.vy[2], box.L, box.r));
  EXPECT_EQ(w.t, 1.0);  // (10 - 8.5 - 1) / 0.5
  const plab::model::Event e = plab::pair_candidate(box, p, 0, 1);
  EXPECT_EQ(e.kind, plab::model::kPair);
  EXPECT_EQ(e.lo, 0);
  EXPECT_EQ(e.hi, 1);
  EXPECT_EQ(e.t, 1.0);  // centres 4 apart closing at 2 per step: touching (2r = 2) at t = 1
}

}  // namespace
