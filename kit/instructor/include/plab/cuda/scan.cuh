/// \file cuda/scan.cuh
/// \brief The exclusive prefix sum the GPU counting sorts share (stages 06 and 08: counts per
/// cell into where each cell starts, counts per particle into where its candidates start), with
/// CUB's DeviceScan.
#pragma once

#include <cub/device/device_scan.cuh>

#include <cstddef>

#include "plab/cuda/check.hpp"

namespace plab::cuda {

/// out[i] becomes in[0] + ... + in[i - 1] for i < `size` (out[0] = 0), on stream `s`; `temp` of
/// `temp_bytes` bytes, at least exclusive_scan_bytes(size). `in` and `out` may be the same array
/// (a scan in place: CUB guarantees it from CUB 2.0, CUDA 12; the kit needs CUDA 13).
inline void exclusive_scan(const int* in, int* out, int size, void* temp, std::size_t temp_bytes,
                           cudaStream_t s) {
  PLAB_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(temp, temp_bytes, in, out, size, s));
}

/// Bytes of temporary storage exclusive_scan() needs for `size` counters.
inline std::size_t exclusive_scan_bytes(int size) {
  std::size_t bytes = 0;
  PLAB_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, bytes, static_cast<const int*>(nullptr),
                                                static_cast<int*>(nullptr), size));
  return bytes;
}

}  // namespace plab::cuda
