/// \file cuda/stream.hpp
/// \brief Owners of a CUDA stream and of a graph, and a timer made of CUDA events (ordering two
/// streams with events is stage 05's exercise, written in the stage).
#pragma once

#include "plab/cuda/check.hpp"

namespace plab::cuda {

/// A stream that does not synchronise with the legacy default stream.
class Stream {
 public:
  Stream() { PLAB_CUDA_CHECK(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking)); }
  ~Stream() { cudaStreamDestroy(s_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  operator cudaStream_t() const { return s_; }  //!< for CUDA calls and launches
  /// Waits for everything queued on the stream.
  void sync() const { PLAB_CUDA_CHECK(cudaStreamSynchronize(s_)); }

 private:
  cudaStream_t s_ = nullptr;
};

/// A CUDA graph recorded from the work a function queues on a stream, replayed with launch().
class Graph {
 public:
  Graph() = default;
  ~Graph() { reset(); }
  Graph(const Graph&) = delete;
  Graph& operator=(const Graph&) = delete;
  /// Records what `queue()` puts on `stream` (and streams it forks) instead of running it.
  template <class F>
  void record(cudaStream_t stream, F&& queue) {
    reset();
    PLAB_CUDA_CHECK(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal));
    queue();
    PLAB_CUDA_CHECK(cudaStreamEndCapture(stream, &graph_));
    PLAB_CUDA_CHECK(cudaGraphInstantiate(&exec_, graph_, 0));
  }
  /// Queues one replay on `stream`.
  void launch(cudaStream_t stream) const { PLAB_CUDA_CHECK(cudaGraphLaunch(exec_, stream)); }
  /// Whether a graph is recorded.
  [[nodiscard]] bool ready() const { return exec_ != nullptr; }

 private:
  void reset() {
    if (exec_) cudaGraphExecDestroy(exec_);
    if (graph_) cudaGraphDestroy(graph_);
    exec_ = nullptr;
    graph_ = nullptr;
  }
  cudaGraph_t graph_ = nullptr;
  cudaGraphExec_t exec_ = nullptr;
};

/// Times device work with CUDA events: start() before a stretch of queued work, stop() after it;
/// seconds() waits for the last stop and returns the total of every stretch so far.
class EventTimer {
 public:
  EventTimer() {
    PLAB_CUDA_CHECK(cudaEventCreate(&start_));
    PLAB_CUDA_CHECK(cudaEventCreate(&stop_));
  }
  ~EventTimer() {
    cudaEventDestroy(start_);
    cudaEventDestroy(stop_);
  }
  EventTimer(const EventTimer&) = delete;
  EventTimer& operator=(const EventTimer&) = delete;

  /// Marks the start of a stretch, unless one is open.
  void start(cudaStream_t stream) {
    if (open_) return;
    PLAB_CUDA_CHECK(cudaEventRecord(start_, stream));
    open_ = true;
  }
  /// Marks the (current) end of the open stretch.
  void stop(cudaStream_t stream) { PLAB_CUDA_CHECK(cudaEventRecord(stop_, stream)); }
  /// Closes the open stretch (waiting for it) and adds it to the total.
  void close() {
    if (!open_) return;
    PLAB_CUDA_CHECK(cudaEventSynchronize(stop_));
    float ms = 0;
    PLAB_CUDA_CHECK(cudaEventElapsedTime(&ms, start_, stop_));
    total_ += ms / 1e3;
    open_ = false;
  }
  /// Seconds over every closed stretch.
  [[nodiscard]] double seconds() const { return total_; }

 private:
  cudaEvent_t start_ = nullptr, stop_ = nullptr;
  bool open_ = false;
  double total_ = 0;
};

}  // namespace plab::cuda
