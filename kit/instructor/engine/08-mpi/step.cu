/// \file kit/instructor/engine/08-mpi/step.cu
/// \brief Stage 08 on one GPU per rank: the candidate search and narrow phase of step.cpp's
/// find_candidates() on the rank's GPU (kernels.cuh), the rest of the step (halo, rounds,
/// migration) on the host as step.cpp does it. plab::make_gpu_stepper(), which step.cpp's
/// make_stepper() takes with `--device gpu`.
//
// =================================================================================================
//  GIVEN  (no exercise here: stage 08's exercises are the halo, the rounds and the migration)
//         Each step, on each rank: its particles (owned, then ghosts), the slabs each takes part
//         in and the grid (fit_grid(), on the host) go to its GPU; per time slab: bin_count ->
//         CUB scan -> bin_scatter -> find_pairs, which files (key, time) for every pair in the
//         step; then a CUB radix sort by key and a unique-by-key give step.cpp's list, sorted,
//         each pair once, which comes back for the rounds. Same pairs, same times, same order:
//         the same bits as the CPU path at any rank count.
//  READ   handouts/engine-08.md (the GPU path)   TEST   ctest -L engine -R stage08 (a GPU machine)
// =================================================================================================
#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "launchers.cuh"
#include "plab/cuda/stream.hpp"
#include "plab/stage.hpp"
#include "search.hpp"

namespace plab {
namespace dist {
namespace {

/// A device array that keeps its memory when asked for fewer elements than it holds (the
/// particles here change from step to step).
template <class T>
class Buffer {
 public:
  /// Room for at least `n` elements (the contents are lost when it grows).
  void reserve(std::size_t n) {
    if (n > a_.size()) a_.resize(n + n / 4 + 64);
  }
  /// Copies `host` to the front of the buffer, growing it first, in order with `stream`.
  void put(const std::vector<T>& host, cudaStream_t stream) {
    reserve(host.size());
    if (!host.empty())
      PLAB_CUDA_CHECK(cudaMemcpyAsync(a_.get(), host.data(), host.size() * sizeof(T),
                                      cudaMemcpyHostToDevice, stream));
  }
  /// Copies the first `n` elements into `host` (resized), in order with `stream` (not waiting).
  void get(std::vector<T>& host, std::size_t n, cudaStream_t stream) const {
    host.resize(n);
    if (n)
      PLAB_CUDA_CHECK(cudaMemcpyAsync(host.data(), a_.get(), n * sizeof(T),
                                      cudaMemcpyDeviceToHost, stream));
  }
  [[nodiscard]] T* data() const { return a_.get(); }                  //!< the device pointer
  [[nodiscard]] std::size_t size() const { return a_.size(); }        //!< elements held
  [[nodiscard]] std::size_t bytes() const { return a_.bytes(); }      //!< bytes held

 private:
  cuda::DeviceArray<T> a_;
};

/// One rank's GPU and what its search keeps from step to step.
class DeviceSearch {
 public:
  /// Binds GPU `device` to this process.
  explicit DeviceSearch(int device) {
    PLAB_CUDA_CHECK(cudaSetDevice(device));
    stream_ = std::make_unique<cuda::Stream>();
    length_.reserve(2);
  }

  /// The PairSearch of search.hpp on this GPU.
  void run(const Box& box, const LocalGrid& lg, const Local& s, const std::vector<int>& first,
           const std::vector<int>& last, std::vector<FoundPair>& found) {
    const cudaStream_t st = *stream_;
    const int n = s.size();
    found.clear();
    if (n == 0) return;
    x_.put(s.p.x, st), y_.put(s.p.y, st), vx_.put(s.p.vx, st), vy_.put(s.p.vy, st);
    id_.put(s.id, st), first_.put(first, st), last_.put(last, st);
    place_.reserve(n), entry_id_.reserve(n), entry_.reserve(n);
    const int cells = lg.g.cells();
    filled_.reserve(cells + 1), start_.reserve(cells + 1);
    if (key_.size() == 0) grow(n + 1024);  // a first guess: about one pair a particle
    int length = search(box, lg, s.owned, n, cells);
    if (length > static_cast<int>(key_.size())) {  // the list was too short: again, longer
      grow(length);
      length = search(box, lg, s.owned, n, cells);
    }
    // Sort by key on the bits a local index pair uses, then one of each key.
    int bits = 32;
    while (bits < 64 && (std::uint64_t{1} << (bits - 32)) < static_cast<std::uint64_t>(n)) ++bits;
    std::size_t sort_bytes = 0, unique_bytes = 0;
    launch::sort_pairs(nullptr, sort_bytes, key_.data(), sorted_key_.data(), time_.data(),
                       sorted_time_.data(), length, bits, st);
    launch::unique_pairs(nullptr, unique_bytes, sorted_key_.data(), sorted_time_.data(),
                         key_.data(), time_.data(), length_.data() + 1, length, st);
    temp_.reserve(std::max(sort_bytes, unique_bytes));
    sort_bytes = unique_bytes = temp_.size();
    launch::sort_pairs(temp_.data(), sort_bytes, key_.data(), sorted_key_.data(), time_.data(),
                       sorted_time_.data(), length, bits, st);
    launch::unique_pairs(temp_.data(), unique_bytes, sorted_key_.data(), sorted_time_.data(),
                         key_.data(), time_.data(), length_.data() + 1, length, st);
    std::vector<int> kept;
    length_.get(kept, 2, st);
    PLAB_CUDA_CHECK(cudaStreamSynchronize(st));
    key_.get(keys_, kept[1], st);
    time_.get(times_, kept[1], st);
    PLAB_CUDA_CHECK(cudaStreamSynchronize(st));
    found.resize(kept[1]);
    for (int q = 0; q < kept[1]; ++q)
      found[q] = FoundPair{times_[q], static_cast<int>(keys_[q] >> 32),
                           static_cast<int>(keys_[q] & 0xffffffffu)};
  }

 private:
  /// Room for `pairs` pairs found in a step (and their sorted copies).
  void grow(int pairs) {
    for (auto* b : {&key_, &sorted_key_}) b->reserve(pairs);
    for (auto* b : {&time_, &sorted_time_}) b->reserve(pairs);
  }

  /// Every slab's counting sort and search; returns the pairs found (filed when they fit).
  int search(const Box& box, const LocalGrid& lg, int owned, int n, int cells) {
    const cudaStream_t st = *stream_;
    const kernels::Arrays a{n,
                            owned,
                            x_.data(),
                            y_.data(),
                            vx_.data(),
                            vy_.data(),
                            id_.data(),
                            first_.data(),
                            last_.data(),
                            filled_.data(),
                            start_.data(),
                            place_.data(),
                            entry_id_.data(),
                            entry_.data(),
                            key_.data(),
                            time_.data(),
                            static_cast<int>(std::min<std::size_t>(key_.size(), time_.size())),
                            length_.data()};
    temp_.reserve(cuda::exclusive_scan_bytes(cells + 1));
    PLAB_CUDA_CHECK(cudaMemsetAsync(length_.data(), 0, sizeof(int), st));
    for (int k = 0; k < lg.g.slabs; ++k) {
      const kernels::SlabGrid d{lg.g, lg.x0, lg.y0, k, cells};
      PLAB_CUDA_CHECK(cudaMemsetAsync(filled_.data(), 0, (cells + 1) * sizeof(int), st));
      launch::bin_count(a, d, st);
      cuda::exclusive_scan(filled_.data(), start_.data(), cells + 1, temp_.data(), temp_.size(), st);
      launch::bin_scatter(a, d, st);
      launch::find_pairs(a, d, box.r, st);
    }
    std::vector<int> length;
    length_.get(length, 1, st);
    PLAB_CUDA_CHECK(cudaStreamSynchronize(st));
    return length[0];
  }

  std::unique_ptr<cuda::Stream> stream_;
  Buffer<double> x_, y_, vx_, vy_;
  Buffer<int> id_, first_, last_, filled_, start_, place_, entry_id_;
  Buffer<kernels::Entry> entry_;
  Buffer<std::uint64_t> key_, sorted_key_;
  Buffer<double> time_, sorted_time_;
  Buffer<int> length_;  //!< [0]: pairs found; [1]: pairs kept by the unique-by-key
  Buffer<unsigned char> temp_;
  std::vector<std::uint64_t> keys_;  //!< the kept keys, on the host
  std::vector<double> times_;        //!< their times
};

/// This process's GPU search, made at its first step (after MPI has started: the rank picks
/// its GPU).
std::unique_ptr<DeviceSearch> the_search;

/// search.hpp's PairSearch on this rank's GPU: rank % the GPUs this machine has.
void search_on_gpu(const Box& box, const Ranks& r, const LocalGrid& lg, const Local& s,
                   const std::vector<int>& first, const std::vector<int>& last,
                   std::vector<FoundPair>& found) {
  if (!the_search) {
    cuda::require_device();
    int count = 0;
    PLAB_CUDA_CHECK(cudaGetDeviceCount(&count));
    the_search = std::make_unique<DeviceSearch>(r.rank % count);
  }
  the_search->run(box, lg, s, first, last, found);
}

}  // namespace
}  // namespace dist

/// Stage 08's GPU path (stage.hpp): sets dist::gpu_search (every rank calls this: rank 0 from
/// make_stepper(), the others from stage_worker() with the CPU asked for), and with `--device
/// gpu` returns the kit's MPI driver stepping on the GPU (NoDevice where none can be used);
/// nullptr otherwise (the CPU path).
std::unique_ptr<Stepper> make_gpu_stepper(const Box& box, Particles& p,
                                          const StageOptions& options) {
  dist::gpu_search = &dist::search_on_gpu;
  if (options.device != Device::kGpu) return nullptr;
  return dist::mpi_stage_any_cut(box, p, dist::step, cuda::require_device(), dist::first_owner);
}

}  // namespace plab
