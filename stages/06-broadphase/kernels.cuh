/// \file stages/06-broadphase/kernels.cuh
/// \brief Stage 06's kernels (device code only): each particle hashed to a cell of a uniform grid
/// in each time slab of the step, the cell starts of the sorted keys, the neighbour search
/// filing the pairs that meet into one list, the mutual-earliest rounds over it, and apply.
#pragma once

#include "plab/cuda/particles.hpp"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

namespace plab::kernels {

using cuda::ParticlesView;
constexpr int kSelectThreads = 1024;          //!< the one block of select_pairs
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

/// One pair event the search files: particles lo < hi meet at time t (steps).
struct Pair {
  int lo, hi;
  double t;
};

/// One step's working arrays (pointers into memory the host class owns).
struct StepArrays {
  int *key_in, *id_in;    //!< per entry k * N + i: its bucket (slab * cells + cell), particle i
  int *key_out, *id_out;  //!< the same, sorted by bucket
  int* start;             //!< slabs * cells + 1: bucket b holds entries [start[b], start[b + 1])
  Pair* list;             //!< the pairs filed this step
  int capacity;           //!< room in `list`
  int* partner;           //!< the plan: Plan::kFree, Plan::kWall, or the other particle
  double* ptime;          //!< the plan's pair time
  unsigned long long *best_t, *best_pair;  //!< a round's earliest pair of each particle: bits of
                                           //!< its time, then lo << 32 | hi
  Flags* flags;           //!< see Flags
};

/// Midpoint time of slab `k`.
__device__ inline double slab_mid(int k, const Grid& g) { return (k + 0.5) / g.slabs; }

/// The slab that holds time `t` (0 <= t < 1).
__device__ inline int slab_of(double t, const Grid& g) {
  const int k = static_cast<int>(t * g.slabs);
  return k < g.slabs ? k : g.slabs - 1;
}

/// The cell of coordinate `v` along one axis, clamped to [0, side - 1] (0 for not-a-number):
/// clamping never separates two neighbours.
__device__ inline int cell_index(double v, const Grid& g) {
  const double c = floor(v * g.inv_cell);
  if (!(c > 0)) return 0;
  return c >= g.side ? g.side - 1 : static_cast<int>(c);
}

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

// EXERCISE 4: the binning. Kernel `bin`, one thread per particle i and slab k (k = blockIdx.y):
// entry k * N + i gets id_in = i and key_in = its bucket, k * g.cells() + row * g.side + column
// of its position at the slab's midpoint (slab_mid(), cell_index()). Kernel `cell_starts`, one
// thread per entry e of the sorted keys (key_out): start[b] = e for every bucket b after the
// previous entry's key up to e's own (empty buckets included); the last entry also sets every
// later bucket, up to start[slabs * cells], to the number of entries.

// EXERCISE 5: the neighbour search. Kernel `find_pairs(p, box, a, g, entries)`, one thread per
// sorted entry e (particle i = id_out[e], slab k = key_out[e] / g.cells()): every entry of slab
// k in the cells within reach_of() of i's midpoint position, along both axes (cells of a row
// are contiguous: one run of entries a row, from start[...first cell] to start[...last + 1]).
// For each other particle j that i files (files_pair()): model::pair_time() with the lower
// index first; file() it when it is in the step, meets in slab k (slab_of(): so once) and
// comes before both walls (model::before_walls(), wall_of()).

// EXERCISE 6: the sparse selection. Kernel `select_pairs(a)` in one block of kSelectThreads
// (nothing when flags->overflow; m = flags->pairs pairs in `list`): rounds, until no pair has
// both particles free (partner == Plan::kFree). A round, barriers between its parts: (1) each
// pair with both particles free lowers best_t of both to its time's bits (atomicMin;
// __double_as_longlong, t >= 0); (2) each such pair whose time is a particle's best_t lowers
// that particle's best_pair to lo << 32 | hi; (3) a pair that is best_pair of both particles
// is accepted (partner, ptime of both); (4) every pair's particles get kNone again, and
// __syncthreads_or() tells whether a pair with both particles free is left. Walls: apply.

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
