/// \file generate.hpp
/// \brief Reproducible random scenes (model.md's Generation), the same bits on every platform.
#pragma once

#include <cstdint>
#include <string>

#include "plab/scene.hpp"

namespace plab {

/// SplitMix64: a small generator with a fixed, documented output sequence.
class SplitMix64 {
 public:
  /// Starts the sequence at `seed`.
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  /// The next 64-bit output.
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// A double uniform in [0, 1): the top 53 bits times 2^-53 (exact, no library mapping).
  double uniform01() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

/// The seed used when none is given.
inline constexpr std::uint64_t kDefaultSeed = 2019;

/// Speed range of generated particles, in length units per step.
struct SpeedRange {
  double min = 0;  //!< lowest speed
  double max = 0;  //!< highest speed
};

/// model.md's default speeds: between L/(8r) and L/4 (the smaller is the lower bound).
SpeedRange default_speeds(const Box& box);

/// A speed range written `MIN:MAX` (`plab gen --speed`, the runner's `--speed`).
/// \throws std::invalid_argument, saying what was expected, when `text` is not two numbers
/// 0 <= MIN <= MAX
SpeedRange parse_speed_range(const std::string& text);

/// Generates `n` particles: centres uniform in \f$[r, L-r]^2\f$ with no two disks overlapping
/// (reject and redraw), speeds uniform in `speeds`, directions uniform (a point in the unit disc
/// drawn by rejection, normalised: no sin/cos). Particle by particle: centre, then velocity.
/// \throws InputError when the box is too full to place every disk
Particles generate(const Box& box, std::size_t n, std::uint64_t seed, SpeedRange speeds);

}  // namespace plab
