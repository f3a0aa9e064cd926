/// \file stage.hpp
/// \brief The one shape of every stage: what it is (plab::StageInfo, declared in its folder's
/// `stage.json`), the options it takes (plab::StageOptions) and its one entry point,
/// plab::make_stepper().
///
/// Every stage's library defines plab::make_stepper(). A CPU stage writes plab::step() (its
/// exercise) and hands it to the kit in one line, plab::cpu_stage():
///
///     std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& o) {
///       return cpu_stage(box, p, o, {step});
///     }
///
/// A CPU stage that keeps working memory between steps (buffers sized once, an order kept from
/// the last step) holds it in an object of its own, a plab::CpuStep, rather than in function
/// statics or globals, and hands the kit a new one (stage 06):
///
///     std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& o) {
///       return cpu_stage(box, p, o, std::make_unique<BroadPhase>());
///     }
///
/// A CUDA stage returns its own Stepper, which keeps the state on the GPU between steps; the exact
/// event-driven stage 07 returns one that keeps its continuous-time state. Stage 08 writes only
/// plab::dist::step(): the kit's kit/mpi/stage_entry.cpp (its `kit_sources`) defines its
/// make_stepper() and stage_worker(). The runner
/// (`plab-run-NN-IMPL`) and the stage tests are compiled once and linked with each stage's
/// library; they read what the stage is from plab::stage_info(), which CMake writes from the
/// stage's `stage.json`. The kit's driver does everything else: reading the scene, printing,
/// timing (see plab::simulate()).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "plab/errors.hpp"
#include "plab/model.hpp"
#include "plab/plan.hpp"
#include "plab/scene.hpp"
#include "plab/stepper.hpp"

#ifndef PLAB_STAGE_ID
/// The two-digit number of the stage being compiled (set by CMake for each stage's sources).
#define PLAB_STAGE_ID "??"
#endif

/// Marks an exercise a student has not written yet: stops the run with a message naming it.
/// Replace the whole line with your code.
#define PLAB_EXERCISE(n, what) \
  throw ::plab::NotDone(PLAB_STAGE_ID, (n), (what))

namespace plab {

/// What a stage is, as its folder's `stage.json` declares it (CMake writes it into the stage's
/// library; the runner, the tests and `plab` read it; see docs/ARCHITECTURE.md).
struct StageInfo {
  std::string id;     //!< the two-digit number ("06")
  std::string name;   //!< the folder's name after the number ("broadphase")
  std::string impl;   //!< which tree this library was built from: "solution", "student" or
                      //!< "engine" (kit/instructor/engine)
  std::string model;  //!< "stepped" (model.md's model) or "exact" (continuous time: stage 07,
                      //!< its own golden files and tests)
  bool needs_gpu = false;   //!< runs only on a CUDA device (stages 04, 05)
  bool gpu_path = false;    //!< a CPU stage built with a GPU path beside it (stage 06 with nvcc)
  bool float_path = false;  //!< also steps in float (`--real float`, for plab accuracy only)
  long long test_max_n = 0;             //!< the largest scene its golden tests run
  std::vector<std::string> test_sizes;  //!< the dataset sizes its golden tests run
  std::vector<std::string> switches;    //!< changes that StageOptions::off can turn off (05)
  std::vector<std::string> simd;        //!< narrower vector paths its tests also run (06 engine)
  bool mpi = false;                     //!< runs on several processes started by mpirun (08)
  int (*worker)() = nullptr;            //!< with `mpi`: plab::stage_worker()
  bool openmp = false;                  //!< shares its work among OpenMP threads (`--threads`)
};

/// This stage's declaration (defined in the library CMake builds for it).
const StageInfo& stage_info();

/// Where a stage with both a CPU and a GPU path runs.
enum class Device {
  kAuto,  //!< the GPU when one can be used, otherwise the CPU
  kCpu,   //!< the CPU path
  kGpu,   //!< the GPU path, or NoDevice
};

/// The real type a run steps in.
enum class Real {
  kDouble,  //!< model.md's doubles: every golden output
  kFloat,   //!< the float variant of a stage with StageInfo::float_path (plab accuracy only)
};

/// The options a run passes to its stage: from the runner's command line (`plab-run-NN-IMPL
/// --help`), or the tests. Stages read these, never the environment.
struct StageOptions {
  Device device = Device::kAuto;  //!< `--device auto|cpu|gpu`
  Real real = Real::kDouble;      //!< `--real double|float`
  std::string simd;               //!< `--simd portable|avx2`: narrower vectors than the widest
                                  //!< the CPU has ("": the widest; the pair test of stage
                                  //!< 06's engine)
  std::vector<std::string> off;   //!< `--off a,b`: the stage's changes to turn off, to measure
                                  //!< what each buys (stage 05: graph, streams, branchless)
  double sweep_alpha = 0;         //!< `--sweep-alpha A`: stage 06's grid (GPU; the engine's CPU path too), slabs per
                                  //!< sqrt(N) v/L (0: the stage's measured best)

  /// Whether `change` is turned off.
  [[nodiscard]] bool is_off(const std::string& change) const;

  /// The documented overrides, for scripts that set them around `plab` commands:
  /// PLAB_DEVICE (device), PLAB_SIMD (simd), PLAB_CUDA_OFF (off, comma-separated),
  /// PLAB_SWEEP_ALPHA (sweep_alpha). The runner's options, given, win.
  static StageOptions from_environment();
};

/// Starts a run of this stage from `p` with `options`: every stage defines it (stage 08 through
/// the kit's kit/mpi/stage_entry.cpp).
/// \param box     the box and radius
/// \param p       the initial state; a CPU stage advances it in place, a GPU stage copies it
/// \param options what the run asked for
/// \throws NoDevice when the stage needs a GPU and none can be used
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p,
                                      const StageOptions& options = {});

/// A stage on several processes (`mpi` in its stage.json: 08) starts them here, first thing in
/// the runner: returns -1 in the process that goes on as the runner (rank 0), or, in every
/// other process, the exit status once it has served rank 0's run to its end.
int stage_worker();

/// Advances every particle by one step, as model.md says: a CPU stage's exercise.
/// \param box the box and radius
/// \param p   the state at the start of the step; on return, the state at its end
void step(const Box& box, Particles& p);

/// The same step in `float` (a stage with StageInfo::float_path: 06), for `plab accuracy` only.
void step_float(const Box& box, ParticlesOf<float>& p);

/// A CPU stage's step function in floats (see step_float()).
using FloatStepFn = void (*)(const Box&, ParticlesOf<float>&);

/// A stage's GPU path beside its CPU step (stage 06's step.cu): the GPU Stepper, or nullptr when
/// `options.device` is kAuto and no GPU can be used (throws NoDevice for kGpu).
using GpuStarter = std::unique_ptr<Stepper> (*)(const Box&, Particles&, const StageOptions&);

/// The GPU path of a stage whose `stage.json` declares `cuda_sources` (defined there; built
/// without nvcc, the kit's stand-in, kit/src/no_gpu_path.cpp, says there is none).
std::unique_ptr<Stepper> make_gpu_stepper(const Box& box, Particles& p,
                                          const StageOptions& options);

/// What a CPU stage hands to cpu_stage(): its step, and what it has beside it.
struct CpuStage {
  StepFn step;                     //!< model.md's step in doubles (the exercise)
  FloatStepFn step_float = nullptr;  //!< its float variant, if the stage has one
  GpuStarter gpu = nullptr;        //!< its GPU path, if the stage has one
};

/// A CPU stage's entry point: `stage.gpu` when `options` and the machine allow it, the float
/// variant for Real::kFloat, otherwise `stage.step` applied to `p` in place.
std::unique_ptr<Stepper> cpu_stage(const Box& box, Particles& p, const StageOptions& options,
                                   const CpuStage& stage);

/// A CPU stage's step together with what it keeps between steps: its buffers are members, so one
/// run's state lives exactly as long as the run (no function statics, no globals). cpu_stage()
/// takes a new one a run and calls step() once a step.
class CpuStep {
 public:
  virtual ~CpuStep() = default;
  /// Advances every particle by one step, as model.md says (plab::step()'s contract).
  /// \param box the box and radius
  /// \param p   the state at the start of the step; on return, the state at its end
  virtual void step(const Box& box, Particles& p) = 0;
};

/// cpu_stage() for a stage whose step is an object (see CpuStep): `gpu` (its GPU path, if any)
/// when `options` and the machine allow it, otherwise `state` steps `p` in place on the CPU.
/// \throws std::runtime_error for Real::kFloat (such a stage has no float variant)
std::unique_ptr<Stepper> cpu_stage(const Box& box, Particles& p, const StageOptions& options,
                                   std::unique_ptr<CpuStep> state, GpuStarter gpu = nullptr);

}  // namespace plab
