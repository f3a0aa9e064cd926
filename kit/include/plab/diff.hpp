/// \file diff.hpp
/// \brief Comparing two outputs (or digest files): where they first differ, and how much.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace plab {

/// The first difference between two outputs.
struct Difference {
  long line = 0;             //!< 1-based line number of the first differing line
  std::string step;          //!< its step
  std::string particle;      //!< its particle index (empty for digest lines)
  std::string field;         //!< the first differing field (x, y, vx, vy, pc, wc, digest, ...)
  std::string expected;      //!< the expected value of that field
  std::string actual;        //!< the actual value
  long differing_lines = 0;  //!< how many lines differ in all (missing lines count)
  /// A readable one-paragraph report.
  [[nodiscard]] std::string describe() const;
};

/// Compares two outputs line by line; nothing when they are equal.
std::optional<Difference> first_difference(std::string_view expected, std::string_view actual);

/// Whether one step of an expected output is printed the same in another.
struct StepMatch {
  long long step = 0;  //!< a step that the expected output prints
  bool equal = false;  //!< the actual output prints the same lines for it, word for word
};

/// Step by step (the grader's score of one-step runs): for every step the expected output prints,
/// in order of first appearance, whether the actual prints the same lines for it. A step's lines
/// are those of 6 or more words whose first word is that step, in order; any other line (a short
/// one, one not starting with a whole number: a student's output may be anything) is in no step.
std::vector<StepMatch> compare_steps(std::string_view expected, std::string_view actual);

}  // namespace plab
