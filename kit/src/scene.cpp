/// \file scene.cpp
/// \brief Small definitions of scene.hpp and errors.hpp.
#include "plab/scene.hpp"

#include "plab/errors.hpp"

namespace plab {

void Particles::resize(std::size_t n) {
  x.resize(n);
  y.resize(n);
  vx.resize(n);
  vy.resize(n);
  pc.resize(n);
  wc.resize(n);
}

const char* mode_name(Mode mode) { return mode == Mode::kPrint ? "print" : "perf"; }

InputError::InputError(const std::string& file, long line, const std::string& expected,
                       const std::string& found)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) +
                         ": expected " + expected + ", found " + found) {}

}  // namespace plab
