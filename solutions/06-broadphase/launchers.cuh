/// \file solutions/06-broadphase/launchers.cuh
/// \brief Stage 06's launchers: grid size, launch on a stream, check; the sort of the entries
/// by bucket is CUB's DeviceRadixSort (cuda::key_bits() and cuda::sort_bytes() in
/// plab/cuda/slab_grid.cuh).
#pragma once

#include <cstddef>

#include "kernels.cuh"
#include "plab/cuda/check.hpp"
#include "plab/stage.hpp"

namespace plab::launch {

constexpr int kThreads = 256;  //!< threads per block of the per-particle and per-entry kernels

/// Blocks of kThreads covering `n`.
inline unsigned blocks(long long n) { return static_cast<unsigned>((n + kThreads - 1) / kThreads); }

inline void start_step(int n, const kernels::StepArrays& a, cudaStream_t s) {
  kernels::start_step<<<blocks(n), kThreads, 0, s>>>(n, a);
  PLAB_CUDA_CHECK_LAUNCH("start_step");
}

/// The binning: kernels::bin on (N / kThreads) x slabs blocks, the sort of the entries by key
/// (key_in, id_in into key_out, id_out; `temp` of sort_bytes()), then kernels::cell_starts.
inline void bin(const cuda::ParticlesView& p, const kernels::StepArrays& a, const kernels::Grid& g,
                int entries, void* temp, std::size_t temp_bytes, cudaStream_t s) {
  kernels::bin<<<dim3(blocks(p.n), g.slabs), kThreads, 0, s>>>(p, a, g);
  PLAB_CUDA_CHECK_LAUNCH("bin");
  PLAB_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp, temp_bytes, a.key_in, a.key_out, a.id_in,
                                                  a.id_out, entries, 0, cuda::key_bits(g), s));
  kernels::cell_starts<<<blocks(entries), kThreads, 0, s>>>(a, g, entries);
  PLAB_CUDA_CHECK_LAUNCH("cell_starts");
}

/// The neighbour search: kernels::find_pairs, one thread per entry.
inline void find_pairs(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                       const kernels::Grid& g, int entries, cudaStream_t s) {
  kernels::find_pairs<<<blocks(entries), kThreads, 0, s>>>(p, box, a, g, entries);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs");
}

/// The selection: kernels::select_pairs in one block of kernels::kSelectThreads.
inline void select_pairs(const kernels::StepArrays& a, cudaStream_t s) {
  kernels::select_pairs<<<1, kernels::kSelectThreads, 0, s>>>(a);
  PLAB_CUDA_CHECK_LAUNCH("select_pairs");
}

inline void apply(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                  cudaStream_t s) {
  kernels::apply<<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("apply");
}

}  // namespace plab::launch
