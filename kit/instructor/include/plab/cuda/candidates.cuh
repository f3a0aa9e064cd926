/// \file cuda/candidates.cuh
/// \brief Each particle's candidate pair events of a step, stored compactly (stage 06 on): the
/// search appends each pair it finds to one list and counts it under both particles; an
/// exclusive scan of the counts and one pass over the list then lay every particle's events side
/// by side (compressed rows). The memory follows the pairs the scene has, not a fixed number of
/// slots per particle (cuda/slots.cuh, stages 04 and 05), which matters at 10^7 particles and
/// more: a few bytes a particle instead of 16 slots of 12 bytes. Device code (CompactView) and its
/// host owner (DeviceCandidates).
///
/// A step, on the device:
/// 1. the counts set to 0 (clear the `count` array), and the list's length (a counter the
///    stage keeps, for instance in its flags) too;
/// 2. the search calls CompactView::file() for each pair it keeps: the pair goes to the list
///    (when there is room) and both counts go up;
/// 3. `end` = the exclusive scan of `count` (where each particle's events start);
/// 4. CompactView::place() for every pair of the list: each writes its index in the list at
///    `end[lo]` and `end[hi]` and moves both on by one, so that afterwards `end[i]` is one past
///    particle `i`'s last event, which starts at `end[i] - count[i]`.
///
/// When the list had no room for every pair, the host grows it (DeviceCandidates::grow()) and
/// the step is done again. Events land in any order; the rounds do not depend on it (the event
/// key orders candidates completely), and a pair filed twice is harmless.
#pragma once

#include <climits>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "plab/cuda/check.hpp"
#include "plab/model.hpp"  // PLAB_HD

namespace plab::cuda {

/// One pair event of a step as the search files it.
struct Pair {
  int lo;    //!< lower particle index
  int hi;    //!< higher particle index
  double t;  //!< pair time (steps)
};

/// What the kernels receive (inside the stage's arrays): the list, the counts, and the compressed
/// rows. It reads like cuda::SlotsView for the rounds (cuda/rounds.cuh): `count[i]`,
/// other_at(), time_at() and `cap` (no particle ever runs out: the list does, as a whole).
/// A row holds the list's index of each of the particle's pairs (4 bytes an event, not the 12 of
/// a copy of the other particle and the time): the pair is read from the list.
struct CompactView {
  int* count;      //!< pair events of each particle
  int* end;        //!< after place(): one past particle `i`'s last event in `row`
  Pair* list;      //!< the pairs filed this step, in any order
  int capacity;    //!< room in `list` (and for twice as many events in `row`)
  int* row;        //!< the list's index of each event, particle by particle
  /// When not null: each particle's first kSlotted events as file() files them (the list's
  /// index of each, at `slot[i * kSlotted + s]`), so that a stage may read a particle's events
  /// without the scan and place() when none has more than kSlotted.
  int* slot = nullptr;
  static constexpr int kSlotted = 8;   //!< events a particle has room for in `slot`
  static constexpr int cap = INT_MAX;  //!< no per-particle limit (rounds.cuh reads it)

  /// The other particle of particle `i`'s event `s` (after place()): of the pair (lo, hi) that
  /// holds `i`, the one that is not `i`.
  __device__ int other_at(int i, int s) const {
    const Pair& e = list[row[end[i] - count[i] + s]];
    return e.lo ^ e.hi ^ i;
  }
  /// The pair time of particle `i`'s event `s` (after place()).
  __device__ double time_at(int i, int s) const { return list[row[end[i] - count[i] + s]].t; }

  /// Files the pair event (lo, hi, t): counts it under both particles and puts it in the list
  /// at the place `*length` gives (atomically: any thread may file), when there is room; and,
  /// with `slot`, its index in both particles' slots. Returns false when a particle had no slot
  /// left (more than kSlotted events).
  __device__ bool file(int lo, int hi, double t, int* length) const {
    const int q = atomicAdd(length, 1);
    if (q < capacity) list[q] = Pair{lo, hi, t};
    const int s_lo = atomicAdd(&count[lo], 1), s_hi = atomicAdd(&count[hi], 1);
    if (!slot) return true;
    if (s_lo < kSlotted) slot[lo * kSlotted + s_lo] = q;
    if (s_hi < kSlotted) slot[hi * kSlotted + s_hi] = q;
    return s_lo < kSlotted && s_hi < kSlotted;
  }
  /// Lays pair `q` of the list into both particles' rows (after `end` became the exclusive scan
  /// of `count`).
  __device__ void place(int q) const {
    const Pair& e = list[q];
    row[atomicAdd(&end[e.lo], 1)] = q;
    row[atomicAdd(&end[e.hi], 1)] = q;
  }
};

/// The compact candidates in device memory: the counts and row ends for `n` particles, and a
/// list with room for `capacity` pairs. The rows (rows() ints) are the owner's to place: they
/// are written and read only after the search, so a stage may lay them over memory the search
/// used (stage 06's engine lays them over the slab passes' arrays).
class DeviceCandidates {
 public:
  /// Room for `n` particles and at least `capacity` pairs a step (contents uninitialised).
  DeviceCandidates(int n, int capacity)
      : count_(static_cast<std::size_t>(n)), end_(static_cast<std::size_t>(n)) {
    allocate(capacity);
  }
  /// Room for at least `needed` pairs a step, once the work queued on `stream` (which may use
  /// the arrays) is done. The list is allocated again: its address changes (a recorded graph
  /// that holds it must be recorded again), and the rows must be as long as rows() again.
  void grow(int needed, cudaStream_t stream) {
    PLAB_CUDA_CHECK(cudaStreamSynchronize(stream));
    allocate(needed);
  }
  /// The view kernels take, with the rows at `rows`, `length` ints long: at least rows() (the
  /// list may have grown since the owner laid them).
  /// \throws std::logic_error when the rows are shorter than the list needs.
  [[nodiscard]] CompactView view(int* rows, std::size_t length) const {
    if (length < this->rows())
      throw std::logic_error("DeviceCandidates::view(): rows of " + std::to_string(length) +
                             " ints for a list of " + std::to_string(capacity_) +
                             " pairs (lay the rows out again after grow())");
    return {count_.get(), end_.get(), list_.get(), capacity_, rows};
  }
  /// Room in the list, in pairs.
  [[nodiscard]] int capacity() const { return capacity_; }
  /// Length of the rows the view needs: two events a pair.
  [[nodiscard]] std::size_t rows() const { return 2 * static_cast<std::size_t>(capacity_); }
  /// Bytes held on the device (the rows are the owner's).
  [[nodiscard]] std::size_t bytes() const {
    return count_.bytes() + end_.bytes() + list_.bytes();
  }

 private:
  /// Allocates the list for `capacity` pairs (at least one).
  void allocate(int capacity) {
    capacity_ = capacity > 0 ? capacity : 1;
    list_.resize(static_cast<std::size_t>(capacity_));
  }

  int capacity_ = 0;             //!< CompactView::capacity
  DeviceArray<int> count_;       //!< CompactView::count
  DeviceArray<int> end_;         //!< CompactView::end
  DeviceArray<Pair> list_;       //!< CompactView::list
};

}  // namespace plab::cuda
