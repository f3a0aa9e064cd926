/// \file sweep.hpp
/// \brief The broad phase of stage 06: a space-time grid that finds every pair that can meet in a
/// step, and few others, without testing all N^2/2 pairs.
///
/// The step is split into \f$K\f$ equal time slabs. In slab \f$k\f$, with midpoint \f$t_m\f$ and
/// half-width \f$h = 1/(2K)\f$, each particle is binned by its position \f$p + t_m v\f$ into square
/// cells of side \f$c \ge 2r + v_{max}/K + m\f$. If MODEL.md's pair time \f$t < 1\f$, the centres are
/// (within rounding) \f$2r\f$ apart at \f$t\f$, which lies in some slab, \f$|t - t_m| \le h\f$; so
/// their relative position \f$d\f$ at \f$t_m\f$ and relative velocity \f$w\f$ satisfy
/// \f$\min_{|s| \le h} |d + s w| \le 2r + m\f$ (close_in_slab()), which puts them in the same or
/// adjacent cells. Each slab costs a pass over the particles, and fewer slabs mean larger cells
/// with more pairs to test: choose() balances the two from the scene. The margin \f$m\f$ (a
/// millionth of the scene's scale) covers rounding, so no pair with \f$t < 1\f$ is ever dropped.
#pragma once

#include <algorithm>
#include <cmath>

#include "plab/model.hpp"
#include "plab/scene.hpp"

namespace plab::sweep {

/// The space-time grid of one step.
struct Grid {
  int slabs = 1;          //!< time slabs K
  double cell = 1;        //!< side of a square cell (length units)
  double inv_cell = 1;    //!< 1 / cell
  double origin = 0;      //!< x and y of the grid's low corner
  int side = 1;           //!< cells per side
  int bucket_bits = 0;    //!< cells are hashed into 2^bucket_bits buckets (about 2N)
  double reach = 0;       //!< 2r + margin: the distance that makes a candidate
};

/// Midpoint time of slab `k`.
PLAB_HD inline double slab_mid(int k, const Grid& g) { return (k + 0.5) / g.slabs; }

/// The cell column (or row) of coordinate `v`, clamped to the grid (0 for not-a-number).
PLAB_HD inline int cell_of(double v, const Grid& g) {
  const double c = floor((v - g.origin) * g.inv_cell);
  if (!(c > 0)) return 0;
  return c >= g.side ? g.side - 1 : static_cast<int>(c);
}

/// The bucket of cell (cx, cy): a multiplicative hash of its index. Cells that share a bucket only
/// add pairs to test (close_in_slab() sorts them out), so the grid can be fine without its memory
/// and its per-slab clearing growing with the number of cells.
PLAB_HD inline unsigned bucket_of(int cx, int cy, const Grid& g) {
  const unsigned long long index = static_cast<unsigned long long>(cy) * g.side + cx;
  return g.bucket_bits == 0
             ? 0u
             : static_cast<unsigned>((index * 0x9E3779B97F4A7C15ull) >> (64 - g.bucket_bits));
}

/// How far a particle of velocity (vx, vy) moves in half a slab, a hair over (for rounding): the
/// quick-reject distance close_in_slab() takes for each particle.
PLAB_HD inline double slab_reach(double vx, double vy, const Grid& g) {
  return sqrt(vx * vx + vy * vy) * (0.5 / g.slabs) * (1 + 1e-9);
}

/// Whether two particles, `d` apart (relative position at the slab's midpoint) with relative
/// velocity `w`, come within the grid's reach during the slab: \f$\min_{|s| \le h} |d + s w| \le
/// reach\f$, without a division. `ra`, `rb`: each particle's \f$h |v|\f$, for a quick reject.
PLAB_HD inline bool close_in_slab(double dx, double dy, double wx, double wy, double ra, double rb,
                                  const Grid& g) {
  const double dd = dx * dx + dy * dy;
  const double far = g.reach + (ra + rb);  // symmetric in the two particles, bit for bit
  if (dd > far * far) return false;  // farther apart than both can close in half a slab
  const double h = 0.5 / g.slabs;
  const double ww = wx * wx + wy * wy;
  const double q = dx * wx + dy * wy;  // the closest approach is at s = -q / ww
  const double rr = g.reach * g.reach;
  if (q <= h * ww && q >= -h * ww) return !(dd * ww - q * q > rr * ww);
  const double s = (q > 0) ? -h : h;  // the end of the slab nearer to the closest approach
  const double ex = dx + s * wx, ey = dy + s * wy;
  return !(ex * ex + ey * ey > rr);  // not-a-number counts as close
}

/// Chooses the grid for `n` particles of speed at most `vmax` whose coordinates stay within
/// `extent` of the origin: \f$K \approx \alpha \sqrt N \, v_{max} / L\f$ slabs (between 1 and 256),
/// cells of side \f$2r + v_{max}/K + m\f$, at most `max_side` per side, hashed into about \f$2N\f$
/// buckets.
inline Grid choose_for(const Box& box, std::size_t n, double vmax, double extent,
                       double alpha = 1.0, int max_side = 1 << 20) {
  Grid g;
  if (!std::isfinite(vmax) || !std::isfinite(extent)) {  // no geometry to trust: one cell
    g.reach = HUGE_VAL;
    return g;
  }
  const double margin = 1e-6 * (extent + vmax + box.r);
  g.reach = 2 * box.r + margin;
  g.slabs = static_cast<int>(std::clamp(
      std::ceil(alpha * std::sqrt(static_cast<double>(n)) * vmax / extent), 1.0, 256.0));
  const double span = extent + 2 * (vmax + g.reach);  // paths leave the box by at most vmax
  g.origin = -(vmax + g.reach);
  g.cell = std::max(g.reach + vmax / g.slabs + margin, span / max_side);
  g.inv_cell = 1 / g.cell;
  g.side = std::max(1, static_cast<int>(std::ceil(span * g.inv_cell)));
  while ((std::size_t{1} << g.bucket_bits) < 2 * n && g.bucket_bits < 30) ++g.bucket_bits;
  return g;
}

/// The largest speed (times `headroom`) and the extent of a state, for choose_for().
template <class Real>
inline void speed_and_extent(const Box& box, const ParticlesOf<Real>& p, double& vmax,
                             double& extent, double headroom = 1.0) {
  double v2 = 0;
  extent = box.L;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double vx = p.vx[i], vy = p.vy[i];
    v2 = std::max(v2, vx * vx + vy * vy);
    extent = std::max({extent, std::fabs(double(p.x[i])), std::fabs(double(p.y[i]))});
  }
  vmax = std::sqrt(v2) * (1 + 1e-12) * headroom;
}

/// The grid for the current state (see choose_for()).
template <class Real>
inline Grid choose(const Box& box, const ParticlesOf<Real>& p) {
  double vmax = 0, extent = 0;
  speed_and_extent(box, p, vmax, extent);
  return choose_for(box, p.size(), vmax, extent);
}

}  // namespace plab::sweep
