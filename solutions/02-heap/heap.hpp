/// \file solutions/02-heap/heap.hpp
/// \brief Stage 02's idea: a binary min-heap kept in one array, which hands out the least of its
/// items in O(log n) comparisons, where stage 01 scanned every event time again.
//
// =================================================================================================
//  GOAL   A min-heap of any T ordered by Less: the least item on top, each push and pop in
//         O(log n) comparisons. The array holds the heap level by level: items()[0] is the least,
//         and the children of items()[k] are items()[2k + 1] and items()[2k + 2], neither less
//         than it.
//         1. push: add an item and restore that order (handout 02, exercise 1);
//         2. pop: remove the top and restore that order (handout 02, exercise 2).
//         No library heap (std::priority_queue, std::push_heap, ...): the heap is the exercise.
//  READ   handouts/02-heap.md           TEST   ./plab test --impl student --stage 02
// =================================================================================================
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "plab/stage.hpp"

namespace plab {

/// A binary min-heap of `T` in one array, the least item by `Less` on top (stage 02: the candidate
/// events, the earliest by model::key_less() on top).
template <class T, class Less>
class MinHeap {
 public:
  /// An empty heap ordered by `less` (less(a, b): a comes before b).
  explicit MinHeap(Less less = Less()) : less_(less) {}

  /// Whether the heap holds no item.
  [[nodiscard]] bool empty() const { return items_.empty(); }
  /// How many items it holds.
  [[nodiscard]] std::size_t size() const { return items_.size(); }
  /// The least item (the heap must not be empty).
  [[nodiscard]] const T& top() const { return items_.front(); }
  /// The array, level by level (the kit's heap test reads it).
  [[nodiscard]] const std::vector<T>& items() const { return items_; }

  /// Adds `x`, in O(log n) comparisons.
  void push(const T& x) {
    // EXERCISE 1: the new item at the end, then up while it is less than its parent.
    items_.push_back(x);
    for (std::size_t k = items_.size() - 1; k > 0;) {
      const std::size_t parent = (k - 1) / 2;
      if (!less_(items_[k], items_[parent])) break;
      std::swap(items_[k], items_[parent]);
      k = parent;
    }
  }

  /// Removes the least item, in O(log n) comparisons (the heap must not be empty).
  void pop() {
    // EXERCISE 2: the last item in the root's place, then down while a child is less than it,
    // swapped with the lesser child.
    if (items_.size() > 1) items_.front() = std::move(items_.back());
    items_.pop_back();
    const std::size_t n = items_.size();
    for (std::size_t k = 0;;) {
      const std::size_t left = 2 * k + 1, right = left + 1;
      if (left >= n) break;
      const std::size_t child = right < n && less_(items_[right], items_[left]) ? right : left;
      if (!less_(items_[child], items_[k])) break;
      std::swap(items_[k], items_[child]);
      k = child;
    }
  }

 private:
  std::vector<T> items_;  //!< the heap, level by level
  Less less_;             //!< the order: less_(a, b) when a comes before b
};

}  // namespace plab
