/// \file plan_team.hpp
/// \brief Instructor only: sparse_greedy_plan() by a team of OpenMP threads (stage 06's CPU
/// path): the same plan, with the passes over the particles and the candidates in parallel. C++20
/// atomics (std::atomic_ref), so host code only. Stage 06 asks the student for this selection:
/// kit/instructor/, left out of a student release and of a graded build.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <span>
#include <utility>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "plab/greedy.hpp"
#include "plab/unwritten.hpp"

namespace plab {

/// Working memory of sparse_greedy_plan_in_team(), kept between steps (no allocation per step
/// once it has grown); it sizes itself. Its large arrays are Buffers: the team writes their pages
/// first, in parallel (at N = 10^6 one thread zeroing them took 5.7 ms of the first two steps).
struct SparseSelection {
  Buffer<model::Event> pairs;          //!< every thread's pairs, one thread's after the other
  std::vector<std::size_t> from;       //!< where each thread's pairs start in `pairs`
  Buffer<int> best;                    //!< each particle's choice in a round: a pair's place
  std::vector<std::vector<int>> open;  //!< per thread: the places of its pairs still open
  std::vector<int> still;              //!< per thread: whether it has a pair still open
};

/// A Plan (plan.hpp: the same fields, the same meaning) in Buffers, for the team: growing it
/// writes nothing, since sparse_greedy_plan_in_team() writes every particle's `partner` in each
/// call, and `time` wherever it writes a pair, in parallel (a Plan's growth zeroes 12 bytes a
/// particle in one thread: part of the 7.9 ms before the first step's parallel region at N = 10^6).
struct TeamPlan {
  Buffer<int> partner;  //!< Plan::kFree, Plan::kWall, or the index of the other particle of a pair
  Buffer<double> time;  //!< the pair's time (unwritten for the others)
  /// Whether particle `i` already has an event.
  [[nodiscard]] bool taken(int i) const { return partner[i] != Plan::kFree; }
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
/// `plan` (a Plan or a TeamPlan) must hold `wall.size()` particles.
template <class Planned>
void sparse_greedy_plan_in_team(std::vector<model::Event>& mine, std::span<const double> wall,
                                Planned& plan, SparseSelection& work) {
  const int n = static_cast<int>(wall.size());
#ifdef _OPENMP
  const int t = omp_get_thread_num(), threads = omp_get_num_threads();
#else
  const int t = 0, threads = 1;
#endif
  // The walls are read anywhere in the array: prefetched kAhead pairs ahead (so are the rounds').
  constexpr std::size_t kAhead = 16;
  std::size_t kept_pairs = 0;
  for (std::size_t k = 0; k < mine.size(); ++k) {
    if (k + kAhead < mine.size()) {
      __builtin_prefetch(&wall[mine[k + kAhead].lo]);
      __builtin_prefetch(&wall[mine[k + kAhead].hi]);
    }
    const model::Event e = mine[k];
    if (model::before_walls(e.t, wall[e.lo], wall[e.hi])) mine[kept_pairs++] = e;
  }
  mine.resize(kept_pairs);
#pragma omp single
  {
    work.from.resize(threads + 1);
    work.open.resize(threads);
    work.still.resize(threads);
    resize_dropping(work.best, n);
  }
  work.from[t + 1] = mine.size();
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) plan.partner[i] = Plan::kFree;
#pragma omp single
  {  // every thread's pairs in one array, thread after thread
    work.from[0] = 0;
    for (int u = 0; u < threads; ++u) work.from[u + 1] += work.from[u];
    resize_dropping(work.pairs, work.from[threads]);
  }
  std::vector<int>& open = work.open[t];
  open.clear();
  for (std::size_t k = 0; k < mine.size(); ++k) {
    work.pairs[work.from[t] + k] = mine[k];
    open.push_back(static_cast<int>(work.from[t] + k));
  }
  const auto store = [](int& at, int value) {  // a pair found twice is written by two threads
    std::atomic_ref<int>(at).store(value, std::memory_order_relaxed);
  };
  const auto same = [&](int p, const model::Event& e) {  // the same key (a pair found twice)
    return !model::key_less(work.pairs[p], e) && !model::key_less(e, work.pairs[p]);
  };
  // The rounds read and write particles anywhere in the arrays (scene order is random in space):
  // each loop prefetches what the pair kAhead places on in `open` will read or write, and the
  // pairs its particles chose, which it reads, kAhead / 2 places on.
  enum Loop { kOpen, kChoose, kTake };
  const auto ahead = [&](std::size_t k, Loop loop) {
    if (k + kAhead < open.size()) {
      const model::Event& f = work.pairs[open[k + kAhead]];
      for (const int i : {f.lo, f.hi}) {
        if (loop == kTake) {  // the choice read, the plan written
          __builtin_prefetch(&work.best[i]);
          __builtin_prefetch(&plan.partner[i], 1);
          __builtin_prefetch(&plan.time[i], 1);
          continue;
        }
        __builtin_prefetch(&work.best[i], 1);  // the choice written, and the plan read to open
        if (loop == kOpen) __builtin_prefetch(&plan.partner[i]);
      }
    }
    if (loop != kOpen && k + kAhead / 2 < open.size()) {
      const model::Event& f = work.pairs[open[k + kAhead / 2]];
      for (const int i : {f.lo, f.hi})
        __builtin_prefetch(
            &work.pairs[std::atomic_ref(work.best[i]).load(std::memory_order_relaxed)]);
    }
  };
  for (;;) {
    // Open pairs: those whose particles are both free; their particles have chosen none yet.
    std::size_t kept = 0;
    for (std::size_t k = 0; k < open.size(); ++k) {
      ahead(k, kOpen);
      const int p = open[k];
      const model::Event& e = work.pairs[p];
      if (plan.taken(e.lo) || plan.taken(e.hi)) continue;
      open[kept++] = p;
      store(work.best[e.lo], p);
      store(work.best[e.hi], p);
    }
    open.resize(kept);
    work.still[t] = kept > 0;
#pragma omp barrier
    bool any = false;
    for (int u = 0; u < threads; ++u) any |= work.still[u] != 0;
    if (!any) break;
    // Choose: each particle's earliest open pair (an atomic minimum of the pairs' keys).
    for (std::size_t k = 0; k < open.size(); ++k) {
      ahead(k, kChoose);
      const int p = open[k];
      const model::Event& e = work.pairs[p];
      for (const int i : {e.lo, e.hi}) {
        std::atomic_ref<int> best(work.best[i]);
        int seen = best.load(std::memory_order_relaxed);
        while (model::key_less(e, work.pairs[seen]) &&
               !best.compare_exchange_weak(seen, p, std::memory_order_relaxed)) {
        }
      }
    }
#pragma omp barrier
    // Take each pair that both its particles chose.
    for (std::size_t k = 0; k < open.size(); ++k) {
      ahead(k, kTake);
      const int p = open[k];
      const model::Event& e = work.pairs[p];
      if (!same(work.best[e.lo], e) || !same(work.best[e.hi], e)) continue;
      store(plan.partner[e.lo], e.hi);
      store(plan.partner[e.hi], e.lo);
      std::atomic_ref<double>(plan.time[e.lo]).store(e.t, std::memory_order_relaxed);
      std::atomic_ref<double>(plan.time[e.hi]).store(e.t, std::memory_order_relaxed);
    }
#pragma omp barrier
  }
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i)
    if (!plan.taken(i) && model::in_step(wall[i])) plan.partner[i] = Plan::kWall;
}

}  // namespace plab
