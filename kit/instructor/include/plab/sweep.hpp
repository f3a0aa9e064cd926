/// \file sweep.hpp
/// \brief The broad phase of stage 06: a space-time grid that finds every pair that can meet in a
/// step, and few others, without testing all N^2/2 pairs.
///
/// The step is split into \f$K\f$ equal time slabs. In slab \f$k\f$, with midpoint \f$t_m\f$ and
/// half-width \f$h = 1/(2K)\f$, each particle is binned by its position \f$p + t_m v\f$ into a dense
/// grid of rows of height \f$c \ge 2r + 2 h v_{cut} + 2m\f$, each split into narrow columns. If
/// model.md's pair time \f$t < 1\f$, the centres are (within rounding) \f$2r\f$ apart at \f$t\f$, which lies in some slab,
/// \f$|t - t_m| \le h\f$; so their relative position \f$d\f$ at \f$t_m\f$ and relative velocity
/// \f$w\f$ satisfy \f$\min_{|s| \le h} |d + s w| \le 2r + m\f$ (close_in_slab()), and their midpoint
/// positions are at most \f$2r + m + h(|v_a| + |v_b|)\f$ apart. For two particles no faster than
/// \f$v_{cut}\f$ that puts them in the same or adjacent rows, and within the reach of the one that
/// comes first in cell order, which searches the entries after it (search_of()). A faster
/// particle ("fast") searches every entry within its own reach instead, which covers every
/// partner no faster than itself (a partner faster still searches for it). So the cell size
/// follows the bulk of the speeds, not the single fastest particle of a hot gas.
///
/// Two more things no pair needs: time after a particle's wall time (model.md's key puts the wall
/// first, so a later pair event of that particle is never accepted: path_end(), last_slab()),
/// and cells outside the box (paths before their wall time stay inside; cell_of() clamps, which
/// never separates two neighbours). The margin \f$m\f$ (a millionth of the scene's scale) covers
/// rounding, so no pair with \f$t < 1\f$ that can be accepted is ever dropped.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <vector>

#include "plab/model.hpp"
#include "plab/scene.hpp"

namespace plab::sweep {

/// The space-time grid of one step: rows of height `cell`, each split into kColumnsPerCell
/// narrow columns, so that a particle's neighbours in a row are one run of entries as narrow as
/// its reach.
struct Grid {
  int slabs = 1;           //!< time slabs K
  double half = 0.5;       //!< half a slab, h = 1 / (2K)
  double cell = 1;         //!< row height (length units): at least the reach of a slow particle
  double inv_cell = 1;     //!< 1 / cell
  double inv_column = 1;   //!< 1 / column width
  int rows = 1;            //!< rows: the grid covers [0, rows * cell) in y
  int columns = 1;         //!< columns: [0, columns * column width) in x; cells are row-major
  double reach = 0;        //!< 2r + margin: the distance that makes a candidate
  double margin = 0;       //!< the rounding margin m
  double v_cut = 0;        //!< particles no faster than this are "slow" (see search_of())
  double v_cut2 = 0;       //!< v_cut^2 (a particle is fast when its squared speed exceeds it)
  /// Number of cells, rows x columns.
  [[nodiscard]] PLAB_HD int cells() const { return rows * columns; }
};

/// Columns per row height (the narrower, the fewer entries a run holds beyond a slow particle's
/// reach, and the more cells to count).
constexpr int kColumnsPerCell = 4;

/// Midpoint time of slab `k`.
PLAB_HD inline double slab_mid(int k, const Grid& g) { return (k + 0.5) / g.slabs; }

/// The index of coordinate `v` in units of `1 / inv` (floor), clamped to [0, count - 1]
/// (0 for not-a-number). Clamping never separates two neighbours.
PLAB_HD inline int clamped_index(double v, double inv, int count) {
  const double c = floor(v * inv);
  if (!(c > 0)) return 0;
  return c >= count ? count - 1 : static_cast<int>(c);
}

/// The row of coordinate `y`.
PLAB_HD inline int row_of(double y, const Grid& g) { return clamped_index(y, g.inv_cell, g.rows); }

/// The column of coordinate `x`.
PLAB_HD inline int column_of(double x, const Grid& g) {
  return clamped_index(x, g.inv_column, g.columns);
}

/// The cell (row-major) of the point (x, y).
PLAB_HD inline int cell_of(double x, double y, const Grid& g) {
  return row_of(y, g) * g.columns + column_of(x, g);
}

/// When a particle's path stops mattering for pairs: its wall time `tw` if that is in the step
/// (a pair event at or after it loses to the wall and is never accepted), else 1. Not-a-number
/// gives 1 (the wall is then no candidate).
PLAB_HD inline double path_end(double tw) { return (tw < 1) ? tw : 1.0; }

/// The last slab a particle whose path ends at `end` takes part in (slabs 0 .. last_slab), or -1
/// when no pair of it can be accepted (its wall comes at or before time 0).
PLAB_HD inline int last_slab(double end, const Grid& g) {
  if (!(end > 0)) return -1;
  const double k = floor(end * g.slabs);
  return k >= g.slabs - 1 ? g.slabs - 1 : static_cast<int>(k);
}

/// What a particle searches for partners in each slab: the entries whose midpoint positions lie
/// within `d` of its own along both axes. A slow one (no faster than v_cut) only those after it
/// in cell order, in its own row and the row above: the rest of its cell and the columns of its
/// row up to `x + d`, then the columns from `x - d` to `x + d` of the next row, two runs of
/// entries. A fast one all of them, one run per row.
struct Search {
  double d;   //!< how far, along each axis
  bool fast;  //!< faster than v_cut: searches every entry within `d`, before or after it
};

/// The search of a particle of velocity (vx, vy). Two particles that meet in a slab are at most
/// \f$2r + m + h(|v_a| + |v_b|)\f$ apart at its midpoint. A slow particle's
/// \f$d = 2r + 2m + h(|v| + v_{cut})\f$ covers every slow partner, whichever of the two comes first
/// in cell order, and is at most a row's height, so the partner is in its row or the next. A fast
/// one's \f$d = 2r + 2m + 2h|v|\f$ covers every partner no faster than itself (a partner faster
/// still searches for it). The factor \f$1 + 10^{-6}\f$ (with \f$m\f$) also covers midpoints and
/// velocities rounded to float (the GPU engine's entries: Single), whose error grows with the
/// speed, which can outgrow the \f$v_{max}\f$ that set \f$m\f$ when the grid is kept for a run.
PLAB_HD inline Search search_of(double vx, double vy, const Grid& g) {
  const double v2 = vx * vx + vy * vy;
  const bool fast = v2 > g.v_cut2;
  const double v = sqrt(v2);
  return {(g.reach + g.margin + g.half * (fast ? 2 * v : v + g.v_cut)) * (1 + 1e-6), fast};
}

/// A Search in 4 bytes instead of 16, for the CPU engine's sort, which moves every entry's fields
/// once a slab and on many threads is bound by the bytes it moves: the reach rounded up to float
/// (a reach a little longer only tests a few more entries, so every pair the search must find is
/// still found), its sign the `fast` flag (a not-a-number's too).
struct PackedSearch {
  float packed;  //!< the reach, negative for a fast entry
  /// `q` packed: its reach rounded up to float, negative when `q.fast`.
  static PackedSearch of(const Search& q) {
    // 1e-7 is more than float's rounding of a normal number (2^-24): nextafter() only where the
    // result is not one (reaches below 10^-38)
    float d = static_cast<float>(q.d * (1 + 1e-7));
    if (d < q.d) d = std::nextafter(d, INFINITY);
    return {std::copysign(d, q.fast ? -1.0f : 1.0f)};
  }
  [[nodiscard]] double d() const { return std::fabs(packed); }  //!< at least Search::d
  [[nodiscard]] bool fast() const { return std::signbit(packed); }  //!< Search::fast
};

/// The columns [lo, hi] whose x lies within `d` of `x` (every column when either end is not a
/// number).
PLAB_HD inline void columns_within(double x, double d, const Grid& g, int& lo, int& hi) {
  const double from = x - d, to = x + d;
  const bool known = (from == from) && (to == to);
  lo = known ? column_of(from, g) : 0;
  hi = known ? column_of(to, g) : g.columns - 1;
}

/// The rows [lo, hi] whose y lies within `d` of `y` (every row when either end is not a number).
PLAB_HD inline void rows_within(double y, double d, const Grid& g, int& lo, int& hi) {
  const double from = y - d, to = y + d;
  const bool known = (from == from) && (to == to);
  lo = known ? row_of(from, g) : 0;
  hi = known ? row_of(to, g) : g.rows - 1;
}

/// Whether two particles, `d` apart (relative position at the slab's midpoint) with relative
/// velocity `w`, come within the grid's reach during the slab: \f$\min_{|s| \le h} |d + s w| \le
/// reach\f$. Written without branches or divisions so that a loop over candidates vectorises: the
/// closest approach lies inside the slab when \f$|d \cdot w| \le h |w|^2\f$, and then its squared
/// distance times \f$|w|^2\f$ is \f$|d|^2 |w|^2 - (d \cdot w)^2\f$; otherwise the nearer end of the
/// slab is closest, at squared distance \f$|d|^2 - 2h|d \cdot w| + h^2 |w|^2\f$. Not-a-number
/// counts as close.
PLAB_HD inline bool close_in_slab(double dx, double dy, double wx, double wy, const Grid& g) {
  const double dd = dx * dx + dy * dy;
  const double ww = wx * wx + wy * wy;
  const double q = fabs(dx * wx + dy * wy);
  const double rr = g.reach * g.reach;
  const bool inside = q <= g.half * ww;
  const bool near_inside = !(dd * ww - q * q > rr * ww);
  const bool near_end = !((dd - 2 * g.half * q) + g.half * g.half * ww > rr);
  return (inside & near_inside) | (!inside & near_end);
}

/// close_in_slab() in single precision, for the GPU engine's pass search, whose entries hold
/// each midpoint and velocity rounded to float (16 bytes an entry instead of 32; float arithmetic
/// instead of double). It passes every pair that close_in_slab()'s exact arithmetic passes on the
/// unrounded values (a superset: a pair passed in excess gets model.md's pair time, which is all
/// a candidate ever is), by these bounds, with \f$u = 2^{-24}\f$:
/// - rounding: a midpoint coordinate lies within \f$L + h|v_c|\f$ of the box (its path before its
///   wall is inside), so the rounded relative position and velocity are off by at most
///   \f$u(2\sqrt2 L + h s + |d|)\f$ and \f$u(s + |w|)\f$, where \f$s\f$ is the pair's
///   \f$|v_x| + |v_y|\f$ summed over both (`s` below): the closest approach moves by at most the
///   first plus \f$h\f$ times the second;
/// - arithmetic: each side of the two comparisons is off by at most \f$16u(|d|^2 + h^2|w|^2)\f$
///   (times \f$|w|^2\f$ in the first), and a slab end taken for the inside (or back) costs
///   \f$(q - h|w|^2)^2/|w|^2\f$, a few \f$u^2\f$ of the same.
/// So, with \f$a\f$ the reach plus \f$4uL\f$, the allowance is \f$(a + 2uhs)^2\f$ (Single::rr,
/// `k1` and `k2`, each with \f$32u\f$ of itself to spare) plus Single::slack \f$= 64u\f$ times
/// \f$|d|^2 + h^2|w|^2\f$ (the error that grows with the pair's own lengths). Where float could
/// overflow or go subnormal (single_of()), `rr` is infinite and every pair passes. Not-a-number
/// counts as close. `Sweep.SingleNeverDropsAPair` checks it on random pairs that meet,
/// `Sweep.SingleIsTight` that it passes few pairs the double test does not.
struct Single {
  float half = 0;   //!< h rounded up (a longer slab only widens the test)
  float half2 = 0;  //!< h^2 rounded up
  float rr = 0;     //!< the allowance's constant part, a^2, rounded up; +inf: every pair passes
  float k1 = 0;     //!< times s: 4uah, rounded up
  float k2 = 0;     //!< times s^2: 4u^2h^2, rounded up
  float slack = 0;  //!< 64u: the allowance's part that grows with the pair's lengths
  float s_most = 0;  //!< \f$|v_x| + |v_y|\f$ of any entry, rounded up: what a test of one entry
                     //!< against many can take for the partner's part of `s`
  /// The allowance's part that does not grow with the pair's lengths, for a pair whose `s` is at
  /// most `s`: \f$(a + 2uhs)^2\f$ (as `rr + s (k1 + k2 s)`). It grows with `s`, as does its
  /// rounding, so any upper bound of the pair's `s` gives an allowance at least as wide.
  PLAB_HD float base(float s) const { return rr + s * (k1 + k2 * s); }
};

/// `x` rounded up to a float.
inline float float_up(double x) {
  if (!(x <= FLT_MAX)) return x == x ? HUGE_VALF : static_cast<float>(x);  // past float's range
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, HUGE_VALF);
  return f;
}

/// The single-precision test's constants for grid `g` in a box of side `L`, for speeds that never
/// exceed `vbound` (the square root of the summed squared speeds: elastic collisions and walls
/// keep that sum). Every pair passes when the scales leave float's comfortable range: a reach below
/// 2^-20, or positions and speeds past 10^8 (the products must stay normal and finite).
inline Single single_of(const Grid& g, double L, double vbound) {
  constexpr double u = 0x1p-24;
  Single s;
  s.half = float_up(g.half);
  s.half2 = float_up(static_cast<double>(s.half) * s.half);
  s.slack = static_cast<float>(64 * u);
  const double a = g.reach + 4 * u * L, h = s.half, spare = 1 + 32 * u;
  const bool comfortable = a >= 0x1p-20 && L + vbound < 1e8 && a < 1e8;
  s.rr = comfortable ? float_up(a * a * spare) : HUGE_VALF;
  s.k1 = float_up(4 * u * a * h * spare);
  s.k2 = float_up(4 * u * u * h * h * spare);
  s.s_most = float_up(std::sqrt(2.0) * vbound * (1 + 1e-9));
  return s;
}

/// A midpoint coordinate of the float search: the start `x` moved by `v` to slab time `tm`, less
/// `origin` (a rank's grid origin in stage 08's engine; 0 in stage 06's, where it changes nothing),
/// rounded to float. The entry is sorted by it and the search reads it, so the two agree; Single's
/// bounds hold while it lies within \f$L + h|v|\f$ of 0.
PLAB_HD inline float rounded_midpoint(double x, double v, double tm, double origin = 0) {
  return static_cast<float>((x + tm * v) - origin);
}

/// close_in_slab_single() with the allowance's constant part given: `base` at least
/// Single::base() of the pair's `s` (a test of one entry against many computes it once).
PLAB_HD inline bool close_in_slab_within(float dx, float dy, float wx, float wy, float base,
                                         const Single& c) {
  const float dd = dx * dx + dy * dy;
  const float ww = wx * wx + wy * wy;
  const float q = fabsf(dx * wx + dy * wy);
  const float hw = c.half2 * ww;
  const float allow = base + c.slack * (dd + hw);
  const bool tiny = ww < 0x1p-60f;  // products could go subnormal: close (never dropped)
  const bool inside = q <= c.half * ww;
  const bool near_inside = !(dd * ww - q * q > allow * ww);
  const bool near_end = !((dd - 2 * c.half * q) + hw > allow);
  return tiny | (inside & near_inside) | (!inside & near_end);
}

/// close_in_slab() on float midpoints and velocities (Single): `d` and `w` as there, `s` the
/// pair's \f$|v_x| + |v_y|\f$ summed over both particles (or more).
PLAB_HD inline bool close_in_slab_single(float dx, float dy, float wx, float wy, float s,
                                         const Single& c) {
  return close_in_slab_within(dx, dy, wx, wy, c.base(s), c);
}

/// Chooses the grid for `active` particles, most no faster than `v_cut`, the fastest `vmax`, in a
/// box of side `extent`: \f$K = \lceil \alpha \sqrt N \, v_{cut} / L \rceil\f$ slabs (between 1
/// and 256), which balances the per-slab pass over the particles (cost \f$\propto K N\f$) against
/// the pairs in neighbouring cells (\f$\propto N^2 v_{cut}^2 / (K L^2)\f$);
/// rows of height \f$2r + 2m + v_{cut}/K\f$, each split into kColumnsPerCell columns, no more
/// cells than about \f$4N\f$.
inline Grid choose_for(const Box& box, int active, double v_cut, double vmax, double extent,
                       double alpha = 1.0) {
  Grid g;
  if (!std::isfinite(vmax) || !std::isfinite(extent) || !std::isfinite(v_cut)) {
    g.reach = g.margin = g.cell = HUGE_VAL;  // no geometry to trust: one cell, all pairs
    g.inv_cell = g.inv_column = 0;
    return g;
  }
  g.margin = 1e-6 * (extent + vmax + box.r);
  g.reach = 2 * box.r + g.margin;
  g.slabs = static_cast<int>(std::clamp(
      std::ceil(alpha * std::sqrt(static_cast<double>(std::max(active, 1))) * v_cut / extent),
      1.0, 256.0));
  g.half = 0.5 / g.slabs;
  g.v_cut = v_cut;
  g.v_cut2 = v_cut * v_cut;
  // A row is at least a slow particle's reach (search_of()), so slow partners are one row apart.
  const double wanted = (g.reach + 2 * g.margin + 2 * g.half * v_cut) * (1 + 1e-9);
  const int most = std::max(1, static_cast<int>(std::sqrt(4.0 * std::max(active, 1) / kColumnsPerCell)));
  g.rows = std::clamp(static_cast<int>(std::min(std::ceil(extent / wanted), 1e9)), 1, most);
  g.cell = std::max(wanted, extent / g.rows);
  g.inv_cell = 1 / g.cell;
  g.columns = g.rows * kColumnsPerCell;
  g.inv_column = kColumnsPerCell / g.cell;
  return g;
}

/// The particles choose() samples: one of every sample_stride() that take part, in index order.
inline std::size_t sample_stride(std::size_t n) { return std::max<std::size_t>(1, n / 1024); }

/// The grid for `active` particles whose fastest squared speed is `max2`, from `sample` (the squared
/// speeds of the particles sample_stride() picks, in any order; reordered here): `v_cut` at the
/// `quantile` of the sample. `unordered`: a speed was not a number (no geometry to trust).
inline Grid choose_from_sample(const Box& box, int active, double max2, bool unordered,
                               std::vector<double>& sample, double quantile = 0.9,
                               double alpha = 1.0) {
  double cut2 = 0;
  if (unordered) {
    cut2 = max2 = HUGE_VAL;
  } else if (!sample.empty()) {
    const std::size_t m = sample.size();
    auto at = sample.begin() + std::min<std::size_t>(m - 1, static_cast<std::size_t>(quantile * m));
    std::nth_element(sample.begin(), at, sample.end());
    cut2 = *at;
  }
  return choose_for(box, active, std::sqrt(cut2) * (1 + 1e-12), std::sqrt(max2) * (1 + 1e-12),
                    box.L, alpha);
}

/// Chooses the grid for a state whose paths end at `end` (path_end() of each wall time): the
/// particles that take part, the fastest of them, and `v_cut` at the `quantile` of their speeds
/// (the rest are fast), estimated from at most about 1024 of them taken at even strides
/// (choose_from_sample()). `scratch` is working memory.
template <class Real>
inline Grid choose(const Box& box, const ParticlesOf<Real>& p, const std::vector<double>& end,
                   std::vector<double>& scratch, double quantile = 0.9, double alpha = 1.0) {
  const std::size_t n = p.size(), stride = sample_stride(n);
  scratch.clear();
  int active = 0;
  double max2 = 0;
  bool unordered = false;  // a not-a-number speed: no geometry to trust
  for (std::size_t i = 0; i < n; ++i) {
    if (!(end[i] > 0)) continue;  // takes no part (path_end() is never not-a-number)
    const double v2 = double(p.vx[i]) * double(p.vx[i]) + double(p.vy[i]) * double(p.vy[i]);
    unordered |= (v2 != v2);
    max2 = std::max(max2, v2);
    if (active++ % stride == 0) scratch.push_back(v2);
  }
  return choose_from_sample(box, active, max2, unordered, scratch, quantile, alpha);
}

}  // namespace plab::sweep
