/// \file 06-broadphase.cpp
/// \brief Stage 06's idea as a spec: a space-time grid lists the pairs that can meet in the step
/// and only those get a pair time, yet the output is model.md's, bit for bit: no pair that meets
/// is missed, however far apart its cells, and nothing is invented for pairs that cannot meet.
#include "cases.hpp"
#include "plab/datasets.hpp"
#include "plab/plan.hpp"

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
  return disks(all);
}

/// 400 disks at rest, 5 apart (x and y = 2.5, 7.5, ..., 97.5) in a box of 100, then `more`: with
/// 400 disks the grid (plab::grid::choose()) has 20 x 20 cells of 5, one disk a cell. The lane
/// y = 50 lies 2.5 from the rows either side, so a disk moving along it touches none of them.
plab::Particles fine_lattice_and(std::initializer_list<Disk> more) {
  std::vector<Disk> all;
  for (int j = 0; j < 20; ++j)
    for (int i = 0; i < 20; ++i) all.push_back({2.5 + 5 * i, 2.5 + 5 * j, 0, 0});
  all.insert(all.end(), more);
  return disks(all);
}

// A pair that can meet is found even when the two sit in cells far apart because one is fast:
// disk 400 at x = 5 (speed 86) meets disk 401 at rest at x = 28.5 (gap 23.5 - 2 = 21.5) at
// t = 0.25. Every other disk is at rest, so the grid has one slab (midpoint 0.5) and cells of 5:
// at the midpoint 400 stands at 5 + 43 = 48, column 9, and 401 at column 5, four columns away.
// Searching the 3 x 3 cells around each disk misses the pair; the fast disk's own reach (2r +
// 86) does not. Exchange: v400 = 0, v401 = 86; on 0.75: x401 = 28.5 + 64.5 = 93 (its wall:
// (99 - 28.5)/86 > 0.75). The 400 others stay put, uncounted.
TEST(Stage06Spec, AFastDiskFindsItsPartnerInAFarCell) {
  const plab::Particles start = fine_lattice_and({{5, 50, 86, 0}, {28.5, 50, 0, 0}});
  plab::Particles expected = fine_lattice_and({{26.5, 50, 0, 0}, {93, 50, 86, 0}});
  expected.pc[400] = expected.pc[401] = 1;
  EXPECT_STATE(expected, run({100, 1}, start));
}

// The same pair the other way round: the fast disk now has the higher index (401), so the pair is
// found only if the faster particle of a pair searches for it whatever their indices (a search
// that tests a pair only from its lower index, 400 at rest here, with 3 x 3 cells, misses it).
// Exchange: v401 = 0 at x = 26.5, v400 = 86; on 0.75: x400 = 93.
TEST(Stage06Spec, AFastDiskOfHigherIndexFindsItsPartner) {
  const plab::Particles start = fine_lattice_and({{28.5, 50, 0, 0}, {5, 50, 86, 0}});
  plab::Particles expected = fine_lattice_and({{93, 50, 86, 0}, {26.5, 50, 0, 0}});
  expected.pc[400] = expected.pc[401] = 1;
  EXPECT_STATE(expected, run({100, 1}, start));
}

// The overlap rule holds in the grid: two disks 1 apart, moving apart, meet at time 0 (t1 = -1.5,
// t2 = 0.5) and cross: 44 -> 45, 45 -> 44.
TEST(Stage06Spec, AnOverlappingPairMovingApartIsFound) {
  const plab::Particles start = lattice_and({{44, 50, -1, 0}, {45, 50, 1, 0}});
  plab::Particles expected = lattice_and({{45, 50, 1, 0}, {44, 50, -1, 0}});
  expected.pc[20] = expected.pc[21] = 1;
  EXPECT_STATE(expected, run({100, 1}, start));
}

// A particle's path ends at its wall: 21 reaches the wall at ((100 - 98) - 1)/2 = 0.5, before 20
// catches it (gap 98 - 93.75 - 2 = 2.25 at speed 3: 0.75), so the pair is dropped; 20's own wall
// is at ((100 - 93.75) - 1)/5 = 1.05, so it moves freely, to 98.75; 21 reflects: 99, back 1: 98.
TEST(Stage06Spec, APairAfterAWallIsNeverTaken) {
  const plab::Particles start = lattice_and({{93.75, 50, 5, 0}, {98, 50, 2, 0}});
  plab::Particles expected = lattice_and({{98.75, 50, 5, 0}, {98, 50, -2, 0}});
  expected.wc[21] = 1;
  EXPECT_STATE(expected, run({100, 1}, start));
}

// Pairs that cannot meet in the step get no event, however close: two disks touching side by
// side, moving in parallel (a = 0), and two passing each other on lines 2.5 apart (disc =
// 4096 - 256 * 18.25 < 0) all move freely.
TEST(Stage06Spec, PairsThatCannotMeetMoveFreely) {
  const plab::Particles start =
      lattice_and({{40, 45, 3, 0}, {40, 47, 3, 0}, {56, 52.5, -4, 0}, {52, 50, 4, 0}});
  plab::Particles expected =
      lattice_and({{43, 45, 3, 0}, {43, 47, 3, 0}, {52, 52.5, -4, 0}, {56, 50, 4, 0}});
  EXPECT_STATE(expected, run({100, 1}, start));
}

// A broad phase tests only the pairs that can be near: one step of a sparse scene at the density
// of the grade's idea test (N = 20000 in a box of 282843, speeds 10 to 50: about 10^-5 of a disk's
// neighbours within its reach) tests a small share of the N(N - 1)/2 = 2 x 10^8 pairs with
// plab::pair_candidate() (counted by the kit: plab::pair_tests()). A search of every pair gives
// the right output here, but not in time on the grade's scene of 10^6 particles.
TEST(Stage06Spec, TestsFewOfThePairs) {
  plab::GenParams g;
  g.n = 20000;
  g.L = 282843;
  g.r = 1;
  g.steps = 1;
  g.mode = plab::Mode::kPerf;
  g.seed = 2019;
  g.speed_min = 10;
  g.speed_max = 50;
  const plab::Scene scene = plab::generate_scene(g);
  const long long before = plab::pair_tests();
  run(scene.box, scene.particles);
  const double made = static_cast<double>(plab::pair_tests() - before);
  const double every = 0.5 * static_cast<double>(g.n) * static_cast<double>(g.n - 1);
  EXPECT_LE(made, 0.01 * every)
      << "one step of N = 20000 sparse particles tested " << made << " pairs with "
      << "plab::pair_candidate(), " << 100 * made / every << "% of all " << every
      << ": a broad phase tests only the partners in the cells within its distance d of each "
         "particle (handout 06, exercise 2), at most 1% of them here";
}

// The hand-built cases of stages 01-03 (a few disks: one cell, or a grid of a few).
TEST(Stage06Spec, EveryHandBuiltCase) {
  for (const Case& c : all_cases()) expect_case(c);
}

}  // namespace
