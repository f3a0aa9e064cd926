/// \file model_test.cpp
/// \brief Hand-computed cases for every primitive of model.hpp (binary-exact inputs where possible).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "plab/generate.hpp"
#include "plab/model.hpp"

#if __has_include("plab/branchless.hpp")  // instructor only (kit/instructor): stage 05's answer
#include "plab/branchless.hpp"
#define PLAB_HAVE_BRANCHLESS 1
#endif

namespace m = plab::model;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double L = 10;
constexpr double r = 1;

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

struct P {
  double x, y, vx, vy;
  long long c = 0;
};
}  // namespace

TEST(WallTime, EachDirectionAndZero) {
  EXPECT_EQ(m::axis_wall_time<double>(5, -2, L, r), 2.0);   // (5 - 1) / (0 - -2)
  EXPECT_EQ(m::axis_wall_time<double>(5, 2, L, r), 2.0);    // ((10 - 5) - 1) / 2
  EXPECT_EQ(m::axis_wall_time<double>(5, 0, L, r), kInf);   // resting: never (the original: 4/0 or 0/0)
  EXPECT_EQ(m::axis_wall_time<double>(9, 0, L, r), kInf);   // resting on the wall x = L - r: not NaN
  EXPECT_EQ(m::axis_wall_time<double>(9.5, 1, L, r), -0.5); // already past L - r: negative, still counts
  EXPECT_EQ(m::wall_time<double>(3, 6, -2, 4, L, r), 0.75);  // tx = 1, ty = 0.75
  const m::WallTimes w = m::wall_times<double>(3, 6, -2, 4, L, r);
  EXPECT_EQ(w.tx, 1.0);
  EXPECT_EQ(w.ty, 0.75);
  EXPECT_EQ(m::wall_time<double>(w), 0.75);
}

TEST(PairTime, HeadOnMidStep) {
  // Centres 10.5 apart closing at 4 per step: they touch (distance 2) at t = 8.5 / 4 = 2.125.
  EXPECT_EQ(m::pair_time<double>(5, 10, 2, 0, 15.5, 10, -2, 0, r), 2.125);
  EXPECT_EQ(m::pair_time<double>(9, 10, 2, 0, 11.5, 10, -2, 0, r), 0.125);
}

TEST(PairTime, GrazingHasZeroDiscriminant) {
  // Paths 2 = 2r apart: c = 25, b = -20, a = 4, disc = 400 - 16 * 25 = 0, t = 20 / 8.
  EXPECT_EQ(m::pair_time<double>(5, 10, 1, 0, 10, 12, -1, 0, r), 2.5);
  EXPECT_EQ(m::pair_time<double>(5, 10, 1, 0, 10, 12.000001, -1, 0, r), kInf);  // a hair further: a miss
}

TEST(PairTime, OverlapCollidesAtOnceWhicheverWayItMoves) {
  EXPECT_EQ(m::pair_time<double>(5, 10, 1, 0, 6, 10, -1, 0, r), 0.0);   // approaching: t1 = -0.5, t2 = 1.5
  EXPECT_EQ(m::pair_time<double>(15, 10, -1, 0, 16, 10, 1, 0, r), 0.0); // separating: t1 = -1.5, t2 = 0.5
  EXPECT_EQ(m::pair_time<double>(10, 10, 1, 2, 10, 10, -2, 1, r), 0.0); // coincident centres
}

TEST(PairTime, NoEvent) {
  EXPECT_EQ(m::pair_time<double>(5, 5, 0, 0, 6.5, 5, 0, 0, r), kInf);    // a == 0 (same velocity), overlapping
  EXPECT_EQ(m::pair_time<double>(5, 5, 1, 1, 8, 5, 1, 1, r), kInf);      // a == 0, apart
  EXPECT_EQ(m::pair_time<double>(5, 5, -1, 0, 9, 5, 1, 0, r), kInf);     // receding: both roots negative
  EXPECT_EQ(m::pair_time<double>(5, 5, 1, 0, 9, 9, 1, 1, r), kInf);      // disc < 0: paths never close
  EXPECT_EQ(m::pair_time<double>(5, 10, 2, 0, 11, 10, -2, 0, r), 1.0);   // exactly t = 1: not in this step
  EXPECT_FALSE(m::in_step<double>(1.0));
  EXPECT_TRUE(m::in_step<double>(0.0));
  EXPECT_TRUE(m::in_step<double>(-0.5));
}

TEST(EventKey, OrderIsTimeThenKindThenIndices) {
  EXPECT_TRUE(m::key_less(m::pair_event_key(0.25, 5, 6), m::wall_event_key(0.5, 0)));
  EXPECT_TRUE(m::key_less(m::wall_event_key(0.5, 9), m::pair_event_key(0.5, 0, 1)));  // wall wins a tie
  EXPECT_TRUE(m::key_less(m::pair_event_key(0.5, 0, 7), m::pair_event_key(0.5, 1, 2)));
  EXPECT_TRUE(m::key_less(m::pair_event_key(0.5, 1, 2), m::pair_event_key(0.5, 1, 3)));
  EXPECT_TRUE(m::key_less(m::wall_event_key(0.5, 2), m::wall_event_key(0.5, 3)));
  EXPECT_FALSE(m::key_less(m::wall_event_key(0.5, 2), m::wall_event_key(0.5, 2)));  // strict
  EXPECT_TRUE(m::key_less(m::wall_event_key(-0.5, 9), m::pair_event_key(0, 0, 1)));
}

TEST(FreeMove, WholeStep) {
  double x = 2, y = 3;
  m::free_move<double>(x, y, 0.5, -1);
  EXPECT_EQ(x, 2.5);
  EXPECT_EQ(y, 2.0);
}

TEST(WallEvent, XFirstThenStopAtSecondWall) {
  P p{2, 6, -2, 4};  // tx = 0.5, ty = 0.75: reflect in x at (1, 8), stop at y = 9 at t = 0.75
  m::wall_event<double>(p.x, p.y, p.vx, p.vy, p.c, L, r);
  EXPECT_EQ(p.x, 1.5);
  EXPECT_EQ(p.y, 9.0);
  EXPECT_EQ(p.vx, 2.0);
  EXPECT_EQ(p.vy, 4.0);
  EXPECT_EQ(p.c, 1);
}

TEST(WallEvent, XFirstNoSecondWall) {
  P p{2, 5, -2, 1};  // tx = 0.5, ty = 4: reflect, move the remaining 0.5
  m::wall_event<double>(p.x, p.y, p.vx, p.vy, p.c, L, r);
  EXPECT_EQ(p.x, 2.0);
  EXPECT_EQ(p.y, 6.0);
  EXPECT_EQ(p.vx, 2.0);
}

TEST(WallEvent, YFirstIsTheMirror) {
  P p{6, 2, 4, -2};
  m::wall_event<double>(p.x, p.y, p.vx, p.vy, p.c, L, r);
  EXPECT_EQ(p.x, 9.0);
  EXPECT_EQ(p.y, 1.5);
  EXPECT_EQ(p.vx, 4.0);
  EXPECT_EQ(p.vy, 2.0);
}

TEST(WallEvent, ExactCornerReflectsBoth) {
  P p{3, 3, -4, -4};  // tx = ty = 0.5
  m::wall_event<double>(p.x, p.y, p.vx, p.vy, p.c, L, r);
  EXPECT_EQ(p.x, 3.0);
  EXPECT_EQ(p.y, 3.0);
  EXPECT_EQ(p.vx, 4.0);
  EXPECT_EQ(p.vy, 4.0);
  EXPECT_EQ(p.c, 1);
}

TEST(WallEvent, RestingAxisNeverReflects) {
  P p{9, 5, 0, 8};  // on the wall x = L - r with vx = 0: only y reflects (ty = 0.5)
  m::wall_event<double>(p.x, p.y, p.vx, p.vy, p.c, L, r);
  EXPECT_EQ(p.x, 9.0);
  EXPECT_EQ(p.y, 5.0);
  EXPECT_EQ(p.vy, -8.0);
  EXPECT_TRUE(same_bits(p.vx, 0.0));
}

#ifdef PLAB_HAVE_BRANCHLESS
TEST(WallEvent, BranchlessGivesTheSameBits) {
  // The hand cases above, then many random states, including exact corners and resting axes.
  plab::SplitMix64 rng(42);
  int corners = 0;
  for (int k = 0; k < 200000; ++k) {
    P a{};
    switch (k % 4) {
      case 0: a = {1 + 8 * rng.uniform01(), 1 + 8 * rng.uniform01(), 20 * rng.uniform01() - 10,
                   20 * rng.uniform01() - 10}; break;
      case 1: { const double d = 1 + 3 * rng.uniform01(); a = {1 + d, 1 + d, -4 * d, -4 * d}; break; }
      case 2: a = {1 + 8 * rng.uniform01(), 9, 0, 20 * rng.uniform01() - 10}; break;
      default: a = {2 + std::floor(6 * rng.uniform01()), 2 + std::floor(6 * rng.uniform01()),
                    std::floor(8 * rng.uniform01()) - 4, std::floor(8 * rng.uniform01()) - 4};
    }
    const m::WallTimes w = m::wall_times<double>(a.x, a.y, a.vx, a.vy, L, r);
    if (!(m::wall_time<double>(w) < 1)) continue;
    corners += w.tx == w.ty;
    P b = a;
    m::wall_event<double>(a.x, a.y, a.vx, a.vy, a.c, L, r);
    m::wall_event_branchless<double>(b.x, b.y, b.vx, b.vy, b.c, L, r);
    ASSERT_TRUE(same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.vx, b.vx) &&
                same_bits(a.vy, b.vy) && a.c == b.c)
        << "case " << k;
  }
  EXPECT_GT(corners, 1000);  // the corner branch was really exercised
}
#endif

TEST(PairEvent, HeadOnExchangesVelocities) {
  P i{9, 10, 2, 0}, j{11.5, 10, -2, 0};  // meet at t = 0.125 at x = 9.25 and 11.25
  ASSERT_TRUE(m::pair_event<double>(i.x, i.y, i.vx, i.vy, i.c, j.x, j.y, j.vx, j.vy, j.c, 0.125, 20, r));
  EXPECT_EQ(i.vx, -2.0);
  EXPECT_EQ(j.vx, 2.0);
  EXPECT_EQ(i.x, 9.25 - 2 * 0.875);
  EXPECT_EQ(j.x, 11.25 + 2 * 0.875);
  EXPECT_EQ(i.y, 10.0);
  EXPECT_EQ(i.c, 1);
  EXPECT_EQ(j.c, 1);
  // Zero components are stored as +0.0, never -0.0.
  EXPECT_TRUE(same_bits(i.vy, 0.0));
  EXPECT_TRUE(same_bits(j.vy, 0.0));
}

TEST(PairEvent, StopsAtWallForTheRestOfTheStep) {
  P i{3, 10, 0, 0}, j{6, 10, -4, 0};  // collide at t = 0.25; i then reaches x = r at t = 0.75
  const double t = m::pair_time<double>(i.x, i.y, i.vx, i.vy, j.x, j.y, j.vx, j.vy, r);
  ASSERT_EQ(t, 0.25);
  m::pair_event<double>(i.x, i.y, i.vx, i.vy, i.c, j.x, j.y, j.vx, j.vy, j.c, t, 20, r);
  EXPECT_EQ(i.x, 1.0);
  EXPECT_EQ(i.vx, -4.0);
  EXPECT_EQ(j.x, 5.0);
  EXPECT_TRUE(same_bits(j.vx, 0.0));
}

TEST(PairEvent, TangentialVelocityUnchangedWhenGrazing) {
  P i{7.5, 10, 1, 0}, j{7.5, 12, -1, 0};  // touching, normal along y, velocities along x
  m::pair_event<double>(i.x, i.y, i.vx, i.vy, i.c, j.x, j.y, j.vx, j.vy, j.c, 0.0, 40, r);
  EXPECT_EQ(i.vx, 1.0);
  EXPECT_EQ(j.vx, -1.0);
  EXPECT_EQ(i.x, 8.5);
  EXPECT_EQ(i.c, 1);
}

TEST(PairEvent, CoincidentCentresAreDropped) {
  P i{10, 10, 1, 2}, j{10, 10, -2, 1};
  EXPECT_FALSE(m::pair_event<double>(i.x, i.y, i.vx, i.vy, i.c, j.x, j.y, j.vx, j.vy, j.c, 0.0, 20, r));
  EXPECT_EQ(i.x, 11.0);
  EXPECT_EQ(i.y, 12.0);
  EXPECT_EQ(j.x, 8.0);
  EXPECT_EQ(j.y, 11.0);
  EXPECT_EQ(i.c, 0);
  EXPECT_EQ(j.c, 0);
}

TEST(PairEvent, ConservesKineticEnergyAndMomentum) {
  plab::SplitMix64 rng(7);
  for (int k = 0; k < 10000; ++k) {
    P i{50, 50, 10 * rng.uniform01() - 5, 10 * rng.uniform01() - 5};
    P j{50 + 2 * rng.uniform01(), 51.5, 10 * rng.uniform01() - 5, 10 * rng.uniform01() - 5};
    const double e0 = i.vx * i.vx + i.vy * i.vy + j.vx * j.vx + j.vy * j.vy;
    const double px = i.vx + j.vx, py = i.vy + j.vy;
    m::pair_event<double>(i.x, i.y, i.vx, i.vy, i.c, j.x, j.y, j.vx, j.vy, j.c, 0.0, 100, r);
    EXPECT_NEAR(i.vx * i.vx + i.vy * i.vy + j.vx * j.vx + j.vy * j.vy, e0, 1e-12 * (1 + e0));
    EXPECT_NEAR(i.vx + j.vx, px, 1e-12 * (1 + std::fabs(px)));
    EXPECT_NEAR(i.vy + j.vy, py, 1e-12 * (1 + std::fabs(py)));
  }
}

TEST(RestOfStep, UsesTheOtherAssociation) {
  // ((L - r) - x) and ((L - x) - r) round differently for some x; rest_of_step must use the first.
  plab::SplitMix64 rng(3);
  const double big_l = 10.3, small_r = 0.7;
  int differing = 0;
  for (int k = 0; k < 1000; ++k) {
    const double x0 = 1 + 8 * rng.uniform01();
    const double v = 50;  // reaches the wall well inside the step
    if (((big_l - small_r) - x0) == ((big_l - x0) - small_r)) continue;
    ++differing;
    double x = x0, y = 5;
    m::rest_of_step<double>(x, y, v, 0, 0.0, big_l, small_r);
    EXPECT_TRUE(same_bits(x, x0 + (((big_l - small_r) - x0) / v) * v));
  }
  EXPECT_GT(differing, 10);
}

TEST(AxisTimeTo, EachDirectionAndZero) {
  EXPECT_EQ(m::axis_time_to<double>(3, 2, 1, 9), 3.0);     // (9 - 3) / 2
  EXPECT_EQ(m::axis_time_to<double>(3, -2, 1, 9), 1.0);    // (3 - 1) / (0 - -2)
  EXPECT_EQ(m::axis_time_to<double>(3, 0, 1, 9), kInf);
  EXPECT_EQ(m::axis_time_to<double>(9.5, 1, 1, 9), -0.5);  // already past hi: negative
  EXPECT_EQ(m::axis_rest_wall_time<double>(5, 2, L, r), 2.0);  // the bounds r and L - r
  EXPECT_EQ(m::axis_rest_wall_time<double>(5, -2, L, r), 2.0);
}

TEST(ContinuousTime, PositionAt) {
  EXPECT_EQ(m::position_at<double>(2, 0.5, 1, 3), 3.0);   // 2 + (3 - 1) * 0.5
  EXPECT_EQ(m::position_at<double>(2, 0.5, 3, 1), 1.0);   // backwards in time
  EXPECT_EQ(m::position_at<double>(2, 0.5, 4, 4), 2.0);   // at its own time: where it is stored
}

TEST(ContinuousTime, AxisExitTimeNeverBeforeNow) {
  EXPECT_EQ(m::axis_exit_time<double>(3, 2, 1, 9), 3.0);
  EXPECT_EQ(m::axis_exit_time<double>(3, -2, 1, 9), 1.0);
  EXPECT_EQ(m::axis_exit_time<double>(3, 0, 1, 9), kInf);
  EXPECT_TRUE(same_bits(m::axis_exit_time<double>(9.5, 1, 1, 9), 0.0));   // past hi: now, +0.0
  EXPECT_TRUE(same_bits(m::axis_exit_time<double>(9, 1, 1, 9), 0.0));     // on hi
  EXPECT_EQ(m::axis_exit_time<double>(0.5, 1, 1, 9), 8.5);                 // below lo, moving up
}

TEST(ContinuousTime, ExitWallTimes) {
  const m::WallTimes w = m::exit_wall_times<double>(3, 6, -2, 4, L, r);
  EXPECT_EQ(w.tx, 1.0);   // (3 - 1) / 2
  EXPECT_EQ(w.ty, 0.75);  // ((10 - 1) - 6) / 4
  EXPECT_EQ(m::wall_time<double>(w), 0.75);
  const m::WallTimes past = m::exit_wall_times<double>(9.5, 5, 1, 0, L, r);
  EXPECT_TRUE(same_bits(past.tx, 0.0));
  EXPECT_EQ(past.ty, kInf);
  // The association of axis_rest_wall_time(): ((L - r) - x) = 7.800000000000002 here, where
  // ((L - x) - r) = 7.8.
  const double big_l = 10.3, small_r = 0.7, x = 1.8;
  ASSERT_NE((big_l - small_r) - x, (big_l - x) - small_r);
  EXPECT_TRUE(same_bits(m::exit_wall_times<double>(x, 5, 1, 0, big_l, small_r).tx,
                        (big_l - small_r) - x));
}

TEST(ContinuousTime, ContactTimeFromAnyOrigin) {
  // i stored at t = 1 at x = 2 moving +1, j stored at t = 0 at x = 10 moving -1 (same y).
  // From t0 = 1: centres 2 and 9, gap 7 - 2r = 5 closing at 2: t = 45 / (14 + 4) = 2.5.
  EXPECT_EQ(m::contact_time_from<double>(1, 2, 5, 1, 0, 1, 10, 5, -1, 0, 0, r), 2.5);
  // From t0 = 2: centres 3 and 8, t = 21 / (10 + 4) = 1.5 (the same contact, at time 3.5).
  EXPECT_EQ(m::contact_time_from<double>(2, 2, 5, 1, 0, 1, 10, 5, -1, 0, 0, r), 1.5);
  // From t0 = 4: centres 5 and 6, overlapping and approaching: now.
  EXPECT_EQ(m::contact_time_from<double>(4, 2, 5, 1, 0, 1, 10, 5, -1, 0, 0, r), 0.0);
  // From t0 = 5: centres 6 and 5, they have passed: receding, never.
  EXPECT_EQ(m::contact_time_from<double>(5, 2, 5, 1, 0, 1, 10, 5, -1, 0, 0, r), kInf);
}

TEST(Reflect, FlipsTheAxesHit) {
  double vx = 3, vy = -4;
  m::reflect<double>(vx, vy, true, false);
  EXPECT_EQ(vx, -3.0);
  EXPECT_EQ(vy, -4.0);
  m::reflect<double>(vx, vy, false, true);
  EXPECT_EQ(vx, -3.0);
  EXPECT_EQ(vy, 4.0);
  m::reflect<double>(vx, vy, true, true);  // a corner
  EXPECT_EQ(vx, 3.0);
  EXPECT_EQ(vy, -4.0);
  m::reflect<double>(vx, vy, false, false);
  EXPECT_EQ(vx, 3.0);
  EXPECT_EQ(vy, -4.0);
}
