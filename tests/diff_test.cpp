/// \file diff_test.cpp
/// \brief `plab diff`: the first differing step, particle and field, and how many lines differ.
#include <gtest/gtest.h>

#include "plab/diff.hpp"

namespace {

const char* kA = "0 0 1.00000000 2.00000000 3.00000000 4.00000000\n"
                 "0 1 5.00000000 6.00000000 7.00000000 8.00000000\n"
                 "1 0 1.00000000 2.00000000 3.00000000 4.00000000 0 1\n"
                 "1 1 5.00000000 6.00000000 7.00000000 8.00000000 0 0\n";

TEST(Diff, EqualIsNothing) { EXPECT_FALSE(plab::first_difference(kA, kA)); }

TEST(Diff, NamesStepParticleField) {
  std::string b = kA;
  b.replace(b.find("7.00000000"), 10, "7.00000001");
  b.replace(b.find("0 0\n"), 4, "0 1\n");
  const auto d = plab::first_difference(kA, b);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->line, 2);
  EXPECT_EQ(d->step, "0");
  EXPECT_EQ(d->particle, "1");
  EXPECT_EQ(d->field, "vx");
  EXPECT_EQ(d->expected, "7.00000000");
  EXPECT_EQ(d->actual, "7.00000001");
  EXPECT_EQ(d->differing_lines, 2);
  EXPECT_NE(d->describe().find("step 0, particle 1, field vx"), std::string::npos);
}

TEST(Diff, CountersAndMissingLines) {
  std::string b = kA;
  b.replace(b.find("0 1\n"), 4, "2 1\n");
  auto d = plab::first_difference(kA, b);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->field, "pc");
  const std::string shorter(kA, std::string(kA).find("1 1 "));
  d = plab::first_difference(kA, shorter);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->line, 4);
  EXPECT_EQ(d->field, "line");
  EXPECT_EQ(d->differing_lines, 1);
}

TEST(Diff, DigestLines) {
  const auto d = plab::first_difference("0 00000000000000aa\n1 00000000000000bb\n",
                                        "0 00000000000000aa\n1 00000000000000bc\n");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->step, "1");
  EXPECT_EQ(d->field, "digest");
  EXPECT_TRUE(d->particle.empty());
}

}  // namespace
