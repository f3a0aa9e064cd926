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
  // EXERCISE 2: launch kernels::find_pairs (one thread per particle) and check the launch.
  PLAB_EXERCISE(2, "find each particle's pair events of the step: kernel find_pairs");
}

inline void choose([[maybe_unused]] int n, [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 3: launch kernels::choose and check the launch.
  PLAB_EXERCISE(3, "the rounds on the device: kernels choose and accept, and their host loop");
}

inline void accept([[maybe_unused]] int n, [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 3: launch kernels::accept and check the launch.
  PLAB_EXERCISE(3, "the rounds on the device: kernels choose and accept, and their host loop");
}

inline void apply([[maybe_unused]] const cuda::ParticlesView& p, [[maybe_unused]] const Box& box,
                  [[maybe_unused]] const kernels::StepArrays& a) {
  // EXERCISE 4: launch kernels::apply and check the launch.
  PLAB_EXERCISE(4, "apply the plan: kernel apply");
}

}  // namespace plab::launch
