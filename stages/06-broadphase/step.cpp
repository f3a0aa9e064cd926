/// \file stages/06-broadphase/step.cpp
/// \brief Stage 06, broad phase (CPU, OpenMP): a space-time grid finds every pair that can meet
/// in the step, MODEL.md's pair time is computed for those alone, and the events are chosen by a
/// greedy pass over the sparse candidates. Same bits as stages 01-05.
//
// =================================================================================================
//  GOAL   Stage 03 tests N^2/2 pairs a step; at N = 10^4 in the report's box only about 2000 can
//         meet. Find them, and few others, with plab::sweep (read sweep.hpp first):
//         1. broad phase: for each time slab k (in parallel), sort the particles into the grid's
//            cells by their positions at the slab's midpoint (a counting sort), then test each
//            particle against the same and the next cells (half of the 3 x 3 neighbourhood) with
//            sweep::close_in_slab();
//         2. narrow phase: MODEL.md's pair time for each pair that passed; wall times;
//         3. MODEL.md's greedy selection over the sparse candidates (plab::greedy_plan), then apply.
//            A pair found in two slabs is listed twice: harmless, the greedy pass takes it once.
//         Memory O(N + candidates + cells): no N x N anything.
//  READ   handouts/06-broadphase.md     TEST   ./plab test --impl student --stage 06
// =================================================================================================
#include <omp.h>

#include <cmath>
#include <vector>

#include "plab/stage.hpp"
#include "plab/sweep.hpp"

namespace plab {

/// One step in reals of type `Real`: `double` is MODEL.md's step, `float` the variant that
/// `plab accuracy` measures (the broad phase always works in double).
template <class Real>
void step_in([[maybe_unused]] const Box& box, ParticlesOf<Real>& p) {
  [[maybe_unused]] const int n = static_cast<int>(p.size());
  [[maybe_unused]] const sweep::Grid g = sweep::choose(box, p);
  [[maybe_unused]] std::vector<model::Event> events;

  // EXERCISE 1: for each slab k (an OpenMP loop over slabs: each thread keeps its own arrays and
  // its own list of events), sort the particles into buckets by the cells of their midpoint
  // positions p + slab_mid(k) v: count per bucket (sweep::bucket_of(cx, cy, g)), prefix sums,
  // scatter (copy the midpoint positions and velocities in bucket order: the next loop reads
  // them in that order). Then test every particle against the later particles of its own bucket
  // and all particles of the buckets of cells (+1, 0), (-1, +1), (0, +1), (+1, +1) with
  // sweep::close_in_slab(). Why only half of the 3 x 3 neighbourhood? (handout 06)
  // EXERCISE 2: for each pair that passed, MODEL.md's pair time (pair_candidate(box, p, i, j),
  // i < j); keep it if model::in_step(). Add every wall event of the step (wall_candidate()).
  PLAB_EXERCISE(1, "the broad phase: each slab's particles binned, neighbouring cells tested");

  // EXERCISE 3: choose the events (plab::greedy_plan(), MODEL.md's greedy rule over the sparse
  // candidates) and apply them in parallel (plab::apply_one()).
  PLAB_EXERCISE(3, "select the events and apply them");
}

void step(const Box& box, Particles& p) { step_in(box, p); }

void step_float(const Box& box, ParticlesOf<float>& p) { step_in(box, p); }

}  // namespace plab
