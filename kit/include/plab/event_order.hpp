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
///
/// The tallies live in the kit's library (kit/src/tallies.cpp), out of this header: a
/// comparison adds to them, and nothing else a stage can name writes them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "plab/model.hpp"

namespace plab {

/// The earlier of two events by model.md's key (time, then wall before pair, then indices).
struct EventOrder {
  /// Threads whose comparisons are tallied apart (the first to compare; later ones count alone).
  static constexpr int kThreads = 256;

  /// Whether `a` comes before `b` (model::key_less()), counted and traced on this thread.
  bool operator()(const model::Event& a, const model::Event& b) const {
    const bool less = model::key_less(a, b);
    tally(a, b, less);
    return less;
  }
  /// The comparisons made so far on this thread.
  static long long count();
  /// The comparisons so far on this thread, folded in order: which pairs of events were
  /// compared (each pair either way round: `less(a, b)` and `less(b, a)` fold alike), in which
  /// order, as one number.
  static std::uint64_t trace();
  /// The comparisons of two events in the step (model::in_step()) of each thread that made any,
  /// in the order the threads first compared (read it when no thread compares: after the step's
  /// parallel loops have ended).
  static std::vector<long long> in_step_by_thread();
  /// How evenly `threads` threads shared the comparisons of two events in the step loop by loop:
  /// for each epoch of the clock of the kit's OpenMP counter (kit/instructor/src/ompcount.cpp,
  /// preloaded by the checks of stage 03: one loop, or the serial code between two), `threads`
  /// times the least that any of the `threads` busiest threads made in it, summed. Work-sharing
  /// loops that split their iterations evenly give nearly all of them; a round made by one thread
  /// (in `single`, say) gives none of its comparisons, however the rounds fall to the threads.
  /// -1 when the run kept no epochs (the counter was not loaded). Read it as in_step_by_thread().
  static long long balanced(int threads);
  /// The later event of every comparison of two events in the step, on every thread, summed
  /// (each event as a 64-bit number): the same for any order of the comparisons and any split
  /// of them among threads. Read it as in_step_by_thread().
  static std::uint64_t later_sum();
  /// A trace or a sum as the runner's report and plab-rounds write it: 16 hexadecimal digits
  /// (JSON numbers lose a 64-bit integer's low bits).
  static std::string hex(std::uint64_t v);

 private:
  /// One comparison of `a` with `b` that found `less`, added to this thread's tally.
  static void tally(const model::Event& a, const model::Event& b, bool less);
};

}  // namespace plab
