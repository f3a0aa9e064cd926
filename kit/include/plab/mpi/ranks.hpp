/// \file mpi/ranks.hpp
/// \brief The kit's MPI plumbing (library plab::mpi, what stage 08 links): the decomposition of
/// the box into slabs, this rank's particles (owned, then ghosts), and the driver on rank 0 that
/// the other ranks serve (MPI's start and end, the scatter of the scene, the gather of the
/// output). The stage's idea, every MPI call of a step (the halo, the rounds across ranks,
/// migration), is its step, in its own step.cpp, which it hands to mpi_stage() and serve() as a
/// CPU stage hands its step to plab::cpu_stage().
///
/// The kit counts a step's messages without the stage's help, through MPI's profiling interface:
/// ranks.cpp defines the sends in every mode (blocking or not), MPI_Sendrecv and
/// MPI_Sendrecv_replace, the collectives, rooted or not, blocking or not (MPI_Alltoall,
/// MPI_Alltoallv, MPI_Alltoallw, MPI_Allreduce, MPI_Allgather, MPI_Allgatherv, MPI_Bcast,
/// MPI_Gather, MPI_Gatherv, MPI_Scatter, MPI_Scatterv, MPI_Reduce, MPI_Reduce_scatter,
/// MPI_Reduce_scatter_block, MPI_Scan, MPI_Exscan: the bytes this rank sends to other ranks, 16
/// more a message for its envelope; an all-reduce counts its buffer once) and the calls that wait
/// or poll (receives, probes, waits, tests, barriers: time), each calling the library's PMPI_
/// version; what could move data past
/// the count (one-sided windows, persistent requests, neighbourhood collectives, MPI I/O) ends the
/// run with a message. The runner's summary (mpirun -np N build/bin/plab-run-08-IMPL SCENE), its
/// `--report` JSON and `plab bench --stage 08 --ranks ...` give the sum of the bytes, the same
/// split by the MPI function that sent them, and the most seconds any rank spent in them.
#pragma once

#include <mpi.h>

#include <memory>
#include <string>
#include <vector>

#include "plab/stage.hpp"

namespace plab::dist {

/// The rank's view of the run: who it is and how the box is cut.
struct Ranks {
  MPI_Comm comm = MPI_COMM_WORLD;  //!< every rank of the run
  int rank = 0;                    //!< this rank (0 reads, prints and drives)
  int ranks = 1;                   //!< how many
  double L = 0;                    //!< the box side: rank k owns the slab x in [k L/R, (k+1) L/R)
  bool gpu = false;                //!< this run steps on the GPU (rank 0's `--device gpu`, sent
                                   //!< to every rank with the start): each rank binds one
                                   //!< GPU, rank % the GPUs its machine has

  /// The rank that owns a particle whose centre is at `x` (centres outside the box, which
  /// overlaps can make, go to the first or last slab; a not-a-number to the first).
  [[nodiscard]] int owner_of(double x) const {
    const double k = x / (L / ranks);
    return k >= ranks ? ranks - 1 : (k >= 1 ? static_cast<int>(k) : 0);
  }
  /// The lower x of rank k's slab.
  [[nodiscard]] double slab_lo(int k) const { return k * (L / ranks); }
  /// The upper x of rank k's slab.
  [[nodiscard]] double slab_hi(int k) const { return (k + 1) * (L / ranks); }
};

/// One particle as it travels between ranks: its global index and its state.
struct Record {
  double x;     //!< centre x
  double y;     //!< centre y
  double vx;    //!< velocity x
  double vy;    //!< velocity y
  long long pc; //!< collisions with other particles so far
  long long wc; //!< collisions with walls so far
  int id;               //!< its index in the scene (the event keys and the output use it)
  int pad = 0;          //!< (keeps the struct a multiple of 8 bytes)
};

/// This rank's particles: `owned` ones first (whose centre lies in its slab), then the ghosts,
/// copies of other ranks' particles near its slab, received from `ghosts_from[q]` ..
/// `ghosts_from[q + 1]` of rank q, in the order rank q listed them in `sent_to[q]`.
struct Local {
  Particles p;                            //!< state, per field
  std::vector<int> id;                    //!< each particle's index in the scene
  int owned = 0;                          //!< particles [0, owned) are this rank's
  std::vector<std::vector<int>> sent_to;  //!< per rank: the owned particles it has as ghosts
  std::vector<int> ghosts_from;           //!< per rank: where its ghosts start (R + 1 entries)

  /// Particles here, owned and ghosts.
  [[nodiscard]] int size() const { return static_cast<int>(id.size()); }
  /// Particle k as a Record.
  [[nodiscard]] Record record(int k) const {
    return {p.x[k], p.y[k], p.vx[k], p.vy[k], p.pc[k], p.wc[k], id[k]};
  }
  /// Appends a Record.
  void push(const Record& r);
  /// Keeps the owned particles only (drops every ghost).
  void drop_ghosts();
};

/// One step of the distributed model on this rank (a stage's step.cpp: its exercises): from the
/// owned particles of `s` at the start of the step to those it owns at its end (ghosts dropped).
using DistStepFn = void (*)(const Box& box, const Ranks& r, Local& s);

/// Stage 08's plab::make_stepper(), on rank 0: a run whose every call (start, step, read,
/// traffic, end) the other ranks follow, every rank stepping with `step`.
/// \param box  the box and radius
/// \param p    the initial state, which rank 0 scatters to the owners
/// \param step the stage's step
/// \param gpu  the GPU's name when the run steps on one GPU per rank (Ranks::gpu on every rank:
///             `step` reads it), "" on the CPU
std::unique_ptr<Stepper> mpi_stage(const Box& box, Particles& p, DistStepFn step,
                                   const std::string& gpu = "");

/// The rank that owns a particle at (x, y) before the first step, for `ranks` ranks in a box of
/// side `L` (mpi_stage_any_cut()).
using OwnerFn = int (*)(double x, double y, double L, int ranks);

/// mpi_stage() for the instructor's engine (kit/instructor/engine/08-mpi), whose ranks own the
/// particles of blocks of the box, not the kit's slabs: rank 0 scatters the particles by
/// `owner` (the kit's slabs when it is nullptr), and the gather of the output takes each rank's
/// particles wherever they are. mpi_stage() instead checks, at every gather, that each rank owns
/// exactly the particles whose centres lie in its slab (Ranks::owner_of()): a stage whose rank 0
/// took every particle over would otherwise step them all alone with no message a step. plab
/// grade refuses a stage's code that calls this one.
std::unique_ptr<Stepper> mpi_stage_any_cut(const Box& box, Particles& p, DistStepFn step,
                                           const std::string& gpu = "", OwnerFn owner = nullptr);

/// The stage's step on this rank, which its step.cpp defines: the kit's entry points
/// (kit/mpi/stage_entry.cpp, a stage's `kit_sources`) hand it to mpi_stage() and serve(), so
/// that the driver a stage runs under, and what it reports of the ranks' bytes and work, is the
/// kit's.
void step(const Box& box, const Ranks& r, Local& s);

/// Stage 08's plab::stage_worker(): starts MPI; returns -1 on rank 0 (which goes on as the
/// runner), and on every other rank serves rank 0's runs, stepping with `step`, until rank 0
/// ends, then returns its exit status (0).
int serve(DistStepFn step);

}  // namespace plab::dist
