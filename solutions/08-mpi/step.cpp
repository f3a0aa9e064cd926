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
//         2. candidates, local: walls of the owned particles, pairs with an owned particle;
//         3. the rounds of stage 03 across ranks: each unresolved owned particle chooses its
//            earliest event; the choices of the ghosts come from their owners; a pair is
//            accepted when both chose it; the ghosts' "resolved" flags come back each round;
//         4. apply (a pair with a ghost: both owners compute it, each keeps its own particle);
//         5. migration: particles now in another rank's slab move there (any rank, any distance).
//  READ   handouts/08-mpi.md             TEST   ./plab test --impl student --stage 08
// =================================================================================================
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

/// 1. The halo: copies of every particle that could meet one of a rank's own in this step.
void share_halo(const Ranks& r, const Box& box, Local& s) {
  double vmax = 0;
  for (int k = 0; k < s.owned; ++k) vmax = std::fmax(vmax, std::fabs(s.p.vx[k]));
  // Two disks whose centres are further apart in x than this cannot touch within the step (with
  // a margin far above rounding: a ghost too many costs nothing, one too few changes the bits).
  const double h = (2 * max_over_ranks(r, vmax) + 2 * box.r) * (1 + 1e-9) + 1e-9 * box.L;
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
/// here (each computed with the lower scene index first, as every stage does).
void find_candidates(const Box& box, const Local& s, std::vector<double>& wall,
                     CandidateLists& cand) {
  const Particles& p = s.p;
  std::vector<std::vector<FoundPair>> found(1);
  wall.assign(s.size(), model::never());
  for (int i = 0; i < s.owned; ++i) {
    wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
    for (int j = i + 1; j < s.size(); ++j) {
      const bool ij = s.id[i] < s.id[j];
      const int a = ij ? i : j, b = ij ? j : i;
      const double t = model::pair_time(p.x[a], p.y[a], p.vx[a], p.vy[a], p.x[b], p.y[b],
                                        p.vx[b], p.vy[b], box.r);
      if (model::in_step(t)) found[0].push_back(FoundPair{t, i, j});
    }
  }
  cand.build(s.size(), found);
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
  share_halo(r, box, s);
  std::vector<double> wall;
  CandidateLists cand;
  find_candidates(box, s, wall, cand);
  const std::vector<model::Event> chosen = choose_events(r, s, wall, cand);
  apply_events(box, chosen, cand, s);
  migrate(r, s);
}

}  // namespace plab::dist
