/// \file grid.hpp
/// \brief Stage 06's space-time grid, chosen from the scene (given): the step cut into time
/// slabs, the box into square cells, and the cell of a point.
///
/// The step is split into \f$K\f$ equal time slabs. In slab \f$k\f$, with midpoint \f$t_m\f$ and
/// half-width \f$h = 1/(2K)\f$, each particle stands at its midpoint position \f$p + t_m v\f$. If
/// two particles meet at a time \f$t\f$ of slab \f$k\f$ (model.md's pair time), their centres are
/// \f$2r\f$ apart at \f$t\f$, and \f$|t - t_m| \le h\f$: at the midpoint they are at most
/// \f$2r + h(|v_a| + |v_b|)\f$ apart, plus rounding, which Grid::margin covers. The cell side is
/// about that distance for the bulk of the particles (the 90% slowest), so most partners are in
/// neighbouring cells; a faster particle's partners may be several cells away. Which cells to
/// search, and the binning into cells, are stage 06's exercises (handout 06).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "plab/scene.hpp"

namespace plab::grid {

/// The space-time grid of one step: `slabs` time slabs, `side` x `side` square cells (row-major:
/// cell = row * side + column) covering the box; points outside it go to the nearest cell.
struct Grid {
  int slabs = 1;         //!< time slabs K
  double half = 0.5;     //!< half a slab, h = 1 / (2K)
  int side = 1;          //!< cells along each axis
  double inv_cell = 0;   //!< 1 / the cell side (0: one cell holds everything)
  double reach = 0;      //!< 2r + margin: how close two centres come when they meet
  double margin = 0;     //!< what rounding may add to a distance (a millionth of the scene)

  /// Number of cells, side x side.
  [[nodiscard]] int cells() const { return side * side; }

  /// Midpoint time of slab `k`.
  [[nodiscard]] double slab_mid(int k) const { return (k + 0.5) / slabs; }

  /// The slab that holds time `t` of the step (0 <= t < 1).
  [[nodiscard]] int slab_of(double t) const {
    const double k = std::floor(t * slabs);
    return k >= slabs - 1 ? slabs - 1 : (k > 0 ? static_cast<int>(k) : 0);
  }

  /// The last slab a particle with wall time `wall` takes part in, or -1 for none: a pair event
  /// at or after the particle's wall time is never accepted (the wall comes first in model.md's
  /// key), so its path stops mattering there.
  [[nodiscard]] int last_slab(double wall) const {
    const double end = wall < 1 ? wall : 1.0;  // a not-a-number wall time is no event: 1
    if (!(end > 0)) return -1;
    return slab_of(end);
  }

  /// The row or column of coordinate `v`: floor(v / cell side), clamped to [0, side - 1] (0 for
  /// not-a-number). Clamping keeps the order of coordinates, so it never separates neighbours.
  [[nodiscard]] int index_of(double v) const {
    const double c = std::floor(v * inv_cell);
    if (!(c > 0)) return 0;
    return c >= side ? side - 1 : static_cast<int>(c);
  }

  /// The cell of the point (x, y).
  [[nodiscard]] int cell_of(double x, double y) const { return index_of(y) * side + index_of(x); }

  /// The rows (or columns) [lo, hi] that hold a coordinate within `d` of `v`: every one when
  /// either end is not a number.
  void indices_within(double v, double d, int& lo, int& hi) const {
    const double from = v - d, to = v + d;
    const bool known = (from == from) && (to == to);
    lo = known ? index_of(from) : 0;
    hi = known ? index_of(to) : side - 1;
  }
};

/// Chooses the grid of a step from each particle's squared speed `speed2` and wall time `wall`
/// (the particles whose wall comes at time 0 take no part). With \f$v_{cut}\f$ the speed of the
/// 90% slowest of those that take part (from a sample of about 1024 of them):
/// \f$K = \lceil \alpha \sqrt N \, v_{cut} / L \rceil\f$ slabs (1 to 256; more slabs: more
/// binning, fewer particles a cell; \f$\alpha = 0.8\f$ was the fastest of 0.3, 0.6, 0.8 and 1 for
/// stage 06 at N = 10^4) and cells of side at least \f$2r + 2m + 2 h v_{cut}\f$, no more than
/// about \f$N\f$ of them. A speed or size that is not finite gives one slab and one cell.
inline Grid choose(const Box& box, const std::vector<double>& speed2,
                   const std::vector<double>& wall, double alpha = 0.8) {
  const std::size_t n = speed2.size(), stride = std::max<std::size_t>(1, n / 1024);
  std::vector<double> sample;
  int active = 0;
  double max2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(wall[i] < 1 ? wall[i] > 0 : true)) continue;  // takes no part (Grid::last_slab())
    max2 = (speed2[i] > max2 || speed2[i] != speed2[i]) ? speed2[i] : max2;
    if (active++ % stride == 0) sample.push_back(speed2[i]);
  }
  double cut2 = 0;
  if (!sample.empty() && max2 == max2) {
    const auto quantile = static_cast<std::ptrdiff_t>(0.9 * static_cast<double>(sample.size()));
    const auto at = sample.begin() + quantile;
    std::nth_element(sample.begin(), at, sample.end());
    cut2 = *at;
  }
  const double v_cut = std::sqrt(cut2) * (1 + 1e-12), vmax = std::sqrt(max2) * (1 + 1e-12);
  Grid g;
  if (!std::isfinite(vmax) || !std::isfinite(box.L) || !std::isfinite(box.r)) {
    g.reach = g.margin = HUGE_VAL;  // no geometry to trust: one cell, every pair
    return g;
  }
  g.margin = 1e-6 * (box.L + vmax + box.r);
  g.reach = 2 * box.r + g.margin;
  const double slabs = std::ceil(alpha * std::sqrt(std::max(active, 1)) * v_cut / box.L);
  g.slabs = static_cast<int>(std::clamp(slabs, 1.0, 256.0));
  g.half = 0.5 / g.slabs;
  // The cell side: the bound above for two particles of speed v_cut (reach, then one margin for
  // the rounded midpoints), and one margin more of slack for the cells' own arithmetic. That slack
  // is the grid's: a search's distance is the bound, not the cell side.
  const double cell = (g.reach + 2 * g.margin + 2 * g.half * v_cut) * (1 + 1e-9);
  const int most = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(active))));
  g.side = std::clamp(static_cast<int>(std::min(std::floor(box.L / cell), 1e9)), 1, most);
  g.inv_cell = g.side / box.L;
  return g;
}

}  // namespace plab::grid
