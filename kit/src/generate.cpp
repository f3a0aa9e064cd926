/// \file generate.cpp
/// \brief model.md's generator: no two disks overlap, speeds and directions without libm.
#include "plab/generate.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "plab/errors.hpp"

namespace plab {

SpeedRange default_speeds(const Box& box) {
  const double a = box.L / (8 * box.r);
  const double b = box.L / 4;
  return SpeedRange{std::min(a, b), std::max(a, b)};
}

namespace {

/// A uniform grid of cells at least 2r wide, used only to reject overlapping centres quickly.
class OccupancyGrid {
 public:
  OccupancyGrid(const Box& box, std::size_t n) : r_(box.r) {
    const double most = std::floor(box.L / (2 * box.r));
    const double wanted = std::ceil(std::sqrt(static_cast<double>(n)));
    side_ = static_cast<long>(std::max(1.0, std::min(most, wanted)));
    cell_ = box.L / static_cast<double>(side_);
    cells_.resize(static_cast<std::size_t>(side_ * side_));
  }
  /// Whether a disk at (x, y) would overlap (or touch) one already placed.
  [[nodiscard]] bool overlaps(double x, double y, const Particles& p) const {
    const long cx = cell_of(x);
    const long cy = cell_of(y);
    const double min_d2 = (2 * r_) * (2 * r_);
    for (long gx = std::max(0L, cx - 1); gx <= std::min(side_ - 1, cx + 1); ++gx)
      for (long gy = std::max(0L, cy - 1); gy <= std::min(side_ - 1, cy + 1); ++gy)
        for (int j : cells_[gx * side_ + gy]) {
          const double dx = x - p.x[j];
          const double dy = y - p.y[j];
          if (dx * dx + dy * dy <= min_d2) return true;
        }
    return false;
  }
  void add(double x, double y, int i) { cells_[cell_of(x) * side_ + cell_of(y)].push_back(i); }

 private:
  [[nodiscard]] long cell_of(double v) const {
    return std::clamp(static_cast<long>(v / cell_), 0L, side_ - 1);
  }
  double r_;
  long side_ = 1;
  double cell_ = 1;
  std::vector<std::vector<int>> cells_;
};

}  // namespace

Particles generate(const Box& box, std::size_t n, std::uint64_t seed, SpeedRange speeds) {
  constexpr long kAttempts = 100000;  // per particle, before the box is declared too full
  SplitMix64 rng(seed);
  Particles p;
  p.resize(n);
  OccupancyGrid grid(box, n);
  const double span = box.L - 2 * box.r;
  for (std::size_t i = 0; i < n; ++i) {
    long attempt = 0;
    double x = 0;
    double y = 0;
    do {
      if (++attempt > kAttempts) {
        const double fraction = static_cast<double>(n) * M_PI * box.r * box.r / (box.L * box.L);
        throw InputError("cannot place particle " + std::to_string(i) + " of " +
                         std::to_string(n) + " without overlap after " +
                         std::to_string(kAttempts) + " tries: the box is too full (area fraction " +
                         std::to_string(fraction) + "); use a larger L or fewer particles");
      }
      x = box.r + rng.uniform01() * span;
      y = box.r + rng.uniform01() * span;
    } while (grid.overlaps(x, y, p));
    grid.add(x, y, static_cast<int>(i));
    p.x[i] = x;
    p.y[i] = y;
    const double speed = speeds.min + (speeds.max - speeds.min) * rng.uniform01();
    double u = 0;
    double v = 0;
    double s = 0;
    do {
      u = 2 * rng.uniform01() - 1;
      v = 2 * rng.uniform01() - 1;
      s = u * u + v * v;
    } while (s == 0 || s > 1);
    const double norm = std::sqrt(s);
    p.vx[i] = speed * (u / norm);
    p.vy[i] = speed * (v / norm);
  }
  return p;
}

}  // namespace plab
