/// \file candidates_test.cpp
/// \brief candidates.hpp as a specification: pairs found by any number of threads are filed
/// under both of their particles, in compressed rows, and a particle with none has an empty row.
#include <gtest/gtest.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "plab/candidates.hpp"

namespace {

/// Particle `i`'s entries as sorted (other, time) pairs.
std::vector<std::pair<int, double>> row(const plab::CandidateLists& c, int i) {
  std::vector<std::pair<int, double>> r;
  for (int k = c.start[i]; k < c.start[i + 1]; ++k) r.emplace_back(c.other[k], c.time[k]);
  std::sort(r.begin(), r.end());
  return r;
}

TEST(CandidateLists, EveryPairIsFiledUnderBothParticles) {
  // Two threads' lists: thread 0 found (0, 2) and (1, 2), thread 1 found (0, 3).
  const std::vector<std::vector<plab::FoundPair>> found{{{0.5, 0, 2}, {0.25, 1, 2}},
                                                        {{0.75, 0, 3}}};
  plab::CandidateLists c;
  c.build(5, found);
  ASSERT_EQ(c.start.size(), 6u);
  EXPECT_EQ(c.start.back(), 6);  // three pairs, two entries each
  using Row = std::vector<std::pair<int, double>>;
  EXPECT_EQ(row(c, 0), (Row{{2, 0.5}, {3, 0.75}}));
  EXPECT_EQ(row(c, 1), (Row{{2, 0.25}}));
  EXPECT_EQ(row(c, 2), (Row{{0, 0.5}, {1, 0.25}}));
  EXPECT_EQ(row(c, 3), (Row{{0, 0.75}}));
  EXPECT_TRUE(row(c, 4).empty());  // a particle with no candidate
}

TEST(CandidateLists, RebuildingForgetsTheLastStep) {
  plab::CandidateLists c;
  c.build(3, {{{0.5, 0, 1}, {0.5, 1, 2}}});
  c.build(3, {{}});
  EXPECT_EQ(c.start, (std::vector<int>{0, 0, 0, 0}));
  EXPECT_TRUE(c.other.empty());
}

TEST(CandidateLists, MemoryGrowsWithTheCandidatesNotWithNSquared) {
  plab::CandidateLists c;
  const int n = 10000;
  c.build(n, {{{0.5, 0, 1}}});
  EXPECT_EQ(c.bytes(), (n + 1) * sizeof(int) + 2 * sizeof(int) + 2 * sizeof(double));
}

}  // namespace
