/// \file solutions/08-mpi/step.cpp
/// \brief Stage 08, MPI: the box cut into slabs, one per rank; each rank steps the particles
/// whose centre lies in its slab, with copies of its neighbours' particles within reach (the
/// halo), chooses the events by stage 03's mutual-earliest rounds across ranks, and hands the
/// particles that left its slab to their new owners. Same bits as stages 01-06 at any rank count.
//
// =================================================================================================
//  GOAL   One step of model.md on R ranks, each holding only its slab's particles:
//         1. the halo: every rank sends each other rank copies of its particles that could meet
//            one of that rank's in this step (within h = 2 max|vx| + 2r of its slab, in x);
//         2. candidates, local (given): walls of the owned particles, pairs with an owned one,
//            tested only within 3 x 3 cells of the reach;
//         3. the rounds of stage 03 across ranks: each unresolved owned particle chooses its
//            earliest event; the choices of the ghosts come from their owners; a pair is
//            accepted when both chose it; the ghosts' "resolved" flags come back each round;
//         4. apply (a pair with a ghost: both owners compute it, each keeps its own particle);
//         5. migration: particles now in another rank's slab move there (any rank, any distance).
//  READ   handouts/08-mpi.md             TEST   ./plab test --impl student --stage 08
// =================================================================================================
#include <algorithm>
#include <cmath>
#include <vector>

#include "plab/candidates.hpp"
#include "ranks.hpp"

namespace plab::dist {

namespace {

/// Sends, for every rank q, value[k] of each owned particle k in s.sent_to[q], and writes what
/// comes back into value[] of the ghosts, in the order their owners listed them.
template <class T>
void share_with_ghosts(const Ranks& r, const Local& s, std::vector<T>& value) {
  std::vector<std::vector<T>> out(r.ranks);
  for (int q = 0; q < r.ranks; ++q)
    for (int k : s.sent_to[q]) out[q].push_back(value[k]);
  const std::vector<T> in = all_to_all(r, out);
  std::copy(in.begin(), in.end(), value.begin() + s.owned);
}

/// How far apart in x and in y two disks can start and still touch within the step: each
/// moves at most max|v| along an axis, the largest over every rank (max_over_ranks()), so
/// 2 max|v| + 2r, with a margin far above rounding (a pair tested too many costs nothing, one
/// missed changes the bits).
struct Reach {
  double x;  //!< in x: the halo's width
  double y;  //!< in y
};
Reach reach_of(const Ranks& r, const Box& box, const Local& s) {
  double vx = 0, vy = 0;
  for (int k = 0; k < s.owned; ++k) {
    vx = std::fmax(vx, std::fabs(s.p.vx[k]));
    vy = std::fmax(vy, std::fabs(s.p.vy[k]));
  }
  const auto with_margin = [&](double v) { return (2 * v + 2 * box.r) * (1 + 1e-9) + 1e-9 * box.L; };
  return {with_margin(max_over_ranks(r, vx)), with_margin(max_over_ranks(r, vy))};
}

/// 1. The halo: copies of every particle that could meet one of a rank's own in this step.
void share_halo(const Ranks& r, const Reach& reach, Local& s) {
  const double h = reach.x;  // further apart in x than this, two disks cannot touch in the step
  s.sent_to.assign(r.ranks, {});
  std::vector<std::vector<Record>> out(r.ranks);
  for (int k = 0; k < s.owned; ++k)
    for (int q = 0; q < r.ranks; ++q)
      if (q != r.rank && s.p.x[k] >= r.slab_lo(q) - h && s.p.x[k] <= r.slab_hi(q) + h) {
        s.sent_to[q].push_back(k);
        out[q].push_back(s.record(k));
      }
  for (const Record& rec : all_to_all(r, out, &s.ghosts_from)) s.push(rec);
  for (int& start : s.ghosts_from) start += s.owned;
}

/// 2. The candidates of the owned particles: their walls, and their pairs with any particle
/// here (each computed with the lower scene index first, as every stage does). Only the pairs
/// within `reach` in x and in y can meet: the particles are sorted into square cells of the
/// larger reach, and each owned particle is tested against the 3 x 3 cells around its own.
void find_candidates(const Box& box, const Local& s, const Reach& reach,
                     std::vector<double>& wall, CandidateLists& cand) {
  const Particles& p = s.p;
  const int n = s.size();
  std::vector<std::vector<FoundPair>> found(1);
  wall.assign(n, model::never());
  if (n == 0) return cand.build(0, found);
  double x0 = p.x[0], x1 = p.x[0], y0 = p.y[0], y1 = p.y[0];
  for (int k = 1; k < n; ++k) {
    x0 = std::fmin(x0, p.x[k]), x1 = std::fmax(x1, p.x[k]);
    y0 = std::fmin(y0, p.y[k]), y1 = std::fmax(y1, p.y[k]);
  }
  double w = std::fmax(reach.x, reach.y);
  while (((x1 - x0) / w + 1) * ((y1 - y0) / w + 1) > 4.0 * n + 16) w *= 2;  // cells <= 4n
  const int nx = static_cast<int>((x1 - x0) / w) + 1, ny = static_cast<int>((y1 - y0) / w) + 1;
  const auto cell_x = [&](int k) { return static_cast<int>((p.x[k] - x0) / w); };
  const auto cell_y = [&](int k) { return static_cast<int>((p.y[k] - y0) / w); };
  std::vector<int> start(static_cast<std::size_t>(nx) * ny + 1, 0), sorted(n);
  for (int k = 0; k < n; ++k) ++start[cell_y(k) * nx + cell_x(k) + 1];
  for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (int k = 0; k < n; ++k) sorted[fill[cell_y(k) * nx + cell_x(k)]++] = k;
  for (int i = 0; i < s.owned; ++i) {
    wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
    const int cx = cell_x(i), cy = cell_y(i);
    for (int y = std::max(cy - 1, 0); y <= std::min(cy + 1, ny - 1); ++y)
      for (int x = std::max(cx - 1, 0); x <= std::min(cx + 1, nx - 1); ++x)
        for (int e = start[y * nx + x]; e < start[y * nx + x + 1]; ++e) {
          const int j = sorted[e];
          if (j <= i) continue;  // each owned pair once; every ghost is after the owned
          const bool ij = s.id[i] < s.id[j];
          const int a = ij ? i : j, b = ij ? j : i;
          const double t = model::pair_time(p.x[a], p.y[a], p.vx[a], p.vy[a], p.x[b], p.y[b],
                                            p.vx[b], p.vy[b], box.r);
          if (model::in_step(t)) found[0].push_back(FoundPair{t, i, j});
        }
  }
  cand.build(n, found);
}

/// 3. Stage 03's rounds across ranks. Returns each owned particle's event (walls and pairs
/// keyed by scene indices; `t` = never for none), the same as model.md's greedy over every rank.
std::vector<model::Event> choose_events(const Ranks& r, const Local& s,
                                        const std::vector<double>& wall,
                                        const CandidateLists& cand) {
  const int n = s.size();
  const model::Event none = model::pair_event_key(model::never(), -1, -1);
  std::vector<char> resolved(n, 0);
  std::vector<model::Event> best(n, none), chosen(s.owned, none);
  for (bool open = true; open;) {
    share_with_ghosts(r, s, resolved);  // whom the ghosts' owners resolved last round
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
    share_with_ghosts(r, s, best);  // what the ghosts chose
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
    open = any_rank(r, left);
  }
  return chosen;
}

/// 4. Applies each owned particle's event. A pair with a ghost is computed here too, on the
/// ghost's copy, in the same order as its owner computes it: both keep the same bits.
void apply_events(const Box& box, const std::vector<model::Event>& chosen,
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

/// 5. Migration: every owned particle now in another rank's slab goes there; ghosts are dropped.
void migrate(const Ranks& r, Local& s) {
  std::vector<std::vector<Record>> out(r.ranks);
  Local kept;
  for (int k = 0; k < s.owned; ++k) {
    const int q = r.owner_of(s.p.x[k]);
    if (q == r.rank) kept.push(s.record(k));
    else out[q].push_back(s.record(k));
  }
  for (const Record& rec : all_to_all(r, out)) kept.push(rec);
  kept.owned = kept.size();
  s = std::move(kept);
}

}  // namespace

void step(const Box& box, const Ranks& r, Local& s) {
  const Reach reach = reach_of(r, box, s);
  share_halo(r, reach, s);
  std::vector<double> wall;
  CandidateLists cand;
  find_candidates(box, s, reach, wall, cand);
  const std::vector<model::Event> chosen = choose_events(r, s, wall, cand);
  apply_events(box, chosen, cand, s);
  migrate(r, s);
}

}  // namespace plab::dist
