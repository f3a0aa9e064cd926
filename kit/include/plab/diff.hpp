/// \file diff.hpp
/// \brief Comparing two outputs (or digest files): where they first differ, and how much.
#pragma once

#include <optional>
#include <string>
#include <string_view>

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

}  // namespace plab
