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
    trace() = fold(fold(trace() * 0x100000001b3ULL, a), b);
    return model::key_less(a, b);
  }
  /// The comparisons made so far on this thread.
  static long long& count() {
    thread_local long long made = 0;
    return made;
  }
  /// The comparisons so far on this thread, folded in order: which events were compared, in
  /// which order, as one number.
  static std::uint64_t& trace() {
    thread_local std::uint64_t folded = 0xcbf29ce484222325ULL;
    return folded;
  }

 private:
  static std::uint64_t fold(std::uint64_t h, const model::Event& e) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &e.t, sizeof bits);
    h ^= bits + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    return h ^ (static_cast<std::uint64_t>(static_cast<std::uint32_t>(e.lo)) << 32 |
                static_cast<std::uint32_t>(e.hi + 2 * e.kind));
  }
};

}  // namespace plab
