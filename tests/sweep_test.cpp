/// \file sweep_test.cpp
/// \brief The broad phase never drops a pair whose model.md pair time is below 1: random pairs
/// placed to meet at a chosen time, and grazing pairs whose closest approach is right at 2r.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "plab/close_lanes.hpp"
#include "plab/greedy.hpp"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/plan_team.hpp"
#include "plab/sweep.hpp"

namespace {

/// Whether the broad phase finds particles 0 and 1 of `p` in some slab, as stage 06 searches,
/// each entry's midpoint and velocity held as `Real` (its cell, its reach and whether it is fast
/// from those): both take part in the slab (up to their last slabs), `close(dx, dy, wx, wy, s)`
/// (the slab test on the rounded values, `s` the pair's |vx| + |vy|) holds at the slab's midpoint,
/// and either neither is fast and the later in cell order is in the same or the next row within
/// the reach of the earlier, or one lies within the reach of the other, which is fast and at
/// least as fast (sweep::search_of()).
template <class Real, class Close>
bool found_as(const plab::Particles& p, const std::vector<double>& end,
              const plab::sweep::Grid& g, Close close) {
  namespace sweep = plab::sweep;
  Real vx[2], vy[2];
  double v2[2];
  sweep::Search q[2];
  for (int i = 0; i < 2; ++i) {
    vx[i] = static_cast<Real>(p.vx[i]);
    vy[i] = static_cast<Real>(p.vy[i]);
    v2[i] = double(vx[i]) * vx[i] + double(vy[i]) * vy[i];
    q[i] = sweep::search_of(vx[i], vy[i], g);
  }
  const Real s = std::fabs(vx[0]) + std::fabs(vy[0]) + std::fabs(vx[1]) + std::fabs(vy[1]);
  for (int k = 0; k <= std::min(sweep::last_slab(end[0], g), sweep::last_slab(end[1], g)); ++k) {
    const double tm = sweep::slab_mid(k, g);
    Real mx[2], my[2];
    for (int i = 0; i < 2; ++i) {
      mx[i] = static_cast<Real>(p.x[i] + tm * p.vx[i]);
      my[i] = static_cast<Real>(p.y[i] + tm * p.vy[i]);
    }
    if (!close(mx[0] - mx[1], my[0] - my[1], vx[0] - vx[1], vy[0] - vy[1], s)) continue;
    const int col[2] = {sweep::column_of(mx[0], g), sweep::column_of(mx[1], g)};
    const int row[2] = {sweep::row_of(my[0], g), sweep::row_of(my[1], g)};
    if (!q[0].fast && !q[1].fast) {
      // The first in cell order searches the rest of its row and the next one, within its reach.
      const int a = (row[0] < row[1] || (row[0] == row[1] && col[0] <= col[1])) ? 0 : 1, b = 1 - a;
      int x0, x1;
      sweep::columns_within(mx[a], q[a].d, g, x0, x1);
      if (row[b] - row[a] <= 1 && (row[b] > row[a] ? x0 <= col[b] : true) && col[b] <= x1)
        return true;
      continue;
    }
    const int a = (q[0].fast && (!q[1].fast || v2[0] >= v2[1])) ? 0 : 1, b = 1 - a;
    int x0, x1, y0, y1;
    sweep::columns_within(mx[a], q[a].d, g, x0, x1);
    sweep::rows_within(my[a], q[a].d, g, y0, y1);
    if (x0 <= col[b] && col[b] <= x1 && y0 <= row[b] && row[b] <= y1) return true;
  }
  return false;
}

/// found_as() in double with close_in_slab(): the CPU engine's search.
bool found(const plab::Particles& p, const std::vector<double>& end, const plab::sweep::Grid& g) {
  return found_as<double>(p, end, g, [&g](double dx, double dy, double wx, double wy, double) {
    return plab::sweep::close_in_slab(dx, dy, wx, wy, g);
  });
}

/// found_as() in float with close_in_slab_single(): the GPU engine's search.
bool found_single(const plab::Particles& p, const std::vector<double>& end,
                  const plab::sweep::Grid& g, const plab::sweep::Single& single) {
  return found_as<float>(p, end, g, [&single](float dx, float dy, float wx, float wy, float s) {
    return plab::sweep::close_in_slab_single(dx, dy, wx, wy, s, single);
  });
}

/// Each particle's path end (sweep::path_end() of its wall time).
std::vector<double> path_ends(const plab::Box& box, const plab::Particles& p) {
  std::vector<double> end(p.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    end[i] = plab::sweep::path_end(plab::wall_candidate(box, p, static_cast<int>(i)).t);
  return end;
}

/// A scene of `n` particles whose grid is used, with particles 0 and 1 the pair under test.
struct Case {
  plab::Box box;
  plab::Particles p;
};

Case make_case(std::mt19937_64& rng, double L, double r, double speed, int n, double t_meet,
               double miss, bool graze) {
  std::uniform_real_distribution<double> u(0, 1);
  Case c{{L, r}, {}};
  c.p.resize(n);
  for (int i = 2; i < n; ++i) {  // the rest of the scene sets the grid (speeds, extent)
    c.p.x[i] = r + u(rng) * (L - 2 * r);
    c.p.y[i] = r + u(rng) * (L - 2 * r);
    const double a = 2 * M_PI * u(rng);
    c.p.vx[i] = speed * std::cos(a);
    c.p.vy[i] = speed * std::sin(a);
  }
  // Particles 0 and 1 are 2r + miss apart at t_meet, approaching along a random direction.
  const double cx = r + u(rng) * (L - 2 * r), cy = r + u(rng) * (L - 2 * r);
  const double a = 2 * M_PI * u(rng), b = 2 * M_PI * u(rng);
  const double s0 = speed * u(rng), s1 = speed * u(rng);
  const double nx = std::cos(a), ny = std::sin(a);
  const double gap = 2 * r + miss;
  c.p.vx[0] = s0 * std::cos(b);
  c.p.vy[0] = s0 * std::sin(b);
  c.p.vx[1] = s1 * std::cos(b + 2 * M_PI * u(rng));
  c.p.vy[1] = s1 * std::sin(b + 2 * M_PI * u(rng));
  if (graze) {  // relative velocity across the line of centres: closest approach at t_meet
    c.p.vx[1] = c.p.vx[0] - s1 * ny;
    c.p.vy[1] = c.p.vy[0] + s1 * nx;
  }
  c.p.x[0] = cx - t_meet * c.p.vx[0];
  c.p.y[0] = cy - t_meet * c.p.vy[0];
  c.p.x[1] = cx + gap * nx - t_meet * c.p.vx[1];
  c.p.y[1] = cy + gap * ny - t_meet * c.p.vy[1];
  return c;
}

/// A random pair that the model makes meet in the step (and before both walls), in a scene of
/// up to 61 particles: boxes 10 .. 10^6, radii L/10 .. L/10^5, speeds from tiny to a box a step,
/// 2r apart give or take a few ulps at any time of the step, grazing on even trials.
struct Meeting {
  Case c;
  double L = 0, r = 0, speed = 0;  //!< the scene's scales
  double t = 0;                    //!< the pair's time (model.md)
  std::vector<double> end;         //!< each particle's path end
};

/// Draws the next Meeting for `trial`; false when the pair does not meet in the step before both
/// walls (a pair at or after either wall time loses to that wall and is never accepted).
bool next_meeting(std::mt19937_64& rng, int trial, Meeting& m) {
  std::uniform_real_distribution<double> u(0, 1);
  m.L = std::pow(10.0, 1 + 5 * u(rng));              // 10 .. 10^6
  m.r = m.L * std::pow(10.0, -1 - 4 * u(rng));       // L/10 .. L/10^5
  m.speed = m.L * std::pow(10.0, -6 + 6 * u(rng));   // tiny .. a whole box a step
  const int n = 2 + static_cast<int>(u(rng) * 60);
  // meet right at the margin: 2r apart give or take a few ulps, at any time of the step
  const double miss = (u(rng) - 0.5) * 8 * std::numeric_limits<double>::epsilon() * m.L;
  m.c = make_case(rng, m.L, m.r, m.speed, n, u(rng), miss, trial % 2 == 0);
  m.t = plab::pair_candidate(m.c.box, m.c.p, 0, 1).t;
  m.end = path_ends(m.c.box, m.c.p);
  return plab::model::in_step(m.t) && m.t < m.end[0] && m.t < m.end[1];
}

TEST(Sweep, NeverDropsAPairThatMeetsInTheStep) {
  std::mt19937_64 rng(2026);
  long checked = 0;
  Meeting m;
  for (int trial = 0; trial < 200000; ++trial) {
    if (!next_meeting(rng, trial, m)) continue;
    ++checked;
    std::vector<double> scratch;
    const plab::sweep::Grid g = plab::sweep::choose(m.c.box, m.c.p, m.end, scratch, trial % 3 / 2.0);
    ASSERT_TRUE(found(m.c.p, m.end, g)) << "pair time " << m.t << " dropped: L " << m.L << " r "
                                        << m.r << " speed " << m.speed << " slabs " << g.slabs
                                        << " v_cut " << g.v_cut;
  }
  EXPECT_GT(checked, 50000);
}

// The CPU engine's 4-byte search: the reach never shorter than the double one (a shorter reach
// could drop a pair), barely longer, and the fast flag kept, from tiny to huge and odd values.
TEST(Sweep, PackedSearchNeverShortens) {
  std::mt19937_64 rng(30);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> reaches{0, 1e-45, 1e-39, 1.17e-38, 1e-30, 1, 3.0000001, 1e38, 3.4e38, 1e300,
                              INFINITY};
  for (int k = 0; k < 200000; ++k)
    reaches.push_back(std::pow(10.0, -40 + 80 * u(rng)) * (1 + u(rng)));
  for (const double d : reaches)
    for (const bool fast : {false, true}) {
      const plab::sweep::PackedSearch q = plab::sweep::PackedSearch::of({d, fast});
      ASSERT_GE(q.d(), d) << d;
      if (d > 1e-37 && d < 1e38) {
        ASSERT_LE(q.d(), d * (1 + 3e-7)) << d;
      }
      ASSERT_EQ(q.fast(), fast) << d;
    }
  for (const bool fast : {false, true}) {  // a not-a-number reach (a particle of no speed known)
    const plab::sweep::PackedSearch q = plab::sweep::PackedSearch::of({-NAN, fast});
    EXPECT_TRUE(std::isnan(q.d()));
    EXPECT_EQ(q.fast(), fast);
  }
}

TEST(Sweep, GridFromTheScene) {
  plab::Particles p;
  p.resize(10000);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.x[i] = 20000 * u(rng);
    p.y[i] = 20000 * u(rng);
    p.vx[i] = 5000 * (2 * u(rng) - 1) / std::sqrt(2.0);
    p.vy[i] = 5000 * (2 * u(rng) - 1) / std::sqrt(2.0);
  }
  std::vector<double> scratch;
  const plab::Box box{20000, 1};
  plab::sweep::Grid g = plab::sweep::choose(box, p, path_ends(box, p), scratch);
  EXPECT_GT(g.slabs, 1);  // long sweeps: several slabs
  EXPECT_LT(g.cell, 2 + 6000.0 / g.slabs);
  EXPECT_LE(g.cells(), 4 * 10000);  // no more cells than about 4N
  EXPECT_LT(g.v_cut, 5000);         // the fastest 10% search wider
  p.vx[0] = 1e6;  // one very fast particle changes only the rounding margin (a millionth of it)
  const plab::sweep::Grid hot = plab::sweep::choose(box, p, path_ends(box, p), scratch);
  EXPECT_EQ(hot.slabs, g.slabs);
  EXPECT_NEAR(hot.cell, g.cell, 0.02 * g.cell);
  EXPECT_TRUE(plab::sweep::search_of(p.vx[0], p.vy[0], g).fast);
  EXPECT_GT(plab::sweep::search_of(p.vx[0], p.vy[0], g).d, 1e6 / g.slabs);
  p.vx.assign(p.size(), 0);
  p.vy.assign(p.size(), 0);
  g = plab::sweep::choose(box, p, path_ends(box, p), scratch);
  EXPECT_EQ(g.slabs, 1);  // at rest: one slab, cells of about 2r (at most 2N of them)
  EXPECT_FALSE(plab::sweep::search_of(0, 0, g).fast);
}

TEST(Sweep, WallsEndPaths) {
  plab::sweep::Grid g;
  g.slabs = 8;
  EXPECT_EQ(plab::sweep::last_slab(plab::sweep::path_end(2.0), g), 7);   // no wall this step
  EXPECT_EQ(plab::sweep::last_slab(plab::sweep::path_end(0.3), g), 2);   // wall at 0.3: slabs 0-2
  EXPECT_EQ(plab::sweep::last_slab(plab::sweep::path_end(0.0), g), -1);  // the wall wins at 0
  EXPECT_EQ(plab::sweep::last_slab(plab::sweep::path_end(-1.0), g), -1);
  EXPECT_EQ(plab::sweep::last_slab(plab::sweep::path_end(NAN), g), 7);  // no wall candidate
}

TEST(Plan, SparseGreedyIsGreedy) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> pick(0, 39);
  std::uniform_int_distribution<int> step(0, 7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<double> wall(40);
    std::vector<plab::model::Event> all, pairs;
    for (int i = 0; i < 40; ++i) {
      wall[i] = step(rng) / 4.0;  // many ties, some walls after the step
      if (plab::model::in_step(wall[i])) all.push_back(plab::model::wall_event_key(wall[i], i));
    }
    for (int e = 0; e < 30; ++e) {
      const int i = pick(rng), j = pick(rng);
      if (i == j) continue;
      const auto pair = plab::model::pair_event_key(step(rng) / 8.0, std::min(i, j), std::max(i, j));
      all.push_back(pair);
      pairs.push_back(pair);
      if (e % 5 == 0) pairs.push_back(pair);  // found twice
    }
    const plab::Plan want = plab::greedy_plan(all, wall.size());
    const plab::Plan got = plab::sparse_greedy_plan(pairs, wall);
    ASSERT_EQ(got.partner, want.partner) << "trial " << trial;
    for (int i = 0; i < 40; ++i)
      if (want.partner[i] >= 0) {
        ASSERT_EQ(got.time[i], want.time[i]);
      }
  }
}


TEST(Plan, SparseGreedyInTeamIsSparseGreedy) {
  // The team version (stage 06's CPU path) on the same kind of candidate sets, split over 1 to 5
  // threads in a different order each time: always the serial plan. Small sets of few times
  // (ties everywhere, a pair repeated at other times), then larger and denser ones whose pairs
  // form long chains of falling times (the rounds then take many rounds), on up to 8 threads.
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 700; ++trial) {
    const bool large = trial >= 500;
    const int n = large ? 300 + trial : 40;
    const int count = large ? 3 * n : 30;
    std::uniform_int_distribution<int> pick(0, n - 1);
    std::uniform_int_distribution<int> step(0, large ? 1000 : 7);
    std::uniform_int_distribution<int> near(1, 3);
    std::vector<double> wall(n);
    std::vector<plab::model::Event> pairs;
    for (int i = 0; i < n; ++i) wall[i] = large ? 0.5 + step(rng) / 1000.0 : step(rng) / 4.0;
    for (int e = 0; e < count; ++e) {
      const int i = pick(rng);
      // in the large sets, mostly neighbours by index, with later times further along: chains
      const int j = large && e % 4 != 0 ? std::min(n - 1, i + near(rng)) : pick(rng);
      if (i == j) continue;
      const double t = large && e % 4 != 0 ? 0.4 * (n - i) / n + step(rng) / 1e6 : step(rng) / 8.0;
      const auto pair = plab::model::pair_event_key(large ? t : step(rng) / 8.0, std::min(i, j),
                                                    std::max(i, j));
      pairs.push_back(pair);
      if (e % 5 == 0) pairs.push_back(pair);  // found twice
    }
    std::vector<plab::model::Event> serial = pairs;
    const plab::Plan want = plab::sparse_greedy_plan(serial, wall);
#ifdef _OPENMP
    const int threads = large ? 1 + trial % 8 : 1 + trial % 5;
#else
    const int threads = 1;
#endif
    std::shuffle(pairs.begin(), pairs.end(), rng);
    std::vector<std::vector<plab::model::Event>> parts(threads);
    for (std::size_t e = 0; e < pairs.size(); ++e) parts[e % threads].push_back(pairs[e]);
    plab::Plan got;
    got.partner.resize(wall.size());
    got.time.resize(wall.size());
    plab::SparseSelection work;
#pragma omp parallel num_threads(threads)
    {
#ifdef _OPENMP
      const int t = omp_get_thread_num();
#else
      const int t = 0;
#endif
      plab::sparse_greedy_plan_in_team(parts[t], wall, got, work);
    }
    ASSERT_EQ(got.partner, want.partner) << "trial " << trial;
    for (int i = 0; i < n; ++i)
      if (want.partner[i] >= 0) {
        ASSERT_EQ(got.time[i], want.time[i]) << "trial " << trial << " particle " << i;
      }
  }
}

}  // namespace

// The GPU engine's pass search (float entries, the single-precision slab test) finds every pair
// the model makes meet, also when the pair has become far faster than the first state that set
// the grid (the GPU keeps its grid for the whole run). The double search is checked on the same
// boosted pairs.
TEST(Sweep, SingleNeverDropsAPair) {
  std::mt19937_64 rng(2027);
  std::uniform_real_distribution<double> u(0, 1);
  long checked = 0;
  Meeting m;
  for (int trial = 0; trial < 200000; ++trial) {
    if (!next_meeting(rng, trial, m)) continue;
    ++checked;
    // The grid of a first state up to 10^4 times slower (speeds stay below the square root of
    // the summed squares: sqrt(N) times the first fastest at most).
    const double boost = trial % 4 == 0 ? 1 : std::pow(10.0, 4 * u(rng));
    plab::Particles first = m.c.p;
    for (std::size_t i = 0; i < first.size(); ++i) {
      first.vx[i] /= boost;
      first.vy[i] /= boost;
    }
    std::vector<double> scratch;
    const plab::sweep::Grid g =
        plab::sweep::choose(m.c.box, first, path_ends(m.c.box, first), scratch, trial % 3 / 2.0);
    double energy = 0;
    for (std::size_t i = 0; i < m.c.p.size(); ++i)
      energy += m.c.p.vx[i] * m.c.p.vx[i] + m.c.p.vy[i] * m.c.p.vy[i];
    const plab::sweep::Single single = plab::sweep::single_of(g, m.L, std::sqrt(energy));
    ASSERT_TRUE(std::isfinite(single.rr)) << "L " << m.L << " r " << m.r << " speed " << m.speed;
    ASSERT_TRUE(found_single(m.c.p, m.end, g, single))
        << "pair time " << m.t << " dropped in float: L " << m.L << " r " << m.r << " speed "
        << m.speed << " boost " << boost << " slabs " << g.slabs << " v_cut " << g.v_cut;
    ASSERT_TRUE(found(m.c.p, m.end, g)) << "pair time " << m.t << " dropped: L " << m.L << " r "
                                        << m.r << " speed " << m.speed << " boost " << boost;
  }
  EXPECT_GT(checked, 50000);
}

// The single-precision test passes (almost) only what the double test passes: its allowance
// is a few millionths of the reach, not a looser net.
TEST(Sweep, SingleIsTight) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  plab::sweep::Grid g;
  g.slabs = 8;
  g.half = 0.5 / g.slabs;
  g.margin = 1e-6 * 2e5;
  g.reach = 2 + g.margin;
  const plab::sweep::Single single = plab::sweep::single_of(g, 1e5, 5e6);
  long both = 0, only_single = 0, only_double = 0;
  for (int trial = 0; trial < 1000000; ++trial) {
    const double x0 = 1e5 * u(rng), y0 = 1e5 * u(rng);
    const double x1 = x0 + 40 * (u(rng) - 0.5), y1 = y0 + 40 * (u(rng) - 0.5);
    const double vx0 = 5000 * (u(rng) - 0.5), vy0 = 5000 * (u(rng) - 0.5);
    const double vx1 = 5000 * (u(rng) - 0.5), vy1 = 5000 * (u(rng) - 0.5);
    const bool d = plab::sweep::close_in_slab(x0 - x1, y0 - y1, vx0 - vx1, vy0 - vy1, g);
    const float fx0 = float(x0), fy0 = float(y0), fx1 = float(x1), fy1 = float(y1);
    const float fvx0 = float(vx0), fvy0 = float(vy0), fvx1 = float(vx1), fvy1 = float(vy1);
    const bool s = plab::sweep::close_in_slab_single(
        fx0 - fx1, fy0 - fy1, fvx0 - fvx1, fvy0 - fvy1,
        std::fabs(fvx0) + std::fabs(fvy0) + std::fabs(fvx1) + std::fabs(fvy1), single);
    both += d && s;
    only_single += s && !d;
    only_double += d && !s;
  }
  EXPECT_EQ(only_double, 0);
  EXPECT_GT(both, 1000);
  EXPECT_LT(only_single, both / 20 + 10) << "the float test passes " << only_single
                                          << " pairs the double test does not, of " << both;
}

// The CPU engines test one entry against sixteen at a time with the allowance's constant part
// computed once for the entry, for any partner (lanes::base_of(): its own |vx| + |vy| plus
// Single::s_most). Every pair the pairwise test passes must pass there too, on every vector path,
// with the bound on speeds the engines pass (the fastest speed, times 1 + 10^-6). The partners
// that tell are those the speed term matters for: moving with entry 0 (|w| small, so the
// allowance is its constant part) at about 45 degrees (|vx| + |vy| at its largest, sqrt(2) |v|),
// placed at the allowance's edge. Others move at random and lie anywhere near the reach: at the
// report's scales the lanes pass hardly more of those than the pairwise test.
TEST(Sweep, LanesPassEveryPairThePairTestPasses) {
  namespace sweep = plab::sweep;
  namespace lanes = plab::lanes;
  constexpr int kN = lanes::kLanesSingle;
  constexpr double u24 = 0x1p-24;
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0, 1);
  struct Scale {
    double L, r, speed, half;
  };
  // The report's scales, and a small reach against fast particles (the speed term ~8% of it).
  for (const Scale sc : {Scale{2e5, 1, 5000, 0.1}, Scale{1e4, 1e-3, 1e6, 0.5}}) {
    sweep::Grid g;
    g.half = sc.half;
    g.margin = 1e-6 * (sc.L + 2 * sc.speed + sc.r);
    g.reach = 2 * sc.r + g.margin;
    std::vector<float> x(2 * kN), y(2 * kN), vx(2 * kN), vy(2 * kN);
    const lanes::SingleFields f{x.data(), y.data(), vx.data(), vy.data()};
    long edge_passes = 0, broad_passes = 0, broad_lanes_only = 0;
    for (int trial = 0; trial < 20000; ++trial) {
      // Entry 0, then sixteen partners whose distance at slab time s (their closest approach
      // when they move together) is `gap`: even ones at the allowance's edge for the pair's own
      // speeds, odd ones anywhere from half the reach to one and a half.
      const double angle0 = M_PI / 4 + 0.05 * (2 * u(rng) - 1) + M_PI / 2 * (trial % 4);
      const double px = sc.L * u(rng), py = sc.L * u(rng);
      const double pvx = sc.speed * std::cos(angle0), pvy = sc.speed * std::sin(angle0);
      x[0] = float(px), y[0] = float(py), vx[0] = float(pvx), vy[0] = float(pvy);
      double vmax = std::hypot(pvx, pvy);
      for (int b = 1; b <= kN; ++b) {
        const bool edge = b % 2 == 0;
        const double angle = 2 * M_PI * u(rng), cx = std::cos(angle), cy = std::sin(angle);
        // an edge partner's relative velocity is small and across the line between them, so
        // that `gap` is their closest approach
        const double slow = 1e-5 * sc.speed * (2 * u(rng) - 1);
        const double wx = edge ? pvx - slow * cy : sc.speed * (2 * u(rng) - 1);
        const double wy = edge ? pvy + slow * cx : sc.speed * (2 * u(rng) - 1);
        vmax = std::max(vmax, std::hypot(wx, wy));
        const double s_pair = std::fabs(pvx) + std::fabs(pvy) + std::fabs(wx) + std::fabs(wy);
        const double rim = g.reach + 4 * u24 * sc.L + 2 * u24 * sc.half * s_pair;
        const double gap = edge ? rim * (1 + 2e-4 * (2 * u(rng) - 1)) : g.reach * (0.5 + u(rng));
        const double s = sc.half * (2 * u(rng) - 1);
        const double dx = gap * cx, dy = gap * cy;
        x[b] = float(px + dx - s * (wx - pvx)), y[b] = float(py + dy - s * (wy - pvy));
        vx[b] = float(wx), vy[b] = float(wy);
      }
      const sweep::Single single = sweep::single_of(g, sc.L, vmax * (1 + 1e-6));
      ASSERT_TRUE(std::isfinite(single.rr));
      const float base = lanes::base_of(f, 0, single);
      const unsigned portable = lanes::close_lanes_single(f, 0, base, 1, single);
#if PLAB_AVX2
      if (__builtin_cpu_supports("avx512f")) {
        ASSERT_EQ(lanes::close_lanes_single_avx512(f, 0, base, 1, single), portable);
      }
#endif
      for (int b = 1; b <= kN; ++b) {
        const float s = std::fabs(vx[0]) + std::fabs(vy[0]) + (std::fabs(vx[b]) + std::fabs(vy[b]));
        const bool pair = sweep::close_in_slab_single(x[0] - x[b], y[0] - y[b], vx[0] - vx[b],
                                                      vy[0] - vy[b], s, single);
        const bool lane = (portable >> (b - 1)) & 1u;
        ASSERT_TRUE(!pair || lane) << "L " << sc.L << " r " << sc.r << ": a pair the pair test "
                                   << "passes is dropped by the lanes (entry " << b << ")";
        if (b % 2 == 0) {
          edge_passes += pair;
        } else {
          broad_passes += pair;
          broad_lanes_only += lane && !pair;
        }
      }
    }
    // About half the edge pairs pass: the test is at the edge, where a narrower allowance drops
    EXPECT_GT(edge_passes, 40000) << "L " << sc.L;
    EXPECT_LT(edge_passes, 120000) << "L " << sc.L << ": " << edge_passes << " of 160000";
    EXPECT_GT(broad_passes, 50000) << "L " << sc.L;
    if (sc.r == 1) {  // the report's scales: the bound on the partner's speed costs nothing
      EXPECT_LT(broad_lanes_only, broad_passes / 1000) << broad_lanes_only << " more of "
                                                       << broad_passes;
    }
  }
}
