/// \file driver.cpp
/// \brief The loop every stage runs in: print, step, time, repeat.
#include "plab/driver.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <numeric>

namespace plab {
namespace {

/// Writes the collisions of step `s` (the counters that grew from `before` to `after`), and
/// makes `before` the new start.
void write_events(long long s, Particles& before, const Particles& after, std::FILE* out) {
  for (std::size_t i = 0; i < after.size(); ++i) {
    if (after.wc[i] != before.wc[i]) std::fprintf(out, "%lld %zu wall\n", s, i);
    if (after.pc[i] != before.pc[i]) std::fprintf(out, "%lld %zu pair\n", s, i);
  }
  before.wc = after.wc;
  before.pc = after.pc;
}

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Divides (`down`) or multiplies every velocity by `k` (exact when k is a power of two).
void scale_velocities(Particles& p, int k, bool down) {
  const double f = k;
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.vx[i] = down ? p.vx[i] / f : p.vx[i] * f;
    p.vy[i] = down ? p.vy[i] / f : p.vy[i] * f;
  }
}

long long sum(const std::vector<long long>& v) { return std::accumulate(v.begin(), v.end(), 0LL); }

/// Progress on stderr, at most a few times a second, only after the run has taken a moment.
class Progress {
 public:
  Progress(bool on, long long total) : on_(on), total_(total), start_(Clock::now()) {}
  void update(long long done) {
    if (!on_) return;
    const double t = seconds_since(start_);
    if (t < 1.0 || t - last_ < 0.25) return;
    last_ = t;
    std::fprintf(stderr, "\r  step %lld/%lld (%.0f%%), %.1f s, about %.0f s left ", done, total_,
                 100.0 * done / total_, t, t / done * (total_ - done));
    shown_ = true;
  }
  ~Progress() {
    if (shown_) std::fprintf(stderr, "\r%60s\r", "");
  }

 private:
  bool on_;
  long long total_;
  Clock::time_point start_;
  double last_ = 0;
  bool shown_ = false;
};

}  // namespace

RunStats simulate(Scene scene, MakeStepper make, OutputWriter& out, const RunOptions& options) {
  RunStats stats;
  const auto t0 = Clock::now();
  Particles& p = scene.particles;
  const long long steps = scene.steps;
  const long long pc0 = sum(p.pc);
  const long long wc0 = sum(p.wc);
  Progress progress(options.progress, steps);
  if (options.digest) std::fputs(digest_line(0, digest(p)).c_str(), options.digest);
  // K substeps: the same paths in steps of 1/K. The stage runs on velocities divided by K; what
  // is printed, digested and audited has them in length units per printed step again (a copy,
  // so that the stage's own state is never scaled).
  const int k = std::max(1, options.substeps);
  const Particles initial = k > 1 ? p : Particles();  // the state as shown at step 0 (K > 1)
  if (k > 1) scale_velocities(p, k, /*down=*/true);
  const std::unique_ptr<Stepper> stage = make(scene.box, p);
  Particles scaled;
  auto read = [&]() -> const Particles& {
    stage->read(p);
    if (k == 1) return p;
    scaled = p;
    scale_velocities(scaled, k, /*down=*/false);
    return scaled;
  };
  const Particles* shown = k > 1 ? &initial : &p;  // the state as shown
  // the counters at the start of the step (only kept for options.events)
  Particles before = options.events ? p : Particles();
  // Steps are audited from the state before them (model.md's steps only: K == 1, not stage 07).
  const bool audit_steps = options.audit && options.audit_steps && k == 1;
  const bool with_oracle = p.size() <= 3000;  // the oracle is O(N^2) a step
  Particles audited;  // the state before the step (audit_steps)
  if (options.audit) options.audit->state(scene.box, *shown, 0);
  if (audit_steps) audited = *shown;
  double clock_seconds = 0;
  for (long long s = 0; s < steps; ++s) {
    if (options.print && (scene.mode == Mode::kPrint || s == 0)) {
      if (s > 0) shown = &read();
      out.block(s, *shown, false);
    }
    const auto ts = Clock::now();
    for (int sub = 0; sub < k; ++sub) stage->step();
    clock_seconds += seconds_since(ts);
    if (options.digest || options.events || options.audit) shown = &read();
    if (options.audit) options.audit->state(scene.box, *shown, s + 1);
    if (audit_steps) {
      options.audit->step(scene.box, audited, *shown, with_oracle);
      audited = *shown;
    }
    if (options.digest) std::fputs(digest_line(s + 1, digest(*shown)).c_str(), options.digest);
    if (options.events) write_events(s, before, *shown, options.events);
    progress.update(s + 1);
  }
  const auto ts = Clock::now();
  shown = &read();  // waits for queued steps: part of the step time on the driver's clock
  clock_seconds += seconds_since(ts);
  if (options.print) out.block(steps, *shown, true);
  out.flush();
  stats.particles = p.size();
  stats.steps = steps;
  stats.step_seconds = stage->own_seconds() >= 0 ? stage->own_seconds() : clock_seconds;
  stats.timer = stage->own_seconds() >= 0 ? "cuda events" : "steady_clock";
  stats.device = stage->device();
  stats.device_bytes = stage->device_bytes();
  stats.bandwidth = stage->memory_bandwidth();
  stats.traffic = stage->traffic();
  stats.pair_events = (sum(p.pc) - pc0) / 2;
  stats.wall_events = sum(p.wc) - wc0;
  stats.total_seconds = seconds_since(t0);
  return stats;
}

RunStats simulate(Scene scene, StepFn step, OutputWriter& out, const RunOptions& options) {
  const MakeStepper make = [step](const Box& box, Particles& p) {
    return std::unique_ptr<Stepper>(std::make_unique<HostStepper>(step, box, p));
  };
  return simulate(std::move(scene), make, out, options);
}

std::string simulate_to_string(const Scene& scene, StepFn step) {
  OutputWriter out(nullptr);
  simulate(scene, step, out);
  return out.text();
}

}  // namespace plab
