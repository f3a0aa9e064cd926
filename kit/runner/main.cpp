/// \file runner/main.cpp
/// \brief The program built for each stage (`plab-run-NN-IMPL`): reads a scene, runs the stage's
/// step() with the kit's driver, writes the output. `plab run` starts it.
#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "plab/driver.hpp"
#include "plab/errors.hpp"
#include "plab/generate.hpp"
#include "plab/grading.hpp"
#include "plab/io.hpp"
#include "plab/runtime.hpp"
#include "plab/stage.hpp"

#ifndef PLAB_EXACT_STAGE
#define PLAB_EXACT_STAGE 0
#endif

namespace {

/// A stepper that writes "DONE TOTAL" to a status file after each step, in place, so that
/// `plab run` can say where a run was when it hung or crashed.
class StatusStepper final : public plab::Stepper {
 public:
  StatusStepper(std::unique_ptr<plab::Stepper> inner, int fd, long long total)
      : inner_(std::move(inner)), fd_(fd), total_(total) {
    write_status();
  }
  void step() override {
    inner_->step();
    ++done_;
    write_status();
  }
  void read(plab::Particles& p) override { inner_->read(p); }
  [[nodiscard]] double own_seconds() const override { return inner_->own_seconds(); }
  [[nodiscard]] std::string device() const override { return inner_->device(); }
  [[nodiscard]] std::size_t device_bytes() const override { return inner_->device_bytes(); }

 private:
  void write_status() {
    char line[64];
    const int n = std::snprintf(line, sizeof line, "%20lld %20lld\n", done_, total_);
    if (pwrite(fd_, line, n, 0) < 0) fd_ = -1;
  }
  std::unique_ptr<plab::Stepper> inner_;
  int fd_;
  long long total_;
  long long done_ = 0;
};

/// `make`, reporting every step in the status file `path` (none when `path` is empty).
plab::MakeStepper with_status(plab::MakeStepper make, const std::string& path, long long total) {
  if (path.empty()) return make;
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write the status file " + path);
  return [make, fd, total](const plab::Box& box, plab::Particles& p) -> std::unique_ptr<plab::Stepper> {
    return std::make_unique<StatusStepper>(make(box, p), fd, total);
  };
}

}  // namespace

int main(int argc, char** argv) {
  std::string scene_path, out_path, digest_path, report_path, events_path, mode, step_from, explain;
  long long steps = -1;
  std::string schedule = "dynamic,16";
  int threads = 0;
  std::uint64_t seed = plab::kDefaultSeed;
  bool quiet = false;
  int substeps = 1;
  std::string real = "double";
  std::string audit_path, audit_log_path, status_path;
  CLI::App app{"Runs stage " PLAB_STAGE_ID " (" PLAB_IMPL ") on a scene and writes model.md's output."};
  app.add_option("scene", scene_path, "scene file (model.md's input format)")->required();
  app.add_option("--out", out_path, "write the output here instead of stdout (all or nothing)");
  app.add_option("--digest", digest_path, "write one state digest per step to this file");
  app.add_option("--threads", threads, "threads for stages that use them (default: all cores)");
  app.add_option("--schedule", schedule,
                 "OpenMP schedule of the stage's schedule(runtime) loops: static, dynamic or "
                 "guided, with an optional ,CHUNK")->capture_default_str();
  app.add_option("--seed", seed, "seed for scenes without particle lines")->capture_default_str();
  app.add_option("--events", events_path,
                 "write `STEP INDEX wall|pair` for every collision to this file (plab render)");
  app.add_option("--mode", mode, "print or perf, instead of the scene's own mode")
      ->check(CLI::IsMember({"print", "perf"}));
  app.add_option("--steps", steps, "run this many steps instead of the scene's S")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--step-from-each", step_from,
                 "grading: from each block of this print-mode output, run one step and print it");
  app.add_option("--explain", explain,
                 "grading: K:i,j,... says the events of particles i, j, ... in step K (by the kit's "
                 "greedy oracle, from this stage's state at the start of step K)");
  app.add_option("--report", report_path,
                 "write the run's timing as JSON to this file (what plab bench reads)");
  app.add_option("--substeps", substeps,
                 "plab accuracy: K model steps of 1/K per printed step (K a power of two keeps the "
                 "velocity scaling exact); not model.md's output")
      ->check(CLI::Range(1, 1 << 20))->capture_default_str();
  app.add_option("--real", real,
                 "plab accuracy: run the model in float (stages built with it: 06) instead of "
                 "model.md's double; never for golden outputs")
      ->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  app.add_option("--audit", audit_path,
                 "check every state and step at full precision (no NaN, centres in the box, "
                 "overlaps, energy, counters, energy of each collision in ulps) and write the "
                 "worst of each as JSON to this file (plab stress)");
  app.add_option("--audit-log", audit_log_path, "with --audit: one JSON line per state here");
  app.add_option("--status", status_path,
                 "keep `STEPS-DONE STEPS` in this file, rewritten after every step (plab run "
                 "reads it to say where a hung or crashed run was)");
  app.add_flag("--quiet", quiet, "no timing summary on stderr");
  CLI11_PARSE(app, argc, argv);

  try {
    plab::set_threads(threads);
    plab::set_schedule(schedule);
    plab::Scene scene = plab::load_scene(scene_path, seed);
    if (!mode.empty()) scene.mode = (mode == "print") ? plab::Mode::kPrint : plab::Mode::kPerf;
    if (steps >= 0) scene.steps = steps;
    if (!step_from.empty()) {
      plab::OutputFile out(out_path);
      plab::step_from_each(scene.box, plab::parse_output(plab::read_file(step_from), step_from),
                           plab::make_stepper, out.get());
      out.commit();
      return 0;
    }
    if (!explain.empty()) {
      std::vector<int> which;
      const auto colon = explain.find(':');
      const long long k = std::stoll(explain.substr(0, colon));
      std::string list = colon == std::string::npos ? "" : explain.substr(colon + 1);
      for (std::size_t at = 0; at < list.size();) {
        const auto comma = list.find(',', at);
        which.push_back(std::stoi(list.substr(at, comma - at)));
        at = comma == std::string::npos ? list.size() : comma + 1;
      }
      plab::Particles p = scene.particles;
      const auto stage = plab::make_stepper(scene.box, p);
      for (long long s = 0; s < k; ++s) stage->step();
      stage->read(p);
      std::fputs(plab::describe_events(scene.box, p, which).c_str(), stdout);
      return 0;
    }
    plab::MakeStepper make = plab::make_stepper;
    if (real == "float") {
#if PLAB_FLOAT_STAGE
      make = plab::make_float_stepper;
#else
      throw std::runtime_error("stage " PLAB_STAGE_ID " has no float variant (--real float)");
#endif
    }
    make = with_status(make, status_path, scene.steps * substeps);
    plab::OutputFile out(out_path);
    plab::OutputFile digest(digest_path, /*optional=*/true);
    plab::OutputFile events(events_path, /*optional=*/true);
    plab::OutputFile audit_log(audit_log_path, /*optional=*/true);
    plab::Audit audit;
    audit.log = audit_log.get();
    plab::OutputWriter writer(out.get());
    const plab::RunStats stats =
        plab::simulate(scene, make, writer,
                       {digest.get(), events.get(),
                        !quiet && status_path.empty() && plab::stderr_is_terminal(),
                        audit_path.empty() ? nullptr : &audit, /*audit_steps=*/!PLAB_EXACT_STAGE,
                        substeps});
    out.commit();
    digest.commit();
    events.commit();
    audit_log.commit();
    if (!audit_path.empty()) {
      plab::OutputFile report(audit_path);
      std::fputs(audit.json().c_str(), report.get());
      report.commit();
    }
    if (!report_path.empty()) {
      plab::OutputFile report(report_path);
      const nlohmann::json j = {
          {"stage", PLAB_STAGE_ID},         {"impl", PLAB_IMPL},
          {"n", scene.particles.size()},    {"steps", scene.steps},
          {"threads", plab::get_threads()}, {"device", stats.device},
          {"timer", stats.timer},           {"step_seconds", stats.step_seconds},
          {"device_bytes", stats.device_bytes},
          {"total_seconds", stats.total_seconds},
          {"pair_events", stats.pair_events}, {"wall_events", stats.wall_events},
          {"substeps", substeps},           {"real", real}};
      const std::string text = j.dump(2) + "\n";
      std::fputs(text.c_str(), report.get());
      report.commit();
    }
    if (!quiet)
      std::fprintf(stderr,
                   "stage %s (%s) on %s: N=%zu S=%lld threads=%d: %.3f s in steps (%.3f ms/step, "
                   "%s), %.3f s total; %lld pair and %lld wall collisions\n",
                   PLAB_STAGE_ID, PLAB_IMPL, stats.device.c_str(), scene.particles.size(),
                   scene.steps, plab::get_threads(), stats.step_seconds,
                   scene.steps ? 1e3 * stats.step_seconds / scene.steps : 0.0,
                   stats.timer.c_str(), stats.total_seconds, stats.pair_events, stats.wall_events);
    if (!quiet && stats.device_bytes)
      std::fprintf(stderr, "stage %s (%s): %.2f MB of device memory held\n", PLAB_STAGE_ID,
                   PLAB_IMPL, stats.device_bytes / 1e6);
    return 0;
  } catch (const plab::NoDevice& e) {
    std::fprintf(stderr, "stage %s: %s\n", PLAB_STAGE_ID, e.what());
    return 4;
  } catch (const plab::NotDone& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
