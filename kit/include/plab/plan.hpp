/// \file plan.hpp
/// \brief The events chosen for one step (at most one per particle), and applying them.
#pragma once

#include <vector>

#include "plab/model.hpp"
#include "plab/scene.hpp"

namespace plab {

/// Each particle's event for this step, one array per field.
struct Plan {
  static constexpr int kFree = -1;  //!< `partner[i]`: no event, particle `i` moves freely
  static constexpr int kWall = -2;  //!< `partner[i]`: particle `i` hits a wall
  std::vector<int> partner;   //!< kFree, kWall, or the index of the other particle of a pair
  std::vector<double> time;   //!< the event time (pairs; unused otherwise)

  /// Clears the plan for `n` particles: every particle free.
  void reset(std::size_t n) {
    partner.assign(n, kFree);
    time.assign(n, 0.0);
  }
  /// Whether particle `i` already has an event.
  [[nodiscard]] bool taken(int i) const { return partner[i] != kFree; }
  /// Records an accepted event for particle `i` only (the other particle of a pair records it
  /// itself): parallel loops where each iteration writes only its own particle use this.
  void accept_for(int i, const model::Event& e) {
    if (e.kind == model::kWall) {
      partner[i] = kWall;
    } else {
      partner[i] = (e.lo == i) ? e.hi : e.lo;
      time[i] = e.t;
    }
  }
  /// Records an accepted event (wall or pair) for its particles.
  void accept(const model::Event& e) {
    if (e.kind == model::kWall) {
      partner[e.lo] = kWall;
    } else {
      partner[e.lo] = e.hi;
      partner[e.hi] = e.lo;
      time[e.lo] = e.t;
      time[e.hi] = e.t;
    }
  }
};

/// The fields of the particles as plain pointers, the form host+device code takes: a host
/// ParticlesOf<Real>'s arrays here, plab::cuda::ParticlesView (the same six names) on the device.
template <class Real>
struct FieldPointers {
  Real* x;         //!< centre x (length units)
  Real* y;         //!< centre y (length units)
  Real* vx;        //!< velocity x (length units per step)
  Real* vy;        //!< velocity y (length units per step)
  long long* pc;   //!< collisions with other particles so far
  long long* wc;   //!< collisions with walls so far
};

/// apply_planned()'s wall event unless a stage gives its own: model::wall_event() as a function
/// object. A stage passes another form of the same event (stage 05's branchless one) as a
/// struct with this call operator; it must give the same bits.
struct BranchyWall {
  /// model::wall_event() on particle `(x, y, vx, vy, wc)`.
  template <class Real>
  PLAB_HD void operator()(Real& x, Real& y, Real& vx, Real& vy, long long& wc, Real L,
                          Real r) const {
    model::wall_event(x, y, vx, vy, wc, L, r);
  }
};

/// Applies particle `i`'s planned event, the plan given as plain arrays (`partner[i]`:
/// Plan::kFree, Plan::kWall or the other particle; `time[i]`: the pair time, read for a pair
/// only): a free move, a wall event, or a pair event applied by its lower index, which writes
/// both particles. Host and device: apply_one() calls it on the CPU, the CUDA stages' `apply`
/// kernels on the GPU, so both run the same operations in the same order. `p`: any struct of
/// field pointers named as FieldPointers. `Wall` is the form of the wall event (BranchyWall, or
/// a stage's own struct with the same call operator, chosen once at compile time).
template <class Wall = BranchyWall, class Fields, class Real>
PLAB_HD inline void apply_planned(const Fields& p, const int* partner, const double* time, int i,
                                  Real L, Real r) {
  const int j = partner[i];
  if (j == Plan::kFree) {
    model::free_move(p.x[i], p.y[i], p.vx[i], p.vy[i]);
  } else if (j == Plan::kWall) {
    Wall{}(p.x[i], p.y[i], p.vx[i], p.vy[i], p.wc[i], L, r);
  } else if (i < j) {
    model::pair_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.pc[i], p.x[j], p.y[j], p.vx[j], p.vy[j],
                      p.pc[j], static_cast<Real>(time[i]), L, r);
  }
}

/// Applies particle `i`'s planned event, from a plan's two arrays (Plan's `partner` and `time`).
/// A pair is applied by its lower index only, so calling this for every `i` in any order, or in
/// parallel, writes each particle exactly once.
template <class Real>
inline void apply_one(const Box& box, ParticlesOf<Real>& p, const int* partner,
                      const double* time, int i) {
  const FieldPointers<Real> f{p.x.data(), p.y.data(), p.vx.data(), p.vy.data(), p.pc.data(),
                              p.wc.data()};
  apply_planned(f, partner, time, i, static_cast<Real>(box.L), static_cast<Real>(box.r));
}

/// Applies particle `i`'s planned event (the same, from `plan`).
template <class Real>
inline void apply_one(const Box& box, ParticlesOf<Real>& p, const Plan& plan, int i) {
  apply_one(box, p, plan.partner.data(), plan.time.data(), i);
}

/// Applies every planned event (sequentially).
template <class Real>
inline void apply(const Box& box, ParticlesOf<Real>& p, const Plan& plan) {
  const int n = static_cast<int>(p.size());
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

/// The wall event of particle `i` as a candidate, from its start-of-step state (the time of a
/// `float` run is kept exactly in the event's double).
template <class Real>
inline model::Event wall_candidate(const Box& box, const ParticlesOf<Real>& p, int i) {
  return model::wall_event_key(model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i],
                                                static_cast<Real>(box.L), static_cast<Real>(box.r)),
                               i);
}

namespace detail {
/// This thread's count of pair tests, in the kit's tallies (kit/src/tallies.cpp), taken once.
long long* pair_tests_here();
}  // namespace detail

/// The pair tests that stage 06's code made so far (its pair_candidate() calls), summed over the
/// threads: the runner reports them (`--report`: pair_tests), and stage 06's spec asks that a
/// broad phase test far fewer than every pair. Read it when no thread tests pairs.
long long pair_tests();

// Stage 06's own code counts its pair tests (PLAB_STAGE_NUMBER, set by the kit's CMake for a
// stage's files); no other code does: stages 01 to 03 test every pair, most of them rejected at
// once, and the count cost stage 03 a fifth of its time. The two pair_candidate()s live in two
// inline namespaces, so that they are two functions to the linker: a program holding both (a stage
// 06 program with the kit's oracle) keeps each where it is called.
#if defined(PLAB_STAGE_NUMBER) && PLAB_STAGE_NUMBER == 6
inline namespace counted {
#else
inline namespace uncounted {
#endif
/// The pair event of particles `i < j` as a candidate, from their start-of-step state (counted in
/// stage 06: pair_tests()).
template <class Real>
inline model::Event pair_candidate(const Box& box, const ParticlesOf<Real>& p, int i, int j) {
#if defined(PLAB_STAGE_NUMBER) && PLAB_STAGE_NUMBER == 6
  thread_local long long* const mine = detail::pair_tests_here();
  ++*mine;
#endif
  return model::pair_event_key(model::pair_time(p.x[i], p.y[i], p.vx[i], p.vy[i], p.x[j], p.y[j],
                                                p.vx[j], p.vy[j], static_cast<Real>(box.r)),
                               i, j);
}
}  // namespace counted or uncounted

}  // namespace plab
