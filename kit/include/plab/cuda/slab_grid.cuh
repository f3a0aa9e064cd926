/// \file cuda/slab_grid.cuh
/// \brief Stage 06 on the GPU, what the lab does not write (given): the space-time grid of the
/// step and its cell of a point, the arrays the kernels share, and the host side of a run
/// (cuda::SlabGridStepper: the grid's choice, the arrays' memory, the steps recorded once as a
/// CUDA graph, the redo of a step whose pairs overflowed the list). The binning, the neighbour
/// search and the sparse selection are stage 06's exercises (handout 06), in the stage's files.
#pragma once

#include <cub/device/device_radix_sort.cuh>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>

#include "plab/cuda/check.hpp"
#include "plab/cuda/particles.hpp"
#include "plab/cuda/stepper.hpp"
#include "plab/cuda/stream.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

constexpr unsigned long long kNone = ~0ull;  //!< "no pair yet" in best_t and best_pair

/// What the host reads after a batch of steps.
struct Flags {
  int pairs;             //!< pairs filed this step
  int overflow;          //!< pairs a step needed when the list had no room for them (else 0)
  long long steps_done;  //!< steps applied so far
};

/// The step split into `slabs` time slabs; in each, a particle is binned by its position at the
/// slab's midpoint into side x side square cells covering the box (an entry: slab, particle).
struct Grid {
  int slabs;         //!< time slabs K of the step
  int side;          //!< cells along each axis
  double inv_cell;   //!< 1 / cell width
  double reach;      //!< 2r + a rounding margin (length units)
  double per_speed;  //!< a slab's width 1/K, plus a millionth for rounding
  [[nodiscard]] __host__ __device__ int cells() const { return side * side; }  //!< of a slab
};

/// One pair event the search files.
struct Pair {
  int lo;    //!< the lower particle index
  int hi;    //!< the higher
  double t;  //!< the pair time (steps)
};

/// One step's working arrays (pointers into memory the host class owns).
struct StepArrays {
  int* key_in;   //!< per entry k * N + i: its bucket, slab * cells + cell
  int* id_in;    //!< ... its particle i
  int* key_out;  //!< the keys, sorted
  int* id_out;   //!< the particles, in the sorted keys' order
  int* start;             //!< slabs * cells + 1: bucket b holds entries [start[b], start[b + 1])
  Pair* list;             //!< the pairs filed this step
  int capacity;           //!< room in `list`
  int* partner;           //!< the plan: Plan::kFree, Plan::kWall, or the other particle
  double* ptime;          //!< the plan's pair time
  unsigned long long* best_t;     //!< in a round: each particle's earliest pair time (bits)
  unsigned long long* best_pair;  //!< ... the smallest lo << 32 | hi at that time
  Flags* flags;           //!< see Flags
};

/// Midpoint time of slab `k`.
__device__ inline double slab_mid(int k, const Grid& g) { return (k + 0.5) / g.slabs; }

/// The slab that holds time `t` (0 <= t < 1).
__device__ inline int slab_of(double t, const Grid& g) {
  return min(static_cast<int>(t * g.slabs), g.slabs - 1);
}

/// The cell of coordinate `v` along one axis, clamped to [0, side - 1] (0 for not-a-number):
/// clamping never separates two neighbours.
__device__ inline int cell_index(double v, const Grid& g) {
  const double c = floor(v * g.inv_cell);
  if (!(c > 0)) return 0;
  return c >= g.side ? g.side - 1 : static_cast<int>(c);
}

}  // namespace plab::kernels

namespace plab::cuda {

/// The bits of a bucket key of grid `g` (the sort looks at no others).
inline int key_bits(const kernels::Grid& g) {
  int bits = 1;
  while (bits < 31 && (1 << bits) < g.slabs * g.cells()) ++bits;
  return bits;
}

/// Bytes of temporary storage CUB's sort of `entries` (key, particle) entries of grid `g` needs.
inline std::size_t sort_bytes(const kernels::Grid& g, int entries) {
  std::size_t bytes = 0;
  int* none = nullptr;
  PLAB_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, bytes, none, none, none, none, entries,
                                                  0, key_bits(g)));
  return bytes;
}

/// The host side of stage 06 on the GPU: the grid (`grid_`, `entries_` = slabs x N), the arrays
/// of StepArrays and the sort's `temp_` on the device, the step's kernels recorded once as a
/// CUDA graph and replayed, and the flags read after the first step and then every kCheckEvery:
/// a step whose pairs overflowed the list stopped the batch (its kernels skip their work), and
/// the host redoes it and the later ones with a list twice the pairs it needed. A stage writes
/// queue_kernels() alone.
class SlabGridStepper : public DeviceStepper<kernels::Flags> {
 public:
  static constexpr long long kMostEntries = 1 << 27;  //!< (slab, particle) entries at most
  static constexpr long long kCheckEvery = 32;        //!< steps between two looks at the flags

  void step() override {
    DeviceStepper::step();  // look at the flags after the first step, then every kCheckEvery
    if (n_ > 0 && (asked_ == 1 || asked_ % kCheckEvery == 0)) catch_up();
  }

  /// Copies `p` to the device for a run on the GPU named `device`, with alpha sqrt(N) v / L
  /// time slabs for the particles' mean speed v.
  SlabGridStepper(std::string device, const Box& box, const Particles& p, double alpha)
      : DeviceStepper(std::move(device), box, p, Queue::kOwnStream), list_(n_ + 1024),
        partner_(n_), ptime_(n_), best_t_(n_), best_pair_(n_) {
    choose_grid(p, alpha);
    entries_ = static_cast<int>(static_cast<long long>(n_) * grid_.slabs);
    for (auto* v : {&key_in_, &id_in_, &key_out_, &id_out_}) v->resize(entries_);
    start_.resize(static_cast<std::size_t>(grid_.slabs) * grid_.cells() + 1);
    temp_.resize(sort_bytes(grid_, entries_));
    sync();
  }

 protected:
  /// Queues the kernels of one step on `main_`, over the arrays `a` (recorded, not run: the
  /// graph replays them each step).
  virtual void queue_kernels(const kernels::StepArrays& a) = 0;

  kernels::Grid grid_{};                //!< the step's grid
  int entries_ = 0;                     //!< slabs x N
  DeviceArray<unsigned char> temp_;     //!< the sort's temporary storage (sort_bytes())

 private:
  void queue_step() override {
    if (stale_) graph_.record(main_, [this] { queue_kernels(arrays()); });
    stale_ = false;
    graph_.launch(main_);
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

  /// The device arrays of one step.
  [[nodiscard]] kernels::StepArrays arrays() const {
    return {key_in_.get(),  id_in_.get(),  key_out_.get(), id_out_.get(),
            start_.get(),   list_.get(),   static_cast<int>(list_.size()),
            partner_.get(), ptime_.get(),  best_t_.get(),  best_pair_.get(),
            flags_.get()};
  }

  /// alpha sqrt(N) v / L slabs for the mean speed v, and cells as wide as the reach of a
  /// particle of that speed, at most about 4N a slab. Without a finite mean speed, one slab and
  /// one cell (every pair is tested).
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
    return bytes_of(key_in_, id_in_, key_out_, id_out_, start_, list_, partner_, ptime_, best_t_,
                    best_pair_, temp_);
  }

  DeviceArray<int> key_in_, id_in_, key_out_, id_out_, start_;
  DeviceArray<kernels::Pair> list_;
  DeviceArray<int> partner_;
  DeviceArray<double> ptime_;
  DeviceArray<unsigned long long> best_t_, best_pair_;
  Graph graph_;
  bool stale_ = true;  //!< the graph must be recorded (again)
};

}  // namespace plab::cuda
