/// \file model.hpp
/// \brief The simulation model of model.md, written once: every formula every stage uses.
///
/// Each function is a small inline function marked `PLAB_HD`, so the same code compiles for the
/// CPU and, under nvcc, for the GPU. Every stage and every test calls these functions; no stage
/// types a formula again. Bit-identical results across stages and devices follow from three
/// rules: every operation below is one IEEE-754 double operation evaluated in the order written,
/// the project is compiled without FMA contraction (`-ffp-contract=off`, nvcc `--fmad=false`),
/// and nothing is compiled with fast-math. See \ref model_page for the equations.
///
/// The functions are templates on the real type `Real`, deduced from the arguments: model.md and
/// every golden output use `double`; `plab accuracy` also runs the model in `float`, and the
/// stress suite evaluates the pair time in `long double` to measure the rounding of the double
/// form. Instantiated with `double`, each function is exactly the double code it always was.
#pragma once

#include <math.h>  // sqrt, usable in both host and device code

#if defined(__CUDACC__)
/// Marks a function as callable from host and device code (empty outside nvcc).
#define PLAB_HD __host__ __device__
#else
#define PLAB_HD
#endif

namespace plab::model {

/// Positive infinity: the time of an event that never happens.
template <class Real = double>
PLAB_HD inline Real never() { return Real(__builtin_huge_val()); }

/// The two kinds of event; the value is the second component of the event key.
enum EventKind : int {
  kWall = 0,  //!< a particle hits a wall (wins ties against pairs)
  kPair = 1,  //!< two particles collide
};

/// One candidate event: a small plain struct, ordered by key_less().
struct Event {
  double t;  //!< time from the step start, in steps
  int kind;  //!< plab::model::kWall or plab::model::kPair
  int lo;    //!< particle index (wall) or lower index of the pair
  int hi;    //!< same as `lo` for a wall, higher index for a pair
};

/// The strict total order of model.md: by time, then wall before pair, then indices.
PLAB_HD inline bool key_less(const Event& a, const Event& b) {
  if (a.t != b.t) return a.t < b.t;
  if (a.kind != b.kind) return a.kind < b.kind;
  if (a.lo != b.lo) return a.lo < b.lo;
  return a.hi < b.hi;
}

/// A wall event for particle `p` at time `t`.
PLAB_HD inline Event wall_event_key(double t, int p) { return Event{t, kWall, p, p}; }
/// A pair event for particles `i < j` at time `t`.
PLAB_HD inline Event pair_event_key(double t, int i, int j) { return Event{t, kPair, i, j}; }

/// Time for a centre at `pos` moving at `v` along one axis to reach a wall, start-of-step form:
/// \f$ t = (pos - r)/(0 - v) \f$ if \f$v < 0\f$, else \f$ ((L - pos) - r)/v \f$; \f$+\infty\f$ if \f$v = 0\f$.
template <class Real>
PLAB_HD inline Real axis_wall_time(Real pos, Real v, Real L, Real r) {
  if (v == 0) return never<Real>();
  return (v < 0) ? (pos - r) / (0 - v) : ((L - pos) - r) / v;
}

/// The wall times of one particle along each axis.
template <class Real>
struct WallTimesOf {
  Real tx;  //!< time to reach a wall along x (steps; may be negative, +inf if vx == 0)
  Real ty;  //!< time to reach a wall along y
};
/// The wall times in model.md's doubles.
using WallTimes = WallTimesOf<double>;

/// Both axis wall times of a particle, from the start-of-step state.
template <class Real>
PLAB_HD inline WallTimesOf<Real> wall_times(Real x, Real y, Real vx, Real vy, Real L, Real r) {
  return WallTimesOf<Real>{axis_wall_time(x, vx, L, r), axis_wall_time(y, vy, L, r)};
}

/// The wall time of a particle: \f$ t_w = \min(t_x, t_y) \f$, written `(ty < tx) ? ty : tx`.
template <class Real>
PLAB_HD inline Real wall_time(WallTimesOf<Real> w) { return (w.ty < w.tx) ? w.ty : w.tx; }

/// The wall time of a particle from its start-of-step state.
template <class Real>
PLAB_HD inline Real wall_time(Real x, Real y, Real vx, Real vy, Real L, Real r) {
  return wall_time(wall_times(x, y, vx, vy, L, r));
}

/// Pair time of particles `i < j` (pass `i` first): the earliest \f$t\f$ with
/// \f$ |\Delta p + t \Delta v| = 2r \f$, from
/// \f$ c = (\Delta x^2 + \Delta y^2) - (4r)r \f$, \f$ b = 2(\Delta x \Delta v_x + \Delta y \Delta v_y) \f$,
/// \f$ a = \Delta v_x^2 + \Delta v_y^2 \f$, \f$ D = b^2 - (4a)c \f$.
/// Returns \f$ t_1 = (-\sqrt D - b)/(2a) \f$ when positive, 0 when the pair overlaps now
/// (\f$ t_1 \le 0 < t_2 \f$), and +inf when there is no event (\f$a = 0\f$, \f$D < 0\f$, or both roots past).
template <class Real>
PLAB_HD inline Real pair_time(Real xi, Real yi, Real vxi, Real vyi,
                                Real xj, Real yj, Real vxj, Real vyj, Real r) {
  const Real dx = xi - xj;
  const Real dy = yi - yj;
  const Real dvx = vxi - vxj;
  const Real dvy = vyi - vyj;
  const Real c = (dx * dx + dy * dy) - (4 * r) * r;
  const Real b = 2 * (dx * dvx + dy * dvy);
  const Real a = dvx * dvx + dvy * dvy;
  const Real disc = b * b - (4 * a) * c;
  if (a == 0 || disc < 0) return never<Real>();
  const Real t1 = (-sqrt(disc) - b) / (2 * a);
  if (t1 > 0) return t1;
  const Real t2 = (sqrt(disc) - b) / (2 * a);
  if (t2 > 0) return Real(0);
  return never<Real>();
}

/// The robust contact time of two disks (stage 07, the stress suite): the earliest \f$t \ge 0\f$
/// with \f$ |\Delta p + t \Delta v| = 2r \f$ for the relative position `(dx, dy)` and velocity
/// `(dvx, dvy)` at the current time. With half-\f$b\f$ coefficients
/// \f$ b = \Delta p \cdot \Delta v \f$, \f$ a = |\Delta v|^2 \f$, \f$ c = |\Delta p|^2 - (2r)^2 \f$:
/// receding or parallel pairs (\f$ b \ge 0 \f$) never meet; an overlapping pair that approaches
/// (\f$ c \le 0 \f$) meets now (0); otherwise, when \f$ D = b^2 - ac > 0 \f$,
/// \f[ t = \frac{c}{-b + \sqrt{D}} \f]
/// which never subtracts two nearly equal numbers (the textbook \f$ (-b - \sqrt D)/a \f$ does,
/// for grazing and near-contact pairs) and never divides by \f$ a = 0 \f$.
/// This is not model.md's pair time: the stepped stages must keep pair_time() for their bits.
template <class Real>
PLAB_HD inline Real contact_time(Real dx, Real dy, Real dvx, Real dvy, Real r) {
  const Real b = dx * dvx + dy * dvy;
  if (!(b < 0)) return never<Real>();
  const Real c = (dx * dx + dy * dy) - (2 * r) * (2 * r);
  if (c <= 0) return Real(0);
  const Real a = dvx * dvx + dvy * dvy;
  const Real disc = b * b - a * c;
  if (!(disc > 0)) return never<Real>();
  return c / (-b + sqrt(disc));
}

/// Whether an event at time `t` happens in this step (the window is half-open: \f$ t < 1 \f$).
template <class Real>
PLAB_HD inline bool in_step(Real t) { return t < 1; }

/// Whether a pair event at time `t` can be accepted at all against its particles' wall times:
/// one at or after either wall time loses to that wall (it comes first in model.md's key) and is
/// never accepted. A not-a-number wall time is no candidate and beats nothing.
template <class Real>
PLAB_HD inline bool before_walls(Real t, Real wall_i, Real wall_j) {
  return !(wall_i <= t) && !(wall_j <= t);
}

/// A particle without an event moves a whole step: \f$ x \leftarrow x + v_x,\ y \leftarrow y + v_y \f$.
template <class Real>
PLAB_HD inline void free_move(Real& x, Real& y, Real vx, Real vy) {
  x = x + vx;
  y = y + vy;
}

/// Applies a wall event to one particle (branchy form of model.md), from its start-of-step state:
/// move to the first wall, reflect, then move on for the rest of the step, stopping at the second
/// wall if it is reached; at an exact corner both axes reflect. Increments `wc`.
template <class Real>
PLAB_HD inline void wall_event(Real& x, Real& y, Real& vx, Real& vy, long long& wc,
                               Real L, Real r) {
  const WallTimesOf<Real> w = wall_times(x, y, vx, vy, L, r);
  const Real tx = w.tx;
  const Real ty = w.ty;
  if (tx < ty) {
    x = x + tx * vx;
    y = y + tx * vy;
    vx = -vx;
    const Real m = (ty < 1) ? (ty - tx) : (1 - tx);
    x = x + m * vx;
    y = y + m * vy;
  } else if (tx == ty) {
    x = x + tx * vx;
    y = y + tx * vy;
    vx = -vx;
    vy = -vy;
    x = x + (1 - tx) * vx;
    y = y + (1 - tx) * vy;
  } else {
    x = x + ty * vx;
    y = y + ty * vy;
    vy = -vy;
    const Real m = (tx < 1) ? (tx - ty) : (1 - ty);
    x = x + m * vx;
    y = y + m * vy;
  }
  wc = wc + 1;
}

/// Reflects a velocity in the walls that were hit: \f$ v_x \leftarrow -v_x \f$ when `flip_x`,
/// \f$ v_y \leftarrow -v_y \f$ when `flip_y` (both at a corner). A negation is exact, so any form of
/// a wall hit that flips through this keeps the speed bit for bit.
template <class Real>
PLAB_HD inline void reflect(Real& vx, Real& vy, bool flip_x, bool flip_y) {
  vx = flip_x ? -vx : vx;
  vy = flip_y ? -vy : vy;
}

/// Time for a centre at `pos` moving at `v` along one axis to reach `lo` (moving down) or `hi`
/// (moving up): \f$ t = (pos - lo)/(0 - v) \f$ if \f$v < 0\f$, else \f$ (hi - pos)/v \f$;
/// \f$+\infty\f$ if \f$v = 0\f$. Negative when the centre is already past the bound it moves to.
template <class Real>
PLAB_HD inline Real axis_time_to(Real pos, Real v, Real lo, Real hi) {
  if (v == 0) return never<Real>();
  return (v < 0) ? (pos - lo) / (0 - v) : (hi - pos) / v;
}

/// Time along one axis to a wall after a pair collision: axis_time_to() the bounds \f$r\f$ and
/// \f$L - r\f$, that is \f$ ((L - r) - pos)/v \f$ moving up (note the association, which differs
/// from axis_wall_time() and rounds differently: both are the original's).
template <class Real>
PLAB_HD inline Real axis_rest_wall_time(Real pos, Real v, Real L, Real r) {
  return axis_time_to(pos, v, r, L - r);
}

/// Moves a particle for the rest of the step after a collision at time `t`, stopping at a wall
/// if one is reached before the step ends.
template <class Real>
PLAB_HD inline void rest_of_step(Real& x, Real& y, Real vx, Real vy, Real t,
                                 Real L, Real r) {
  const Real wx = axis_rest_wall_time(x, vx, L, r);
  const Real wy = axis_rest_wall_time(y, vy, L, r);
  const Real rest = 1 - t;
  const Real move = (wx >= rest && wy >= rest) ? rest : ((wy < wx) ? wy : wx);
  x = x + move * vx;
  y = y + move * vy;
}

/// A velocity component that equals zero is stored as +0.0.
template <class Real>
PLAB_HD inline Real positive_zero(Real v) { return (v == 0) ? Real(0) : v; }

/// Applies the pair event of particles `i < j` at time `t`, from their start-of-step state:
/// move both to time `t`, exchange the velocity components along the normal
/// \f$ n = (p_i - p_j)/|p_i - p_j| \f$ (equal masses), then finish the step with rest_of_step().
/// When the centres coincide at `t` the event is dropped: both move freely, nothing is counted.
/// \return true when the collision happened (and `pci`, `pcj` were incremented).
template <class Real>
PLAB_HD inline bool pair_event(Real& xi, Real& yi, Real& vxi, Real& vyi, long long& pci,
                               Real& xj, Real& yj, Real& vxj, Real& vyj, long long& pcj,
                               Real t, Real L, Real r) {
  Real pxi = xi + t * vxi;
  Real pyi = yi + t * vyi;
  Real pxj = xj + t * vxj;
  Real pyj = yj + t * vyj;
  Real nx = pxi - pxj;
  Real ny = pyi - pyj;
  const Real m = sqrt(nx * nx + ny * ny);
  if (m == 0) {
    free_move(xi, yi, vxi, vyi);
    free_move(xj, yj, vxj, vyj);
    return false;
  }
  nx = nx / m;
  ny = ny / m;
  const Real tx = -ny;
  const Real ty = nx;
  const Real ain = nx * vxi + ny * vyi;
  const Real ait = tx * vxi + ty * vyi;
  const Real ajn = nx * vxj + ny * vyj;
  const Real ajt = tx * vxj + ty * vyj;
  // Equal masses: the normal components are exchanged (ajn goes to i, ain to j).
  vxi = positive_zero(ajn * nx + ait * tx);
  vyi = positive_zero(ajn * ny + ait * ty);
  vxj = positive_zero(ain * nx + ajt * tx);
  vyj = positive_zero(ain * ny + ajt * ty);
  rest_of_step(pxi, pyi, vxi, vyi, t, L, r);
  rest_of_step(pxj, pyj, vxj, vyj, t, L, r);
  xi = pxi;
  yi = pyi;
  xj = pxj;
  yj = pyj;
  pci = pci + 1;
  pcj = pcj + 1;
  return true;
}

// ---------------------------------------------------------------------------------------------
// The continuous-time variant (stage 07, exact event-driven dynamics): no steps, every particle
// stored at its own time, every collision applied at the moment of contact. Not model.md's stepped
// model: the stepped stages never call these.
// ---------------------------------------------------------------------------------------------

/// Where a centre stored at `pos` at time `t0`, moving at `v`, is at time `t`:
/// \f$ pos + (t - t_0)\,v \f$ (one axis; `t` may be earlier than `t0`).
template <class Real>
PLAB_HD inline Real position_at(Real pos, Real v, Real t0, Real t) {
  return pos + (t - t0) * v;
}

/// Time from now until a centre at `pos` moving at `v` leaves `[lo, hi]` along one axis, never
/// before now: \f$ \max(0, t) \f$ with \f$t\f$ from axis_time_to() (\f$+\infty\f$ if \f$v = 0\f$).
/// Stage 07 takes it for the walls (exit_wall_times()) and for its cell crossings.
template <class Real>
PLAB_HD inline Real axis_exit_time(Real pos, Real v, Real lo, Real hi) {
  const Real t = axis_time_to(pos, v, lo, hi);
  return (t > 0) ? t : Real(0);
}

/// The wall times of a particle from its stored state, continuous-time variant: along each axis
/// axis_exit_time() of \f$[r, L - r]\f$, i.e. \f$ \max(0, ((L - r) - pos)/v) \f$ moving up and
/// \f$ \max(0, (pos - r)/(0 - v)) \f$ moving down (the association of axis_rest_wall_time(), not
/// of wall_times()). The hit is at wall_time() of these; the axes whose time equals it reflect.
template <class Real>
PLAB_HD inline WallTimesOf<Real> exit_wall_times(Real x, Real y, Real vx, Real vy,
                                                 Real L, Real r) {
  return WallTimesOf<Real>{axis_exit_time(x, vx, r, L - r), axis_exit_time(y, vy, r, L - r)};
}

/// The contact time of two disks stored at their own times (particle `i` at time `ti`, `j` at
/// `tj`), counted from the time origin `t0`: both centres are carried to `t0` by position_at(),
/// and contact_time() takes the relative position
/// \f$ d = (p_i + (t_0 - t_i) v_i) - (p_j + (t_0 - t_j) v_j) \f$ and velocity
/// \f$ w = v_i - v_j \f$.
/// \return the time after `t0` (0: touching and approaching now; +inf: never).
template <class Real>
PLAB_HD inline Real contact_time_from(Real t0, Real xi, Real yi, Real vxi, Real vyi, Real ti,
                                      Real xj, Real yj, Real vxj, Real vyj, Real tj, Real r) {
  const Real dx = position_at(xi, vxi, ti, t0) - position_at(xj, vxj, tj, t0);
  const Real dy = position_at(yi, vyi, ti, t0) - position_at(yj, vyj, tj, t0);
  return contact_time(dx, dy, vxi - vxj, vyi - vyj, r);
}

/// The elastic collision of two equal disks in contact, continuous-time variant: the velocity
/// components along the line of centres are exchanged,
/// \f$ b = d \cdot (v_i - v_j),\ f = b / |d|^2,\ v_i \mathrel{-}= f d,\ v_j \mathrel{+}= f d \f$
/// with \f$ d = p_i - p_j \f$ at the contact (both centres at the same time), in this order of
/// operations (stage 07's golden files hold its bits). It is not pair_event()'s unit-normal form:
/// the two round differently. Positions do not move.
template <class Real>
PLAB_HD inline void exchange_along_centres(Real dx, Real dy, Real& vxi, Real& vyi, Real& vxj,
                                           Real& vyj) {
  const Real b = dx * (vxi - vxj) + dy * (vyi - vyj);
  const Real f = b / (dx * dx + dy * dy);
  vxi = vxi - f * dx;
  vyi = vyi - f * dy;
  vxj = vxj + f * dx;
  vyj = vyj + f * dy;
}

}  // namespace plab::model
