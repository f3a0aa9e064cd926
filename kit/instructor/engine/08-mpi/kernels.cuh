/// \file kit/instructor/engine/08-mpi/kernels.cuh
/// \brief Stage 08's kernels (device code only): one rank's candidate search on its GPU. Per time
/// slab, a counting sort of the particles that take part (owned and ghosts) into the cells of
/// the rank's grid (atomics, then a CUB scan), and a search of each entry's neighbouring cells
/// with the narrow phase at once: the pairs in the step go to one list as (key, time), which a
/// radix sort and a unique-by-key (launchers.cuh) turn into step.cpp's sorted list.
#pragma once

#include <cstdint>

#include "plab/model.hpp"
#include "plab/sweep.hpp"

namespace plab::dist::kernels {

/// What the pair search reads of an entry, in one 32-byte sector.
struct alignas(32) Entry {
  double x, y;    //!< midpoint position in the slab, shifted by the grid's origin
  double vx, vy;  //!< velocity
};

/// The rank's grid as the kernels see it, for one time slab.
struct SlabGrid {
  sweep::Grid g;  //!< slabs, cells, reach (step.cpp's fit_grid())
  double x0;      //!< the grid's origin: positions are shifted by (x0, y0) before binning
  double y0;      //!< ...
  int k;          //!< the slab
  int cells;      //!< g.cells()
};

/// The rank's particles and one slab's working arrays (device pointers the host class owns).
struct Arrays {
  int n;                 //!< particles here, owned and ghosts
  int owned;             //!< particles [0, owned) are owned; the others are ghosts
  const double* x;       //!< state at the start of the step
  const double* y;       //!< ...
  const double* vx;      //!< ...
  const double* vy;      //!< ...
  const int* id;         //!< each particle's index in the scene (the pair time's order)
  const int* first;      //!< the first slab each particle takes part in
  const int* last;       //!< the last one
  int* filled;           //!< cells + 1: entries counted into each cell of the slab
  int* start;            //!< the exclusive scan of `filled`: cell c holds [start[c], start[c + 1])
  int* place;            //!< per particle: its place in its cell (bin_count())
  int* entry_id;         //!< per entry: the particle
  Entry* entry;          //!< per entry: what the search reads
  std::uint64_t* key;    //!< per pair found: (lower local index << 32) | higher
  double* time;          //!< per pair found: its time
  int capacity;          //!< room in `key` and `time`
  int* length;           //!< pairs found this step (may exceed `capacity`: the host then grows)
};

/// Whether particle i takes part in slab k.
__device__ inline bool in_slab(const Arrays& a, int i, int k) {
  return a.first[i] <= k && k <= a.last[i];
}

/// Particle i's cell in slab d.k, and its shifted midpoint position (the same arithmetic as
/// step.cpp's bin()).
__device__ inline int cell_at(const Arrays& a, int i, const SlabGrid& d, double& mx, double& my) {
  const double tm = sweep::slab_mid(d.k, d.g);
  mx = (a.x[i] + tm * a.vx[i]) - d.x0;
  my = (a.y[i] + tm * a.vy[i]) - d.y0;
  return sweep::cell_of(mx, my, d.g);
}

/// Counting sort, pass 1: each particle in slab d.k counts itself into its cell and keeps its
/// place there.
__global__ void bin_count(Arrays a, SlabGrid d) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= a.n || !in_slab(a, i, d.k)) return;
  double mx, my;
  a.place[i] = atomicAdd(&a.filled[cell_at(a, i, d, mx, my)], 1);
}

/// Counting sort, pass 2 (after the scan of `filled` into `start`): each entry to its place.
__global__ void bin_scatter(Arrays a, SlabGrid d) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= a.n || !in_slab(a, i, d.k)) return;
  double mx, my;
  const int e = a.start[cell_at(a, i, d, mx, my)] + a.place[i];
  a.entry_id[e] = i;
  a.entry[e] = Entry{mx, my, a.vx[i], a.vy[i]};
}

/// Entry e against entries [from, to) of the slab: each pair that passes sweep::close_in_slab()
/// (not e itself, not two ghosts) gets model.md's pair time, lower scene index first (the
/// narrow phase of step.cpp), and is filed when it is in the step.
__device__ inline void test_entries(const Arrays& a, const SlabGrid& d, double r, int e, int from,
                                    int to) {
  const int i = a.entry_id[e];
  const bool ghost = i >= a.owned;
  const Entry me = a.entry[e];
  for (int f = from; f < to; ++f) {
    const int j = a.entry_id[f];
    if (f == e || (ghost && j >= a.owned)) continue;
    const Entry o = a.entry[f];
    if (!sweep::close_in_slab(me.x - o.x, me.y - o.y, me.vx - o.vx, me.vy - o.vy, d.g)) continue;
    const int p = a.id[i] < a.id[j] ? i : j, q = p == i ? j : i;
    const double t = model::pair_time(a.x[p], a.y[p], a.vx[p], a.vy[p], a.x[q], a.y[q], a.vx[q],
                                      a.vy[q], r);
    if (!model::in_step(t)) continue;
    const int at = atomicAdd(a.length, 1);
    if (at >= a.capacity) continue;  // counted: the host grows the list and searches again
    const int lo = i < j ? i : j, hi = i < j ? j : i;
    a.key[at] = (static_cast<std::uint64_t>(lo) << 32) | static_cast<std::uint32_t>(hi);
    a.time[at] = t;
  }
}

/// The search of slab d.k, one thread per entry (step.cpp's search(), stage 06's neighbourhood):
/// a slow entry against the later entries of its row up to the last column within its reach,
/// then the columns within reach of the next row; a fast entry against every entry within its
/// reach (sweep::search_of()), one run per row. An owned entry tests every entry there, a ghost
/// only the owned ones: the pairs are step.cpp's (which orders each cell's owned entries first;
/// the pairs a slow search finds do not depend on the order inside a cell).
__global__ void find_pairs(Arrays a, SlabGrid d, double r) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= a.start[d.cells]) return;
  const int columns = d.g.columns;
  const Entry me = a.entry[e];
  const sweep::Search q = sweep::search_of(me.vx, me.vy, d.g);
  int x0, x1;
  sweep::columns_within(me.x, q.d, d.g, x0, x1);
  if (!q.fast) {
    const int y = sweep::row_of(me.y, d.g);
    test_entries(a, d, r, e, e + 1, a.start[y * columns + x1 + 1]);
    if (y + 1 < d.g.rows)
      test_entries(a, d, r, e, a.start[(y + 1) * columns + x0],
                   a.start[(y + 1) * columns + x1 + 1]);
  } else {  // a pair found twice is harmless: the unique-by-key keeps one
    int y0, y1;
    sweep::rows_within(me.y, q.d, d.g, y0, y1);
    for (int y = y0; y <= y1; ++y)
      test_entries(a, d, r, e, a.start[y * columns + x0], a.start[y * columns + x1 + 1]);
  }
}

}  // namespace plab::dist::kernels
