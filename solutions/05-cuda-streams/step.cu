/// \file solutions/05-cuda-streams/step.cu
/// \brief Stage 05, CUDA with streams and branchless walls: stage 04 reorganised so that the host
/// never waits inside a step. Same bits as stages 01-04.
//
// =================================================================================================
//  GOAL   Two changes to a GPU step, each measured with --off (it turns a change off):
//         1. streams: the wall times on the stepper's stream beside the pair search on a second
//            one, forked and joined by CUDA events (EXERCISE 1, this file);
//         2. the branchless wall event in apply: one path for every thread of a warp, the same
//            bits as model::wall_event() (EXERCISE 2, kernels.cuh).
//         Given, from the report's Part 2 (switch `graph` turns the last one off): the pair search
//         on a 2D grid (tiles of j in shared memory, j > i only) with slots laid out
//         [slot][particle]; every round of a step in one block (resolve: stage 04's rounds, no
//         host round trip per round); one step recorded once as a CUDA graph and replayed. Slots
//         that run out are caught on the device and the step is redone by the host.
//         --off graph,streams,branchless turns changes off, to measure what each buys; the
//         starting point runs with --off streams,branchless.
//  READ   handouts/05-cuda-streams.md   TEST   ./plab test --impl student --stage 05
// =================================================================================================
#include <memory>
#include <string>

#include "launchers.cuh"
#include "plab/cuda/stepper.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

/// Which of the stage's changes are on (all by default; see --off above).
struct Options {
  bool graph = true;       //!< replay one recorded step instead of launching its kernels
  bool streams = true;     //!< wall times on a second stream, beside the pair search
  bool branchless = true;  //!< the branchless wall event

  /// The changes the run's StageOptions::off leaves on.
  static Options from(const StageOptions& asked) {
    Options o;
    o.graph = !asked.is_off("graph");
    o.streams = !asked.is_off("streams");
    o.branchless = !asked.is_off("branchless");
    return o;
  }
};

/// A run of stage 05: queues steps on its own stream without waiting for them (the kit's
/// cuda::DeviceStepper holds the particles, the flags and the timer, and reads the state back).
class CudaStepper final : public cuda::DeviceStepper<kernels::Flags> {
 public:
  CudaStepper(const Box& box, const Particles& p, const StageOptions& asked)
      : DeviceStepper(cuda::require_device(), box, p, cuda::Queue::kOwnStream),
        options_(Options::from(asked)), wall_(n_), slots_(n_, 8), best_(n_),
        resolved_(n_), contested_(n_), partner_(n_), ptime_(n_) {
    if (options_.streams) {  // the second stream, and the events that fork and join it
      PLAB_CUDA_CHECK(cudaStreamCreateWithFlags(&side_, cudaStreamNonBlocking));
      PLAB_CUDA_CHECK(cudaEventCreateWithFlags(&forked_, cudaEventDisableTiming));
      PLAB_CUDA_CHECK(cudaEventCreateWithFlags(&joined_, cudaEventDisableTiming));
    }
    sync();
  }
  ~CudaStepper() override {
    if (side_) cudaStreamDestroy(side_);
    if (forked_) cudaEventDestroy(forked_);
    if (joined_) cudaEventDestroy(joined_);
  }
  CudaStepper(const CudaStepper&) = delete;
  CudaStepper& operator=(const CudaStepper&) = delete;

 private:
  /// Queues one step: the recorded graph, or its kernels one by one.
  void queue_step() override {
    if (!options_.graph) return queue_kernels();
    // Recorded once (again when the slots were reallocated), then replayed: one launch per step
    // instead of five.
    if (graph_stale_) {
      graph_.record(main_, [this] { queue_kernels(); });
      graph_stale_ = false;
    }
    graph_.launch(main_);
  }

  /// The kernels of one step, on two streams when options_.streams.
  void queue_kernels() {
    const cudaStream_t side = options_.streams ? side_ : main_;
    if (options_.streams) {  // fork: the side stream waits for what main_ has queued so far
      PLAB_CUDA_CHECK(cudaEventRecord(forked_, main_));
      PLAB_CUDA_CHECK(cudaStreamWaitEvent(side_, forked_, 0));
    }
    launch::wall_times(p_.view(), box_, arrays(), main_);
    slots_.clear_counts(side);
    launch::find_pairs(p_.view(), box_, arrays(), side);
    if (options_.streams) {  // join: resolve (on main_) waits for the pair search
      PLAB_CUDA_CHECK(cudaEventRecord(joined_, side_));
      PLAB_CUDA_CHECK(cudaStreamWaitEvent(main_, joined_, 0));
    }
    launch::resolve(n_, arrays(), main_);
    launch::apply(p_.view(), box_, arrays(), options_.branchless, main_);
  }

  /// Waits for the queued steps; when one ran out of slots (the device then skipped it and every
  /// step after it), grows the slots and queues the skipped steps again.
  void catch_up() override {
    for (;;) {
      const kernels::Flags f = flags_.read(main_);
      if (f.steps_done == asked_ || f.overflow == 0) return;
      slots_.grow(f.overflow, main_);
      graph_stale_ = true;  // the recorded graph holds the old slots' addresses
      flags_.clear(&kernels::Flags::overflow, main_);
      for (long long s = f.steps_done; s < asked_; ++s) queue_step();
      timer_.stop(main_);
    }
  }

  [[nodiscard]] std::size_t arrays_bytes() const override {
    return cuda::bytes_of(wall_, slots_, best_, resolved_, contested_, partner_, ptime_);
  }

  /// The working arrays as the kernels see them.
  [[nodiscard]] kernels::StepArrays arrays() const {
    return {wall_.get(),      slots_.view(),   best_.get(),  resolved_.get(),
            contested_.get(), partner_.get(),  ptime_.get(), flags_.get()};
  }

  Options options_;
  cudaStream_t side_ = nullptr;                        //!< the pair search's stream (streams on)
  cudaEvent_t forked_ = nullptr, joined_ = nullptr;    //!< fork and join of the two streams
  cuda::DeviceArray<double> wall_;
  cuda::DeviceSlots<cuda::SlotLayout::kBySlot> slots_;
  cuda::DeviceArray<model::Event> best_;
  cuda::DeviceArray<char> resolved_;
  cuda::DeviceArray<int> contested_, partner_;
  cuda::DeviceArray<double> ptime_;
  cuda::Graph graph_;
  bool graph_stale_ = true;  // the graph must be recorded (again) before its next replay
};

}  // namespace

/// Stage 05's entry point (stage.hpp): a run on the GPU (NoDevice without one).
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return std::make_unique<CudaStepper>(box, p, options);
}

}  // namespace plab
