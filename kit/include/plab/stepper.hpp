/// \file stepper.hpp
/// \brief A stage as the driver sees it: something that holds the state and advances it a step.
///
/// CPU stages only write plab::step(); the kit wraps it in a host Stepper. CUDA stages keep the
/// state on the GPU between steps and implement a Stepper of their own, so that the driver copies
/// the state back only when it prints (every step in print mode, twice in perf mode).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "plab/scene.hpp"

namespace plab {

/// The state of a run and the way it advances.
class Stepper {
 public:
  virtual ~Stepper() = default;
  /// Advances the state by one step. May return before the work is done (a GPU queue).
  virtual void step() = 0;
  /// Copies the state after the last step into `p` (waits for the work queued so far).
  virtual void read(Particles& p) = 0;
  /// Seconds spent in steps as the stage measures them itself (CUDA events), or a negative
  /// value when the driver's clock around step() is the right measure (CPU stages).
  [[nodiscard]] virtual double own_seconds() const { return -1; }
  /// What the stage ran on, for timing reports ("cpu" or the GPU's name).
  [[nodiscard]] virtual std::string device() const { return "cpu"; }
  /// Bytes of device memory the stage holds now (0 for CPU stages).
  [[nodiscard]] virtual std::size_t device_bytes() const { return 0; }
  /// The memory bandwidth of the device the stage ran on, in bytes a second, as the stage
  /// measured it (the kit's engine: a device-to-device copy), or 0 when it did not (plab bench
  /// then prints no floor for it).
  [[nodiscard]] virtual double memory_bandwidth() const { return 0; }
  /// What a stage on several processes measured about its messages so far (the others: none).
  struct Traffic {
    double bytes_sent = 0;    //!< bytes every rank sent to the others, summed over the ranks
    double comm_seconds = 0;  //!< seconds in exchanges and reductions (waits included), on
                              //!< the rank that spent the most
    int ranks = 1;            //!< processes
    /// Per rank: CPU seconds of its steps outside the stage's MPI calls, the process's CPU clock
    /// read at each change (kit/mpi: the work each rank did; empty for a stage on one process).
    std::vector<double> work_seconds;
    /// Per rank: CPU seconds of its steps inside the stage's MPI calls (waits that spin).
    std::vector<double> mpi_seconds;
    /// bytes_sent split by the MPI function that sent them ("MPI_Sendrecv", ...), most first.
    std::vector<std::pair<std::string, double>> bytes_by_call;
  };
  /// This run's Traffic (a stage on several processes asks every rank: call it after the steps).
  virtual Traffic traffic() { return {}; }
};

/// A stage's step function (see stage.hpp).
using StepFn = void (*)(const Box&, Particles&);

/// The Stepper of a CPU stage: `step` advances the caller's particles in place.
class HostStepper final : public Stepper {
 public:
  /// Advances `p` itself (no copy), which must outlive the stepper.
  HostStepper(StepFn step, const Box& box, Particles& p) : step_(step), box_(box), p_(&p) {}
  void step() override { step_(box_, *p_); }
  void read(Particles& p) override {
    if (&p != p_) p = *p_;
  }

 private:
  StepFn step_;
  Box box_;
  Particles* p_;
};

/// A CPU stage run in another real type (`plab accuracy`'s float variant, never a golden
/// output): it keeps its own copy of the state in `Real` and rounds it to doubles when read.
template <class Real>
class RealStepper final : public Stepper {
 public:
  /// The stage's step function in `Real`.
  using StepIn = void (*)(const Box&, ParticlesOf<Real>&);
  /// Starts from `p`, each value rounded to `Real`.
  RealStepper(StepIn step, const Box& box, const Particles& p)
      : step_(step), box_(box), q_(p.template as<Real>()) {}
  void step() override { step_(box_, q_); }
  void read(Particles& p) override { p = q_.template as<double>(); }

 private:
  StepIn step_;
  Box box_;
  ParticlesOf<Real> q_;
};

}  // namespace plab
