/// \file solutions/06-broadphase/kernels.cuh
/// \brief Stage 06's kernels (device code only): each particle hashed to a cell of a uniform grid
/// in each time slab of the step, the cell starts of the sorted keys, the neighbour search
/// filing the pairs that meet into one list, the mutual-earliest rounds over it, and apply. The
/// grid and the arrays they share (Grid, StepArrays, Flags, Pair) are in plab/cuda/slab_grid.cuh.
#pragma once

#include "plab/cuda/particles.hpp"
#include "plab/cuda/slab_grid.cuh"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

using cuda::ParticlesView;
constexpr int kSelectThreads = 1024;  //!< the one block of select_pairs

/// How far along each axis a particle of velocity (vx, vy) searches around its midpoint
/// position: two particles that meet in a slab are at most 2r + h(|v_a| + |v_b|) apart at its
/// midpoint (h = 1/(2K)), so within the faster one's 2r + 2h|v|.
__device__ inline double reach_of(double vx, double vy, const Grid& g) {
  return (g.reach + sqrt(vx * vx + vy * vy) * g.per_speed) * (1 + 1e-9);
}

/// Whether particle i files its pair with j: the faster of the two (its reach covers the other),
/// the lower index when both are as fast; so each pair is filed once.
__device__ inline bool files_pair(const ParticlesView& p, int i, int j) {
  const double vi = p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i];
  const double vj = p.vx[j] * p.vx[j] + p.vy[j] * p.vy[j];
  return vj < vi || (vj == vi && i < j);
}

/// Particle i's wall time (model.md).
__device__ inline double wall_of(const ParticlesView& p, const Box& box, int i) {
  return model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
}

/// Files the pair event (lo, hi, t); when the list is full, raises `overflow` to the pairs the
/// step needs (the host grows the list and redoes the step).
__device__ inline void file(const StepArrays& a, int lo, int hi, double t) {
  const int q = atomicAdd(&a.flags->pairs, 1);
  if (q < a.capacity)
    a.list[q] = Pair{lo, hi, t};
  else
    atomicMax(&a.flags->overflow, q + 1);
}

/// Every particle free, no earliest pair, the list empty.
__global__ void start_step(int n, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  a.partner[i] = Plan::kFree;
  a.best_t[i] = a.best_pair[i] = kNone;
  if (i == 0) a.flags->pairs = 0;
}

/// The binning (grid: particles x slabs): entry k * N + i gets particle i and its bucket in
/// slab k, the cell of its position at the slab's midpoint.
__global__ void bin(ParticlesView p, StepArrays a, Grid g) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x, k = blockIdx.y;
  if (i >= p.n) return;
  const double tm = slab_mid(k, g);
  const double mx = p.x[i] + tm * p.vx[i], my = p.y[i] + tm * p.vy[i];
  const long long e = static_cast<long long>(k) * p.n + i;
  a.key_in[e] = k * g.cells() + cell_index(my, g) * g.side + cell_index(mx, g);
  a.id_in[e] = i;
}

/// After the sort, one thread per entry: the entry starts the buckets after the previous
/// entry's up to its own (empty ones too); the last entry also ends every later bucket.
__global__ void cell_starts(StepArrays a, Grid g, int entries) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= entries) return;
  const int key = a.key_out[e];
  for (int b = (e == 0 ? 0 : a.key_out[e - 1] + 1); b <= key; ++b) a.start[b] = e;
  if (e == entries - 1)
    for (int b = key + 1; b <= g.slabs * g.cells(); ++b) a.start[b] = entries;
}

/// The neighbour search, one thread per sorted entry (particle i in slab k): the entries of
/// slab k in the cells within reach_of() of i's midpoint, one run of entries per row of cells.
/// A pair is filed when i files it (files_pair()), it meets in slab k (so once) and before both
/// walls (a later pair loses to the wall).
__global__ void find_pairs(ParticlesView p, Box box, StepArrays a, Grid g, int entries) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= entries) return;
  const int i = a.id_out[e], k = a.key_out[e] / g.cells();
  const double tm = slab_mid(k, g);
  const double mx = p.x[i] + tm * p.vx[i], my = p.y[i] + tm * p.vy[i];
  const double d = reach_of(p.vx[i], p.vy[i], g);
  const int x0 = cell_index(mx - d, g), x1 = cell_index(mx + d, g);
  for (int y = cell_index(my - d, g); y <= cell_index(my + d, g); ++y) {
    const int* row = a.start + k * g.cells() + y * g.side;
    for (int f = row[x0]; f < row[x1 + 1]; ++f) {
      const int j = a.id_out[f];
      if (j == i || !files_pair(p, i, j)) continue;
      const int lo = min(i, j), hi = max(i, j);
      const double t = model::pair_time(p.x[lo], p.y[lo], p.vx[lo], p.vy[lo], p.x[hi], p.y[hi],
                                        p.vx[hi], p.vy[hi], box.r);
      if (model::in_step(t) && slab_of(t, g) == k &&
          model::before_walls(t, wall_of(p, box, lo), wall_of(p, box, hi)))
        file(a, lo, hi, t);
    }
  }
}

/// The sparse selection in one block: rounds until no filed pair has both particles free. In a
/// round each free particle's earliest pair (by time, then (lo, hi): model.md's key) is found by
/// two atomicMin passes, and a pair that is the earliest of both its particles is accepted: the
/// greedy pass's plan. Every pair filed comes before both walls; walls come after (apply).
__global__ void __launch_bounds__(kSelectThreads) select_pairs(StepArrays a) {
  if (a.flags->overflow) return;  // the host redoes this step with a longer list
  const int m = a.flags->pairs;
  for (;;) {
    for (int phase = 0; phase < 3; ++phase) {
      for (int q = threadIdx.x; q < m; q += blockDim.x) {
        const Pair e = a.list[q];
        const auto t = static_cast<unsigned long long>(__double_as_longlong(e.t));  // t >= 0
        const unsigned long long key = static_cast<unsigned long long>(e.lo) << 32 | e.hi;
        const bool free =
            phase < 2 && a.partner[e.lo] == Plan::kFree && a.partner[e.hi] == Plan::kFree;
        if (phase == 0 && free) {  // the earliest time of each free particle
          atomicMin(&a.best_t[e.lo], t);
          atomicMin(&a.best_t[e.hi], t);
        } else if (phase == 1 && free) {  // the smallest (lo, hi) at that time
          if (a.best_t[e.lo] == t) atomicMin(&a.best_pair[e.lo], key);
          if (a.best_t[e.hi] == t) atomicMin(&a.best_pair[e.hi], key);
        } else if (phase == 2 && a.best_pair[e.lo] == key && a.best_pair[e.hi] == key) {
          a.partner[e.lo] = e.hi;  // the earliest of both: accepted
          a.partner[e.hi] = e.lo;
          a.ptime[e.lo] = a.ptime[e.hi] = e.t;
        }
      }
      __syncthreads();
    }
    int open = 0;
    for (int q = threadIdx.x; q < m; q += blockDim.x) {  // clear the bests; any pair left?
      const Pair e = a.list[q];
      a.best_t[e.lo] = a.best_t[e.hi] = a.best_pair[e.lo] = a.best_pair[e.hi] = kNone;
      open |= a.partner[e.lo] == Plan::kFree && a.partner[e.hi] == Plan::kFree;
    }
    if (!__syncthreads_or(open)) break;
  }
}

/// Applies the plan (plab::apply_one()'s code): a particle no pair took hits its wall when its
/// wall time is in the step. Nothing when the step was stopped.
__global__ void apply(ParticlesView p, Box box, StepArrays a) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= p.n || a.flags->overflow) return;
  if (i == 0) a.flags->steps_done += 1;
  if (a.partner[i] == Plan::kFree && model::in_step(wall_of(p, box, i))) a.partner[i] = Plan::kWall;
  apply_planned(p, a.partner, a.ptime, i, box.L, box.r);
}

}  // namespace plab::kernels
