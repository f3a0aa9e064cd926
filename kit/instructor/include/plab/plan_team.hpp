/// \file plan_team.hpp
/// \brief Instructor only: sparse_greedy_plan() by a team of OpenMP threads (stage 06's CPU
/// path): the same plan, with the passes over the particles and the candidates in parallel. C++20
/// atomics (std::atomic_ref), so host code only. Stage 06 asks the student for this selection:
/// kit/instructor/, left out of a student release and of a graded build.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <utility>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "plab/greedy.hpp"

namespace plab {

/// A pair candidate for sparse_greedy_plan_in_team(), with its two particles' places: numbers
/// that the caller gives every particle, distinct in [0, n), close together for particles close
/// in space (stage 06's engine: a particle's place in slab 0's cell order).
struct Candidate {
  model::Event e;  //!< the pair's event (model::pair_event_key(): lower index first)
  int at_lo;       //!< the place of particle e.lo
  int at_hi;       //!< the place of particle e.hi
};

/// Working memory of sparse_greedy_plan_in_team(), kept between steps (no allocation per step
/// once it has grown); it sizes itself.
struct SparseSelection {
  std::vector<Candidate> pairs;        //!< every pair, by owner (the thread whose places hold it)
  std::vector<std::size_t> from;       //!< where each owner's pairs start in `pairs`
  std::vector<std::size_t> to;         //!< per (owner, thread): where the thread's pairs for it go
  std::vector<int> best;               //!< per place: the particle's choice in a round (in `pairs`)
  std::vector<char> taken;             //!< per place: whether the particle is taken
  std::vector<std::vector<int>> open;  //!< per thread: its pairs still open
  std::vector<int> still;              //!< per thread: whether it has a pair still open
};

/// sparse_greedy_plan() by a team of threads: every thread of an OpenMP parallel region calls it
/// (it holds barriers), each with its own part `mine` of the candidates (pairs with t < 1, in any
/// order, repeats allowed; it drops the dominated ones from it). The same plan as
/// sparse_greedy_plan(), whatever the split, the order and the places. Each thread drops its
/// pairs at or after either particle's wall (the wall comes first in key order and takes the
/// particle); every pair left comes before both its walls, so the pairs alone decide who meets
/// whom, by stage 03's "mutual earliest" rounds (handout 03 proves that they give the greedy
/// plan): each particle of an open pair (both its particles free) chooses its earliest open pair,
/// an atomic minimum by model::key_less() (a strict total order, so the choice does not depend on
/// which thread folds first), and a pair that both its particles chose is taken (a pair whose
/// particles meet no other, in the first round). Then each particle left free takes its wall
/// when the wall is in the step. Four barriers to share the pairs out, three a round, one more.
///
/// Who works on which pair: the places are cut into one range a thread, and each pair goes to the
/// thread that owns its lower place (its owner), which keeps the rounds' per-particle arrays (the
/// choice, whether taken) by place. When places follow space, a thread's rounds then read and
/// write lines of those arrays that few other threads touch; a pair's finder (in stage 06's
/// engine, whoever searched that chunk of cells in that slab) would share them with the threads
/// that found the same particles in other slabs, and contend for them.
/// `plan` must hold `wall.size()` particles.
inline void sparse_greedy_plan_in_team(std::vector<Candidate>& mine,
                                       const std::vector<double>& wall, Plan& plan,
                                       SparseSelection& work) {
  const int n = static_cast<int>(wall.size());
#ifdef _OPENMP
  const int t = omp_get_thread_num(), threads = omp_get_num_threads();
#else
  const int t = 0, threads = 1;
#endif
  const auto owner = [&](const Candidate& c) {
    return static_cast<int>(static_cast<long long>(std::min(c.at_lo, c.at_hi)) * threads / n);
  };
#pragma omp single
  {
    work.from.resize(threads + 1);
    work.to.resize(static_cast<std::size_t>(threads) * threads);
    work.open.resize(threads);
    work.still.resize(threads);
    work.best.resize(n);
    work.taken.resize(n);
  }
  // Drop the pairs at or after either wall (the walls are read anywhere in the array: prefetched
  // kAhead pairs ahead), and count the others by owner.
  std::size_t* to = &work.to[static_cast<std::size_t>(t) * threads];  // this thread's, by owner
  std::fill(to, to + threads, 0);
  constexpr std::size_t kAhead = 16;
  std::size_t kept_pairs = 0;
  for (std::size_t k = 0; k < mine.size(); ++k) {
    if (k + kAhead < mine.size()) {
      __builtin_prefetch(&wall[mine[k + kAhead].e.lo]);
      __builtin_prefetch(&wall[mine[k + kAhead].e.hi]);
    }
    const Candidate c = mine[k];
    if (!model::before_walls(c.e.t, wall[c.e.lo], wall[c.e.hi])) continue;
    mine[kept_pairs++] = c;
    ++to[owner(c)];
  }
  mine.resize(kept_pairs);
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) {
    plan.partner[i] = Plan::kFree;
    work.taken[i] = 0;  // (by place)
  }
#pragma omp single
  {  // where each thread's pairs for each owner go: owners in order, finders in order within
    std::size_t at = 0;
    for (int u = 0; u < threads; ++u) {
      work.from[u] = at;
      for (int f = 0; f < threads; ++f) {
        std::size_t& count = work.to[static_cast<std::size_t>(f) * threads + u];
        const std::size_t here = count;
        count = at;
        at += here;
      }
    }
    work.from[threads] = at;
    work.pairs.resize(at);
  }
  for (const Candidate& c : mine) work.pairs[to[owner(c)]++] = c;
#pragma omp barrier
  std::vector<int>& open = work.open[t];
  open.resize(work.from[t + 1] - work.from[t]);
  for (std::size_t k = 0; k < open.size(); ++k) open[k] = static_cast<int>(work.from[t] + k);
  const auto store = [](auto& at, auto value) {  // a pair found twice is written by two threads
    std::atomic_ref(at).store(value, std::memory_order_relaxed);
  };
  const auto same = [&](int p, const model::Event& e) {  // the same key (a pair found twice)
    return !model::key_less(work.pairs[p].e, e) && !model::key_less(e, work.pairs[p].e);
  };
  const auto taken = [&](int at) {
    return std::atomic_ref(work.taken[at]).load(std::memory_order_relaxed) != 0;
  };
  for (;;) {
    // Open pairs: those whose particles are both free; their particles have chosen none yet.
    std::size_t kept = 0;
    for (const int p : open) {
      const Candidate& c = work.pairs[p];
      if (taken(c.at_lo) || taken(c.at_hi)) continue;
      open[kept++] = p;
      store(work.best[c.at_lo], p);
      store(work.best[c.at_hi], p);
    }
    open.resize(kept);
    work.still[t] = kept > 0;
#pragma omp barrier
    bool any = false;
    for (int u = 0; u < threads; ++u) any |= work.still[u] != 0;
    if (!any) break;
    // Choose: each particle's earliest open pair (an atomic minimum of the pairs' keys).
    for (const int p : open) {
      const Candidate& c = work.pairs[p];
      for (const int i : {c.at_lo, c.at_hi}) {
        std::atomic_ref<int> best(work.best[i]);
        int seen = best.load(std::memory_order_relaxed);
        while (model::key_less(c.e, work.pairs[seen].e) &&
               !best.compare_exchange_weak(seen, p, std::memory_order_relaxed)) {
        }
      }
    }
#pragma omp barrier
    // Take each pair that both its particles chose.
    for (const int p : open) {
      const Candidate& c = work.pairs[p];
      if (!same(work.best[c.at_lo], c.e) || !same(work.best[c.at_hi], c.e)) continue;
      store(work.taken[c.at_lo], char{1});
      store(work.taken[c.at_hi], char{1});
      store(plan.partner[c.e.lo], c.e.hi);
      store(plan.partner[c.e.hi], c.e.lo);
      store(plan.time[c.e.lo], c.e.t);
      store(plan.time[c.e.hi], c.e.t);
    }
#pragma omp barrier
  }
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i)
    if (!plan.taken(i) && model::in_step(wall[i])) plan.partner[i] = Plan::kWall;
}

}  // namespace plab
