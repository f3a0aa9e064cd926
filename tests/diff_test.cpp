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

TEST(CompareSteps, EachStepOfTheExpectedWordForWord) {
  // Spacing does not matter; a wrong line costs its step only; short lines and lines that do not
  // start with a whole number belong to no step (a student's output may hold anything).
  std::string b = kA;
  b.replace(b.find("1 1 5.00000000"), 14, "1  1 5.00000001");
  b = "debug: starting\nx y z 1 2 3 4\n" + b;
  auto m = plab::compare_steps(kA, b);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].step, 0);
  EXPECT_TRUE(m[0].equal);
  EXPECT_EQ(m[1].step, 1);
  EXPECT_FALSE(m[1].equal);
  m = plab::compare_steps(kA, "");
  ASSERT_EQ(m.size(), 2u);
  EXPECT_FALSE(m[0].equal || m[1].equal);
  const std::string extra = std::string(kA) + "0 2 1.00000000 2.00000000 3.00000000 4.00000000\n";
  m = plab::compare_steps(kA, extra);  // a line more in step 0 (wherever it is) makes it wrong
  EXPECT_FALSE(m[0].equal);
  EXPECT_TRUE(m[1].equal);
  EXPECT_TRUE(plab::compare_steps("", kA).empty());
}

}  // namespace
