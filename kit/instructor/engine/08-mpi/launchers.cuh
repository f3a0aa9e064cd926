/// \file kit/instructor/engine/08-mpi/launchers.cuh
/// \brief Stage 08's launchers: grid size, launch on a stream, check; the CUB radix sort and
/// unique-by-key that order the pairs found (the counting sort's scan is the kit's,
/// plab::cuda::exclusive_scan()).
#pragma once

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_select.cuh>

#include "kernels.cuh"
#include "plab/cuda/check.hpp"
#include "plab/cuda/scan.cuh"

namespace plab::dist::launch {

constexpr int kThreads = 256;  //!< threads per block

/// Blocks of kThreads covering `n`.
inline unsigned blocks(long long n) { return static_cast<unsigned>((n + kThreads - 1) / kThreads); }

inline void bin_count(const kernels::Arrays& a, const kernels::SlabGrid& d, cudaStream_t s) {
  kernels::bin_count<<<blocks(a.n), kThreads, 0, s>>>(a, d);
  PLAB_CUDA_CHECK_LAUNCH("bin_count");
}

inline void bin_scatter(const kernels::Arrays& a, const kernels::SlabGrid& d, cudaStream_t s) {
  kernels::bin_scatter<<<blocks(a.n), kThreads, 0, s>>>(a, d);
  PLAB_CUDA_CHECK_LAUNCH("bin_scatter");
}

/// One thread per entry the slab can hold (at most every particle).
inline void find_pairs(const kernels::Arrays& a, const kernels::SlabGrid& d, double r,
                       cudaStream_t s) {
  kernels::find_pairs<<<blocks(a.n), kThreads, 0, s>>>(a, d, r);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs");
}

/// Sorts `m` pairs (key_in, time_in) by key into (key_out, time_out), on the key's low `bits`
/// bits (CUB's radix sort; `temp == nullptr`: sets `temp_bytes` to what it needs).
inline void sort_pairs(void* temp, std::size_t& temp_bytes, const std::uint64_t* key_in,
                       std::uint64_t* key_out, const double* time_in, double* time_out, int m,
                       int bits, cudaStream_t s) {
  PLAB_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp, temp_bytes, key_in, key_out, time_in,
                                                  time_out, m, 0, bits, s));
}

/// Keeps the first of each run of equal keys of `m` sorted pairs (a pair found in several slabs
/// or by both of its particles has the same time each time); `*kept` gets how many (CUB's
/// unique-by-key; `temp == nullptr`: sets `temp_bytes`).
inline void unique_pairs(void* temp, std::size_t& temp_bytes, const std::uint64_t* key_in,
                         const double* time_in, std::uint64_t* key_out, double* time_out,
                         int* kept, int m, cudaStream_t s) {
  PLAB_CUDA_CHECK(cub::DeviceSelect::UniqueByKey(temp, temp_bytes, key_in, time_in, key_out,
                                                 time_out, kept, m, s));
}

}  // namespace plab::dist::launch
