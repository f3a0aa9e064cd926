/// \file 07-event-driven.cpp
/// \brief Stage 07's idea as a spec: exact hard disks in continuous time. Every collision
/// happens at its contact time (model::contact_time(): b = d.w, c = |d|^2 - (2r)^2, a = |w|^2,
/// t = c / (-b + sqrt(b^2 - ac))), a particle may collide any number of times within a unit of
/// time, and the state is read at whole times. Not model.md's stepped model.
#include "spec.hpp"

namespace {

using namespace plab::spec;

// Two disks head-on collide at the exact contact time and exchange velocities: d = -3, w = 2,
// b = -6, c = 5, a = 4, disc = 16: t = 5 / (6 + 4) = 0.5, at x = 3.5 and 5.5; then
// the collision: f = (-2 * 2) / 4 = -1, v0 = 1 - 2 = -1, v1 = -1 + 2 = 1; at t = 1: 3 and 6.
TEST(Stage07Spec, HeadOnPairCollidesAtTheContactTime) {
  EXPECT_STATE(state({{3, 5, -1, 0}, {6, 5, 1, 0}}, {1, 1}, {0, 0}),
               run({10, 1}, disks({{3, 5, 1, 0}, {6, 5, -1, 0}})));
}

// An oblique collision exchanges only the components along the line of centres (the student's
// collide()): r = 2.5, disks touching at t = 0 with d = p0 - p1 = (-3, -4), |d|^2 = 25 = (2r)^2;
// v0 = (7, 1), v1 = 0: b = d.(v0 - v1) = -21 - 4 = -25, f = b / |d|^2 = -1, so
// v0 = v0 - f d = (4, -3) (its tangential part) and v1 = v1 + f d = (3, 4); at t = 1 they are at
// (14, 7) and (16, 18), receding.
TEST(Stage07Spec, AnObliqueCollisionExchangesTheNormalComponents) {
  EXPECT_STATE(state({{14, 7, 4, -3}, {16, 18, 3, 4}}, {1, 1}, {0, 0}),
               run({40, 2.5}, disks({{10, 10, 7, 1}, {13, 14, 0, 0}})));
}

// A disk hits a wall and then the other wall within one unit of time (the stepped model stops at
// the second): from 8.5 at speed 16 in [1, 9]: x = 9 at (9 - 8.5)/16 = 1/32, x = 1 at 1/32 + 8/16,
// then 16 * (1 - 17/32) = 7.5 further: 8.5, moving right again, two wall hits.
TEST(Stage07Spec, ADiskHitsBothWallsWithinOneStep) {
  EXPECT_STATE(state({{8.5, 5, 16, 0}}, {0}, {2}), run({10, 1}, disks({{8.5, 5, 16, 0}})));
}

// A disk collides twice within one unit of time (the stepped model allows one event a step):
// a cradle of three. 0 (speed 4) meets 1 at (3 - 2)/4 = 0.25 (c = 5, b = -12, a = 16: t = 5/20)
// and stops at 3; 1 takes speed 4 and meets 2 at 0.25 + 1/4 = 0.5, stopping at 6; 2 moves from 8
// at speed 4 for 0.5: 10. Disk 1 counts two collisions.
TEST(Stage07Spec, ACollisionChainPassesMomentumOnInOneStep) {
  EXPECT_STATE(state({{3, 5, 0, 0}, {6, 5, 0, 0}, {10, 5, 4, 0}}, {1, 2, 1}, {0, 0, 0}),
               run({20, 1}, disks({{2, 5, 4, 0}, {5, 5, 0, 0}, {8, 5, 0, 0}})));
}

// An exact corner reflects both axes at once (one wall hit): from (8.5, 8.5) at (1, 1), both
// axes reach 9 at 0.5; at t = 1: (8.5, 8.5) moving (-1, -1).
TEST(Stage07Spec, ACornerReflectsBothAxesAtOnce) {
  EXPECT_STATE(state({{8.5, 8.5, -1, -1}}, {0}, {1}), run({10, 1}, disks({{8.5, 8.5, 1, 1}})));
}

// Reading the state at whole times does not change the run (particles are stored at their own
// times and carried to the reading time): reading after each of 7 steps gives the bits of
// reading once after 7, on three disks that meet each other and the walls (L = 12).
TEST(Stage07Spec, ReadingAtWholeTimesDoesNotChangeTheRun) {
  const plab::Box box{12, 1};
  const plab::Particles start = disks({{2, 5, 4, 0.5}, {5, 5.25, 0, 0}, {8, 4.5, -1, 0.25}});
  plab::Particles each = start;
  plab::test::watch_test(7);
  const auto stage = plab::make_stepper(box, each, {});
  for (int s = 0; s < 7; ++s) {
    stage->step();
    stage->read(each);
    plab::test::stepped(s + 1);
  }
  EXPECT_STATE(run(box, start, 7), each);
  long long pairs = 0, walls = 0;
  for (std::size_t i = 0; i < each.size(); ++i) pairs += each.pc[i], walls += each.wc[i];
  EXPECT_GE(pairs, 4) << "at least two collisions (each counted by both disks)";
  EXPECT_GE(walls, 2) << "at least two wall hits";
}

}  // namespace
