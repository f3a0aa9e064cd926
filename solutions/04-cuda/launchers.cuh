/// \file solutions/04-cuda/launchers.cuh
/// \brief Stage 04's launchers: grid size, launch, check. One per kernel, nothing else.
#pragma once

#include "kernels.cuh"
#include "plab/cuda/check.hpp"
#include "plab/cuda/stream.hpp"

namespace plab::launch {

constexpr int kThreads = 128;  //!< threads per block of every kernel

/// Blocks of kThreads covering `n` threads.
inline int blocks(int n) { return (n + kThreads - 1) / kThreads; }

inline void start_step(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a) {
  kernels::start_step<<<blocks(p.n), kThreads>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("start_step");
}

inline void find_pairs(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a) {
  kernels::find_pairs<<<blocks(p.n), kThreads>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs");
}

inline void choose(int n, const kernels::StepArrays& a) {
  kernels::choose<<<blocks(n), kThreads>>>(n, a);
  PLAB_CUDA_CHECK_LAUNCH("choose");
}

inline void accept(int n, const kernels::StepArrays& a) {
  kernels::accept<<<blocks(n), kThreads>>>(n, a);
  PLAB_CUDA_CHECK_LAUNCH("accept");
}

inline void apply(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a) {
  kernels::apply<<<blocks(p.n), kThreads>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("apply");
}

}  // namespace plab::launch
