/// \file scene.cpp
/// \brief Small definitions of scene.hpp and errors.hpp.
#include "plab/scene.hpp"

#include "plab/errors.hpp"

namespace plab {

const char* mode_name(Mode mode) { return mode == Mode::kPrint ? "print" : "perf"; }

InputError::InputError(const std::string& file, long line, const std::string& expected,
                       const std::string& found)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) +
                         ": expected " + expected + ", found " + found) {}

}  // namespace plab
