/// \file cuda/check.hpp
/// \brief The CUDA stages' host-side helpers: one checking macro for every CUDA call, device
/// arrays that free themselves, and finding the GPU.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

/// Checks a CUDA runtime call: on failure throws plab::cuda::Error naming the call, file and line.
#define PLAB_CUDA_CHECK(call) ::plab::cuda::check((call), #call, __FILE__, __LINE__)

/// Checks the last kernel launch (bad configuration, too many resources): use after `<<<...>>>`.
#define PLAB_CUDA_CHECK_LAUNCH(kernel) \
  ::plab::cuda::check(cudaGetLastError(), "launch of " kernel, __FILE__, __LINE__)

namespace plab::cuda {

/// A failed CUDA call.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws Error when `status` is not cudaSuccess (see PLAB_CUDA_CHECK).
inline void check(cudaError_t status, const char* call, const char* file, int line) {
  if (status != cudaSuccess)
    throw Error(std::string("CUDA error: ") + call + " at " + file + ":" + std::to_string(line) +
                ": " + cudaGetErrorString(status));
}

/// Picks the GPU for a run and returns its name.
/// \throws NoDevice when there is no usable device (no GPU, no driver, or a driver too old)
std::string require_device();

/// Why no CUDA device can be used, or an empty string when one can (the tests skip on this).
std::string missing_device();

/// An array of `T` in device memory (cudaMalloc, no managed memory), freed with its owner. In
/// stage 04's build (PLAB_STAGE_NUMBER 4) it has no upload() nor download(): copying the state
/// to the device and back is that stage's exercise 1, so the stage's working arrays are
/// allocated here but never copied from the host.
template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  /// `n` uninitialised elements.
  explicit DeviceArray(std::size_t n) { resize(n); }
  ~DeviceArray() { cudaFree(data_); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;

  /// Replaces the contents with `n` uninitialised elements.
  void resize(std::size_t n) {
    PLAB_CUDA_CHECK(cudaFree(data_));
    data_ = nullptr;
    size_ = n;
    if (n) PLAB_CUDA_CHECK(cudaMalloc(&data_, n * sizeof(T)));
  }
#if !defined(PLAB_STAGE_NUMBER) || PLAB_STAGE_NUMBER != 4
  /// Copies `host` (of size()) to the device, in order with `stream`.
  void upload(const std::vector<T>& host, cudaStream_t stream = nullptr) {
    PLAB_CUDA_CHECK(cudaMemcpyAsync(data_, host.data(), size_ * sizeof(T),
                                    cudaMemcpyHostToDevice, stream));
  }
  /// Copies the array into `host` (resized to size()), in order with `stream` (not waiting).
  void download(std::vector<T>& host, cudaStream_t stream = nullptr) const {
    host.resize(size_);
    PLAB_CUDA_CHECK(cudaMemcpyAsync(host.data(), data_, size_ * sizeof(T),
                                    cudaMemcpyDeviceToHost, stream));
  }
#endif
  [[nodiscard]] T* get() const { return data_; }           //!< the device pointer
  [[nodiscard]] std::size_t size() const { return size_; }  //!< elements
  [[nodiscard]] std::size_t bytes() const { return size_ * sizeof(T); }  //!< bytes held

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace plab::cuda
