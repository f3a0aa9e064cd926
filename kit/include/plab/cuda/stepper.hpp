/// \file cuda/stepper.hpp
/// \brief What the CUDA stages from 05 on have in common: the GPU's name, the particles on the
/// device (stage 04's exercise 1, done: DeviceParticles), the stream the work goes on, the flags
/// the kernels raise, the timer of the steps, and reading the state back. A stage's stepper
/// derives from DeviceStepper and writes only its own step (queue_step()) and arrays. Stage 04
/// writes all of this itself and does not include this header.
#pragma once

#if defined(PLAB_STAGE_NUMBER) && PLAB_STAGE_NUMBER == 4
#error "plab/cuda/stepper.hpp (DeviceParticles, DeviceStepper) is for stages 05 on: stage 04's exercise 1 puts the state in device memory itself (cudaMalloc, cudaMemcpy, cudaFree)"
#endif

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "plab/cuda/check.hpp"
#include "plab/cuda/particles.hpp"
#include "plab/cuda/stream.hpp"
#include "plab/stepper.hpp"

namespace plab::cuda {

/// Bytes held on the device by every argument (anything with `bytes()`: DeviceArray,
/// DeviceSlots, ...).
template <class... Arrays>
[[nodiscard]] std::size_t bytes_of(const Arrays&... arrays) {
  return (std::size_t{0} + ... + arrays.bytes());
}

/// The particles on the device, one DeviceArray per field.
class DeviceParticles {
 public:
  /// Allocates room for `p` and copies it (in order with `stream`).
  explicit DeviceParticles(const Particles& p, cudaStream_t stream = nullptr)
      : x_(p.size()), y_(p.size()), vx_(p.size()), vy_(p.size()), pc_(p.size()), wc_(p.size()) {
    x_.upload(p.x, stream);
    y_.upload(p.y, stream);
    vx_.upload(p.vx, stream);
    vy_.upload(p.vy, stream);
    pc_.upload(p.pc, stream);
    wc_.upload(p.wc, stream);
  }
  /// Copies the state into `p` and waits for it.
  void download(Particles& p, cudaStream_t stream = nullptr) const {
    x_.download(p.x, stream);
    y_.download(p.y, stream);
    vx_.download(p.vx, stream);
    vy_.download(p.vy, stream);
    pc_.download(p.pc, stream);
    wc_.download(p.wc, stream);
    PLAB_CUDA_CHECK(cudaStreamSynchronize(stream));
  }
  /// The view kernels take.
  [[nodiscard]] ParticlesView view() const {
    return {x_.get(), y_.get(), vx_.get(), vy_.get(), pc_.get(), wc_.get(), size()};
  }
  /// Number of particles.
  [[nodiscard]] int size() const { return static_cast<int>(x_.size()); }
  /// Bytes held on the device.
  [[nodiscard]] std::size_t bytes() const {
    return x_.bytes() + y_.bytes() + vx_.bytes() + vy_.bytes() + pc_.bytes() + wc_.bytes();
  }

 private:
  DeviceArray<double> x_, y_, vx_, vy_;
  DeviceArray<long long> pc_, wc_;
};

/// One struct of flags in device memory: the kernels raise them, the host reads and clears them.
template <class Flags>
class DeviceFlags {
 public:
  /// All flags 0, in order with `stream`.
  explicit DeviceFlags(cudaStream_t stream) : flags_(1) {
    PLAB_CUDA_CHECK(cudaMemsetAsync(flags_.get(), 0, flags_.bytes(), stream));
  }
  /// The device pointer kernels take.
  [[nodiscard]] Flags* get() const { return flags_.get(); }
  /// Copies the flags to the host, waiting for the work queued on `stream` before.
  [[nodiscard]] Flags read(cudaStream_t stream) const {
    Flags f{};
    PLAB_CUDA_CHECK(cudaMemcpyAsync(&f, flags_.get(), sizeof f, cudaMemcpyDeviceToHost, stream));
    PLAB_CUDA_CHECK(cudaStreamSynchronize(stream));
    return f;
  }
  /// Sets one flag (a member of Flags) to 0, in order with `stream`.
  template <class T>
  void clear(T Flags::*flag, cudaStream_t stream) {
    PLAB_CUDA_CHECK(cudaMemsetAsync(&(flags_.get()->*flag), 0, sizeof(T), stream));
  }
  /// Reads one flag (waiting for the work queued on `stream`) and clears it when it is set.
  template <class T>
  T take(T Flags::*flag, cudaStream_t stream) {
    const T value = read(stream).*flag;
    if (value) clear(flag, stream);
    return value;
  }
  /// Bytes held on the device.
  [[nodiscard]] std::size_t bytes() const { return flags_.bytes(); }

 private:
  DeviceArray<Flags> flags_;  //!< one Flags
};

/// Where a stepper queues its work.
enum class Queue {
  kDefaultStream,  //!< the legacy default stream: every call in order
  kOwnStream,      //!< a non-blocking stream of the stepper's own (stage 05 on)
};

/// The part of a CUDA stage's Stepper that every stage has: the device's name, the particles on
/// the device, the stream of the work, the flags (`Flags`, the stage's struct) and the timer.
/// step() times queue_step(); read() catches up (catch_up()) and copies the state back.
template <class Flags>
class DeviceStepper : public Stepper {
 public:
  void step() override {
    if (n_ == 0) return;
    timer_.start(main_);
    queue_step();
    timer_.stop(main_);
    ++asked_;
  }
  void read(Particles& p) override {
    catch_up();
    timer_.close();
    p_.download(p, main_);
  }
  [[nodiscard]] double own_seconds() const override { return timer_.seconds(); }
  [[nodiscard]] std::string device() const override { return device_; }
  [[nodiscard]] std::size_t device_bytes() const override {
    return p_.bytes() + flags_.bytes() + arrays_bytes();
  }

 protected:
  /// Copies `p` to the device (on the queue's stream) for a run on the GPU named `device`.
  DeviceStepper(std::string device, const Box& box, const Particles& p, Queue queue)
      : device_(std::move(device)),
        own_(queue == Queue::kOwnStream ? std::make_unique<Stream>() : nullptr),
        main_(own_ ? static_cast<cudaStream_t>(*own_) : nullptr), box_(box), p_(p, main_),
        n_(p_.size()), flags_(main_) {}

  /// Queues one step's work on `main_` (it may wait for some of it, as stage 04's rounds do).
  virtual void queue_step() = 0;
  /// Waits for the queued steps and redoes those the device skipped; read() calls it first.
  virtual void catch_up() {}
  /// Bytes of the stage's own device arrays (device_bytes() adds the particles and the flags).
  [[nodiscard]] virtual std::size_t arrays_bytes() const = 0;
  /// Waits for everything queued on `main_`.
  void sync() const { PLAB_CUDA_CHECK(cudaStreamSynchronize(main_)); }

  std::string device_;            //!< the GPU's name (from cuda::require_device())
  std::unique_ptr<Stream> own_;   //!< the stepper's stream (Queue::kOwnStream), or none
  cudaStream_t main_;             //!< where the work goes: `*own_`, or the default stream
  Box box_;                       //!< the box and radius
  DeviceParticles p_;             //!< the state, on the device between steps
  int n_;                         //!< number of particles
  long long asked_ = 0;           //!< steps queued so far (step() counts them)
  DeviceFlags<Flags> flags_;      //!< what the kernels report to the host
  EventTimer timer_;              //!< the device time of the steps (own_seconds())
};

}  // namespace plab::cuda
