/// \file scene.hpp
/// \brief The state of a simulation: the box, the particles (one array per field), the scene.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace plab {

/// The square box \f$[0, L]^2\f$ and the common radius of the disks.
struct Box {
  double L = 0;  //!< side of the box (length units)
  double r = 0;  //!< radius of every disk (length units)
};

/// The particles, one array per field (index `i` is particle `i`), in reals of type `Real`:
/// `double` everywhere (plab::Particles), `float` only in `plab accuracy`'s float variant.
template <class Real>
struct ParticlesOf {
  std::vector<Real> x;        //!< centre x (length units)
  std::vector<Real> y;        //!< centre y (length units)
  std::vector<Real> vx;       //!< velocity x (length units per step)
  std::vector<Real> vy;       //!< velocity y (length units per step)
  std::vector<long long> pc;  //!< collisions with other particles so far
  std::vector<long long> wc;  //!< collisions with walls so far

  /// Number of particles.
  [[nodiscard]] std::size_t size() const { return x.size(); }
  /// Resizes every field to `n` particles (new ones zero).
  void resize(std::size_t n) {
    x.resize(n);
    y.resize(n);
    vx.resize(n);
    vy.resize(n);
    pc.resize(n);
    wc.resize(n);
  }
  /// The same particles in another real type (each value rounded to it).
  template <class Other>
  [[nodiscard]] ParticlesOf<Other> as() const {
    return ParticlesOf<Other>{{x.begin(), x.end()}, {y.begin(), y.end()}, {vx.begin(), vx.end()},
                              {vy.begin(), vy.end()}, pc, wc};
  }
};

/// The particles in model.md's doubles: what every stage and file uses.
using Particles = ParticlesOf<double>;

/// What the output shows: every step (`print`) or the first and last (`perf`).
enum class Mode { kPrint, kPerf };

/// A scene file read into memory (model.md's input format).
struct Scene {
  Box box;                   //!< the box and radius
  long long steps = 0;       //!< number of steps S
  Mode mode = Mode::kPrint;  //!< output mode
  Particles particles;       //!< the initial state
  bool generated = false;    //!< true when the file had no particle lines and the kit made them
};

/// The name of a mode as written in scene files (`print` or `perf`).
const char* mode_name(Mode mode);

}  // namespace plab
