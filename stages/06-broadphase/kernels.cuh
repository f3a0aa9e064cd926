/// \file stages/06-broadphase/kernels.cuh
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

// EXERCISE 4: the binning. Kernel `bin`, a thread per particle i and slab k = blockIdx.y: entry
// k * N + i gets id_in = i and key_in = k * g.cells() + row * g.side + column of its position
// at the slab's midpoint. Kernel `cell_starts(a, g, entries)`, a thread per sorted entry e:
// start[b] = e for the buckets b after the previous entry's key up to e's own; the last entry
// also sets the later ones, up to start[slabs * cells], to `entries`.

// EXERCISE 5: the neighbour search. Kernel `find_pairs(p, box, a, g, entries)`, a thread per
// sorted entry (particle i, slab k): the entries of slab k in the cells within your exercise 2's
// distance d of i's midpoint (a row's cells are one run of entries; `g.reach` and `g.per_speed`,
// a slab's width plus rounding, are the device grid's), each pair tested by one of its two
// particles as in exercise 2: model::pair_time(), lower index first; file() it when in the step,
// in slab k (slab_of()) and before both walls (model::before_walls(), wall_of()).

// EXERCISE 6: the sparse selection. Kernel `select_pairs(a)`, one block (nothing when
// flags->overflow): rounds over the flags->pairs pairs of `list` until none has both particles
// free (Plan::kFree). A round, with barriers: (1) each free pair lowers best_t of both particles
// to its time's bits (atomicMin); (2) each free pair at a particle's best_t lowers its best_pair
// to lo << 32 | hi; (3) a pair that is best_pair of both is accepted (partner, ptime); (4) the
// bests back to kNone, and __syncthreads_or() says whether a free pair is left.

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
