/// \file stages/04-cuda/step.cu
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
#include "plab/stage.hpp"

namespace plab {
namespace {

/// A run of stage 04: owns the device state and steps it.
class CudaStepper final : public Stepper {
 public:
  CudaStepper(const Box& box, const Particles& p)
      : device_(cuda::require_device()), box_(box), p_(p), n_(p_.size()), wall_(n_), count_(n_),
        best_(n_), resolved_(n_), partner_(n_), ptime_(n_), flags_(2) {
    grow_slots(8);
    PLAB_CUDA_CHECK(cudaMemset(flags_.get(), 0, flags_.bytes()));
  }

  void step() override {
    if (n_ == 0) return;
    timer_.start(nullptr);
    // 1. every wall time and every pair event of the step (more slots if a particle needs them)
    launch::start_step(p_.view(), box_, arrays());
    launch::find_pairs(p_.view(), box_, arrays());
    while (const int needed = read_flag(1)) {
      grow_slots(needed);
      launch::find_pairs(p_.view(), box_, arrays());
    }
    // 2. mutual-earliest rounds, resolved on the device; the host only asks "anyone left?"
    do {
      launch::choose(n_, arrays());
      launch::accept(n_, arrays());
    } while (read_flag(0));
    // 3. every particle's event
    launch::apply(p_.view(), box_, arrays());
    timer_.stop(nullptr);
  }

  void read(Particles& p) override {
    timer_.close();
    p_.download(p);
  }

  [[nodiscard]] double own_seconds() const override { return timer_.seconds(); }
  [[nodiscard]] std::string device() const override { return device_; }
  [[nodiscard]] std::size_t device_bytes() const override {
    return p_.bytes() + wall_.bytes() + count_.bytes() + other_.bytes() + time_.bytes() +
           best_.bytes() + resolved_.bytes() + partner_.bytes() + ptime_.bytes() + flags_.bytes();
  }

 private:
  /// The working arrays as the kernels see them.
  [[nodiscard]] kernels::StepArrays arrays() const {
    return {wall_.get(),     count_.get(),   other_.get(),   time_.get(),  cap_,
            best_.get(),     resolved_.get(), partner_.get(), ptime_.get(), flags_.get()};
  }
  /// Reads flags[k] (waiting for the queued kernels) and clears it.
  int read_flag(int k) {
    int value = 0;
    PLAB_CUDA_CHECK(cudaMemcpy(&value, flags_.get() + k, sizeof value, cudaMemcpyDeviceToHost));
    if (value) PLAB_CUDA_CHECK(cudaMemset(flags_.get() + k, 0, sizeof value));
    return value;
  }
  /// At least `needed` slots per particle (a power of two).
  void grow_slots(int needed) {
    while (cap_ < needed) cap_ = cap_ ? 2 * cap_ : 1;
    other_.resize(static_cast<std::size_t>(n_) * cap_);
    time_.resize(static_cast<std::size_t>(n_) * cap_);
  }

  std::string device_;
  Box box_;
  cuda::DeviceParticles p_;
  int n_;
  int cap_ = 0;
  cuda::DeviceArray<double> wall_;
  cuda::DeviceArray<int> count_, other_;
  cuda::DeviceArray<double> time_;
  cuda::DeviceArray<model::Event> best_;
  cuda::DeviceArray<char> resolved_;
  cuda::DeviceArray<int> partner_;
  cuda::DeviceArray<double> ptime_;
  cuda::DeviceArray<int> flags_;
  cuda::EventTimer timer_;
};

}  // namespace

/// Stage 04's entry point (stage.hpp): a run on the GPU (NoDevice without one).
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions&) {
  return std::make_unique<CudaStepper>(box, p);
}

}  // namespace plab
