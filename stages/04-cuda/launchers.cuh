/// \file stages/04-cuda/launchers.cuh
/// \brief Stage 04's launchers: grid size, launch, check. One per kernel, nothing else.
#pragma once

#include "kernels.cuh"
#include "plab/cuda/check.hpp"
#include "plab/cuda/stream.hpp"
#include "plab/stage.hpp"

namespace plab::launch {

constexpr int kThreads = 128;  //!< threads per block of every kernel

/// Blocks of kThreads covering `n` threads.
inline int blocks(int n) { return (n + kThreads - 1) / kThreads; }

inline void start_step(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a) {
  kernels::start_step<<<blocks(p.n), kThreads>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("start_step");
}

inline void find_pairs([[maybe_unused]] const cuda::ParticlesView& p, [[maybe_unused]] const Box& box,
                       [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 1: launch kernels::find_pairs (one thread per particle) and check the launch.
  PLAB_EXERCISE(1, "find each particle's pair events of the step: kernel find_pairs");
}

inline void choose([[maybe_unused]] int n, [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 2: launch kernels::choose and check the launch.
  PLAB_EXERCISE(2, "a round of mutual-earliest choices: kernels choose and accept");
}

inline void accept([[maybe_unused]] int n, [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 2: launch kernels::accept and check the launch.
  PLAB_EXERCISE(2, "a round of mutual-earliest choices: kernels choose and accept");
}

inline void apply([[maybe_unused]] const cuda::ParticlesView& p, [[maybe_unused]] const Box& box,
                  [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 3: launch kernels::apply and check the launch.
  PLAB_EXERCISE(3, "apply the plan: kernel apply");
}

}  // namespace plab::launch
