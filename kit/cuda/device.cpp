/// \file cuda/device.cpp
/// \brief Finding a usable CUDA device, with the runtime's own reason when there is none.
#include "plab/cuda/check.hpp"
#include "plab/errors.hpp"

namespace plab::cuda {

std::string missing_device() {
  int count = 0;
  // Any error counts as no device: here a machine without a GPU answers "CUDA driver version
  // is insufficient for CUDA runtime version".
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    cudaGetLastError();  // clear it
    return cudaGetErrorString(status);
  }
  if (count == 0) return "cudaGetDeviceCount found none";
  return "";
}

std::string require_device() {
  const std::string why = missing_device();
  if (!why.empty()) throw NoDevice(why);
  int device = 0;
  PLAB_CUDA_CHECK(cudaGetDevice(&device));
  cudaDeviceProp prop{};
  PLAB_CUDA_CHECK(cudaGetDeviceProperties(&prop, device));
  return prop.name;
}

}  // namespace plab::cuda
