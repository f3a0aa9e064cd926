/// \file audit.hpp
/// \brief Checks of a run's states and steps at full precision (`--audit`): what `plab stress`
/// and `plab accuracy` read. No NaN or infinity, every centre in the box, overlaps, energy,
/// counters, and the energy change of each collision in ulps.
#pragma once

#include <cstdio>
#include <string>

#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab {

/// What the audit has seen over a run: the worst of each check, and a line per audited state.
struct Audit {
  long long states = 0;           //!< states audited
  long long steps = 0;            //!< steps whose collisions were audited
  long long nonfinite = 0;        //!< NaN or infinite values seen (any field, any state)
  double outside_ulps = 0;        //!< furthest a centre was outside [r, L - r], in ulps of L
                                  //!< (the distance over the spacing of doubles at L)
  long long overlapping = 0;      //!< the most disks overlapping another, in one state
  double deepest_overlap = 0;     //!< the deepest overlap seen, in units of r
  double energy0 = 0;             //!< kinetic energy of the first audited state
  double energy_drift = 0;        //!< largest |E - E0| / E0 over the run
  double collision_ulps = 0;      //!< largest energy change of one collision, in ulps of its energy
  long long counter_errors = 0;   //!< counters that fell, grew by more than one event per step,
                                  //!< or an odd sum of pair counters
  long long collisions_checked = 0;  //!< collisions whose energy change was measured
  std::FILE* log = nullptr;       //!< one JSON line per audited state (optional)
  /// The greedy oracle the collision check plans with (plab::plan_step(), oracle.hpp), or nullptr
  /// in a build without it: then steps are audited for their counters only.
  Plan (*oracle)(const Box&, const Particles&) = nullptr;

  /// Audits one state (after step `step`).
  void state(const Box& box, const Particles& p, long long step);
  /// Audits one step of model.md's stepped model from `before` to `after`: counters, and, when
  /// `with_oracle` (small scenes: the kit's greedy oracle is O(N^2)) and `oracle` is set, the
  /// energy of each collision against its partner's.
  void step(const Box& box, const Particles& before, const Particles& after, bool with_oracle);
  /// The summary as JSON.
  [[nodiscard]] std::string json() const;
};

/// Kinetic energy of a state (unit masses), summed in long double.
long double kinetic_energy(const Particles& p);

}  // namespace plab
