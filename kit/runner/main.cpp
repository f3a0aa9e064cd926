/// \file runner/main.cpp
/// \brief The program built for each stage (`plab-run-NN-IMPL`): reads a scene, runs the stage
/// with the kit's driver, writes the output. `plab run` starts it. Compiled once, linked with
/// each stage's library (its plab::make_stepper() and plab::stage_info()).
#include <cstdio>
#include <utility>

#include "plab/errors.hpp"
#include "plab/runtime.hpp"
#include "runner.hpp"

int main(int argc, char** argv) {
  const plab::StageInfo& stage = plab::stage_info();
  // A stage on several processes: every process but rank 0 serves rank 0's run and ends here.
  if (stage.worker)
    if (const int status = stage.worker(); status >= 0) return status;
  CLI::App app{"Runs stage " + stage.id + " (" + stage.impl +
               ") on a scene and writes model.md's output."};
  plab::runner::Options o;
  plab::runner::add_options(app, o);
  CLI11_PARSE(app, argc, argv);
  // From here what the stage prints to stdout (a student's debugging) goes to stderr: it never
  // mixes into the output, which alone goes to stdout.
  plab::keep_stdout_for_output();

  try {
    // set-up
    plab::runner::finish_options(o);
    plab::set_threads(o.threads);
    plab::set_schedule(o.schedule);
    plab::Scene scene = plab::runner::load(o);
    // the grader's modes
    if (!o.step_from.empty()) {
      plab::runner::step_from_each(o, scene);
      return 0;
    }
    if (!o.explain.empty()) {
      plab::runner::explain(o, scene);
      return 0;
    }
    // the loop, then the report
    const plab::RunStats stats = plab::runner::simulate_scene(o, std::move(scene));
    plab::runner::report(o, stats);
    return 0;
  } catch (const plab::NoDevice& e) {
    std::fprintf(stderr, "stage %s: %s\n", stage.id.c_str(), e.what());
    return 4;
  } catch (const plab::NotDone& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
