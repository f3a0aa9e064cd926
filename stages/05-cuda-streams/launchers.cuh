/// \file stages/05-cuda-streams/launchers.cuh
/// \brief Stage 05's launchers: grid size, launch on a stream, check. One per kernel.
#pragma once

#include "kernels.cuh"
#include "plab/cuda/check.hpp"
#include "plab/cuda/stream.hpp"
#include "plab/stage.hpp"

namespace plab::launch {

constexpr int kThreads = 128;  //!< threads per block of the one-thread-per-particle kernels

/// Blocks of `threads` covering `n`.
inline int blocks(int n, int threads = kThreads) { return (n + threads - 1) / threads; }

inline void wall_times(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                       cudaStream_t s) {
  kernels::wall_times<<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("wall_times");
}

inline void find_pairs(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                       cudaStream_t s) {
  const dim3 grid(blocks(p.n, kernels::kPairThreads), blocks(p.n, kernels::kTile));
  kernels::find_pairs<<<grid, kernels::kPairThreads, 0, s>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs");
}

inline void resolve(int n, const kernels::StepArrays& a, cudaStream_t s) {
  kernels::resolve<<<1, kernels::kResolveThreads, 0, s>>>(n, a);
  PLAB_CUDA_CHECK_LAUNCH("resolve");
}

inline void apply(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                  bool branchless, cudaStream_t s) {
  // EXERCISE 2: write kernels::BranchlessWall (kernels.cuh), then remove this line.
  if (branchless) PLAB_EXERCISE(2, "the branchless wall event: BranchlessWall in kernels.cuh");
  if (branchless)
    kernels::apply<true><<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  else
    kernels::apply<false><<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("apply");
}

}  // namespace plab::launch
