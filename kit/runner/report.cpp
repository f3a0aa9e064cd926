/// \file runner/report.cpp
/// \brief The runner's report: one timing line on stderr, and the JSON that plab bench reads.
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "plab/event_order.hpp"
#include "plab/io.hpp"
#include "plab/plan.hpp"
#include "plab/runtime.hpp"
#include "runner.hpp"

namespace plab::runner {

namespace {

/// `v` with `digits` digits after the point.
std::string format_fixed(double v, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, v);
  return text;
}

/// `v` as "%.3g" (bytes: 1.23e+06).
std::string format_bytes(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}

}  // namespace

void report(const Options& o, const RunStats& stats) {
  const StageInfo& info = stage_info();
  const int threads = info.openmp ? get_threads() : 1;  // a sequential stage runs on one
  if (!o.report_path.empty()) {
    OutputFile file(o.report_path);
    nlohmann::json by_call = nlohmann::json::object();
    for (const auto& [call, bytes] : stats.traffic.bytes_by_call) by_call[call] = bytes;
    const nlohmann::json j = {
        {"stage", info.id},               {"impl", info.impl},
        {"n", stats.particles},           {"steps", stats.steps},
        {"threads", threads},       {"openmp", info.openmp},
        {"device", stats.device},
        {"timer", stats.timer},           {"step_seconds", stats.step_seconds},
        {"device_bytes", stats.device_bytes}, {"bandwidth", stats.bandwidth},
        {"total_seconds", stats.total_seconds},
        {"pair_events", stats.pair_events}, {"wall_events", stats.wall_events},
        {"substeps", o.substeps},         {"real", o.real},
        {"ranks", stats.traffic.ranks},   {"bytes_sent", stats.traffic.bytes_sent},
        {"bytes_by_call", by_call},       {"comm_seconds", stats.traffic.comm_seconds},
        {"rank_work_seconds", stats.traffic.work_seconds},
        {"rank_mpi_seconds", stats.traffic.mpi_seconds},
        // A stage whose heap is ordered by plab::EventOrder (02): its comparisons on this thread
        // (the steps'), counted and traced; the grader compares them with the kit's heap's
        {"order_comparisons", EventOrder::count()},
        {"order_trace", EventOrder::hex(EventOrder::trace())},
        // A stage whose rounds compare with it (03): the comparisons of events in the step by
        // thread, how evenly the threads shared them loop by loop (the kit's OpenMP counter's
        // epochs), and their later events summed; the grader compares them with plab-rounds'
        {"order_step_comparisons", EventOrder::in_step_by_thread()},
        {"order_balanced_comparisons", EventOrder::balanced(threads)},
        {"order_later_sum", EventOrder::hex(EventOrder::later_sum())},
        // plab::pair_candidate()'s calls on every thread (stage 06's spec: a broad phase's few)
        {"pair_tests", pair_tests()}};
    const std::string text = j.dump(2) + "\n";
    std::fputs(text.c_str(), file.get());
    file.commit();
  }
  if (o.quiet) return;
  std::fprintf(stderr,
               "stage %s (%s) on %s: N=%zu S=%lld%s: %.3f s in steps (%.3f ms/step, "
               "%s), %.3f s total; %lld pair and %lld wall collisions\n",
               info.id.c_str(), info.impl.c_str(), stats.device.c_str(), stats.particles,
               stats.steps, info.openmp ? (" threads=" + std::to_string(threads)).c_str() : "",
               stats.step_seconds,
               stats.steps ? 1e3 * stats.step_seconds / stats.steps : 0.0, stats.timer.c_str(),
               stats.total_seconds, stats.pair_events, stats.wall_events);
  if (stats.traffic.ranks > 1) {
    std::string calls;
    for (const auto& [call, bytes] : stats.traffic.bytes_by_call)
      calls += (calls.empty() ? "; by call: " : ", ") + call + " " + format_bytes(bytes);
    std::fprintf(stderr, "stage %s (%s) on %d ranks: %.3g bytes sent, %.3f s in exchanges (the "
                 "busiest rank)%s\n", info.id.c_str(), info.impl.c_str(), stats.traffic.ranks,
                 stats.traffic.bytes_sent, stats.traffic.comm_seconds, calls.c_str());
  }
  if (!stats.traffic.work_seconds.empty()) {
    std::string work;
    for (std::size_t q = 0; q < stats.traffic.work_seconds.size(); ++q)
      work += (q ? ", " : "") + std::to_string(q) + ": " +
              format_fixed(stats.traffic.work_seconds[q], 3) + " (" +
              format_fixed(stats.traffic.mpi_seconds[q], 3) + ")";
    std::fprintf(stderr, "stage %s (%s), CPU seconds of each rank's steps outside MPI calls "
                 "(inside), measured: %s\n", info.id.c_str(), info.impl.c_str(), work.c_str());
  }
  if (stats.device_bytes)
    std::fprintf(stderr, "stage %s (%s): %.2f MB of device memory held\n", info.id.c_str(),
                 info.impl.c_str(), stats.device_bytes / 1e6);
}

}  // namespace plab::runner
