/// \file generate.cpp
/// \brief model.md's generator: no two disks overlap, speeds and directions without libm.
#include "plab/generate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "plab/errors.hpp"

namespace plab {

SpeedRange default_speeds(const Box& box) {
  const double a = box.L / (8 * box.r);
  const double b = box.L / 4;
  return SpeedRange{std::min(a, b), std::max(a, b)};
}

SpeedRange parse_speed_range(const std::string& text) {
  const auto colon = text.find(':');
  SpeedRange range;
  std::size_t used_min = 0;
  std::size_t used_max = 0;
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no colon");
    range.min = std::stod(text.substr(0, colon), &used_min);
    range.max = std::stod(text.substr(colon + 1), &used_max);
  } catch (const std::exception&) {
    used_min = 0;
  }
  if (used_min == 0 || used_min != colon || colon + 1 + used_max != text.size())
    throw std::invalid_argument("--speed expects MIN:MAX, e.g. 1:5, not '" + text + "'");
  if (!(range.min >= 0 && range.max >= range.min && std::isfinite(range.max)))
    throw std::invalid_argument("--speed needs 0 <= MIN <= MAX, not '" + text + "'");
  return range;
}

namespace {

/// The centres placed so far, filed by a uniform grid of cells at least 2r wide, used only to
/// reject overlapping centres quickly. A cell's centres are a list through `head_` (a cell's last
/// centre) and `next_` (the one filed before it in the same cell): 8 bytes a particle at most, so
/// that 10^9 particles fit beside their own arrays.
class OccupancyGrid {
 public:
  OccupancyGrid(const Box& box, std::size_t n) : r_(box.r), next_(n, -1) {
    const double most = std::floor(box.L / (2 * box.r));
    const double wanted = std::ceil(std::sqrt(static_cast<double>(n)));
    side_ = static_cast<long>(std::max(1.0, std::min(most, wanted)));
    cell_ = box.L / static_cast<double>(side_);
    head_.assign(static_cast<std::size_t>(side_ * side_), -1);
  }
  /// Whether a disk at (x, y) would overlap (or touch) one already placed. A centre the test
  /// accepts is 2r away give or take rounding, so within 4r in x and in y: only the cells that
  /// square meets (of the 3 x 3 around the new centre) can hold one, usually a single cell.
  [[nodiscard]] bool overlaps(double x, double y, const Particles& p) const {
    const long cx = cell_of(x);
    const long cy = cell_of(y);
    const double min_d2 = (2 * r_) * (2 * r_);
    const double near = 4 * r_;
    const long x_hi = std::min(cx + 1, cell_of(x + near));
    const long y_hi = std::min(cy + 1, cell_of(y + near));
    for (long gx = std::max(cx - 1, cell_of(x - near)); gx <= x_hi; ++gx)
      for (long gy = std::max(cy - 1, cell_of(y - near)); gy <= y_hi; ++gy)
        for (int j = head_[gx * side_ + gy]; j >= 0; j = next_[j]) {
          const double dx = x - p.x[j];
          const double dy = y - p.y[j];
          if (dx * dx + dy * dy <= min_d2) return true;
        }
    return false;
  }
  /// The cell of a centre at (x, y).
  [[nodiscard]] long cell_at(double x, double y) const { return cell_of(x) * side_ + cell_of(y); }
  /// Asks memory for a cell's list head (a hint: nothing is read).
  void fetch_cell(long cell) const { __builtin_prefetch(&head_[cell]); }
  /// Asks memory for the first centre filed in a cell (-1: none).
  void fetch_first(long cell, const Particles& p) const {
    if (cell < 0) return;
    const int j = head_[cell];
    if (j < 0) return;
    __builtin_prefetch(&p.x[j]);
    __builtin_prefetch(&p.y[j]);
    __builtin_prefetch(&next_[j]);
  }
  /// Files particle `i`, at (x, y).
  void add(double x, double y, int i) {
    int& head = head_[cell_at(x, y)];
    next_[i] = head;
    head = i;
  }

 private:
  [[nodiscard]] long cell_of(double v) const {
    return std::clamp(static_cast<long>(v / cell_), 0L, side_ - 1);
  }
  double r_;
  long side_ = 1;
  double cell_ = 1;
  std::vector<int> head_;  //!< per cell: its last centre filed, or -1
  std::vector<int> next_;  //!< per particle: the centre filed before it in its cell, or -1
};

/// What one particle takes from the generator (model.md's Generation), in its order.
struct Draws {
  double r;            //!< radius: centres start at r
  double span;         //!< L - 2r: centres are uniform in [r, L - r]
  SpeedRange speeds;   //!< speeds are uniform in this range

  /// A centre: x, then y.
  void centre(SplitMix64& rng, double& x, double& y) const {
    x = r + rng.uniform01() * span;
    y = r + rng.uniform01() * span;
  }
  /// A velocity: the speed, then a direction (a point in the unit disc drawn by rejection,
  /// normalised: no sin/cos).
  void velocity(SplitMix64& rng, double& vx, double& vy) const {
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
    vx = speed * (u / norm);
    vy = speed * (v / norm);
  }
};

/// A copy of the generator that runs kAhead particles ahead of it, as if every first centre were
/// accepted (in a sparse box nearly all are). It names the cells the next particles will check,
/// so that memory fetches them while earlier particles are checked: placing 10^9 particles is
/// otherwise a wait on memory for every one of them. It only fetches; what is placed is the
/// generator's alone. A centre drawn again puts it off the sequence: it restarts from the
/// generator.
class Scout {
 public:
  static constexpr int kAhead = 32;  //!< particles looked ahead

  Scout(const OccupancyGrid& grid, const Draws& draws, const SplitMix64& rng, const Particles& p)
      : grid_(grid), draws_(draws), rng_(rng), p_(p) {
    restart(rng);
  }
  /// The generator placed its particle at the first try: look one particle further.
  void next() {
    double x = 0;
    double y = 0;
    draws_.centre(rng_, x, y);
    double vx = 0;
    double vy = 0;
    draws_.velocity(rng_, vx, vy);
    const long cell = grid_.cell_at(x, y);
    grid_.fetch_cell(cell);  // the cell's list head, now; its first centre, half way there
    ahead_[at_] = cell;
    grid_.fetch_first(ahead_[(at_ + kAhead / 2) % kAhead], p_);
    at_ = (at_ + 1) % kAhead;
  }
  /// Starts again kAhead particles after the generator `rng`.
  void restart(const SplitMix64& rng) {
    rng_ = rng;
    ahead_.fill(-1);
    for (int k = 0; k < kAhead; ++k) next();
  }

 private:
  const OccupancyGrid& grid_;
  const Draws& draws_;
  SplitMix64 rng_;
  const Particles& p_;
  std::array<long, kAhead> ahead_{};  //!< the cells of the next kAhead particles, a ring
  int at_ = 0;                        //!< where the next cell goes in the ring
};

}  // namespace

Particles generate(const Box& box, std::size_t n, std::uint64_t seed, SpeedRange speeds) {
  constexpr long kAttempts = 100000;  // per particle, before the box is declared too full
  SplitMix64 rng(seed);
  Particles p;
  p.resize(n);
  OccupancyGrid grid(box, n);
  const Draws draws{box.r, box.L - 2 * box.r, speeds};
  Scout scout(grid, draws, rng, p);
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
      draws.centre(rng, x, y);
    } while (grid.overlaps(x, y, p));
    grid.add(x, y, static_cast<int>(i));
    p.x[i] = x;
    p.y[i] = y;
    draws.velocity(rng, p.vx[i], p.vy[i]);
    if (attempt == 1) {
      scout.next();
    } else {
      scout.restart(rng);  // the centres drawn again put the scout off the sequence
    }
  }
  return p;
}

}  // namespace plab
