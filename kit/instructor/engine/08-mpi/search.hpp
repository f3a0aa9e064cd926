/// \file kit/instructor/engine/08-mpi/search.hpp
/// \brief What stage 08's step.cpp and its GPU path (step.cu) share: a rank's space-time grid,
/// and the candidate search and narrow phase on the device, which step.cpp calls in place of its
/// own when the run steps on the GPU (Ranks::gpu).
#pragma once

#include <vector>

#include "plab/candidates.hpp"
#include "plab/mpi/ranks.hpp"
#include "plab/sweep.hpp"

namespace plab::dist {

/// One rank's grid (step.cpp's fit_grid()): stage 06's, over coordinates shifted by its origin.
struct LocalGrid {
  sweep::Grid g;  //!< the grid, over coordinates shifted by (x0, y0)
  double x0 = 0;  //!< the least x of the paths
  double y0 = 0;  //!< the least y of the paths
};

/// The search of step.cpp's find_candidates() and its narrow phase, done elsewhere (the GPU):
/// every pair of particles of `s` (owned and ghosts, not two ghosts) that passes
/// sweep::close_in_slab() in a time slab k with first[i] <= k <= last[i] for both, found by the
/// grid `lg`, gets model.md's pair time (lower scene index first); those in the step go to
/// `found` as FoundPair{t, i, j} with local indices i < j, in increasing (i, j), each once: the
/// list step.cpp's own search gives, but for the pairs its float test passes in excess (a few, in
/// the step only after a wall, which the rounds never choose): both lists hold every pair that
/// meets in the step before both walls, so the output is the same.
using PairSearch = void (*)(const Box& box, const Ranks& r, const LocalGrid& lg, const Local& s,
                            const std::vector<int>& first, const std::vector<int>& last,
                            std::vector<FoundPair>& found);

/// One step of the distributed model on this rank (step.cpp; the kit's DistStepFn).
void step(const Box& box, const Ranks& r, Local& s);

/// The rank whose block holds (x, y) in the even cuts that the first step starts from (step.cpp;
/// the kit's OwnerFn): where the kit's scatter places each particle.
int first_owner(double x, double y, double L, int ranks);

/// The GPU's PairSearch (step.cu), set by make_gpu_stepper() when this build has a GPU path;
/// nullptr otherwise (the kit's stand-in, built without nvcc, sets nothing).
extern PairSearch gpu_search;

}  // namespace plab::dist
