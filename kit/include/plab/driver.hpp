/// \file driver.hpp
/// \brief The kit's driver: runs a stage's step() over a scene, printing and timing.
#pragma once

#include <cstdio>
#include <functional>
#include <memory>
#include <string>

#include "plab/audit.hpp"
#include "plab/io.hpp"
#include "plab/scene.hpp"
#include "plab/stepper.hpp"

namespace plab {

/// Starts a stage's run from a state (plab::make_stepper() of stage.hpp has this type).
using MakeStepper = std::function<std::unique_ptr<Stepper>(const Box&, Particles&)>;

/// What a run measured.
struct RunStats {
  std::size_t particles = 0;   //!< N
  long long steps = 0;         //!< steps run (printed steps: model steps over substeps)
  double step_seconds = 0;     //!< time spent in steps (not reading or printing): the driver's
                               //!< clock around step(), or the stage's own (CUDA events)
  std::string timer;           //!< how step_seconds was measured: "steady_clock" or "cuda events"
  std::string device;          //!< what the stage ran on: "cpu" or the GPU's name
  std::size_t device_bytes = 0;  //!< device memory the stage held at the end (GPU stages)
  double bandwidth = 0;        //!< Stepper::memory_bandwidth(): bytes a second, 0 when unmeasured
  double total_seconds = 0;    //!< the whole simulation, printing included
  long long pair_events = 0;   //!< pair collisions counted over the run
  long long wall_events = 0;   //!< wall collisions counted over the run
  Stepper::Traffic traffic;    //!< a stage on several processes: its messages
};

/// Options of a run.
struct RunOptions {
  std::FILE* digest = nullptr;  //!< where to write one digest line per step (optional)
  std::FILE* events = nullptr;  //!< where to write `STEP INDEX wall|pair` for each collision in
                                //!< step STEP (from the counters; optional, for plab render)
  bool progress = false;        //!< show progress on stderr
  Audit* audit = nullptr;       //!< audit every state, and every step when substeps == 1
                                //!< (plab stress, plab accuracy; optional)
  bool audit_steps = true;      //!< with `audit`: also the steps (model.md's one event per
                                //!< particle per step; off for the exact stage)
  int substeps = 1;             //!< `plab accuracy`: K model steps per printed step (velocities
                                //!< divided by K, K S steps, every K-th state printed with its
                                //!< velocities times K); a power of two keeps both scalings exact
  bool print = true;            //!< write the state blocks (false: run and time only, for scenes
                                //!< too large to print; digests and events are still written)
};

/// Runs `scene` with `step`, writing model.md's output to `out`: in print mode the blocks of steps
/// 0..S-1 then the final block (step S, with `pc wc`); in perf mode the step-0 block and the final
/// block (only the final block when S = 0); no block without `options.print`. The state is read
/// back from the stage only when it is printed or digested, and at the end (for the counters). With `options.substeps` = K > 1 each printed step is K model steps of
/// 1/K (model.md's model refined in time; not model.md's output).
RunStats simulate(Scene scene, MakeStepper make, OutputWriter& out, const RunOptions& options = {});

/// The same for a CPU stage's step function.
RunStats simulate(Scene scene, StepFn step, OutputWriter& out, const RunOptions& options = {});

/// Runs a scene and returns its whole output as text (for tests).
std::string simulate_to_string(const Scene& scene, StepFn step);

}  // namespace plab
