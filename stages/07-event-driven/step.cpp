/// \file stages/07-event-driven/step.cpp
/// \brief Stage 07, exact event-driven reference: continuous-time hard disks with every
/// collision (no once-per-step limit), a priority queue of predicted events, and cell lists.
/// Not MODEL.md's stepped model: this is the truth the stepped stages approximate.
//
// =================================================================================================
//  GOAL   Stages 01-06 let a particle collide at most once per step and phase through the rest.
//         Here time runs continuously from event to event (the 2019 report's "heap" idea taken
//         to its end):
//         1. each particle keeps ONE predicted event in a priority queue: its earliest wall hit,
//            pair collision (robust contact time, model::contact_time) or cell crossing;
//         2. pop the earliest; an event is stale when a particle in it has collided since it was
//            predicted (per-particle collision counters): drop it, or predict again when only the
//            partner moved on;
//         3. particles are advanced lazily: each keeps its position at its own last event time;
//         4. cell lists (cells at least 2r wide, crossing events) keep a prediction O(1), so an
//            event costs O(log N), not O(N).
//         The state is printed at integer times, in MODEL.md's output format.
//  READ   handouts/07-event-driven.md     TEST   ./plab test --impl student --stage 07
// =================================================================================================
#include <algorithm>
#include <cmath>
#include <queue>
#include <vector>

#include "plab/stage.hpp"

namespace plab {
namespace {

/// What a predicted event does.
enum Kind : int {
  kPairHit = 0,  //!< particle `i` meets particle `j`
  kWallHit = 1,  //!< particle `i` hits the walls of `axes` (1: x, 2: y, 3: a corner)
  kCross = 2,    //!< particle `i`'s centre leaves its cell along `axes` (1: x, 2: y)
};

/// One predicted event: a small plain struct, kept by value in the queue.
struct Event {
  double t;       //!< absolute time (steps since the start of the run)
  int kind;       //!< a Kind
  int i;          //!< the particle whose prediction this is
  int j;          //!< the partner (kPairHit), or -1
  int axes;       //!< kWallHit / kCross: which axes (bit 1: x, bit 2: y)
  long long ci;   //!< collisions of `i` when predicted (stale when it has changed)
  long long cj;   //!< collisions of `j` when predicted
  bool operator>(const Event& o) const { return t > o.t; }
};

/// Exact hard-disk dynamics as a Stepper: step() advances time by 1.
class EventDriven final : public Stepper {
 public:
  EventDriven(const Box& box, const Particles& p) : box_(box), p_(p) {
    const int n = static_cast<int>(p.size());
    t_.assign(n, 0.0);
    hits_.assign(n, 0);
    last_.assign(n, -1);
    // Cells: at least 2r wide (a pair in cells that are not neighbours is apart by more than 2r),
    // and about two particles a cell on average, so that a prediction looks at a few particles.
    const double side = std::max(2 * box.r, box.L * std::sqrt(2.0 / n));
    cells_ = std::max(1, static_cast<int>(box.L / side));
    cell_side_ = box.L / cells_;
    members_.assign(static_cast<std::size_t>(cells_) * cells_, {});
    cx_.resize(n);
    cy_.resize(n);
    slot_.resize(n);
    for (int i = 0; i < n; ++i) {
      cx_[i] = cell_of(p_.x[i]);
      cy_[i] = cell_of(p_.y[i]);
      insert(i);
    }
    for (int i = 0; i < n; ++i) predict(i);
  }

  void step() override { run_until(now_ + 1); }

  /// The state at the current (integer) time; the run itself is not touched, so printing every
  /// step or only the last gives the same final state.
  void read(Particles& out) override {
    out = p_;
    for (std::size_t i = 0; i < p_.size(); ++i) {
      out.x[i] = p_.x[i] + (now_ - t_[i]) * p_.vx[i];
      out.y[i] = p_.y[i] + (now_ - t_[i]) * p_.vy[i];
    }
  }

 private:
  int cell_of(double pos) const {
    return std::clamp(static_cast<int>(pos / cell_side_), 0, cells_ - 1);
  }
  std::vector<int>& cell(int cx, int cy) { return members_[static_cast<std::size_t>(cy) * cells_ + cx]; }
  void insert(int i) {
    auto& m = cell(cx_[i], cy_[i]);
    slot_[i] = static_cast<int>(m.size());
    m.push_back(i);
  }
  void remove(int i) {
    auto& m = cell(cx_[i], cy_[i]);
    const int last = m.back();
    m[slot_[i]] = last;
    slot_[last] = slot_[i];
    m.pop_back();
  }
  /// Moves particle `i` along its straight path to time `t` (it is stored at its own time).
  void advance(int i, double t) {
    p_.x[i] = p_.x[i] + (t - t_[i]) * p_.vx[i];
    p_.y[i] = p_.y[i] + (t - t_[i]) * p_.vy[i];
    t_[i] = t;
  }

  /// Time from now until a centre at `pos` moving at `v` reaches `lo` or `hi` (+inf if v == 0).
  static double exit_time(double pos, double v, double lo, double hi) {
    if (v > 0) return std::max(0.0, (hi - pos) / v);
    if (v < 0) return std::max(0.0, (pos - lo) / (0 - v));
    return model::never();
  }

  /// Predicts particle `i`'s next event from now (it must be at time now_) and queues it.
  void predict(int i) {
    const double x = p_.x[i], y = p_.y[i], vx = p_.vx[i], vy = p_.vy[i];
    const double L = box_.L, r = box_.r;
    // Walls: the centre reaches r or L - r; both axes at the same time is a corner.
    const double wx = exit_time(x, vx, r, L - r), wy = exit_time(y, vy, r, L - r);
    Event best{now_ + std::min(wx, wy), kWallHit, i, -1, (wx <= wy ? 1 : 0) | (wy <= wx ? 2 : 0),
               hits_[i], 0};
    // Cell crossings (no crossing out of the grid: the walls come first).
    const double lo_x = cx_[i] * cell_side_, lo_y = cy_[i] * cell_side_;
    const double kx = exit_time(x, (vx > 0 && cx_[i] == cells_ - 1) || (vx < 0 && cx_[i] == 0) ? 0 : vx,
                                lo_x, lo_x + cell_side_);
    const double ky = exit_time(y, (vy > 0 && cy_[i] == cells_ - 1) || (vy < 0 && cy_[i] == 0) ? 0 : vy,
                                lo_y, lo_y + cell_side_);
    const double k = std::min(kx, ky);
    if (now_ + k < best.t) best = Event{now_ + k, kCross, i, -1, kx <= ky ? 1 : 2, hits_[i], 0};
    // EXERCISE 1: pairs. For every other particle j of the 3 x 3 cells around i's cell, take j's
    // position now (it is stored at its own time t_[j]), its contact time with i by
    // model::contact_time(), and keep `best` the earliest event. Skip the pair that has just
    // collided when the time is 0 (last_), or rounding can make it collide again and again.
    PLAB_EXERCISE(1, "predict the pair events of a particle");
    queue_.push(best);
  }

  /// Processes every event before time `end`, then sets the clock to `end`.
  void run_until(double end) {
    while (!queue_.empty() && queue_.top().t < end) {
      const Event e = queue_.top();
      queue_.pop();
      // EXERCISE 2: stale events. Drop the event when i has collided since it was predicted (it
      // has a newer prediction); when only the partner j has, set the clock, bring i to it and
      // predict i again.
      PLAB_EXERCISE(2, "skip or redo the stale events");
      now_ = e.t;
      if (e.kind == kCross) {
        advance(e.i, now_);
        remove(e.i);
        if (e.axes & 1) cx_[e.i] += p_.vx[e.i] > 0 ? 1 : -1;
        if (e.axes & 2) cy_[e.i] += p_.vy[e.i] > 0 ? 1 : -1;
        insert(e.i);
        predict(e.i);
      } else if (e.kind == kWallHit) {
        advance(e.i, now_);
        if (e.axes & 1) p_.vx[e.i] = -p_.vx[e.i];
        if (e.axes & 2) p_.vy[e.i] = -p_.vy[e.i];
        ++p_.wc[e.i];
        ++hits_[e.i];
        last_[e.i] = -1;
        predict(e.i);
      } else {
        collide(e.i, e.j);
        predict(e.i);
        predict(e.j);
      }
    }
    now_ = end;
  }

  /// Elastic collision of equal disks at the current time: the components of the velocities
  /// along the line of centres are exchanged, \f$ v_i \mathrel{-}= (b/d^2)\,d,\ v_j \mathrel{+}= (b/d^2)\,d \f$.
  void collide(int i, int j) {
    // EXERCISE 3: bring both to now, then exchange the velocity components along the line of
    // centres: b = d . (v_i - v_j), f = b / |d|^2, v_i -= f d, v_j += f d.
    PLAB_EXERCISE(3, "the elastic collision of two disks");
    ++p_.pc[i];
    ++p_.pc[j];
    ++hits_[i];
    ++hits_[j];
    last_[i] = j;
    last_[j] = i;
  }

  Box box_;
  Particles p_;                    //!< positions at each particle's own time t_[i]
  std::vector<double> t_;          //!< the time each particle's position is stored at
  std::vector<long long> hits_;    //!< collisions so far (wall and pair): what makes events stale
  std::vector<int> last_;          //!< the last pair partner (-1 after a wall)
  std::vector<int> cx_, cy_, slot_;  //!< each particle's cell and its place in the cell's list
  std::vector<std::vector<int>> members_;  //!< the particles of each cell
  int cells_ = 1;                  //!< cells along each axis
  double cell_side_ = 0;           //!< their side (at least 2r)
  double now_ = 0;                 //!< the current time
  std::priority_queue<Event, std::vector<Event>, std::greater<>> queue_;
};

}  // namespace

std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p) {
  return std::make_unique<EventDriven>(box, p);
}

}  // namespace plab
