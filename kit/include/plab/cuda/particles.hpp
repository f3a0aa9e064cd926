/// \file cuda/particles.hpp
/// \brief The particles in device memory, one array per field, and the plain view kernels take.
#pragma once

#include "plab/cuda/check.hpp"
#include "plab/scene.hpp"

namespace plab::cuda {

/// What a kernel receives: the device pointers of every field and the count (a plain struct,
/// passed by value).
struct ParticlesView {
  double* x;       //!< centre x
  double* y;       //!< centre y
  double* vx;      //!< velocity x
  double* vy;      //!< velocity y
  long long* pc;   //!< pair collisions so far
  long long* wc;   //!< wall collisions so far
  int n;           //!< number of particles
};

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

}  // namespace plab::cuda
