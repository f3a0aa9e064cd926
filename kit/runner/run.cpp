/// \file runner/run.cpp
/// \brief What the runner runs: the scene with the stage (the loop is plab::simulate()), and the
/// grader's two modes (one step from each printed block, the events of chosen particles).
#include <cstdio>
#include <stdexcept>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "plab/grading.hpp"
#include "plab/io.hpp"
#include "plab/runtime.hpp"
#include "runner.hpp"
#if PLAB_HAVE_ORACLE
#include "plab/oracle.hpp"
#endif

namespace plab::runner {

namespace {

/// The stage's entry point with this run's options.
MakeStepper stage_maker(const Options& o) {
  const StageOptions options = o.stage;
  return [options](const Box& box, Particles& p) { return make_stepper(box, p, options); };
}

}  // namespace

Scene load(const Options& o) {
  Scene scene = load_scene(o.scene_path, o.seed,
                           o.speed.empty() ? std::nullopt
                                           : std::optional<SpeedRange>(parse_speed_range(o.speed)));
  if (!o.mode.empty()) scene.mode = (o.mode == "print") ? Mode::kPrint : Mode::kPerf;
  if (o.steps >= 0) scene.steps = o.steps;
  return scene;
}

RunStats simulate_scene(const Options& o, Scene scene) {
  const MakeStepper make = with_status(stage_maker(o), o.status_path, scene.steps * o.substeps);
  OutputFile out(o.out_path);
  OutputFile digest(o.digest_path, /*optional=*/true);
  OutputFile events(o.events_path, /*optional=*/true);
  OutputFile audit_log(o.audit_log_path, /*optional=*/true);
  Audit audit;
  audit.log = audit_log.get();
#if PLAB_HAVE_ORACLE
  audit.oracle = plan_step;
#endif
  OutputWriter writer(out.get());
  const RunStats stats =
      simulate(std::move(scene), make, writer,
               {digest.get(), events.get(),
                !o.quiet && o.status_path.empty() && stderr_is_terminal(),
                o.audit_path.empty() ? nullptr : &audit,
                /*audit_steps=*/stage_info().model == "stepped", o.substeps,
                /*print=*/!o.time_only});
  out.commit();
  digest.commit();
  events.commit();
  audit_log.commit();
  if (!o.audit_path.empty()) {
    OutputFile report(o.audit_path);
    std::fputs(audit.json().c_str(), report.get());
    report.commit();
  }
  return stats;
}

void step_from_each(const Options& o, const Scene& scene) {
  OutputFile out(o.out_path);
  plab::step_from_each(scene.box, parse_output(read_file(o.step_from), o.step_from),
                       stage_maker(o), out.get());
  out.commit();
}

void explain(const Options& o, const Scene& scene) {
#if !PLAB_HAVE_ORACLE
  (void)scene;
  throw std::runtime_error(
      "--explain needs the kit's oracle (the event selection of stages 01-03), which this build "
      "leaves out, as a student's copy and a graded build do; in a student's copy the compiled "
      "reference answers it: kit/reference/bin/plab-reference " + o.scene_path + " --explain " +
      o.explain);
#else
  std::vector<int> which;
  const auto colon = o.explain.find(':');
  const long long k = std::stoll(o.explain.substr(0, colon));
  const std::string list = colon == std::string::npos ? "" : o.explain.substr(colon + 1);
  for (std::size_t at = 0; at < list.size();) {
    const auto comma = list.find(',', at);
    which.push_back(std::stoi(list.substr(at, comma - at)));
    at = comma == std::string::npos ? list.size() : comma + 1;
  }
  Particles p = scene.particles;
  const auto stage = make_stepper(scene.box, p, o.stage);
  for (long long s = 0; s < k; ++s) stage->step();
  stage->read(p);
  const std::string said = o.json ? describe_events_json(scene.box, p, which)
                                  : describe_events(scene.box, p, which);
  std::fputs(said.c_str(), output_stream());
#endif
}

}  // namespace plab::runner
