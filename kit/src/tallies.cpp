/// \file tallies.cpp
/// \brief What the kit counts of a stage's work, one tally a thread on a cache line of its own:
/// plab::EventOrder's comparisons (event_order.hpp) and the pair tests of plab::pair_candidate()
/// (plan.hpp). Kept here in the kit's library, so that a stage's code reaches them only by
/// comparing events and testing pairs.
#include "plab/event_order.hpp"
#include "plab/plan.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <utility>

// The loops' clock of the kit's OpenMP counter (kit/instructor/src/ompcount.cpp, preloaded by the
// checks of stage 03): it moves on at every parallel region's start and end, barrier and loop
// end. A weak reference: in a run without the counter its address is null, and no epochs are
// kept.
extern "C" __attribute__((weak)) std::atomic<long long> plab_omp_epoch;

namespace plab {
namespace {

/// One thread's comparisons and trace, on a cache line of its own.
struct alignas(64) Tally {
  long long count = 0;                          //!< comparisons
  std::uint64_t trace = 0xcbf29ce484222325ULL;  //!< the comparisons folded in order
  long long in_step = 0;                        //!< comparisons of two events in the step
  std::uint64_t later = 0;                      //!< their later events, summed
  long long epoch = -1;                         //!< the loops' clock at the last of them
  long long in_epoch = 0;                       //!< how many of them in that epoch
  long long pair_tests = 0;                     //!< pair_candidate() calls
  std::vector<std::pair<long long, long long>> runs;  //!< (epoch, how many) of earlier epochs

  /// One more of them, in `now`'s epoch.
  void note(long long now) {
    if (now != epoch) {
      if (in_epoch > 0) runs.emplace_back(epoch, in_epoch);
      epoch = now;
      in_epoch = 0;
    }
    ++in_epoch;
  }
};

/// The tallies of the first EventOrder::kThreads threads to compare (made on first use).
Tally* slots() {
  static Tally all[EventOrder::kThreads];
  return all;
}
/// How many threads have taken a tally.
std::atomic<int>& taken() {
  static std::atomic<int> n{0};
  return n;
}

/// The tallies taken.
int used() { return std::min(taken().load(), EventOrder::kThreads); }

/// This thread's tally: a slot on its first comparison, or (past kThreads threads) its own.
Tally& mine() {
  thread_local Tally own;
  thread_local Tally* t = [] {
    const int k = taken().fetch_add(1);
    return k < EventOrder::kThreads ? &slots()[k] : &own;
  }();
  return *t;
}

/// One event as a 64-bit number (its time's bits, its kind and particles mixed in).
std::uint64_t mix(const model::Event& e) {
  std::uint64_t h = 0;
  std::memcpy(&h, &e.t, sizeof h);
  h ^= (static_cast<std::uint64_t>(static_cast<std::uint32_t>(e.lo)) << 32 |
        static_cast<std::uint32_t>(e.hi + 2 * e.kind)) * 0x9e3779b97f4a7c15ULL;
  h ^= h >> 31;
  return h * 0xbf58476d1ce4e5b9ULL;
}

}  // namespace

void EventOrder::tally(const model::Event& a, const model::Event& b, bool less) {
  Tally& t = mine();
  ++t.count;
  const std::uint64_t x = mix(a), y = mix(b);  // the pair, whichever way round it is asked
  t.trace = (t.trace ^ ((x + y) ^ (x * y))) * 0x100000001b3ULL;
  if (model::in_step(a.t) && model::in_step(b.t)) {  // (a wall or "none" after the step: not)
    ++t.in_step;
    t.later += less ? y : x;
    if (&plab_omp_epoch != nullptr) t.note(plab_omp_epoch.load(std::memory_order_relaxed));
  }
}

long long EventOrder::count() { return mine().count; }

std::uint64_t EventOrder::trace() { return mine().trace; }

std::vector<long long> EventOrder::in_step_by_thread() {
  std::vector<long long> counts;
  for (int k = 0; k < used(); ++k)
    if (slots()[k].in_step > 0) counts.push_back(slots()[k].in_step);
  return counts;
}

long long EventOrder::balanced(int threads) {
  std::map<long long, std::vector<long long>> by_epoch;
  bool kept = false;
  for (int k = 0; k < used(); ++k) {
    const Tally& t = slots()[k];
    kept = kept || t.epoch >= 0;
    for (const auto& [epoch, made] : t.runs) by_epoch[epoch].push_back(made);
    if (t.in_epoch > 0) by_epoch[t.epoch].push_back(t.in_epoch);
  }
  if (!kept) return -1;
  long long sum = 0;
  for (auto& [epoch, made] : by_epoch) {
    if (static_cast<int>(made.size()) < threads) continue;  // a thread made none in it
    std::sort(made.begin(), made.end(), std::greater<>());
    sum += threads * made[threads - 1];
  }
  return sum;
}

std::uint64_t EventOrder::later_sum() {
  std::uint64_t sum = 0;
  for (int k = 0; k < used(); ++k) sum += slots()[k].later;
  return sum;
}

long long* detail::pair_tests_here() { return &mine().pair_tests; }

long long pair_tests() {
  long long sum = 0;
  for (int k = 0; k < used(); ++k) sum += slots()[k].pair_tests;
  return sum;
}

std::string EventOrder::hex(std::uint64_t v) {
  char text[24];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

}  // namespace plab
