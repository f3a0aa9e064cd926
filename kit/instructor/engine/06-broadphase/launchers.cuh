/// \file kit/instructor/engine/06-broadphase/launchers.cuh
/// \brief Stage 06's launchers: grid size, launch on a stream, check. One per kernel (the
/// counting sort's scan is the kit's, plab::cuda::exclusive_scan()).
#pragma once


#include <cstdlib>
#include <string>

#include "kernels.cuh"
#include "plab/cuda/check.hpp"
#include "plab/cuda/scan.cuh"
#include "plab/cuda/stream.hpp"

namespace plab::launch {

constexpr int kThreads = 256;  //!< threads per block of the per-particle and per-entry kernels

static_assert(kernels::kSearchThreads == kThreads);

/// Blocks of kThreads covering `n`.
inline unsigned blocks(long long n) { return static_cast<unsigned>((n + kThreads - 1) / kThreads); }

/// A pass of fewer entries than this leaves most of the GPU idle (the report's scene has
/// 9 x 10^4 in its one pass; 10^5 particles at the report's density have 10^6).
constexpr long long kSmallPass = 1 << 18;

/// Blocks of find_fast_pairs() for a pass of at most `most` entries: a team of
/// kernels::kFastTeam threads for each fast entry expected. The grid is chosen from the first
/// state, where a tenth of the particles are fast; a gas that heats has more (the report's scene
/// after 500 steps: 21%, as a 2D Maxwell gas of its energy has, exp(-(v_cut / v_rms)^2)), and a
/// team then takes two or three entries in turn. A small pass leaves most of the GPU idle: teams
/// for a fifth of its entries (the report's scene: 0.088 to 0.083 ms a step on an H200). A large
/// pass fills the GPU either way: a tenth (a fifth was 0.7% slower at N = 10^6).
inline unsigned fast_blocks(long long most) {
  return blocks((most / (most < kSmallPass ? 5 : 10) + 1) * kernels::kFastTeam);
}

/// `buckets` > 0: also clears the one pass's bucket counts and fast counter (see the kernel).
inline void start_step(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                       const kernels::DeviceGrid& d, int buckets, cudaStream_t s) {
  const int threads = p.n * kernels::start_step_groups(a);
  kernels::start_step<<<blocks(threads), kThreads, 0, s>>>(p, box, a, d, buckets);
  PLAB_CUDA_CHECK_LAUNCH("start_step");
}

inline void bin_count(const cuda::ParticlesView& p, const kernels::StepArrays& a,
                      const kernels::DeviceGrid& d, cudaStream_t s) {
  kernels::bin_count<<<dim3(blocks(p.n), d.slabs), kThreads, 0, s>>>(p, a, d);
  PLAB_CUDA_CHECK_LAUNCH("bin_count");
}

inline void bin_scatter(const cuda::ParticlesView& p, const kernels::StepArrays& a,
                        const kernels::DeviceGrid& d, cudaStream_t s) {
  kernels::bin_scatter<<<dim3(blocks(p.n), d.slabs), kThreads, 0, s>>>(p, a, d);
  PLAB_CUDA_CHECK_LAUNCH("bin_scatter");
}

/// The pair search of a pass: find_pairs over every entry (the slow ones), then find_fast_pairs
/// over the fast ones it listed (a team of kernels::kFastTeam threads each, on fast_blocks()'s
/// grid), in search shape `S` (kernels::Search).
/// `cleared`: start_step() cleared the fast entries' counter already (a step of one pass).
template <kernels::Search S>
inline void find_pairs_as(const cuda::ParticlesView& p, const Box& box,
                          const kernels::StepArrays& a, const kernels::DeviceGrid& d, bool cleared,
                          cudaStream_t s) {
  const long long most = static_cast<long long>(p.n) * d.slabs;  // entries this pass, at most
  if (!cleared) PLAB_CUDA_CHECK(cudaMemsetAsync(&a.flags->fast, 0, sizeof(int), s));
  kernels::find_pairs<S><<<blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d, true);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs");
  kernels::find_fast_pairs<S><<<fast_blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d,
                                                                                    true);
  PLAB_CUDA_CHECK_LAUNCH("find_fast_pairs");
}

/// The pair search of a pass with the slow entries' tests shared evenly by a warp's lanes
/// (kernels::find_pairs_balanced()), then the fast entries it listed as find_pairs_as() searches
/// them (lean).
inline void find_pairs_balanced(const cuda::ParticlesView& p, const Box& box,
                                const kernels::StepArrays& a, const kernels::DeviceGrid& d,
                                bool cleared, cudaStream_t s) {
  const long long most = static_cast<long long>(p.n) * d.slabs;  // entries this pass, at most
  if (!cleared) PLAB_CUDA_CHECK(cudaMemsetAsync(&a.flags->fast, 0, sizeof(int), s));
  kernels::find_pairs_balanced<<<blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d,
                                                                               true);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs_balanced");
  kernels::find_fast_pairs<kernels::Search::kLean>
      <<<fast_blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d, true);
  PLAB_CUDA_CHECK_LAUNCH("find_fast_pairs");
}

/// The pair search of a pass in the shape `shape` names.
inline void find_pairs(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                       const kernels::DeviceGrid& d, bool cleared, kernels::Search shape,
                       cudaStream_t s) {
  if (shape == kernels::Search::kBatched)
    find_pairs_as<kernels::Search::kBatched>(p, box, a, d, cleared, s);
  else if (shape == kernels::Search::kLean)
    find_pairs_as<kernels::Search::kLean>(p, box, a, d, cleared, s);
  else
    find_pairs_balanced(p, box, a, d, cleared, s);
}

/// The pair search of a pass in two streams at once: the slow entries on `s` in the shape `shape`
/// names, and the fast ones on `side` (a team for every entry of the pass, each keeping its entry
/// only if it is fast: nothing to wait for). The caller orders `side` after the pass's sort and
/// before what reads the pairs.
inline void find_pairs_beside(const cuda::ParticlesView& p, const Box& box,
                              const kernels::StepArrays& a, const kernels::DeviceGrid& d,
                              kernels::Search shape, cudaStream_t s, cudaStream_t side) {
  const long long most = static_cast<long long>(p.n) * d.slabs;  // entries this pass, at most
  if (shape == kernels::Search::kBatched)
    kernels::find_pairs<kernels::Search::kBatched>
        <<<blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d, false);
  else if (shape == kernels::Search::kLean)
    kernels::find_pairs<kernels::Search::kLean>
        <<<blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d, false);
  else
    kernels::find_pairs_balanced<<<blocks(most), kernels::kSearchThreads, 0, s>>>(p, box, a, d,
                                                                                 false);
  PLAB_CUDA_CHECK_LAUNCH("find_pairs");
  kernels::find_fast_pairs<kernels::Search::kLean>
      <<<blocks(most * kernels::kFastTeam), kernels::kSearchThreads, 0, side>>>(p, box, a, d,
                                                                                false);
  PLAB_CUDA_CHECK_LAUNCH("find_fast_pairs");
}

/// Bytes of dynamic shared memory `kernel` (find_pairs_banded(), finish_block()) takes on this
/// GPU: all a block may have (the opt-in limit) less its static shared memory; the kernel is
/// allowed that much.
template <class Kernel>
inline int all_shared_bytes(Kernel* kernel) {
  int device = 0, optin = 0;
  PLAB_CUDA_CHECK(cudaGetDevice(&device));
  PLAB_CUDA_CHECK(
      cudaDeviceGetAttribute(&optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, device));
  cudaFuncAttributes attributes{};
  PLAB_CUDA_CHECK(cudaFuncGetAttributes(&attributes, kernel));
  const int bytes = optin - static_cast<int>(attributes.sharedSizeBytes);
  PLAB_CUDA_CHECK(
      cudaFuncSetAttribute(kernel, cudaFuncAttributeMaxDynamicSharedMemorySize, bytes));
  return bytes;
}

/// Whether find_pairs_banded() is launched programmatically dependent on start_step() (its
/// blocks start while start_step() ends, and wait for it: kernels::wait_for_kernel_before()):
/// on GPUs of compute capability 9 and later, unless PLAB_ENGINE_PDL=off (to measure the
/// difference).
inline bool dependent_launch() {
  static const bool on = [] {
    const char* v = std::getenv("PLAB_ENGINE_PDL");
    if (v && std::string(v) == "off") return false;
    int device = 0, major = 0;
    PLAB_CUDA_CHECK(cudaGetDevice(&device));
    PLAB_CUDA_CHECK(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device));
    return major >= 9;
  }();
  return on;
}

/// The pair search of every slab without the counting sort: `bands` blocks of `band` rows a slab
/// (kernels::find_pairs_banded()), `shared_bytes` of shared memory each, a halo of at most
/// `halo_most` rows.
inline void find_pairs_banded(const cuda::ParticlesView& p, const Box& box,
                              const kernels::StepArrays& a, const kernels::DeviceGrid& d, int band,
                              int bands, int shared_bytes, int halo_most, cudaStream_t s) {
  cudaLaunchConfig_t config{};
  config.gridDim = dim3(bands, d.g.slabs);
  config.blockDim = dim3(kernels::kBandThreads);
  config.dynamicSmemBytes = shared_bytes;
  config.stream = s;
  cudaLaunchAttribute dependent{};
  dependent.id = cudaLaunchAttributeProgrammaticStreamSerialization;
  dependent.val.programmaticStreamSerializationAllowed = 1;
  config.attrs = &dependent;
  config.numAttrs = dependent_launch() ? 1 : 0;
  PLAB_CUDA_CHECK(cudaLaunchKernelEx(&config, kernels::find_pairs_banded, p, box, a, d, band,
                                     shared_bytes, halo_most));
}

/// The rows, start_rounds() and the rounds of a small scene in one block with `shared_bytes` of
/// shared memory (kernels::finish_block()); apply() follows.
inline void finish_block(int n, const kernels::StepArrays& a, int shared_bytes, cudaStream_t s) {
  kernels::finish_block<<<1, kernels::kBlockFinishThreads, shared_bytes, s>>>(n, a, shared_bytes);
  PLAB_CUDA_CHECK_LAUNCH("finish_block");
}

/// One thread per pair the list can hold.
inline void place_pairs(const kernels::StepArrays& a, cudaStream_t s) {
  kernels::place_pairs<<<blocks(a.slots.capacity), kThreads, 0, s>>>(a);
  PLAB_CUDA_CHECK_LAUNCH("place_pairs");
}

inline void start_rounds(int n, const kernels::StepArrays& a, cudaStream_t s) {
  kernels::start_rounds<<<blocks(n), kThreads, 0, s>>>(n, a);
  PLAB_CUDA_CHECK_LAUNCH("start_rounds");
}

inline void resolve(int n, const kernels::StepArrays& a, cudaStream_t s) {
  kernels::resolve<<<1, kernels::kResolveThreads, 0, s>>>(n, a);
  PLAB_CUDA_CHECK_LAUNCH("resolve");
}

/// Blocks of finish_small() for `n` particles: one thread a particle.
inline int finish_small_blocks(int n) {
  return (n + kernels::kFinishThreads - 1) / kernels::kFinishThreads;
}

/// Whether finish_small() can take `n` particles on this GPU: its blocks all resident at once (a
/// cooperative launch).
inline bool finish_small_fits(int n) {
  int device = 0, sms = 0, per_sm = 0;
  PLAB_CUDA_CHECK(cudaGetDevice(&device));
  PLAB_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  PLAB_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernels::finish_small,
                                                                kernels::kFinishThreads, 0));
  const int blocks = finish_small_blocks(n);
  return n > 0 && blocks <= sms * per_sm;
}

/// A cooperative launch (grid barriers), not programmatically dependent on the search before
/// it: so launched, the report's scene was 1.5% slower, and no slower with its blocks forced
/// one to a multiprocessor; likely its early blocks crowd onto the multiprocessors the search
/// leaves free (handouts/engine-gpu.md).
inline void finish_small(const cuda::ParticlesView& p, const Box& box,
                         const kernels::StepArrays& a, cudaStream_t s) {
  cuda::ParticlesView pv = p;
  Box b = box;
  kernels::StepArrays av = a;
  void* args[] = {&pv, &b, &av};
  PLAB_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<void*>(kernels::finish_small),
                                              finish_small_blocks(p.n), kernels::kFinishThreads,
                                              args, 0, s));
}

/// Blocks of resolve_grid that can all be resident at once (a cooperative launch needs that).
inline int resolve_grid_blocks() {
  int device = 0, sms = 0, per_sm = 0;
  PLAB_CUDA_CHECK(cudaGetDevice(&device));
  PLAB_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  PLAB_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernels::resolve_grid,
                                                                kThreads, 0));
  return sms * per_sm;
}

inline void resolve_grid(int n, const kernels::StepArrays& a, int grid_blocks, cudaStream_t s) {
  void* args[] = {&n, const_cast<kernels::StepArrays*>(&a)};
  PLAB_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<void*>(kernels::resolve_grid),
                                              grid_blocks, kThreads, args, 0, s));
}

inline void apply(const cuda::ParticlesView& p, const Box& box, const kernels::StepArrays& a,
                  cudaStream_t s) {
  kernels::apply<<<blocks(p.n), kThreads, 0, s>>>(p, box, a);
  PLAB_CUDA_CHECK_LAUNCH("apply");
}

}  // namespace plab::launch
