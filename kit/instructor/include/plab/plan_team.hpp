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

/// Working memory of sparse_greedy_plan_in_team(), kept between steps (no allocation per step
/// once it has grown); it sizes itself.
struct SparseSelection {
  std::vector<model::Event> pairs;     //!< every thread's pairs, one thread's after the other
  std::vector<std::pair<int, int>> at; //!< per pair: its two particles' places (`place`)
  std::vector<std::size_t> from;       //!< where each thread's pairs start in `pairs`
  std::vector<std::vector<std::pair<int, int>>> mine_at;  //!< per thread: its pairs' places
  std::vector<int> best;               //!< per place: the particle's choice in a round, a pair's place in `pairs`
  std::vector<char> taken;             //!< per place: whether the particle is taken
  std::vector<std::vector<int>> open;  //!< per thread: the places of its pairs still open
  std::vector<int> still;              //!< per thread: whether it has a pair still open
};

/// sparse_greedy_plan() by a team of threads: every thread of an OpenMP parallel region calls it
/// (it holds barriers), each with its own part `mine` of the candidates (pairs with t < 1, in any
/// order, repeats allowed; it drops the dominated ones from it). The same plan as
/// sparse_greedy_plan(), whatever the split and the order. Each thread drops its pairs at or
/// after either particle's wall (the wall comes first in key order and takes the particle); every
/// pair left comes before both its walls, so the pairs alone decide who meets whom, by stage 03's
/// "mutual earliest" rounds (handout 03 proves that they give the greedy plan), every thread on
/// its own pairs: each particle of an open pair (both its particles free) chooses its earliest
/// open pair, an atomic minimum by model::key_less() (a strict total order, so the choice does not
/// depend on which thread folds first), and a pair that both its particles chose is taken (a pair
/// whose particles meet no other, in the first round). Then each particle left free takes its
/// wall when the wall is in the step. Three barriers a round and four more.
/// `plan` must hold `wall.size()` particles.
///
/// `place` (optional) numbers the particles for the rounds' own arrays: particle i's choice and
/// whether it is taken are kept at `place[i]`, a distinct place in [0, n) for every particle of a
/// pair. The plan does not depend on it. A caller whose pairs come in space order (stage 06's
/// engine: its threads' pairs come from runs of cells) gives each particle its place in a cell
/// order, so that a thread's rounds read and write a few nearby cache lines rather than lines
/// anywhere in arrays of n (scene order is random in space). Without it, a particle's place is
/// its index.
inline void sparse_greedy_plan_in_team(std::vector<model::Event>& mine,
                                       const std::vector<double>& wall, Plan& plan,
                                       SparseSelection& work, const int* place = nullptr) {
  const int n = static_cast<int>(wall.size());
#ifdef _OPENMP
  const int t = omp_get_thread_num(), threads = omp_get_num_threads();
#else
  const int t = 0, threads = 1;
#endif
#pragma omp single
  {
    work.from.resize(threads + 1);
    work.mine_at.resize(threads);
    work.open.resize(threads);
    work.still.resize(threads);
    work.best.resize(n);
    work.taken.resize(n);
  }
  // Drop the pairs at or after either wall, and note the places of the others' particles. Both
  // read particles anywhere in the arrays: prefetched kAhead pairs ahead.
  std::vector<std::pair<int, int>>& mine_at = work.mine_at[t];
  mine_at.clear();
  constexpr std::size_t kAhead = 16;
  std::size_t kept_pairs = 0;
  for (std::size_t k = 0; k < mine.size(); ++k) {
    if (k + kAhead < mine.size()) {
      const model::Event& ahead = mine[k + kAhead];
      __builtin_prefetch(&wall[ahead.lo]);
      __builtin_prefetch(&wall[ahead.hi]);
      if (place) {
        __builtin_prefetch(&place[ahead.lo]);
        __builtin_prefetch(&place[ahead.hi]);
      }
    }
    const model::Event e = mine[k];
    if (!model::before_walls(e.t, wall[e.lo], wall[e.hi])) continue;
    mine[kept_pairs++] = e;
    mine_at.push_back(place ? std::pair{place[e.lo], place[e.hi]} : std::pair{e.lo, e.hi});
  }
  mine.resize(kept_pairs);
  work.from[t + 1] = mine.size();
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) {
    plan.partner[i] = Plan::kFree;
    work.taken[i] = 0;  // (by place)
  }
#pragma omp single
  {  // every thread's pairs in one array, thread after thread
    work.from[0] = 0;
    for (int u = 0; u < threads; ++u) work.from[u + 1] += work.from[u];
    work.pairs.resize(work.from[threads]);
    work.at.resize(work.from[threads]);
  }
  std::vector<int>& open = work.open[t];
  open.clear();
  for (std::size_t k = 0; k < mine.size(); ++k) {
    const std::size_t p = work.from[t] + k;
    work.pairs[p] = mine[k];
    work.at[p] = mine_at[k];
    open.push_back(static_cast<int>(p));
  }
  const auto store = [](auto& at, auto value) {  // a pair found twice is written by two threads
    std::atomic_ref(at).store(value, std::memory_order_relaxed);
  };
  const auto same = [&](int p, const model::Event& e) {  // the same key (a pair found twice)
    return !model::key_less(work.pairs[p], e) && !model::key_less(e, work.pairs[p]);
  };
  const auto taken = [&](int at) {
    return std::atomic_ref(work.taken[at]).load(std::memory_order_relaxed) != 0;
  };
  for (;;) {
    // Open pairs: those whose particles are both free; their particles have chosen none yet.
    std::size_t kept = 0;
    for (const int p : open) {
      const auto [a, b] = work.at[p];
      if (taken(a) || taken(b)) continue;
      open[kept++] = p;
      store(work.best[a], p);
      store(work.best[b], p);
    }
    open.resize(kept);
    work.still[t] = kept > 0;
#pragma omp barrier
    bool any = false;
    for (int u = 0; u < threads; ++u) any |= work.still[u] != 0;
    if (!any) break;
    // Choose: each particle's earliest open pair (an atomic minimum of the pairs' keys).
    for (const int p : open) {
      const model::Event& e = work.pairs[p];
      for (const int i : {work.at[p].first, work.at[p].second}) {
        std::atomic_ref<int> best(work.best[i]);
        int seen = best.load(std::memory_order_relaxed);
        while (model::key_less(e, work.pairs[seen]) &&
               !best.compare_exchange_weak(seen, p, std::memory_order_relaxed)) {
        }
      }
    }
#pragma omp barrier
    // Take each pair that both its particles chose.
    for (const int p : open) {
      const model::Event& e = work.pairs[p];
      const auto [a, b] = work.at[p];
      if (!same(work.best[a], e) || !same(work.best[b], e)) continue;
      store(work.taken[a], char{1});
      store(work.taken[b], char{1});
      store(plan.partner[e.lo], e.hi);
      store(plan.partner[e.hi], e.lo);
      store(plan.time[e.lo], e.t);
      store(plan.time[e.hi], e.t);
    }
#pragma omp barrier
  }
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i)
    if (!plan.taken(i) && model::in_step(wall[i])) plan.partner[i] = Plan::kWall;
}

}  // namespace plab
