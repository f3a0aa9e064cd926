/// \file test_log_test.cpp
/// \brief `plab test`'s reading of CTest's log (kit/cli/test_log.hpp): every test's result is
/// counted, a failure whose message breaks CTest's result line included.
#include <gtest/gtest.h>

#include "test_log.hpp"

namespace plab::cli {
namespace {

TEST(TestLog, ReadsEachResultLine) {
  const std::string log =
      "        Start 262: view\n"
      " 24/199 Test #263: stress.short ...........   Passed    3.80 sec\n"
      " 25/199 Test #218: stage04.solution.Golden ...***Skipped   0.05 sec\n"
      " 26/199 Test #5: stage06.engine.Spec ........***Failed    0.97 sec\n"
      "what the test printed\n"
      "      Start 162: stage03.student.AgainstOtherStage\n"
      "99% tests passed, 1 tests failed out of 199\n";
  const std::vector<TestResult> tests = parse_log(log);
  ASSERT_EQ(tests.size(), 3u);
  EXPECT_EQ(tests[0].name, "stress.short");
  EXPECT_EQ(tests[0].status, "Passed");
  EXPECT_DOUBLE_EQ(tests[0].seconds, 3.80);
  EXPECT_EQ(tests[1].status, "Skipped");
  EXPECT_EQ(tests[2].status, "Failed");
  EXPECT_EQ(tests[2].output, "what the test printed\n");  // (not another test's Start line)
}

// CTest writes a failed PASS_REGULAR_EXPRESSION ending in "$\n" into the result line, so that
// the seconds come on the next line: the test is still one failure (it was lost from the counts).
TEST(TestLog, JoinsAResultLineTheMessageBroke) {
  const std::string log =
      "        Start 264: accuracy.short\n"
      " 27/199 Test #264: accuracy.short ......***Failed  Required regular expression not found. "
      "Regex=[cradle +06 cpu double K=8 +[0-9.]+ +1[.]0000$\n"
      "]  0.23 sec\n"
      "plab accuracy: stage 06 (engine) is not built from its current code\n"
      " 28/199 Test #204: stage02.solution.Golden ......   Passed    3.83 sec\n";
  const std::vector<TestResult> tests = parse_log(log);
  ASSERT_EQ(tests.size(), 2u);
  EXPECT_EQ(tests[0].name, "accuracy.short");
  EXPECT_EQ(tests[0].status, "Failed");
  EXPECT_DOUBLE_EQ(tests[0].seconds, 0.23);
  EXPECT_NE(tests[0].output.find("Required regular expression not found"), std::string::npos);
  EXPECT_NE(tests[0].output.find("plab accuracy: stage 06"), std::string::npos);
  EXPECT_EQ(tests[1].name, "stage02.solution.Golden");
  EXPECT_EQ(tests[1].status, "Passed");
}

TEST(TestLog, GivesUpOnAResultLineThatNeverEnds) {
  std::string partial;
  int pieces = 0;
  EXPECT_FALSE(whole_line(partial, pieces, " 1/9 Test #1: a.b ....***Failed  why").has_value());
  for (int k = 0; k < 3; ++k) EXPECT_FALSE(whole_line(partial, pieces, "more").has_value());
  const std::optional<std::string> given_up = whole_line(partial, pieces, "more");
  ASSERT_TRUE(given_up.has_value());
  EXPECT_EQ(given_up->rfind(" 1/9 Test #1: a.b", 0), 0u);
  EXPECT_EQ(whole_line(partial, pieces, "plain line"), std::optional<std::string>("plain line"));
}

}  // namespace
}  // namespace plab::cli
