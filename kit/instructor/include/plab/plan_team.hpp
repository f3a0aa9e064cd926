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
/// once it has grown).
struct SparseSelection {
  std::vector<int> only;                           //!< per particle: its one partner, or none, or many
  std::vector<std::vector<model::Event>> contested;  //!< per thread: pairs that meet another pair
  std::vector<std::pair<model::Event, int>> heads;  //!< the merge: each list's next pair
  std::vector<std::size_t> next;                     //!< the merge: each list's next place
};

/// sparse_greedy_plan() by a team of threads: every thread of an OpenMP parallel region calls it
/// (it holds barriers), each with its own part `mine` of the candidates (pairs with t < 1, in any
/// order, repeats allowed; it drops the dominated ones from it). The same plan as
/// sparse_greedy_plan(), whatever the split and the order: each pass decides from the set of
/// candidates only. Every thread's parts in parallel: drop the pairs at or after a wall, then
/// count each particle's partners (atomics that end in the same state in any order); accept each
/// isolated pair (whose particles meet no other), at its earliest time; the contested rest are
/// sorted (each thread its own), merged and taken in key order by one thread; each particle left
/// free takes its wall.
/// `plan` must hold `wall.size()` particles; `work.contested` one list per thread.
inline void sparse_greedy_plan_in_team(std::vector<model::Event>& mine,
                                       const std::vector<double>& wall, Plan& plan,
                                       SparseSelection& work) {
  constexpr int kNone = -1, kMany = -2;
  const int n = static_cast<int>(wall.size());
#ifdef _OPENMP
  const int t = omp_get_thread_num(), threads = omp_get_num_threads();
#else
  const int t = 0, threads = 1;
#endif
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) {
    plan.partner[i] = Plan::kFree;
    plan.time[i] = -HUGE_VAL;  // no time yet (read for pairs only)
    work.only[i] = kNone;
  }
  mine.erase(std::remove_if(mine.begin(), mine.end(),
                            [&](const model::Event& e) {
                              return !model::before_walls(e.t, wall[e.lo], wall[e.hi]);
                            }),
             mine.end());
  for (const model::Event& e : mine)  // kNone -> the partner -> kMany, in any order
    for (const auto& [i, o] : {std::pair{e.lo, e.hi}, std::pair{e.hi, e.lo}}) {
      std::atomic_ref<int> only(work.only[i]);
      int seen = kNone;
      if (!only.compare_exchange_strong(seen, o, std::memory_order_relaxed) && seen != o &&
          seen != kMany)
        only.store(kMany, std::memory_order_relaxed);
    }
#pragma omp barrier
  const auto alone = [&](const model::Event& e) {
    return work.only[e.lo] == e.hi && work.only[e.hi] == e.lo;
  };
  std::vector<model::Event>& contested = work.contested[t];
  contested.clear();
  for (const model::Event& e : mine) {  // isolated pairs: taken, at the earliest of their times
    if (!alone(e)) {                     // (a pair found twice)
      contested.push_back(e);
      continue;
    }
    std::atomic_ref<int>(plan.partner[e.lo]).store(e.hi, std::memory_order_relaxed);
    std::atomic_ref<int>(plan.partner[e.hi]).store(e.lo, std::memory_order_relaxed);
    std::atomic_ref<double> time(plan.time[e.lo]);
    double seen = time.load(std::memory_order_relaxed);
    while ((seen == -HUGE_VAL || e.t < seen) &&
           !time.compare_exchange_weak(seen, e.t, std::memory_order_relaxed)) {
    }
  }
  std::sort(contested.begin(), contested.end(),  // each thread its own, in parallel
            [](const model::Event& a, const model::Event& b) { return model::key_less(a, b); });
#pragma omp barrier
#pragma omp single
  {  // the contested pairs of every thread in key order (a merge), each taken if both are free
    using Head = std::pair<model::Event, int>;  // a list's next pair, and the list
    const auto later = [](const Head& a, const Head& b) { return model::key_less(b.first, a.first); };
    std::vector<Head>& heads = work.heads;
    std::vector<std::size_t>& next = work.next;
    heads.clear();
    next.assign(threads, 0);
    for (int u = 0; u < threads; ++u)
      if (!work.contested[u].empty()) heads.emplace_back(work.contested[u][next[u]++], u);
    std::make_heap(heads.begin(), heads.end(), later);
    while (!heads.empty()) {
      std::pop_heap(heads.begin(), heads.end(), later);
      const auto [e, u] = heads.back();
      heads.pop_back();
      if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
      if (next[u] < work.contested[u].size()) {
        heads.emplace_back(work.contested[u][next[u]++], u);
        std::push_heap(heads.begin(), heads.end(), later);
      }
    }
  }
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) {
    if (plan.partner[i] >= 0 && i > plan.partner[i])  // an isolated pair's time, kept by its lower
      plan.time[i] = plan.time[plan.partner[i]];      // index so far
    if (!plan.taken(i) && model::in_step(wall[i])) plan.partner[i] = Plan::kWall;
  }
}

}  // namespace plab
