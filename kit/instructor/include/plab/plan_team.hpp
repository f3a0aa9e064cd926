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
/// once it has grown). The caller sizes `only` (a particle each) and `contested` (a thread each);
/// the rest sizes itself.
struct SparseSelection {
  std::vector<int> only;                           //!< per particle: its one partner, or none, or many
  std::vector<std::vector<model::Event>> contested;  //!< per thread: pairs that meet another pair
  std::vector<model::Event> pairs;                   //!< every thread's contested pairs, in turn
  std::vector<std::size_t> from;                     //!< where each thread's pairs start in `pairs`
  std::vector<int> best;      //!< the rounds: each particle's choice (a pair's place, or below)
  std::vector<char> decided;  //!< the rounds: 1 once a particle's event (or none) is decided
  std::vector<std::vector<int>> open_pairs;      //!< per thread: its pairs not yet decided
  std::vector<std::vector<int>> open_particles;  //!< per thread: its particles not yet decided
  std::vector<int> still;                        //!< per thread: whether it left one open
};

/// sparse_greedy_plan() by a team of threads: every thread of an OpenMP parallel region calls it
/// (it holds barriers), each with its own part `mine` of the candidates (pairs with t < 1, in any
/// order, repeats allowed; it drops the dominated ones from it). The same plan as
/// sparse_greedy_plan(), whatever the split and the order: each pass decides from the set of
/// candidates only. Every thread's parts in parallel: drop the pairs at or after a wall, then
/// count each particle's partners (atomics that end in the same state in any order); accept each
/// isolated pair (whose particles meet no other), at its earliest time; the contested rest go
/// through stage 03's "mutual earliest" rounds (handout 03 proves that they give the greedy
/// plan), every thread on its own pairs and particles: each undecided particle chooses its
/// earliest event among its pairs with undecided partners (an atomic minimum by
/// model::key_less(), a strict total order, so the choice does not depend on the order), and a
/// pair that both its particles chose is accepted; then each particle left free takes its wall.
/// `plan` must hold `wall.size()` particles; `work.contested` one list per thread.
inline void sparse_greedy_plan_in_team(std::vector<model::Event>& mine,
                                       const std::vector<double>& wall, Plan& plan,
                                       SparseSelection& work) {
  constexpr int kNone = -1, kMany = -2;
  constexpr int kChoseNothing = -1, kChoseWall = -2;  // `best`, besides a pair's place
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
#pragma omp barrier
#pragma omp single
  {  // room for the rounds
    work.from.assign(threads + 1, 0);
    for (int u = 0; u < threads; ++u) work.from[u + 1] = work.from[u] + work.contested[u].size();
    work.pairs.resize(work.from[threads]);
    work.best.resize(n);
    work.decided.resize(n);
    work.open_pairs.resize(threads);
    work.open_particles.resize(threads);
    work.still.resize(threads);
  }
  // Each thread: its contested pairs into `pairs`, and the particles of its share that meet
  // another in a contested pair (several partners, or one that has several).
  std::vector<int>& pairs_open = work.open_pairs[t];
  std::vector<int>& open = work.open_particles[t];
  pairs_open.clear();
  open.clear();
  for (std::size_t k = 0; k < contested.size(); ++k) {
    work.pairs[work.from[t] + k] = contested[k];
    pairs_open.push_back(static_cast<int>(work.from[t] + k));
  }
  for (int i = static_cast<int>(static_cast<long long>(n) * t / threads),
           end = static_cast<int>(static_cast<long long>(n) * (t + 1) / threads);
       i < end; ++i) {
    const int o = work.only[i];
    if (o == kMany || (o >= 0 && work.only[o] != i)) {
      open.push_back(i);
      work.decided[i] = 0;
    }
  }
  // The rounds: is `p` (a pair's place) earlier than particle i's choice `seen`?
  const auto earlier = [&](int p, int seen, int i) {
    if (seen == kChoseNothing) return true;
    const model::Event& e = work.pairs[p];
    if (seen == kChoseWall) return model::key_less(e, model::wall_event_key(wall[i], i));
    return model::key_less(e, work.pairs[seen]);
  };
  const auto fold = [&](int i, int p) {  // i's choice: the earlier of it and pair p
    std::atomic_ref<int> best(work.best[i]);
    int seen = best.load(std::memory_order_relaxed);
    while (earlier(p, seen, i) && !best.compare_exchange_weak(seen, p, std::memory_order_relaxed)) {
    }
  };
#pragma omp barrier
  for (;;) {  // three barriers a round
    for (const int i : open)  // choose, 1: the wall when it is in the step, else nothing
      work.best[i] = model::in_step(wall[i]) ? kChoseWall : kChoseNothing;
#pragma omp barrier
    std::size_t kept = 0;  // choose, 2: every pair whose particles are both undecided
    for (const int p : pairs_open) {
      const model::Event& e = work.pairs[p];
      if (work.decided[e.lo] || work.decided[e.hi]) continue;
      pairs_open[kept++] = p;
      fold(e.lo, p);
      fold(e.hi, p);
    }
    pairs_open.resize(kept);
#pragma omp barrier
    kept = 0;  // accept: a wall, nothing, or a pair that its other particle chose too
    for (const int i : open) {
      const int c = work.best[i];
      if (c >= 0) {
        const model::Event& e = work.pairs[c];
        const int o = e.lo == i ? e.hi : e.lo;
        const int d = work.best[o];
        if (d < 0 || work.pairs[d].lo != e.lo || work.pairs[d].hi != e.hi) {
          open[kept++] = i;  // left for the next round
          continue;
        }
        plan.partner[i] = o;
        plan.time[i] = e.t;
      } else if (c == kChoseWall) {
        plan.partner[i] = Plan::kWall;
      }
      work.decided[i] = 1;
    }
    open.resize(kept);
    work.still[t] = kept > 0;
#pragma omp barrier
    bool any = false;
    for (int u = 0; u < threads; ++u) any |= work.still[u] != 0;
    if (!any) break;
  }
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) {
    if (plan.partner[i] >= 0 && i > plan.partner[i])  // an isolated pair's time, kept by its lower
      plan.time[i] = plan.time[plan.partner[i]];      // index so far
    if (!plan.taken(i) && model::in_step(wall[i])) plan.partner[i] = Plan::kWall;
  }
}

}  // namespace plab
