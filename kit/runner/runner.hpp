/// \file runner.hpp
/// \brief The runner (`plab-run-NN-IMPL`), compiled once and linked with each stage's library:
/// its options, the modes it runs (a simulation, and the grader's two), and its report.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

#include "plab/driver.hpp"
#include "plab/scene.hpp"
#include "plab/stage.hpp"

namespace plab::runner {

/// Everything the runner's command line says (`plab-run-NN-IMPL --help`).
struct Options {
  std::string scene_path;   //!< the scene file (model.md's input format)
  std::string out_path;     //!< the output file ("": stdout)
  std::string digest_path;  //!< one state digest per step here ("": none)
  std::string events_path;  //!< `STEP INDEX wall|pair` per collision here (plab render)
  std::string report_path;  //!< the run's timing as JSON here (plab bench)
  std::string audit_path;   //!< the audit's worst values as JSON here (plab stress)
  std::string audit_log_path;  //!< with audit_path: one JSON line per state
  std::string status_path;  //!< `STEPS-DONE STEPS`, rewritten after every step (plab run)
  std::string mode;         //!< "print" or "perf" instead of the scene's own ("": the scene's)
  long long steps = -1;     //!< steps instead of the scene's S (-1: the scene's)
  std::string step_from;    //!< grading: one step from each block of this output
  std::string explain;      //!< grading: `K:i,j,...`, the events of those particles in step K
  bool json = false;        //!< with explain: the events as JSON (what the grader reads)
  std::string schedule = "dynamic,16";  //!< the OpenMP schedule of schedule(runtime) loops
  int threads = 0;          //!< threads (0: all cores)
  std::uint64_t seed = 0;   //!< seed for scenes without particle lines
  std::string speed;        //!< `MIN:MAX`, their speeds ("": model.md's default range)
  bool time_only = false;   //!< print no state: run and time the steps only
  int substeps = 1;         //!< plab accuracy: model steps per printed step
  bool quiet = false;       //!< no timing summary on stderr
  std::string device;       //!< StageOptions::device as written ("": PLAB_DEVICE, else auto)
  std::string real = "double";  //!< StageOptions::real as written
  std::string off;          //!< StageOptions::off as written (comma-separated)
  StageOptions stage;       //!< what reaches the stage (device and real filled from the above)
};

/// Declares every option on `app`, with help, writing into `o`.
void add_options(CLI::App& app, Options& o);

/// Fills o.stage (what the command line left out from the environment's documented overrides,
/// StageOptions::from_environment(), where the stage has it) and checks it against what the stage
/// declares (plab::stage_info()): a float path, its switches, its vector paths.
void finish_options(Options& o);

/// The scene the options ask for: the file, with --mode and --steps applied.
Scene load(const Options& o);

/// Runs the scene with the stage, writing the output, digests, events and audit: the loop.
/// The scene is moved in (10^9 particles are 48 GB: one copy only).
RunStats simulate_scene(const Options& o, Scene scene);

/// Grading: from each block of the output o.step_from, one step of the stage, printed.
void step_from_each(const Options& o, const Scene& scene);

/// Grading: the events of the particles o.explain names in its step, on stdout.
void explain(const Options& o, const Scene& scene);

/// The timing summary on stderr and the JSON report (--report).
void report(const Options& o, const RunStats& stats);

/// `make`, reporting every step in the status file `path` (none when `path` is empty).
MakeStepper with_status(MakeStepper make, const std::string& path, long long total);

}  // namespace plab::runner
