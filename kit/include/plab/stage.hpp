/// \file stage.hpp
/// \brief What every stage implements: one function that advances the state by one step.
///
/// Each CPU stage's `step.cpp` (in `stages/NN-name/` for the student, `solutions/NN-name/` for the
/// reference) defines plab::step(). A CUDA stage (compiled with `PLAB_GPU_STAGE` set) defines
/// plab::make_stepper() instead, keeping the state on the GPU between steps; a stage with both
/// (`PLAB_HYBRID_STAGE`) defines both and runs on the GPU when it finds one. The exact
/// event-driven stage 07 (`PLAB_EXACT_STAGE`) defines plab::make_stepper() too: it is not
/// model.md's stepped model, so it has no step(). The kit's driver does
/// everything else: reading the scene, printing, timing (see plab::simulate()).
#pragma once

#include "plab/errors.hpp"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"
#include "plab/stepper.hpp"

#ifndef PLAB_STAGE_ID
/// The two-digit number of the stage being compiled (set by CMake for each stage target).
#define PLAB_STAGE_ID "??"
#endif

/// Marks an exercise a student has not written yet: stops the run with a message naming it.
/// Replace the whole line with your code.
#define PLAB_EXERCISE(n, what) throw ::plab::NotDone(PLAB_STAGE_ID, (n), (what))

namespace plab {

#if PLAB_GPU_STAGE || PLAB_EXACT_STAGE
/// Starts a run of this CUDA stage from `p` (copied to the GPU; throws NoDevice without a GPU),
/// or of the exact event-driven stage (07), which keeps its own continuous-time state.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p);
#else
/// Advances every particle by one step, as model.md says. Implemented once per CPU stage.
/// \param box the box and radius
/// \param p   the state at the start of the step; on return, the state at its end
void step(const Box& box, Particles& p);

#if PLAB_HYBRID_STAGE
/// Starts a run of this stage on the GPU when there is one (and PLAB_DEVICE is not `cpu`),
/// otherwise of its step() on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p);
#else
/// Starts a run of this CPU stage: step() applied to `p` in place.
inline std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p) {
  return std::make_unique<HostStepper>(step, box, p);
}
#endif
#endif

#if PLAB_FLOAT_STAGE
/// The same step in `float` (a stage built with FLOAT: stage 06), for `plab accuracy` only.
void step_float(const Box& box, ParticlesOf<float>& p);
/// Starts a run of step_float() from `p` rounded to floats.
inline std::unique_ptr<Stepper> make_float_stepper(const Box& box, Particles& p) {
  return std::make_unique<RealStepper<float>>(step_float, box, p);
}
#endif

}  // namespace plab
