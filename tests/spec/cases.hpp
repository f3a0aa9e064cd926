/// \file cases.hpp
/// \brief The hand-built cases of model.md's stepped model that the stepped stages' spec tests
/// share (stage 01 and 02 state their rules with them, 03, 04 and 05 run them again in parallel
/// and on the GPU). Each expected state is worked out by hand below, operation by operation as
/// model.md writes them; every value is an integer or a dyadic fraction, so every double is exact.
///
/// Pair time of two disks on one horizontal line, i left of j closing at speed s = vx_i - vx_j:
/// dx = x_i - x_j < 0, c = dx^2 - 4r^2, b = 2 dx s, a = s^2, disc = 16 r^2 s^2, so with r = 1
/// t1 = (-4s - 2 dx s) / (2 s^2) = (|dx| - 2) / s: the gap divided by the closing speed.
/// A head-on pair exchanges vx (the normal is the x axis); the zeros come out as +0.0.
#pragma once

#include <string>
#include <vector>

#include "spec.hpp"

namespace plab::spec {

/// One hand-built case: a scene, the rule it pins down, the state after `steps` steps.
struct Case {
  std::string rule;    //!< the rule, for the failure message
  Box box;             //!< box and radius
  Particles start;     //!< the initial state
  int steps;           //!< steps to run
  Particles expected;  //!< the state after them, by hand
};

/// Runs `c` on the stage under test with `options` and compares to the bit.
inline void expect_case(const Case& c,
                        const StageOptions& options = {}) {
  SCOPED_TRACE(c.rule);
  EXPECT_STATE(c.expected, run(c.box, c.start, c.steps, options));
}

/// Three disks in a row (L = 20): pairs (1,2) at 0.25, (0,1) at 0.5, (0,2) at 0.875.
/// (1,2): gap 2.5 - 2 = 0.5 at speed 2, t = 0.25, first: accepted. (0,1): gap 1 at speed 2, t =
/// 0.5, and (0,2): gap 3.5 at speed 4, t = 0.875: 0's partners are taken, 0 moves freely, 4 -> 6.
/// At 0.25: x1 = 7, x2 = 9.5 - 0.5 = 9; exchange: v1 = -2, v2 = 0; the rest 0.75 of the step:
/// x1 = 7 - 1.5 = 5.5, x2 = 9 (walls far: (7 - 1)/2 = 3 >= 0.75).
inline Case three_in_a_row() {
  return {"the earliest pair wins; its partner's later events are dropped", {20, 1},
          disks({{4, 10, 2, 0}, {7, 10, 0, 0}, {9.5, 10, -2, 0}}), 1,
          state({{6, 10, 2, 0}, {5.5, 10, -2, 0}, {9, 10, 0, 0}}, {0, 1, 1}, {0, 0, 0})};
}

/// Two disks head-on (L = 10), gap 4 - 2 = 2 at speed 2: they touch at t = 1 exactly, which
/// belongs to the next step. Step 1: both move freely, 3 -> 4 and 7 -> 6 (touching). Step 2:
/// dx = -2, c = 0, b = -8, a = 4, disc = 64: t1 = 0 is not > 0, t2 = 2 > 0: pair time 0.
/// Exchange: v0 = -1, v1 = +1; the whole step: 4 -> 3, 6 -> 7.
inline Case head_on_at_one() {
  return {"an event at t = 1 exactly belongs to the next step", {10, 1},
          disks({{3, 5, 1, 0}, {7, 5, -1, 0}}), 2,
          state({{3, 5, -1, 0}, {7, 5, 1, 0}}, {1, 1}, {0, 0})};
}

/// Three disks far apart (L = 10), one wall event each.
/// 0: tx = ((10 - 8.5) - 1)/1 = 0.5, ty = inf: to x = 9, vx = -1, on 1 - 0.5: x = 8.5.
/// 1: tx = ty = 0.5, a corner: to (9, 9), both reflect, on 0.5: (8.5, 8.5).
/// 2: tx = ((10 - 8) - 1)/2 = 0.5 < ty = (2.5 - 1)/2 = 0.75: to (9, 1.5), vx = -2, then
///    m = ty - tx = 0.25: (8.5, 1), where it stops at the second wall (vy is not reflected).
/// No pairs: each pair recedes (b > 0, c > 0: both roots negative).
inline Case walls() {
  return {"one wall event: reflect, stop at a second wall; a corner reflects both axes", {10, 1},
          disks({{8.5, 5, 1, 0}, {8.5, 8.5, 1, 1}, {8, 2.5, 2, -2}}), 1,
          state({{8.5, 5, -1, 0}, {8.5, 8.5, -1, -1}, {8.5, 1, -2, -2}}, {0, 0, 0}, {1, 1, 1})};
}

/// Disk 1 reaches the wall at ((10 - 8.5) - 1)/1 = 0.5, and disk 0 would catch it at the same
/// time (gap 3 - 2 = 1 at speed 3 - 1 = 2): key (0.5, wall, 1) < (0.5, pair, 0, 1). 1 takes its
/// wall (9, then back 0.5: 8.5); 0 (its wall at 3.5/3 > 1) moves freely, 5.5 -> 8.5.
inline Case wall_beats_pair() {
  return {"a wall beats a pair at the same time", {10, 1},
          disks({{5.5, 5, 3, 0}, {8.5, 5, 1, 0}}), 1,
          state({{8.5, 5, 3, 0}, {8.5, 5, -1, 0}}, {0, 0}, {0, 1})};
}

/// Disk 1 at rest between 0 and 2, both 3 away closing at 2: pairs (0,1) and (1,2) both at 0.5.
/// Keys (0.5, pair, 0, 1) < (0.5, pair, 1, 2): (0,1) wins; (0,2) (gap 4 at speed 4) is at 1,
/// outside the step; 2 moves freely, 8 -> 6. At 0.5: x0 = 3, x1 = 5; exchange: v0 = 0, v1 = 2;
/// on 0.5: x0 = 3, x1 = 6.
inline Case lower_index_wins_a_tie() {
  return {"the lower index wins a tie", {10, 1},
          disks({{2, 5, 2, 0}, {5, 5, 0, 0}, {8, 5, -2, 0}}), 1,
          state({{3, 5, 0, 0}, {6, 5, 2, 0}, {6, 5, -2, 0}}, {1, 1, 0}, {0, 0, 0})};
}

/// Two disks overlapping (centres 1 apart, 2r = 2) and moving apart: dx = -1, c = -3, b = 4,
/// a = 4, disc = 64: t1 = -1.5, t2 = 0.5 > 0: pair time 0. Exchange at once: v0 = +1, v1 = -1,
/// so they cross: 4 -> 5, 5 -> 4 (walls 5 and 4 away).
inline Case overlapping_pair() {
  return {"an overlapping pair collides at time 0, whichever way it moves", {10, 1},
          disks({{4, 5, -1, 0}, {5, 5, 1, 0}}), 1,
          state({{5, 5, 1, 0}, {4, 5, -1, 0}}, {1, 1}, {0, 0})};
}

/// Four disks in a row (L = 30): (2,3) at 0.25 (gap 0.5, speed 2), (1,2) at 0.5 (gap 1, speed 2),
/// (0,1) at 0.75 (gap 1.5, speed 2), (1,3) at 0.875 (gap 3.5, speed 4); (0,2), (0,3) after 1.
/// Greedy: (2,3), then (1,2) and (1,3) are blocked, (0,1) is accepted. In mutual-earliest rounds
/// it takes two rounds: round 1 only 2 and 3 choose each other; round 2 0 and 1 do.
/// (2,3) at 0.25: x2 = 12.5, x3 = 14.5, exchange: v2 = -4, v3 = -2; on 0.75: 9.5 and 13.
/// (0,1) at 0.75: x0 = 8, x1 = 10, exchange: v0 = 0, v1 = 2; on 0.25: 8 and 10.5.
inline Case chain_of_four() {
  return {"a chain of pairs, resolved in two rounds, gives the greedy set", {30, 1},
          disks({{6.5, 15, 2, 0}, {10, 15, 0, 0}, {13, 15, -2, 0}, {15.5, 15, -4, 0}}), 1,
          state({{8, 15, 0, 0}, {10.5, 15, 2, 0}, {9.5, 15, -4, 0}, {13, 15, -2, 0}},
                {1, 1, 1, 1}, {0, 0, 0, 0})};
}

/// Every case above: what a parallel or GPU stage must reproduce.
inline std::vector<Case> all_cases() {
  return {three_in_a_row(), head_on_at_one(),   walls(),        wall_beats_pair(),
          lower_index_wins_a_tie(), overlapping_pair(), chain_of_four()};
}

}  // namespace plab::spec
