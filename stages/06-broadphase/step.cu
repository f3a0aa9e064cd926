/// \file stages/06-broadphase/step.cu
/// \brief Stage 06 on the GPU: step.cpp's broad phase as a sort of (slab, particle) entries by
/// cell, a neighbour search into one list of pairs, mutual-earliest rounds over that list, and
/// apply, recorded once as a CUDA graph. plab::make_gpu_stepper(), which step.cpp's
/// make_stepper() takes when there is a GPU (--device cpu forces step.cpp).
//
// =================================================================================================
//  GOAL   Every phase on the device, as the CUDA sample `particles` does its grid:
//         4. binning: each (slab, particle) entry gets the cell of its position at the slab's
//            midpoint as key; sort the entries by key (CUB); find where each cell starts;
//         5. neighbour search: each entry tests the entries of the cells within its reach and
//            files the pairs that meet in its slab into one list (a fast particle searches more
//            cells: exact for any speed);
//         6. the sparse selection: stage 04's mutual-earliest rounds over the list of pairs.
//         A step whose pairs overflow the list stops the batch; the host redoes it, longer.
//  READ   handouts/06-broadphase.md     TEST   ./plab test --impl student --stage 06 (GPU)
// =================================================================================================
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "launchers.cuh"
#include "plab/cuda/stepper.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

constexpr double kAlpha = 1.0;  //!< slabs per sqrt(N) mean speed / L (--sweep-alpha sets another)
constexpr long long kMostEntries = 1 << 27;  //!< (slab, particle) entries at most (and 64 slabs)
constexpr long long kCheckEvery = 32;        //!< steps between two looks at the flags

/// A run of stage 06 on the GPU (cuda::DeviceStepper holds the particles, flags and timer).
class CudaStepper final : public cuda::DeviceStepper<kernels::Flags> {
 public:
  CudaStepper(const Box& box, const Particles& p, std::string device, double alpha)
      : DeviceStepper(std::move(device), box, p, cuda::Queue::kOwnStream), list_(n_ + 1024),
        partner_(n_), ptime_(n_), best_t_(n_), best_pair_(n_) {
    choose_grid(p, alpha);
    entries_ = static_cast<int>(static_cast<long long>(n_) * grid_.slabs);
    for (auto* v : {&key_in_, &id_in_, &key_out_, &id_out_}) v->resize(entries_);
    start_.resize(static_cast<std::size_t>(grid_.slabs) * grid_.cells() + 1);
    temp_.resize(launch::sort_bytes(grid_, entries_));
    sync();
  }

  void step() override {
    DeviceStepper::step();  // look at the flags after the first step, then every kCheckEvery
    if (n_ > 0 && (asked_ == 1 || asked_ % kCheckEvery == 0)) catch_up();
  }

 private:
  void queue_step() override {
    if (stale_) graph_.record(main_, [this] { queue_kernels(); });
    stale_ = false;
    graph_.launch(main_);
  }

  /// The kernels of one step.
  void queue_kernels() {
    const kernels::StepArrays a{key_in_.get(),  id_in_.get(),   key_out_.get(),
                                id_out_.get(),  start_.get(),   list_.get(),
                                static_cast<int>(list_.size()), partner_.get(),
                                ptime_.get(),   best_t_.get(),  best_pair_.get(), flags_.get()};
    launch::start_step(n_, a, main_);
    launch::bin(p_.view(), a, grid_, entries_, temp_.get(), temp_.size(), main_);
    launch::find_pairs(p_.view(), box_, a, grid_, entries_, main_);
    launch::select_pairs(a, main_);
    launch::apply(p_.view(), box_, a, main_);
  }

  /// Waits for the queued steps; redoes those a stop on the device skipped, with a longer list.
  void catch_up() override {
    for (kernels::Flags f = flags_.read(main_); f.overflow > 0; f = flags_.read(main_)) {
      list_.resize(2 * static_cast<std::size_t>(f.overflow));
      stale_ = true;  // the recorded graph holds the old list's address
      flags_.clear(&kernels::Flags::overflow, main_);
      for (long long s = f.steps_done; s < asked_; ++s) queue_step();
      timer_.stop(main_);
    }
  }

  /// alpha sqrt(N) v / L slabs for the mean speed v, and cells as wide as the reach of a
  /// particle of that speed (kernels::reach_of()), at most about 4N a slab. Without a finite
  /// mean speed, one slab and one cell (every pair is tested).
  void choose_grid(const Particles& p, double alpha) {
    double sum = 0;
    for (int i = 0; i < n_; ++i) sum += std::sqrt(p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i]);
    const double v = n_ > 0 ? sum / n_ : 0, L = box_.L, n = std::max(n_, 1);
    const bool known = std::isfinite(v) && std::isfinite(L) && L > 0;
    const double most = static_cast<double>(std::clamp(kMostEntries / std::max(n_, 1), 1LL, 64LL));
    grid_.slabs = known ? static_cast<int>(std::clamp(std::ceil(alpha * std::sqrt(n) * v / L), 1.0,
                                                      most))
                        : 1;
    grid_.reach = 2 * box_.r + 1e-6 * (L + box_.r);
    grid_.per_speed = 1.0 / grid_.slabs + 1e-6;
    const double cell = (grid_.reach + v * grid_.per_speed) * (1 + 1e-9);
    grid_.side = known ? static_cast<int>(std::max(1.0, std::min(L / cell, 2 * std::sqrt(n) + 1)))
                       : 1;
    grid_.inv_cell = known ? grid_.side / L : 0;
  }

  [[nodiscard]] std::size_t arrays_bytes() const override {
    return cuda::bytes_of(key_in_, id_in_, key_out_, id_out_, start_, list_, partner_, ptime_,
                          best_t_, best_pair_, temp_);
  }

  kernels::Grid grid_{};
  int entries_ = 0;  //!< slabs x N
  cuda::DeviceArray<int> key_in_, id_in_, key_out_, id_out_, start_;
  cuda::DeviceArray<kernels::Pair> list_;
  cuda::DeviceArray<int> partner_;
  cuda::DeviceArray<double> ptime_;
  cuda::DeviceArray<unsigned long long> best_t_, best_pair_;
  cuda::DeviceArray<unsigned char> temp_;
  cuda::Graph graph_;
  bool stale_ = true;  //!< the graph must be recorded (again)
};

}  // namespace

/// Stage 06's GPU path (stage.hpp): a run on the GPU when one can be used; nullptr otherwise
/// (step.cpp's make_stepper() then runs the CPU path), NoDevice when the run asked for the GPU.
std::unique_ptr<Stepper> make_gpu_stepper(const Box& box, Particles& p,
                                          const StageOptions& options) {
  if (options.device == Device::kAuto && !cuda::missing_device().empty()) return nullptr;
  return std::make_unique<CudaStepper>(box, p, cuda::require_device(),
                                       options.sweep_alpha > 0 ? options.sweep_alpha : kAlpha);
}

}  // namespace plab
