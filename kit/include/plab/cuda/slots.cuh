/// \file cuda/slots.cuh
/// \brief Each particle's candidate pair events of a step in device memory: a few slots per
/// particle (a sparse row of V3's N x N matrix of times), grown by the host when a particle
/// needs more. Device code (SlotsView) and its host owner (DeviceSlots).
#pragma once

#include <cstddef>

#include "plab/cuda/check.hpp"
#include "plab/model.hpp"  // PLAB_HD

namespace plab::cuda {

/// How the slots of all particles lie in memory.
enum class SlotLayout {
  kByParticle,  //!< particle `i`'s slots side by side, slot `s` at `[i * cap + s]` (stage 04)
  kBySlot,      //!< slot `s` of every particle side by side, at `[s * n + i]`: neighbouring
                //!< threads (particles) read neighbouring addresses (stage 05 on)
};

/// What a kernel receives: the slot arrays (a plain struct, passed by value inside the stage's
/// arrays). A particle's count may exceed `cap`: the events past `cap` are counted, not stored,
/// and the host grows the slots and searches again.
template <SlotLayout Layout>
struct SlotsView {
  int* count;    //!< pair events filed under each particle (can exceed `cap`)
  int* other;    //!< the other particle of each slot
  double* time;  //!< the pair time of each slot (steps)
  int cap;       //!< slots per particle
  int n;         //!< number of particles

  /// Where slot `s` of particle `i` lies in `other` and `time`.
  PLAB_HD int at(int i, int s) const {
    return Layout == SlotLayout::kBySlot ? s * n + i : i * cap + s;
  }
  /// The other particle of slot `s` of particle `i`.
  __device__ int other_at(int i, int s) const { return other[at(i, s)]; }
  /// The pair time of slot `s` of particle `i`.
  __device__ double time_at(int i, int s) const { return time[at(i, s)]; }
  /// Stores the pair event with particle `o` at time `t` in slot `s` of particle `i` when
  /// `s < cap` (the caller keeps the count, and reports one past `cap`).
  __device__ void put(int i, int s, int o, double t) const {
    if (s < cap) {
      other[at(i, s)] = o;
      time[at(i, s)] = t;
    }
  }
  /// Files the pair event with particle `o` at time `t` under particle `i`, in its next slot:
  /// `count[i]` is taken with atomicAdd, so many threads may file under one particle. The slots
  /// then fill in any order, which is harmless: the event key orders candidates completely.
  __device__ void add(int i, int o, double t) const { put(i, atomicAdd(&count[i], 1), o, t); }
};

/// The slots in device memory: the counts, and `cap` slots per particle.
template <SlotLayout Layout>
class DeviceSlots {
 public:
  /// Room for `n` particles with at least `first` slots each (counts uninitialised).
  DeviceSlots(int n, int first) : n_(n), count_(static_cast<std::size_t>(n)) { allocate(first); }

  /// At least `needed` slots per particle (a power of two), once the work queued on `stream`
  /// (which may use the slots) is done. The slot arrays are allocated again: their contents are
  /// lost and their addresses change (a recorded graph that holds them must be recorded again).
  void grow(int needed, cudaStream_t stream) {
    PLAB_CUDA_CHECK(cudaStreamSynchronize(stream));
    allocate(needed);
  }
  /// Sets every particle's count to 0, in order with `stream`.
  void clear_counts(cudaStream_t stream) {
    PLAB_CUDA_CHECK(cudaMemsetAsync(count_.get(), 0, count_.bytes(), stream));
  }
  /// The view kernels take.
  [[nodiscard]] SlotsView<Layout> view() const {
    return {count_.get(), other_.get(), time_.get(), cap_, n_};
  }
  /// Slots per particle.
  [[nodiscard]] int cap() const { return cap_; }
  /// Bytes held on the device.
  [[nodiscard]] std::size_t bytes() const {
    return count_.bytes() + other_.bytes() + time_.bytes();
  }

 private:
  /// Allocates the slot arrays for at least `needed` slots per particle (a power of two).
  void allocate(int needed) {
    while (cap_ < needed) cap_ = cap_ ? 2 * cap_ : 1;
    other_.resize(static_cast<std::size_t>(n_) * cap_);
    time_.resize(static_cast<std::size_t>(n_) * cap_);
  }

  int n_;                        //!< number of particles
  int cap_ = 0;                  //!< slots per particle
  DeviceArray<int> count_;       //!< SlotsView::count
  DeviceArray<int> other_;       //!< SlotsView::other, `n_ * cap_` of them
  DeviceArray<double> time_;     //!< SlotsView::time, `n_ * cap_` of them
};

}  // namespace plab::cuda
