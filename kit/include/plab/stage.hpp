/// \file stage.hpp
/// \brief What every stage implements: one function that advances the state by one step.
///
/// Each stage's `step.cpp` (in `stages/NN-name/` for the student, `solutions/NN-name/` for the
/// reference) defines plab::step(). The kit's driver does everything else: reading the scene,
/// printing, timing (see plab::simulate()).
#pragma once

#include "plab/errors.hpp"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"

#ifndef PLAB_STAGE_ID
/// The two-digit number of the stage being compiled (set by CMake for each stage target).
#define PLAB_STAGE_ID "??"
#endif

/// Marks an exercise a student has not written yet: stops the run with a message naming it.
/// Replace the whole line with your code.
#define PLAB_EXERCISE(n, what) throw ::plab::NotDone(PLAB_STAGE_ID, (n), (what))

namespace plab {

/// Advances every particle by one step, as MODEL.md says. Implemented once per stage.
/// \param box the box and radius
/// \param p   the state at the start of the step; on return, the state at its end
void step(const Box& box, Particles& p);

}  // namespace plab
