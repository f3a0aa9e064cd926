/// \file solutions/04-cuda/step.cu
/// \brief Stage 04, CUDA (the 2019 report's Part 2): V3's phases as kernels, the state on the
/// device between steps, the rounds resolved on the device. Same bits as stages 01-03.
//
// =================================================================================================
//  GOAL   Stage 03's step on the GPU, one thread per particle in every phase:
//         1. start_step + find_pairs: wall times, and each particle's pair events of the step
//            in its own slots (a sparse row of V3's matrix: no N x N array);
//         2. rounds of choose + accept until no particle is left unresolved;
//         3. apply the plan.
//         Device memory by cudaMalloc with explicit copies (no managed memory), plain arrays of
//         doubles, every CUDA call checked (kernels.cuh / launchers.cuh / this host class).
//  READ   handouts/04-cuda.md           TEST   ./plab test --impl student --stage 04
// =================================================================================================
#include <algorithm>
#include <memory>

#include "launchers.cuh"
#include "plab/cuda/stepper.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

/// A run of stage 04: owns the device state and steps it (the kit's cuda::DeviceStepper holds
/// the particles, the flags and the timer, and reads the state back).
class CudaStepper final : public cuda::DeviceStepper<kernels::Flags> {
 public:
  CudaStepper(const Box& box, const Particles& p)
      : DeviceStepper(cuda::require_device(), box, p, cuda::Queue::kDefaultStream), wall_(n_),
        slots_(n_, 8), best_(n_), resolved_(n_), partner_(n_), ptime_(n_) {}

 private:
  void queue_step() override {
    // 1. every wall time and every pair event of the step (more slots if a particle needs them)
    launch::start_step(p_.view(), box_, arrays());
    launch::find_pairs(p_.view(), box_, arrays());
    while (const int needed = flags_.take(&kernels::Flags::overflow, main_)) {
      slots_.grow(needed, main_);
      launch::find_pairs(p_.view(), box_, arrays());
    }
    // 2. mutual-earliest rounds, resolved on the device; the host only asks "anyone left?"
    do {
      launch::choose(n_, arrays());
      launch::accept(n_, arrays());
    } while (flags_.take(&kernels::Flags::unresolved, main_));
    // 3. every particle's event
    launch::apply(p_.view(), box_, arrays());
  }

  [[nodiscard]] std::size_t arrays_bytes() const override {
    return cuda::bytes_of(wall_, slots_, best_, resolved_, partner_, ptime_);
  }

  /// The working arrays as the kernels see them.
  [[nodiscard]] kernels::StepArrays arrays() const {
    return {wall_.get(),     slots_.view(),  best_.get(), resolved_.get(),
            partner_.get(),  ptime_.get(),   flags_.get()};
  }

  cuda::DeviceArray<double> wall_;
  cuda::DeviceSlots<cuda::SlotLayout::kByParticle> slots_;
  cuda::DeviceArray<model::Event> best_;
  cuda::DeviceArray<char> resolved_;
  cuda::DeviceArray<int> partner_;
  cuda::DeviceArray<double> ptime_;
};

}  // namespace

/// Stage 04's entry point (stage.hpp): a run on the GPU (NoDevice without one).
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions&) {
  return std::make_unique<CudaStepper>(box, p);
}

}  // namespace plab
