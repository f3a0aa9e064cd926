/// \file errors.hpp
/// \brief The kit's exceptions: bad input, a starting point's unfinished exercise, no GPU.
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

/// Thrown by a CUDA stage when no usable CUDA device is found (no GPU, no driver, a driver too
/// old): the runner prints one line and exits 4, the tests skip.
class NoDevice : public std::runtime_error {
 public:
  /// `why` is the CUDA runtime's own message.
  explicit NoDevice(const std::string& why) : std::runtime_error("no CUDA device: " + why) {}
};

}  // namespace plab
