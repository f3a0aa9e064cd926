/// \file solutions/04-cuda/step.cu
/// \brief Stage 04, CUDA (the 2019 report's Part 2): V3's phases as kernels, the state on the
/// device between steps, the rounds resolved on the device. Same bits as stages 01-03.
//
// =================================================================================================
//  GOAL   Stage 03's step on the GPU, one thread per particle in every phase:
//         1. the state in device memory: cudaMalloc and cudaMemcpy of each field (no managed
//            memory), copied back only when the driver reads it;
//         2. start_step + find_pairs: wall times, and each particle's pair events of the step
//            in its own slots (a sparse row of V3's matrix: no N x N array);
//         3. rounds of choose + accept until no particle is left unresolved;
//         4. apply the plan.
//         Plain arrays of doubles, every CUDA call checked (kernels.cuh / launchers.cuh / this
//         host class).
//  READ   handouts/04-cuda.md           TEST   ./plab test --impl student --stage 04
// =================================================================================================
#include <memory>
#include <string>
#include <vector>

#include "launchers.cuh"
#include "plab/stage.hpp"
#include "plab/stepper.hpp"

namespace plab {
namespace {

/// A copy of `host` in device memory, allocated here (the caller frees it with cudaFree).
template <class T>
T* to_device(const std::vector<T>& host) {
  T* device = nullptr;
  PLAB_CUDA_CHECK(cudaMalloc(&device, host.size() * sizeof(T)));
  PLAB_CUDA_CHECK(cudaMemcpy(device, host.data(), host.size() * sizeof(T),
                             cudaMemcpyHostToDevice));
  return device;
}

/// Copies `host.size()` elements of `device` into `host` (waits for the work queued before).
template <class T>
void to_host(std::vector<T>& host, const T* device) {
  PLAB_CUDA_CHECK(cudaMemcpy(host.data(), device, host.size() * sizeof(T),
                             cudaMemcpyDeviceToHost));
}

/// A run of stage 04: owns the device state and steps it; work goes on the default stream, so
/// every call runs in order.
class CudaStepper final : public Stepper {
 public:
  CudaStepper(const Box& box, const Particles& p)
      : device_(cuda::require_device()), box_(box), n_(static_cast<int>(p.size())), wall_(n_),
        slots_(n_, 8), best_(n_), resolved_(n_), partner_(n_), ptime_(n_), flags_(1) {
    PLAB_CUDA_CHECK(cudaMemset(flags_.get(), 0, flags_.bytes()));
    upload(p);
  }
  ~CudaStepper() override {
    cudaFree(p_.x);
    cudaFree(p_.y);
    cudaFree(p_.vx);
    cudaFree(p_.vy);
    cudaFree(p_.pc);
    cudaFree(p_.wc);
  }
  CudaStepper(const CudaStepper&) = delete;
  CudaStepper& operator=(const CudaStepper&) = delete;

  void step() override {
    if (n_ == 0) return;
    timer_.start(nullptr);
    queue_step();
    timer_.stop(nullptr);
  }
  void read(Particles& p) override {
    timer_.close();
    download(p);
  }
  [[nodiscard]] double own_seconds() const override { return timer_.seconds(); }
  [[nodiscard]] std::string device() const override { return device_; }
  [[nodiscard]] std::size_t device_bytes() const override {
    return std::size_t(n_) * (4 * sizeof(double) + 2 * sizeof(long long)) + wall_.bytes() +
           slots_.bytes() + best_.bytes() + resolved_.bytes() + partner_.bytes() +
           ptime_.bytes() + flags_.bytes();
  }

 private:
  /// The state on the device: one array per field, allocated and copied from `p`.
  void upload(const Particles& p) {
    p_ = {to_device(p.x),  to_device(p.y),  to_device(p.vx), to_device(p.vy),
          to_device(p.pc), to_device(p.wc), n_};
  }

  /// The state back from the device into `p` (same size).
  void download(Particles& p) const {
    to_host(p.x, p_.x);
    to_host(p.y, p_.y);
    to_host(p.vx, p_.vx);
    to_host(p.vy, p_.vy);
    to_host(p.pc, p_.pc);
    to_host(p.wc, p_.wc);
  }

  void queue_step() {
    // 1. every wall time and every pair event of the step (more slots if a particle needs them)
    launch::start_step(p_, box_, arrays());
    launch::find_pairs(p_, box_, arrays());
    while (const int needed = take(&kernels::Flags::overflow)) {
      slots_.grow(needed, nullptr);
      launch::find_pairs(p_, box_, arrays());
    }
    // 2. mutual-earliest rounds, resolved on the device; the host only asks "anyone left?"
    do {
      launch::choose(n_, arrays());
      launch::accept(n_, arrays());
    } while (take(&kernels::Flags::unresolved));
    // 3. every particle's event
    launch::apply(p_, box_, arrays());
  }

  /// Reads one flag (waiting for the kernels before it) and clears it when it is set.
  int take(int kernels::Flags::*flag) {
    kernels::Flags f{};
    PLAB_CUDA_CHECK(cudaMemcpy(&f, flags_.get(), sizeof f, cudaMemcpyDeviceToHost));
    if (f.*flag) PLAB_CUDA_CHECK(cudaMemset(&(flags_.get()->*flag), 0, sizeof(int)));
    return f.*flag;
  }

  /// The working arrays as the kernels see them.
  [[nodiscard]] kernels::StepArrays arrays() const {
    return {wall_.get(),    slots_.view(), best_.get(), resolved_.get(),
            partner_.get(), ptime_.get(),  flags_.get()};
  }

  std::string device_;                //!< the GPU's name
  Box box_;                           //!< the box and radius
  int n_;                             //!< number of particles
  cuda::ParticlesView p_{};           //!< the state on the device (this class owns the arrays)
  cuda::DeviceArray<double> wall_;    //!< the working arrays (the kit's owners of cudaMalloc)
  cuda::DeviceSlots<cuda::SlotLayout::kByParticle> slots_;
  cuda::DeviceArray<model::Event> best_;
  cuda::DeviceArray<char> resolved_;
  cuda::DeviceArray<int> partner_;
  cuda::DeviceArray<double> ptime_;
  cuda::DeviceArray<kernels::Flags> flags_;  //!< one Flags, raised by the kernels
  cuda::EventTimer timer_;                   //!< the device time of the steps
};

}  // namespace

/// Stage 04's entry point (stage.hpp): a run on the GPU (NoDevice without one).
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions&) {
  return std::make_unique<CudaStepper>(box, p);
}

}  // namespace plab
