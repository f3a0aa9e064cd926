/// \file errors.hpp
/// \brief The kit's exceptions: bad input, and a starting point's unfinished exercise.
#pragma once

#include <stdexcept>
#include <string>

namespace plab {

/// A malformed input: the message reads `FILE:LINE: expected ..., found ...`.
class InputError : public std::runtime_error {
 public:
  /// Builds the message from its parts (`line` 0 means the file as a whole).
  InputError(const std::string& file, long line, const std::string& expected,
             const std::string& found);
  /// A message that does not fit the expected/found shape (e.g. a file that cannot be opened).
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

/// Thrown by a starting point where the student has not written an exercise yet.
class NotDone : public std::runtime_error {
 public:
  /// `stage` is the two-digit stage number, `exercise` the marker number, `what` its title.
  NotDone(const std::string& stage, int exercise, const std::string& what)
      : std::runtime_error("stage " + stage + ": EXERCISE " + std::to_string(exercise) + " (" +
                           what + ") is not done yet") {}
};

}  // namespace plab
