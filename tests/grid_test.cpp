/// \file grid_test.cpp
/// \brief Stage 06's given grid (plab/grid.hpp): cells clamp and keep the order of coordinates,
/// slabs cover the step, walls end a particle's part, and the grid chosen from a scene is wide
/// enough for its slow particles (or one cell when a speed is not finite).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "plab/grid.hpp"

namespace {

/// A grid of `side` x `side` cells of side 1 and `slabs` slabs.
plab::grid::Grid unit_grid(int side, int slabs) {
  plab::grid::Grid g;
  g.side = side;
  g.inv_cell = 1;
  g.slabs = slabs;
  g.half = 0.5 / slabs;
  return g;
}

TEST(Grid, CellsClampAndKeepTheOrder) {
  const plab::grid::Grid g = unit_grid(10, 4);
  EXPECT_EQ(g.index_of(-5), 0);
  EXPECT_EQ(g.index_of(0.5), 0);
  EXPECT_EQ(g.index_of(3.5), 3);
  EXPECT_EQ(g.index_of(1e300), 9);
  EXPECT_EQ(g.index_of(std::nan("")), 0);
  EXPECT_EQ(g.cell_of(3.5, 2.5), 23);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> coordinate(-20, 30);
  for (int k = 0; k < 1000; ++k) {
    const double a = coordinate(rng), b = coordinate(rng);
    if (a <= b) {
      EXPECT_LE(g.index_of(a), g.index_of(b)) << a << " " << b;
    }
  }
  int lo = -1, hi = -1;
  g.indices_within(4.5, 1.2, lo, hi);
  EXPECT_EQ(lo, 3);
  EXPECT_EQ(hi, 5);
  g.indices_within(std::nan(""), 1, lo, hi);  // not a number: every row
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, 9);
  g.indices_within(4.5, HUGE_VAL, lo, hi);
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, 9);
}

TEST(Grid, SlabsCoverTheStepAndWallsEndPaths) {
  const plab::grid::Grid g = unit_grid(1, 4);
  EXPECT_EQ(g.slab_of(0), 0);
  EXPECT_EQ(g.slab_of(0.2499), 0);
  EXPECT_EQ(g.slab_of(0.25), 1);
  EXPECT_EQ(g.slab_of(0.9999), 3);
  EXPECT_DOUBLE_EQ(g.slab_mid(1), 0.375);
  EXPECT_EQ(g.last_slab(0), -1);      // the wall at the start: no pair can be accepted
  EXPECT_EQ(g.last_slab(-1), -1);
  EXPECT_EQ(g.last_slab(0.3), 1);
  EXPECT_EQ(g.last_slab(1), 3);       // no wall in the step
  EXPECT_EQ(g.last_slab(HUGE_VAL), 3);
  EXPECT_EQ(g.last_slab(std::nan("")), 3);
}

TEST(Grid, ChosenFromTheScene) {
  const plab::Box box{1000, 1};
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> speed(0, 5);
  std::vector<double> speed2(10000), wall(10000, 2.0);
  for (double& v2 : speed2) v2 = std::pow(speed(rng), 2);
  const plab::grid::Grid g = plab::grid::choose(box, speed2, wall);
  EXPECT_GE(g.slabs, 1);
  EXPECT_LE(g.slabs, 256);
  EXPECT_DOUBLE_EQ(g.half, 0.5 / g.slabs);
  EXPECT_GT(g.margin, 0);
  EXPECT_DOUBLE_EQ(g.reach, 2 * box.r + g.margin);
  EXPECT_GE(g.side, 1);
  EXPECT_LE(g.side, 100);  // about N cells at most
  // A cell is at least as wide as the path of 90% of the particles in a slab, plus a diameter.
  EXPECT_GE(box.L / g.side, g.reach + 2 * g.half * 4.4);
  speed2[7] = std::numeric_limits<double>::quiet_NaN();
  const plab::grid::Grid one = plab::grid::choose(box, speed2, wall);
  EXPECT_EQ(one.side, 1);
  EXPECT_EQ(one.slabs, 1);
  speed2[7] = HUGE_VAL;
  EXPECT_EQ(plab::grid::choose(box, speed2, wall).cells(), 1);
}

}  // namespace
