/// \file branchless.hpp
/// \brief Instructor only (stage 05's exercise 2, done): the branchless wall event, the same bits
/// as model::wall_event() with less divergence on a GPU, and apply_planned<true>(), which applies
/// a plan with it. The kit's own GPU engine uses it; no student stage may include it.
#pragma once

#include <type_traits>

#include "plab/model.hpp"
#include "plab/plan.hpp"

namespace plab {
namespace model {

/// The branchless wall event: \f$ e = \min(t_x, t_y) \f$, reflect every axis whose time equals
/// \f$e\f$, then move \f$ \min(1, t_{later}) - e \f$ with \f$ t_{later} = 1 \f$ at a corner.
/// Gives the same bits as wall_event(); the kit's tests check it.
template <class Real>
PLAB_HD inline void wall_event_branchless(Real& x, Real& y, Real& vx, Real& vy,
                                          long long& wc, Real L, Real r) {
  const WallTimesOf<Real> w = wall_times(x, y, vx, vy, L, r);
  const Real e = wall_time(w);
  const bool flip_x = (w.tx == e);
  const bool flip_y = (w.ty == e);
  const Real later = (flip_x && flip_y) ? Real(1) : (flip_x ? w.ty : w.tx);
  const Real m = ((later < 1) ? later : Real(1)) - e;
  x = x + e * vx;
  y = y + e * vy;
  reflect(vx, vy, flip_x, flip_y);
  x = x + m * vx;
  y = y + m * vy;
  wc = wc + 1;
}

/// wall_event_branchless() as the wall form apply_planned() takes.
struct BranchlessWall {
  /// wall_event_branchless() on particle `(x, y, vx, vy, wc)`.
  template <class Real>
  PLAB_HD void operator()(Real& x, Real& y, Real& vx, Real& vy, long long& wc, Real L,
                          Real r) const {
    wall_event_branchless(x, y, vx, vy, wc, L, r);
  }
};

}  // namespace model

/// apply_planned() with the wall form chosen by a flag: model::BranchlessWall when `Branchless`,
/// else BranchyWall (the form the kit's GPU engine calls, `apply_planned<true>(...)`).
template <bool Branchless, class Fields, class Real>
PLAB_HD inline void apply_planned(const Fields& p, const int* partner, const double* time, int i,
                                  Real L, Real r) {
  using Wall = std::conditional_t<Branchless, model::BranchlessWall, BranchyWall>;
  apply_planned<Wall>(p, partner, time, i, L, r);
}

}  // namespace plab
