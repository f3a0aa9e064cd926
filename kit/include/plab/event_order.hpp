/// \file event_order.hpp
/// \brief model.md's order of events as a heap's `Less`: plab::model::key_less(), counting the
/// comparisons it makes and folding each into a trace. Stage 02's step orders its MinHeap with
/// it; the runner reports the count and the trace of a run (`--report`: order_comparisons,
/// order_trace), and the grader compares them with the kit's own heap's on the same scene: the
/// same candidates pushed in the same order into a binary heap and popped one by one make the
/// same comparisons of the same events, which a sort, a scan, a set or a library heap do not. The
/// kit's heap probe (kit/grade/probes/heap_probe.cpp) reads them too.
#pragma once

#include <cstdint>
#include <cstring>

#include "plab/model.hpp"

namespace plab {

/// The earlier of two events by model.md's key (time, then wall before pair, then indices).
struct EventOrder {
  /// Whether `a` comes before `b` (model::key_less()), counted and traced.
  bool operator()(const model::Event& a, const model::Event& b) const {
    ++count();
    const std::uint64_t x = mix(a), y = mix(b);  // the pair, whichever way round it is asked
    trace() = (trace() ^ ((x + y) ^ (x * y))) * 0x100000001b3ULL;
    return model::key_less(a, b);
  }
  /// The comparisons made so far on this thread.
  static long long& count() {
    thread_local long long made = 0;
    return made;
  }
  /// The comparisons so far on this thread, folded in order: which pairs of events were
  /// compared (each pair either way round: `less(a, b)` and `less(b, a)` fold alike), in which
  /// order, as one number.
  static std::uint64_t& trace() {
    thread_local std::uint64_t folded = 0xcbf29ce484222325ULL;
    return folded;
  }

 private:
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
