/// \file event_order.hpp
/// \brief model.md's order of events as a comparator: plab::model::key_less(), counting the
/// comparisons it makes on each thread and folding each into a trace. Stage 02's step orders its
/// MinHeap with it; stage 03's rounds compare their events with it. The runner reports the count
/// and the trace of a run (`--report`: order_comparisons, order_trace, order_step_comparisons,
/// order_balanced_comparisons, order_later_sum), and the grader compares them with the kit's own:
/// - stage 02: the same candidates pushed in the same order into a binary heap and popped one by
///   one make the same comparisons of the same events, which a sort, a scan, a set or a library
///   heap do not. The kit's heap probe (kit/grade/probes/heap_probe.cpp) reads them too;
/// - stage 03: the comparisons of two events in the step, and the later event of each summed
///   over every thread (order_step_comparisons by thread, order_later_sum). Mutual-earliest
///   rounds make the same ones however their loops are scheduled and their candidates ordered
///   (in a scan for the least, each event but the least is the later of exactly one comparison),
///   so the grader compares them with plab-rounds' (the kit's rounds); and how evenly the
///   threads shared them loop by loop (balanced(), by the kit's OpenMP counter's clock): a
///   selection on one thread, or a round in `single`, makes each loop's on one thread.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "plab/model.hpp"

// The loops' clock of the kit's OpenMP counter (kit/instructor/src/ompcount.cpp, preloaded by the
// checks of stage 03): it moves on at every parallel region's start and end, barrier and loop
// end. A weak reference: in a run without the counter its address is null, and no epochs are
// kept. (Left out of the docs: Doxygen does not read the attribute.)
/// \cond
extern "C" __attribute__((weak)) std::atomic<long long> plab_omp_epoch;
/// \endcond

namespace plab {

/// The earlier of two events by model.md's key (time, then wall before pair, then indices).
struct EventOrder {
  /// Threads whose comparisons are tallied apart (the first to compare; later ones count alone).
  static constexpr int kThreads = 256;

  /// Whether `a` comes before `b` (model::key_less()), counted and traced on this thread.
  bool operator()(const model::Event& a, const model::Event& b) const {
    Tally& mine = tally();
    ++mine.count;
    const std::uint64_t x = mix(a), y = mix(b);  // the pair, whichever way round it is asked
    mine.trace = (mine.trace ^ ((x + y) ^ (x * y))) * 0x100000001b3ULL;
    const bool less = model::key_less(a, b);
    if (model::in_step(a.t) && model::in_step(b.t)) {  // (a wall or "none" after the step: not)
      ++mine.in_step;
      mine.later += less ? y : x;
      if (&plab_omp_epoch != nullptr) mine.note(plab_omp_epoch.load(std::memory_order_relaxed));
    }
    return less;
  }
  /// The comparisons made so far on this thread.
  static long long& count() { return tally().count; }
  /// The comparisons so far on this thread, folded in order: which pairs of events were
  /// compared (each pair either way round: `less(a, b)` and `less(b, a)` fold alike), in which
  /// order, as one number.
  static std::uint64_t& trace() { return tally().trace; }
  /// The comparisons of two events in the step (model::in_step()) of each thread that made any,
  /// in the order the threads first compared (read it when no thread compares: after the step's
  /// parallel loops have ended).
  static std::vector<long long> in_step_by_thread() {
    std::vector<long long> counts;
    for (int k = 0; k < used(); ++k)
      if (slots()[k].in_step > 0) counts.push_back(slots()[k].in_step);
    return counts;
  }
  /// How evenly `threads` threads shared the comparisons of two events in the step loop by loop:
  /// for each epoch of the counter's clock (one loop, or the serial code between two), `threads`
  /// times the least that any of the `threads` busiest threads made in it, summed. Work-sharing
  /// loops that split their iterations evenly give nearly all of them; a round made by one thread
  /// (in `single`, say) gives none of its comparisons, however the rounds fall to the threads.
  /// -1 when the run kept no epochs (the counter was not loaded). Read it as in_step_by_thread().
  static long long balanced(int threads) {
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
  /// The later event of every comparison of two events in the step, on every thread, summed
  /// (each event as a 64-bit number): the same for any order of the comparisons and any split
  /// of them among threads. Read it as in_step_by_thread().
  static std::uint64_t later_sum() {
    std::uint64_t sum = 0;
    for (int k = 0; k < used(); ++k) sum += slots()[k].later;
    return sum;
  }
  /// A trace or a sum as the runner's report and plab-rounds write it: 16 hexadecimal digits
  /// (JSON numbers lose a 64-bit integer's low bits).
  static std::string hex(std::uint64_t v) {
    char text[24];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
    return text;
  }

 private:
  /// One thread's comparisons and trace, on a cache line of its own.
  struct alignas(64) Tally {
    long long count = 0;                          //!< comparisons
    std::uint64_t trace = 0xcbf29ce484222325ULL;  //!< the comparisons folded in order
    long long in_step = 0;                        //!< comparisons of two events in the step
    std::uint64_t later = 0;                      //!< their later events, summed
    long long epoch = -1;                         //!< the loops' clock at the last of them
    long long in_epoch = 0;                       //!< how many of them in that epoch
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
  /// The tallies of the first kThreads threads to compare.
  static Tally* slots() {
    static Tally all[kThreads];
    return all;
  }
  /// How many threads have taken a tally.
  static std::atomic<int>& next() {
    static std::atomic<int> taken{0};
    return taken;
  }
  /// The tallies taken.
  static int used() { return next().load() < kThreads ? next().load() : kThreads; }
  /// This thread's tally: a slot on its first comparison, or (past kThreads threads) its own.
  static Tally& tally() {
    thread_local Tally own;
    thread_local Tally* mine = [] {
      const int k = next().fetch_add(1);
      return k < kThreads ? &slots()[k] : &own;
    }();
    return *mine;
  }
  /// One event as a 64-bit number (its time's bits, its kind and particles mixed in).
  static std::uint64_t mix(const model::Event& e) {
    std::uint64_t h = 0;
    std::memcpy(&h, &e.t, sizeof h);
    h ^= (static_cast<std::uint64_t>(static_cast<std::uint32_t>(e.lo)) << 32 |
          static_cast<std::uint32_t>(e.hi + 2 * e.kind)) * 0x9e3779b97f4a7c15ULL;
    h ^= h >> 31;
    return h * 0xbf58476d1ce4e5b9ULL;
  }
};

}  // namespace plab
