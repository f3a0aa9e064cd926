/// \file solutions/07-event-driven/step.cpp
/// \brief Stage 07, exact event-driven reference: continuous-time hard disks with every
/// collision (no once-per-step limit), a priority queue of predicted events, and cell lists.
/// Not model.md's stepped model: this is the truth the stepped stages approximate.
//
// =================================================================================================
//  GOAL   Stages 01-06 let a particle collide at most once per step and phase through the rest.
//         Here time runs continuously from event to event (the 2019 report's "heap" idea taken
//         to its end):
//         1. each particle keeps ONE predicted event in a priority queue: its earliest wall hit,
//            pair collision (robust contact time, model::contact_time) or cell crossing;
//         2. pop the earliest; an event that a collision since its prediction has made stale
//            is not a collision: predict the particle again instead;
//         3. particles are advanced lazily: each keeps its position at its own last event time;
//         4. cell lists (cells at least 2r wide, crossing events) keep a prediction O(1), so an
//            event costs O(log N), not O(N).
//         The state is printed at integer times, in model.md's output format.
//  READ   handouts/07-event-driven.md     TEST   ./plab test --impl student --stage 07
// =================================================================================================
#include <algorithm>
#include <cmath>
#include <string>
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

/// One predicted event: a small plain struct, one per particle.
struct Event {
  double t;       //!< absolute time (steps since the start of the run)
  int kind;       //!< a Kind
  int i;          //!< the particle whose prediction this is
  int j;          //!< the partner (kPairHit), or -1
  int axes;       //!< kWallHit / kCross: which axes (bit 1: x, bit 2: y)
  long long cj;   //!< kPairHit: the partner's collision count (hits_[j]) when predicted
};

/// The particles in a binary min-heap by the time of their one predicted event (at the same time,
/// the lower particle first: earlier()). An indexed heap: each particle sits in it once, and a new
/// prediction moves it up or down, so the heap never holds stale entries and stays N long.
class EventQueue {
 public:
  explicit EventQueue(int n) : events_(n), heap_(n), at_(n) {
    for (int i = 0; i < n; ++i) {
      events_[i] = Event{model::never(), kCross, i, -1, 0, 0};
      heap_[i] = Entry{model::never(), i};
      at_[i] = i;
    }
  }
  [[nodiscard]] bool empty() const { return heap_.empty(); }
  /// The earliest event.
  [[nodiscard]] const Event& top() const { return events_[heap_[0].i]; }
  /// Replaces the prediction of particle `e.i` and moves the particle to its place in the heap.
  void set(const Event& e) {
    events_[e.i] = e;
    // EXERCISE 1: the event queue: store the new time at the particle's place, sift up or down.
    const int k = at_[e.i];
    heap_[k].t = e.t;
    if (k > 0 && earlier(heap_[k], heap_[(k - 1) / 2])) up(k);
    else down(k);
  }

 private:
  struct Entry {
    double t;  //!< the event's time, kept beside the particle so that sifting reads one array
    int i;     //!< the particle
  };
  /// The queue's order: the earlier time first and, at the same time, the lower particle. No two
  /// entries tie (each particle is in the heap once), so every correct priority queue pops the
  /// events in this one order, the order the golden files hold.
  static bool earlier(const Entry& a, const Entry& b) {
    return a.t < b.t || (a.t == b.t && a.i < b.i);
  }
  /// Puts entry `e` at place `k` of the heap and records where its particle is.
  void put(int k, const Entry& e) {
    heap_[k] = e;
    at_[e.i] = k;
  }
  /// Moves the entry at `k` up while it is earlier than its parent.
  void up(int k) {
    const Entry e = heap_[k];
    for (; k > 0 && earlier(e, heap_[(k - 1) / 2]); k = (k - 1) / 2) put(k, heap_[(k - 1) / 2]);
    put(k, e);
  }
  /// Moves the entry at `k` down while a child (the earlier one) is earlier.
  void down(int k) {
    const Entry e = heap_[k];
    const int n = static_cast<int>(heap_.size());
    for (int c = 2 * k + 1; c < n; k = c, c = 2 * k + 1) {
      if (c + 1 < n && earlier(heap_[c + 1], heap_[c])) ++c;
      if (!earlier(heap_[c], e)) break;
      put(k, heap_[c]);
    }
    put(k, e);
  }
  std::vector<Event> events_;  //!< each particle's prediction
  std::vector<Entry> heap_;    //!< (time, particle) in heap order
  std::vector<int> at_;        //!< each particle's place in heap_
};

/// Exact hard-disk dynamics as a Stepper: step() advances time by 1.
class EventDriven final : public Stepper {
 public:
  EventDriven(const Box& box, const Particles& p)
      : box_(box), p_(p), particles_(static_cast<long long>(p.size())),
        queue_(static_cast<int>(p.size())) {
    const int n = static_cast<int>(p.size());
    t_.assign(n, 0.0);
    hits_.assign(n, 0);
    last_.assign(n, -1);
    cached_.resize(n);
    // Cells: at least 2r wide (a pair in cells that are not neighbours is apart by more than 2r).
    // Smaller cells mean fewer particles to look at in a prediction, but more crossing events:
    // half a mean free path (L^2 / (4 r N) in a dilute gas) balances the two, and no more than
    // two particles a cell on average (sparse, fast scenes).
    const double free_path = box.L * box.L / (4 * box.r * n) / 2;
    const double side = std::max(2 * box.r, std::min(free_path, box.L * std::sqrt(2.0 / n)));
    cells_ = std::max(1, static_cast<int>(box.L / side));
    cell_side_ = box.L / cells_;
    head_.assign(static_cast<std::size_t>(cells_) * cells_, -1);
    cx_.resize(n);
    cy_.resize(n);
    next_.resize(n);
    prev_.resize(n);
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
      out.x[i] = model::position_at(p_.x[i], p_.vx[i], t_[i], now_);
      out.y[i] = model::position_at(p_.y[i], p_.vy[i], t_[i], now_);
    }
  }

 private:
  int cell_of(double pos) const {
    return std::clamp(static_cast<int>(pos / cell_side_), 0, cells_ - 1);
  }
  /// The first particle of a cell's list (-1: empty); next_ links the rest.
  int& head(int cx, int cy) { return head_[static_cast<std::size_t>(cy) * cells_ + cx]; }
  void insert(int i) {
    int& h = head(cx_[i], cy_[i]);
    prev_[i] = -1;
    next_[i] = h;
    if (h >= 0) prev_[h] = i;
    h = i;
  }
  void remove(int i) {
    if (prev_[i] >= 0) next_[prev_[i]] = next_[i];
    else head(cx_[i], cy_[i]) = next_[i];
    if (next_[i] >= 0) prev_[next_[i]] = prev_[i];
  }
  /// Moves particle `i` along its straight path to time `t` (it is stored at its own time).
  void advance(int i, double t) {
    p_.x[i] = model::position_at(p_.x[i], p_.vx[i], t_[i], t);
    p_.y[i] = model::position_at(p_.y[i], p_.vy[i], t_[i], t);
    t_[i] = t;
  }

  /// Predicts particle `i`'s next event and queues it. Wall and pair times are computed from the
  /// stored states (a pair from the later of its two stored times), never from the current time:
  /// only collisions change the stored states, so cell crossings and stale events leave no trace
  /// in the rounding, and the cell size changes the speed, never the result.
  void predict(int i) {
    // Walls: the centre reaches r or L - r; both axes at the same time is a corner.
    const model::WallTimes w =
        model::exit_wall_times(p_.x[i], p_.y[i], p_.vx[i], p_.vy[i], box_.L, box_.r);
    Event best{std::max(now_, t_[i] + model::wall_time(w)), kWallHit, i, -1,
               (w.tx <= w.ty ? 1 : 0) | (w.ty <= w.tx ? 2 : 0), 0};
    cached_[i] = scan(i, cx_[i] - 1, cx_[i] + 1, cy_[i] - 1, cy_[i] + 1, best);
    schedule(i);
  }

  /// The earliest of `best` and the pair events of `i` with the particles of cells
  /// [gx0, gx1] x [gy0, gy1] (clipped to the grid).
  Event scan(int i, int gx0, int gx1, int gy0, int gy1, Event best) const {
    for (int gy = std::max(0, gy0); gy <= std::min(cells_ - 1, gy1); ++gy) {
      for (int gx = std::max(0, gx0); gx <= std::min(cells_ - 1, gx1); ++gx) {
        for (int j = head_[static_cast<std::size_t>(gy) * cells_ + gx]; j >= 0; j = next_[j]) {
          if (j == i) continue;
          const double t0 = std::max(t_[i], t_[j]);
          const double dt = model::contact_time_from(t0, p_.x[i], p_.y[i], p_.vx[i], p_.vy[i],
                                                     t_[i], p_.x[j], p_.y[j], p_.vx[j], p_.vy[j],
                                                     t_[j], box_.r);
          // The pair that has just collided recedes; rounding must not make it meet again at once.
          if (dt == 0 && last_[i] == j && last_[j] == i) continue;
          if (t0 + dt < best.t) best = Event{std::max(now_, t0 + dt), kPairHit, i, j, 0, hits_[j]};
        }
      }
    }
    return best;
  }

  /// Queues the earlier of particle `i`'s cached wall or pair event and its next cell crossing.
  void schedule(int i) {
    const double vx = p_.vx[i], vy = p_.vy[i];
    const double x = model::position_at(p_.x[i], vx, t_[i], now_);  // now
    const double y = model::position_at(p_.y[i], vy, t_[i], now_);
    // No crossing out of the grid: the walls come first.
    const double lo_x = cx_[i] * cell_side_, lo_y = cy_[i] * cell_side_;
    const double ux = (vx > 0 && cx_[i] == cells_ - 1) || (vx < 0 && cx_[i] == 0) ? 0 : vx;
    const double uy = (vy > 0 && cy_[i] == cells_ - 1) || (vy < 0 && cy_[i] == 0) ? 0 : vy;
    const double kx = model::axis_exit_time(x, ux, lo_x, lo_x + cell_side_);
    const double ky = model::axis_exit_time(y, uy, lo_y, lo_y + cell_side_);
    const double k = now_ + std::min(kx, ky);
    queue_.set(k < cached_[i].t ? Event{k, kCross, i, -1, kx <= ky ? 1 : 2, 0} : cached_[i]);
  }

  /// Particle `i` enters the next cell along `axes`: only the row or column of cells that has
  /// just become its neighbour can add pair events (unless its cached event went stale).
  void cross(int i, int axes) {
    remove(i);
    const int dx = (axes & 1) ? (p_.vx[i] > 0 ? 1 : -1) : 0;
    const int dy = (axes & 2) ? (p_.vy[i] > 0 ? 1 : -1) : 0;
    cx_[i] += dx;
    cy_[i] += dy;
    insert(i);
    const Event& c = cached_[i];
    if (stale(c)) {
      predict(i);
    } else if (dx != 0) {
      cached_[i] = scan(i, cx_[i] + dx, cx_[i] + dx, cy_[i] - 1, cy_[i] + 1, c);
      schedule(i);
    } else {
      cached_[i] = scan(i, cx_[i] - 1, cx_[i] + 1, cy_[i] + dy, cy_[i] + dy, c);
      schedule(i);
    }
  }

  /// Whether event `e` is stale: a pair event whose partner has collided since `e` was predicted
  /// (a collision of `e.i` itself replaces its prediction at once, so only the partner's can
  /// leave one behind). A stale event is not a collision: its particle is predicted again.
  [[nodiscard]] bool stale(const Event& e) const {
    // EXERCISE 2: the partner's collisions now against those when the event was predicted.
    return e.kind == kPairHit && e.cj != hits_[e.j];
  }

  /// Processes every event before time `end`, then sets the clock to `end`.
  void run_until(double end) {
    while (!queue_.empty() && queue_.top().t < end) {
      const Event e = queue_.top();  // each branch below predicts e.i again, replacing it
      if (e.t != now_) at_instant_ = 0;
      else if (++at_instant_ > 64 * particles_ + 1024) jammed();
      now_ = e.t;
      if (stale(e)) {  // the partner moved on: look again
        predict(e.i);
        continue;
      }
      if (e.kind == kCross) {
        cross(e.i, e.axes);
      } else if (e.kind == kWallHit) {
        advance(e.i, now_);
        model::reflect(p_.vx[e.i], p_.vy[e.i], (e.axes & 1) != 0, (e.axes & 2) != 0);
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
    // EXERCISE 3: bring both to now, then collide them there.
    advance(i, now_);
    advance(j, now_);
    model::exchange_along_centres(p_.x[i] - p_.x[j], p_.y[i] - p_.y[j], p_.vx[i], p_.vy[i],
                                  p_.vx[j], p_.vy[j]);
    ++p_.pc[i];
    ++p_.pc[j];
    ++hits_[i];
    ++hits_[j];
    last_[i] = j;
    last_[j] = i;
  }

  /// Stops a run that cannot advance: disks that touch each other and a wall, packed so that none
  /// can move, collide again and again at one instant (hard disks in continuous time have no
  /// answer for such a jammed cluster; the stepped stages, one collision a particle a step, do).
  [[noreturn]] void jammed() const {
    throw InputError("stage 07: at t = " + std::to_string(now_) + " the run processed " +
                     std::to_string(at_instant_) +
                     " events without time advancing: either the scene holds disks that touch "
                     "each other and the walls (a jammed cluster), which continuous-time hard "
                     "disks cannot resolve (give them a gap: the stepped stages 01-06 run it), "
                     "or the stage meets the same events again and again (a collision of disks "
                     "not brought to now, a stale event collided or dropped instead of predicted "
                     "again, a wall or cell crossing taken for stale: only a pair event has a "
                     "partner): every scene of datasets/scenes runs with the kit's solution.");
  }

  Box box_;
  Particles p_;                    //!< positions at each particle's own time t_[i]
  std::vector<double> t_;          //!< the time each particle's position is stored at
  std::vector<long long> hits_;    //!< collisions so far (wall and pair)
  std::vector<int> last_;          //!< the last pair partner (-1 after a wall)
  std::vector<Event> cached_;      //!< each particle's earliest wall or pair event
  std::vector<int> cx_, cy_;       //!< each particle's cell
  std::vector<int> head_;          //!< the first particle of each cell (-1: none)
  std::vector<int> next_, prev_;   //!< the cell lists, linked both ways (-1 ends them)
  int cells_ = 1;                  //!< cells along each axis
  double cell_side_ = 0;           //!< their side (at least 2r)
  double now_ = 0;                 //!< the current time
  long long at_instant_ = 0;       //!< events processed at now_ without time advancing
  long long particles_ = 0;        //!< N (a jam: many events a particle at one instant)
  EventQueue queue_;               //!< every particle's next event
};

}  // namespace

/// Stage 07's entry point (stage.hpp): the exact run in continuous time, read at whole times.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions&) {
  return std::make_unique<EventDriven>(box, p);
}

}  // namespace plab
