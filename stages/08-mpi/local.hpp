/// \file stages/08-mpi/local.hpp
/// \brief Stage 08's given part: what a rank does with its particles on its own, between its
/// messages. The halo's lists (which owned particles each rank needs), a cell list over the
/// owned particles and the ghosts with the narrow phase (stage 06's idea, simply), the local
/// half of stage 03's rounds (each particle's earliest event, then the mutual ones), the events'
/// application, and the particles that leave the slab. No MPI call here: those are step.cpp's.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "plab/candidates.hpp"
#include "plab/mpi/ranks.hpp"

namespace plab::dist {

/// The fastest speed of this rank's owned particles (0 with none).
inline double fastest_here(const Local& s) {
  double v = 0;
  for (int k = 0; k < s.owned; ++k)
    v = std::fmax(v, std::sqrt(s.p.vx[k] * s.p.vx[k] + s.p.vy[k] * s.p.vy[k]));
  return v;
}

/// How far apart, in x and in y, two particles can be at the start of a step and still meet in
/// it: \f$2 v_{max} + 2r\f$ (each moves at most \f$v_{max}\f$), plus the pair time's rounding
/// margin \f$m = 10^{-6} (L + v_{max} + r)\f$ on each side, widened by a billionth.
/// \param box  the box and radius
/// \param vmax the fastest speed of any particle on any rank
inline double reach_of(const Box& box, double vmax) {
  const double margin = 1e-6 * (box.L + vmax + box.r);
  return (2 * vmax + 2 * box.r + 2 * margin) * (1 + 1e-9);
}

/// The halo's lists: to[q] holds the owned particles that rank q needs as ghosts, those within
/// `reach` in x of q's slab (owner_of() is monotone, so ranks owner_of(x - reach) ..
/// owner_of(x + reach)); a position or reach that is not finite goes to every rank.
inline std::vector<std::vector<int>> halo_lists(const Box& box, const Ranks& r, double reach,
                                                const Local& s) {
  std::vector<std::vector<int>> to(r.ranks);
  for (int k = 0; k < s.owned; ++k) {
    const double lo = s.p.x[k] - reach, hi = s.p.x[k] + reach;
    int q0 = 0, q1 = r.ranks - 1;
    if (std::isfinite(lo) && std::isfinite(hi)) {
      q0 = r.owner_of(std::clamp(lo, 0.0, box.L));
      q1 = r.owner_of(std::clamp(hi, 0.0, box.L));
    }
    for (int q = q0; q <= q1; ++q)
      if (q != r.rank) to[q].push_back(k);
  }
  return to;
}

/// Appends the ghosts received from each rank (in[q]: from rank q, in the order of q's list),
/// rank by rank, and notes where each rank's start (Local::ghosts_from).
inline void add_ghosts(const std::vector<std::vector<Record>>& in, Local& s) {
  s.ghosts_from.assign(1, s.owned);
  for (const std::vector<Record>& from_q : in) {
    for (const Record& rec : from_q) s.push(rec);
    s.ghosts_from.push_back(s.size());
  }
}

/// The candidates: every particle's wall time, and the pairs of an owned particle with any
/// particle here that meet in the step (model::pair_time(), lower scene index first, as every
/// stage computes it). A cell list finds them: cells at least `reach` wide over the rectangle
/// the particles cover (no more than about 4n cells), each owned particle tested against the
/// particles of its cell and of the 8 around it; two ghosts are never paired (their owners do it).
inline void find_candidates(const Box& box, double reach, const Local& s,
                            std::vector<double>& wall, CandidateLists& cand) {
  const Particles& p = s.p;
  const int n = s.size();
  wall.resize(n);
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  for (int i = 0; i < n; ++i) {
    wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
    x0 = std::fmin(x0, p.x[i]), x1 = std::fmax(x1, p.x[i]);
    y0 = std::fmin(y0, p.y[i]), y1 = std::fmax(y1, p.y[i]);
  }
  double cell = reach;
  int columns = 1, rows = 1;  // one cell, every pair, when there is no geometry to trust
  const auto count = [&](double extent) { return std::floor(extent / cell) + 1; };
  if (n > 0 && cell > 0 && std::isfinite(cell) && std::isfinite(x1 - x0) &&
      std::isfinite(y1 - y0)) {
    while (count(x1 - x0) * count(y1 - y0) > 4.0 * n + 16) cell *= 2;
    columns = static_cast<int>(count(x1 - x0));
    rows = static_cast<int>(count(y1 - y0));
  }
  const auto index = [](double u, int cells) {  // a cell, 0 for a not-a-number
    return u >= 0 ? (u < cells ? static_cast<int>(u) : cells - 1) : 0;
  };
  std::vector<int> cx(n), cy(n), start(columns * rows + 1, 0), in_cell(n);
  for (int i = 0; i < n; ++i) {
    cx[i] = columns == 1 ? 0 : index((p.x[i] - x0) / cell, columns);
    cy[i] = rows == 1 ? 0 : index((p.y[i] - y0) / cell, rows);
    ++start[cy[i] * columns + cx[i] + 1];
  }
  for (int c = 0; c < columns * rows; ++c) start[c + 1] += start[c];
  std::vector<int> next(start.begin(), start.end() - 1);
  for (int i = 0; i < n; ++i) in_cell[next[cy[i] * columns + cx[i]]++] = i;
  std::vector<std::vector<FoundPair>> found(1);
  for (int i = 0; i < s.owned; ++i)
    for (int y = std::max(cy[i] - 1, 0); y <= std::min(cy[i] + 1, rows - 1); ++y)
      for (int x = std::max(cx[i] - 1, 0); x <= std::min(cx[i] + 1, columns - 1); ++x)
        for (int e = start[y * columns + x]; e < start[y * columns + x + 1]; ++e) {
          const int j = in_cell[e];
          if (j == i || (j < s.owned && j < i)) continue;  // an owned pair once, from its lower
          const int a = s.id[i] < s.id[j] ? i : j, b = a == i ? j : i;
          const double t = model::pair_time(p.x[a], p.y[a], p.vx[a], p.vy[a], p.x[b], p.y[b],
                                            p.vx[b], p.vy[b], box.r);
          if (model::in_step(t)) found[0].push_back(FoundPair{t, std::min(i, j), std::max(i, j)});
        }
  cand.build(n, found);
}

/// The rounds' first half (stage 03), for each unresolved owned particle: its earliest event,
/// its wall or a candidate pair with an unresolved partner, keyed by scene indices (s.id[]).
inline void choose_earliest(const Local& s, const std::vector<double>& wall,
                            const CandidateLists& cand, const std::vector<char>& resolved,
                            std::vector<model::Event>& best) {
  const model::Event none = model::pair_event_key(model::never(), -1, -1);
  for (int i = 0; i < s.owned; ++i) {
    if (resolved[i]) continue;
    model::Event b = model::in_step(wall[i]) ? model::wall_event_key(wall[i], s.id[i]) : none;
    for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) {
      const int o = cand.other[k];
      if (resolved[o]) continue;
      const int lo = std::min(s.id[i], s.id[o]), hi = std::max(s.id[i], s.id[o]);
      const model::Event e = model::pair_event_key(cand.time[k], lo, hi);
      if (model::key_less(e, b)) b = e;
    }
    best[i] = b;
  }
}

/// The rounds' second half (stage 03): accepts each unresolved owned particle's choice when it is
/// no event, a wall, or a pair whose partner (owned or ghost: `best` holds the ghosts' choices)
/// chose it too. Returns whether any owned particle is left unresolved.
inline bool accept_mutual(const Local& s, const CandidateLists& cand,
                          const std::vector<model::Event>& best, std::vector<char>& resolved,
                          std::vector<model::Event>& chosen) {
  bool left = false;
  for (int i = 0; i < s.owned; ++i) {
    if (resolved[i]) continue;
    const model::Event& e = best[i];
    bool mutual = false;
    if (model::in_step(e.t) && e.kind == model::kPair)
      for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) {
        const model::Event& o = best[cand.other[k]];
        if (o.kind == model::kPair && o.lo == e.lo && o.hi == e.hi && o.t == e.t) mutual = true;
      }
    if (!model::in_step(e.t) || e.kind == model::kWall || mutual) {
      chosen[i] = e;
      resolved[i] = 1;
    } else {
      left = true;
    }
  }
  return left;
}

/// Applies each owned particle's event. A pair with a ghost is computed here too, on the
/// ghost's copy, in the same order as its owner computes it: both keep the same bits.
inline void apply_events(const Box& box, const std::vector<model::Event>& chosen,
                         const CandidateLists& cand, Local& s) {
  Particles& p = s.p;
  for (int i = 0; i < s.owned; ++i) {
    const model::Event& e = chosen[i];
    if (!model::in_step(e.t)) {
      model::free_move(p.x[i], p.y[i], p.vx[i], p.vy[i]);
    } else if (e.kind == model::kWall) {
      model::wall_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.wc[i], box.L, box.r);
    } else {
      const int other_id = e.lo == s.id[i] ? e.hi : e.lo;
      int o = -1;
      for (int k = cand.start[i]; k < cand.start[i + 1] && o < 0; ++k)
        if (s.id[cand.other[k]] == other_id) o = cand.other[k];
      if (o < s.owned && s.id[o] < s.id[i]) continue;  // an owned pair: applied from its lower
      const int a = s.id[i] < s.id[o] ? i : o, b = a == i ? o : i;
      model::pair_event(p.x[a], p.y[a], p.vx[a], p.vy[a], p.pc[a], p.x[b], p.y[b], p.vx[b],
                        p.vy[b], p.pc[b], e.t, box.L, box.r);
    }
  }
}

/// The particles that leave: keeps in `s` the owned particles still in this rank's slab (the
/// ghosts are dropped; `owned` is their count) and returns the others, out[q] for rank q.
inline std::vector<std::vector<Record>> leaving(const Ranks& r, Local& s) {
  std::vector<std::vector<Record>> out(r.ranks);
  Local kept;
  for (int k = 0; k < s.owned; ++k) {
    const int q = r.owner_of(s.p.x[k]);
    if (q == r.rank) kept.push(s.record(k));
    else out[q].push_back(s.record(k));
  }
  kept.owned = kept.size();
  s = std::move(kept);
  return out;
}

}  // namespace plab::dist
