/// \file cli/run.cpp
/// \brief `plab run`: simulate a scene with one stage.
#include "common.hpp"

#include "../runner/stage_options.hpp"

namespace plab::cli {

void add_run(CLI::App& app) {
  struct Args {
    std::string stage, impl, scene, out, digest, events, schedule, explain, speed, mode;
    std::string device, off, simd;  // the stage's options, passed on as given
    double sweep_alpha = 0;
    long long steps = -1;
    int threads = 0;
    int ranks = 0;
    double timeout = 0;
    std::uint64_t seed = kDefaultSeed;
    bool quiet = false;
    bool time_only = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand("run", "Simulate SCENE with one stage; output to stdout (or --out), "
                                      "a timing summary to stderr.");
  c->add_option("--stage", a->stage, "stage number, e.g. 01")->required();
  c->add_option("--impl", a->impl,
                "solution (solutions/), student (stages/) or engine (kit/instructor/engine/: the "
                "kit's fast version, instructor only); default: solution when solutions/ exists, "
                "otherwise student");
  c->add_option("--threads", a->threads,
                "threads for stages that use them (they wait passively at barriers, as when "
                "graded, unless OMP_WAIT_POLICY is set)");
  c->add_option("--ranks", a->ranks,
                "processes for a stage that runs on several (08): mpirun starts them, more than "
                "the cores if asked")->check(CLI::Range(1, 4096));
  c->add_option("--schedule", a->schedule, "OpenMP schedule: static, dynamic or guided[,CHUNK]");
  auto* out =
      c->add_option("--out", a->out, "write the output to this file (only when the run succeeds)");
  c->add_option("--digest", a->digest, "write one state digest per step to this file");
  c->add_option("--events", a->events,
                "write `STEP INDEX wall|pair` for every collision to this file (what plab render "
                "and plab view --events read)");
  c->add_option("--steps", a->steps, "run this many steps instead of the scene's S")
      ->check(CLI::NonNegativeNumber);
  c->add_option("--mode", a->mode, "print or perf, instead of the scene's own mode")
      ->check(CLI::IsMember({"print", "perf"}));
  c->add_option("--seed", a->seed, "seed for scenes without particle lines")->capture_default_str();
  c->add_option("--speed", a->speed,
                "speeds MIN:MAX for scenes without particle lines (default: model.md's, L/(8r) "
                "to L/4)");
  auto* time_only = c->add_flag("--time-only", a->time_only,
                                "print no state, only run and time the steps (for scenes too "
                                "large to print: 10^9 particles are about 100 GB of text)");
  c->add_flag("--quiet", a->quiet, "no timing summary");
  c->add_option("--timeout", a->timeout,
                "end the run (and everything it started) after this many seconds, saying at which "
                "step it was; exit status 124")->check(CLI::PositiveNumber);
  c->add_option("--explain", a->explain,
                "K:I[,J...]: instead of the output, the events of particles I, J... in step K (the "
                "kit's oracle, from this stage's state at the start of step K; a student's copy "
                "has no oracle: kit/reference/bin/plab-reference SCENE --explain K:I answers)");
  // The stage's own options (stage.hpp's StageOptions), passed to its program as given: each
  // stage's handout says which it reads
  runner::add_stage_options(*c, a->device, a->simd, a->off, a->sweep_alpha);
  c->add_option("scene", a->scene, "scene file")->required()->check(CLI::ExistingFile);
  time_only->excludes(out);
  c->callback([a, c] {
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    wait_as_the_grader(impl);
    const std::string id = two_digits(a->stage);
    std::vector<std::string> args{require_stage(id, impl), a->scene, "--seed",
                                  std::to_string(a->seed)};
    if (a->threads > 0) args.insert(args.end(), {"--threads", std::to_string(a->threads)});
    if (!a->schedule.empty()) args.insert(args.end(), {"--schedule", a->schedule});
    if (!a->out.empty()) args.insert(args.end(), {"--out", a->out});
    if (!a->digest.empty()) args.insert(args.end(), {"--digest", a->digest});
    if (!a->events.empty()) args.insert(args.end(), {"--events", a->events});
    if (!a->explain.empty()) args.insert(args.end(), {"--explain", a->explain});
    if (a->steps >= 0) args.insert(args.end(), {"--steps", std::to_string(a->steps)});
    if (!a->mode.empty()) args.insert(args.end(), {"--mode", a->mode});
    if (!a->speed.empty()) args.insert(args.end(), {"--speed", a->speed});
    if (!a->device.empty()) args.insert(args.end(), {"--device", a->device});
    if (!a->off.empty()) args.insert(args.end(), {"--off", a->off});
    if (!a->simd.empty()) args.insert(args.end(), {"--simd", a->simd});
    if (c->count("--sweep-alpha") > 0)
      args.insert(args.end(), {"--sweep-alpha", fmt_double(a->sweep_alpha)});
    if (a->time_only) args.emplace_back("--time-only");
    if (a->quiet) args.emplace_back("--quiet");
    const std::string status = temp_path("run.status");
    args.insert(args.end(), {"--status", status});
    if (a->ranks > 0) args = on_ranks(id, impl, a->ranks, args);
    g_status = run_stage_watched(args, {"stage " + id + " (" + impl + ") on " +
                                            fs::path(a->scene).filename().string(),
                                        a->timeout, status, a->ranks});
    fs::remove(status);
    // A run ended from outside (--timeout, a signal) leaves the output it had begun: the runner
    // writes --out's file as FILE.partial and renames it when the run succeeds.
    std::error_code ignored;
    if (g_status != 0 && !a->out.empty()) fs::remove(a->out + ".partial", ignored);
  });
}

}  // namespace plab::cli
