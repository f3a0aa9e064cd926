/// \file runner/options.cpp
/// \brief The runner's command line: every option with its help, and the checks against what
/// the stage declares.
#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "plab/generate.hpp"
#include "runner.hpp"
#include "stage_options.hpp"

namespace plab::runner {

namespace {

/// "a, b and c" (or "none").
std::string listed(const std::vector<std::string>& items) {
  if (items.empty()) return "none";
  std::string text;
  for (std::size_t k = 0; k < items.size(); ++k)
    text += (k == 0 ? "" : k + 1 == items.size() ? " and " : ", ") + items[k];
  return text;
}

}  // namespace

void add_options(CLI::App& app, Options& o) {
  o.seed = kDefaultSeed;
  app.add_option("scene", o.scene_path, "scene file (model.md's input format)")->required();
  auto* out =
      app.add_option("--out", o.out_path, "write the output here instead of stdout (all or nothing)");
  app.add_option("--digest", o.digest_path, "write one state digest per step to this file");
  app.add_option("--threads", o.threads, "threads for stages that use them (default: all cores)");
  app.add_option("--schedule", o.schedule,
                 "OpenMP schedule of the stage's schedule(runtime) loops: static, dynamic or "
                 "guided, with an optional ,CHUNK")->capture_default_str();
  app.add_option("--seed", o.seed, "seed for scenes without particle lines")->capture_default_str();
  app.add_option("--speed", o.speed,
                 "speeds MIN:MAX for scenes without particle lines (default: model.md's, L/(8r) "
                 "to L/4)");
  app.add_option("--events", o.events_path,
                 "write `STEP INDEX wall|pair` for every collision to this file (plab render)");
  app.add_option("--mode", o.mode, "print or perf, instead of the scene's own mode")
      ->check(CLI::IsMember({"print", "perf"}));
  app.add_option("--steps", o.steps, "run this many steps instead of the scene's S")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--step-from-each", o.step_from,
                 "grading: from each block of this print-mode output, run one step and print it");
  auto* explain = app.add_option(
      "--explain", o.explain,
      "grading: K:i,j,... says the events of particles i, j, ... in step K (by the kit's greedy "
      "oracle, from this stage's state at the start of step K)");
  app.add_flag("--json", o.json,
               "with --explain: the events as JSON, each time in full precision (what the "
               "grader reads)")
      ->needs(explain);
  app.add_option("--report", o.report_path,
                 "write the run's timing as JSON to this file (what plab bench reads)");
  app.add_option("--substeps", o.substeps,
                 "plab accuracy: K model steps of 1/K per printed step (K a power of two keeps the "
                 "velocity scaling exact); not model.md's output")
      ->check(CLI::Range(1, 1 << 20))->capture_default_str();
  app.add_option("--audit", o.audit_path,
                 "check every state and step at full precision (no NaN, centres in the box, "
                 "overlaps, energy, counters, energy of each collision in ulps) and write the "
                 "worst of each as JSON to this file (plab stress)");
  app.add_option("--audit-log", o.audit_log_path, "with --audit: one JSON line per state here");
  app.add_option("--status", o.status_path,
                 "keep `STEPS-DONE STEPS` in this file, rewritten after every step (plab run "
                 "reads it to say where a hung or crashed run was)");
  app.add_flag("--quiet", o.quiet, "no timing summary on stderr");
  app.add_flag("--time-only", o.time_only,
               "print no state, only run and time the steps (for scenes too large to print: "
               "10^9 particles are about 100 GB of text)")
      ->excludes(out);

  auto* stage = app.add_option_group("stage options", "what reaches the stage (stage.hpp's "
                                     "StageOptions; the environment's PLAB_DEVICE, PLAB_SIMD, "
                                     "PLAB_CUDA_OFF and PLAB_SWEEP_ALPHA set their defaults)");
  stage->add_option("--real", o.real,
                    "plab accuracy: run the model in float (stages that declare a float path: "
                    "06) instead of model.md's double; never for golden outputs")
      ->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  add_stage_options(*stage, o.device, o.stage.simd, o.off, o.stage.sweep_alpha);
}

void finish_options(Options& o) {
  const StageInfo& info = stage_info();
  // The environment's overrides fill what the command line left out, where the stage has it.
  const StageOptions env = StageOptions::from_environment();
  o.stage.device = o.device == "cpu" ? Device::kCpu
                   : o.device == "gpu" ? Device::kGpu
                   : o.device == "auto" ? Device::kAuto
                                        : env.device;
  std::istringstream off(o.off);
  for (std::string item; std::getline(off, item, ',');)
    if (!item.empty()) o.stage.off.push_back(item);
  if (o.stage.simd.empty() && !info.simd.empty()) o.stage.simd = env.simd;
  if (o.stage.sweep_alpha == 0) o.stage.sweep_alpha = env.sweep_alpha;
  o.stage.real = o.real == "float" ? Real::kFloat : Real::kDouble;
  if (o.stage.real == Real::kFloat && !info.float_path)
    throw std::runtime_error("stage " + info.id + " has no float variant (--real float)");
  for (const std::string& change : o.stage.off)
    if (std::find(info.switches.begin(), info.switches.end(), change) == info.switches.end())
      throw std::runtime_error("stage " + info.id + " has no change called '" + change +
                               "' to turn off (its switches: " + listed(info.switches) + ")");
  if (!o.stage.simd.empty() &&
      std::find(info.simd.begin(), info.simd.end(), o.stage.simd) == info.simd.end())
    throw std::runtime_error("stage " + info.id + " has no vector path called '" + o.stage.simd +
                             "' (its paths: " + listed(info.simd) + ")");
  // PLAB_CUDA_OFF (a script's default, e.g. "none") keeps only the stage's own switches.
  if (o.stage.off.empty())
    for (const std::string& change : env.off)
      if (std::find(info.switches.begin(), info.switches.end(), change) != info.switches.end())
        o.stage.off.push_back(change);
}

}  // namespace plab::runner
