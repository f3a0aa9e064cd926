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

inline void find_pairs([[maybe_unused]] const cuda::ParticlesView& p, [[maybe_unused]] const Box& box,
                       [[maybe_unused]] const kernels::StepArrays& a,
                       [[maybe_unused]] cudaStream_t s) {
  // EXERCISE 1: launch kernels::find_pairs on a grid of (N / kPairThreads) x (N / kTile) blocks
  // (rounded up) on stream s, and check the launch.
  PLAB_EXERCISE(1, "the pair search on a 2D grid with shared-memory tiles: kernel find_pairs");
}

inline void resolve([[maybe_unused]] int n, [[maybe_unused]] const kernels::StepArrays& a,
                    [[maybe_unused]] cudaStream_t s) {
  // EXERCISE 2: launch kernels::resolve as one block of kResolveThreads on stream s, and check it.
  PLAB_EXERCISE(2, "every round of the step in one block: kernel resolve");
}

inline void apply(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                  bool branchless, cudaStream_t s) {
  if (branchless)
    kernels::apply<true><<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  else
    kernels::apply<false><<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("apply");
}

}  // namespace plab::launch
