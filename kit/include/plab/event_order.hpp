/// \file event_order.hpp
/// \brief model.md's order of events as a heap's `Less`: plab::model::key_less(), counting the
/// comparisons it makes. Stage 02's step orders its MinHeap with it, and the kit's heap probe
/// (kit/grade/probes/heap_probe.cpp) drives the same MinHeap<model::Event, EventOrder> alone and
/// reads the count: the heap under test is the very type the step uses.
#pragma once

#include "plab/model.hpp"

namespace plab {

/// The earlier of two events by model.md's key (time, then wall before pair, then indices).
struct EventOrder {
  /// Whether `a` comes before `b` (model::key_less()), counted.
  bool operator()(const model::Event& a, const model::Event& b) const {
    ++count();
    return model::key_less(a, b);
  }
  /// The comparisons made so far on this thread (the probe reads it; a step may ignore it).
  static long long& count() {
    thread_local long long made = 0;
    return made;
  }
};

}  // namespace plab
