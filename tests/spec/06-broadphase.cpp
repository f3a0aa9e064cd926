/// \file 06-broadphase.cpp
/// \brief Stage 06's idea as a spec: a space-time grid lists the pairs that can meet in the step
/// and only those get a pair time, yet the output is model.md's, bit for bit: no pair that meets
/// is missed, however far apart its cells, and nothing is invented for pairs that cannot meet.
#include "cases.hpp"

namespace {

using namespace plab::spec;

/// 20 disks at rest on a lattice (x = 10, 30, ..., 90; y = 10, 30, 70, 90) in a box of 100, then
/// `more`: the lattice fills the grid's cells; its disks cannot meet anyone (no wall, no pair:
/// a pair at rest has a = 0) and must stay where they are.
plab::Particles lattice_and(std::initializer_list<Disk> more) {
  std::vector<Disk> all;
  for (double y : {10, 30, 70, 90})
    for (double x : {10, 30, 50, 70, 90}) all.push_back({x, y, 0, 0});
  all.insert(all.end(), more);
  plab::Particles p;
  p.resize(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    p.x[i] = all[i].x;
    p.y[i] = all[i].y;
    p.vx[i] = all[i].vx;
    p.vy[i] = all[i].vy;
  }
  return p;
}

// A pair that can meet is found even when the two sit in cells far apart because one is fast:
// disk 20 at x = 5 (speed 86) meets disk 21 at rest at x = 50 (gap 45 - 2 = 43) at t = 0.5, eight
// columns away (22 disks: 4 rows of 25, 16 columns of 6.25). At 0.5: x20 = 48, x21 = 50; exchange:
// v20 = 0, v21 = 86; on 0.5: x21 = 50 + 43 = 93 (its wall: (99 - 50)/86 > 0.5). The 20 others
// stay put, uncounted.
TEST(Stage06Spec, AFastDiskFindsItsPartnerInAFarCell) {
  const plab::Particles start = lattice_and({{5, 50, 86, 0}, {50, 50, 0, 0}});
  plab::Particles expected = lattice_and({{48, 50, 0, 0}, {93, 50, 86, 0}});
  expected.pc[20] = expected.pc[21] = 1;
  expect_state(expected, run({100, 1}, start));
}

// The overlap rule holds in the grid: two disks 1 apart, moving apart, meet at time 0 (t1 = -1.5,
// t2 = 0.5) and cross: 44 -> 45, 45 -> 44.
TEST(Stage06Spec, AnOverlappingPairMovingApartIsFound) {
  const plab::Particles start = lattice_and({{44, 50, -1, 0}, {45, 50, 1, 0}});
  plab::Particles expected = lattice_and({{45, 50, 1, 0}, {44, 50, -1, 0}});
  expected.pc[20] = expected.pc[21] = 1;
  expect_state(expected, run({100, 1}, start));
}

// A particle's path ends at its wall: 21 reaches the wall at ((100 - 98) - 1)/2 = 0.5, before 20
// catches it (gap 98 - 93.75 - 2 = 2.25 at speed 3: 0.75), so the pair is dropped; 20's own wall
// is at ((100 - 93.75) - 1)/5 = 1.05, so it moves freely, to 98.75; 21 reflects: 99, back 1: 98.
TEST(Stage06Spec, APairAfterAWallIsNeverTaken) {
  const plab::Particles start = lattice_and({{93.75, 50, 5, 0}, {98, 50, 2, 0}});
  plab::Particles expected = lattice_and({{98.75, 50, 5, 0}, {98, 50, -2, 0}});
  expected.wc[21] = 1;
  expect_state(expected, run({100, 1}, start));
}

// Pairs that cannot meet in the step get no event, however close: two disks touching side by
// side, moving in parallel (a = 0), and two passing each other on lines 2.5 apart (disc =
// 4096 - 256 * 18.25 < 0) all move freely.
TEST(Stage06Spec, PairsThatCannotMeetMoveFreely) {
  const plab::Particles start =
      lattice_and({{40, 45, 3, 0}, {40, 47, 3, 0}, {56, 52.5, -4, 0}, {52, 50, 4, 0}});
  plab::Particles expected =
      lattice_and({{43, 45, 3, 0}, {43, 47, 3, 0}, {52, 52.5, -4, 0}, {56, 50, 4, 0}});
  expect_state(expected, run({100, 1}, start));
}

// The hand-built cases of stages 01-03 (a few disks: one cell, or a grid of a few).
TEST(Stage06Spec, EveryHandBuiltCase) {
  for (const Case& c : all_cases()) expect_case(c);
}

}  // namespace
