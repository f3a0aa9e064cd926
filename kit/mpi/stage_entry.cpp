/// \file kit/mpi/stage_entry.cpp
/// \brief The entry points (stage.hpp) of a stage on MPI, the kit's: rank 0 runs the kit's
/// driver with the stage's plab::dist::step(), every other rank serves it. A stage lists this
/// file in its stage.json's `kit_sources` and writes only its step (stage 08's step.cpp), so
/// that the driver its ranks run under, the owners' check at every gather and the report of the
/// bytes and the work its ranks measured are the kit's, not code a submission could replace.
#include "plab/mpi/ranks.hpp"
#include "plab/stage.hpp"

namespace plab {

/// Every rank's first call (stage.hpp): rank 0 goes on as the runner (-1); the others serve
/// its run, stepping with the stage's step, and return their exit status.
int stage_worker() { return dist::serve(dist::step); }

/// Rank 0's run (stage.hpp): the kit's MPI driver with the stage's step.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions&) {
  return dist::mpi_stage(box, p, dist::step);
}

}  // namespace plab
