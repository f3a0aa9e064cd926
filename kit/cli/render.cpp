/// \file cli/render.cpp
/// \brief `plab render`: animate a run, or two outputs side by side.
#include "common.hpp"

namespace plab::cli {

void add_render(CLI::App& app) {
  struct Args {
    std::string scene, stage = "02", impl, steps, out, mark, from;
    std::vector<std::string> diff;
    int follow = -1;
    double fps = 4;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "render", "Animate a run: the box, the disks at their true radius, one frame per step, "
                "collisions marked (orange: wall, red: pair). With --diff, two outputs side by "
                "side and their first difference ringed.");
  c->add_option("scene", a->scene, "scene file (with --diff: only its L and r are used)")
      ->required()->check(CLI::ExistingFile);
  c->add_option("--stage", a->stage, "stage that runs the scene")->capture_default_str();
  c->add_option("--impl", a->impl, "solution, student or engine (default as for run)");
  c->add_option("--steps", a->steps, "FIRST:LAST steps to draw (default 0:20; with --diff, "
                                     "around the first difference)");
  c->add_option("--follow", a->follow, "highlight this particle and draw its path");
  c->add_option("--from", a->from, "draw this print-mode output (a golden file, yours) instead "
                                   "of running a stage")->check(CLI::ExistingFile);
  c->add_option("--diff", a->diff, "EXPECTED ACTUAL: two print-mode outputs to compare")
      ->expected(2)->check(CLI::ExistingFile);
  c->add_option("--fps", a->fps, "frames per second")->capture_default_str();
  c->add_option("--out", a->out, "FILE.gif or FILE.mp4 (animation), FILE.svg or FILE.png (one "
                                 "frame); default: the scene's name with .gif");
  c->callback([a] {
    const Scene scene = load_scene(a->scene, kDefaultSeed);
    std::string out = a->out;
    if (out.empty()) out = fs::path(a->scene).stem().string() + ".gif";
    std::vector<std::string> args{"python3", "-m", "plab.render",
                                  "--box", fmt_double(scene.box.L), "--radius",
                                  fmt_double(scene.box.r), "--out", out, "--fps",
                                  fmt_double(a->fps), "--plab", bin_dir() + "/plab"};
    if (a->follow >= 0) args.insert(args.end(), {"--follow", std::to_string(a->follow)});
    std::string steps = a->steps;
    if (!a->diff.empty()) {
      const auto d = first_difference(read_file(a->diff[0]), read_file(a->diff[1]));
      if (d) {
        std::printf("%s\n", d->describe().c_str());
        const long step = std::stol(d->step);
        if (steps.empty())  // a few steps before, and the next one (to show its collisions)
          steps = std::to_string(std::max(0L, step - 8)) + ":" +
                  std::to_string(step < scene.steps ? step + 1 : step);
        if (!d->particle.empty())
          args.insert(args.end(),
                      {"--mark", d->step + ":" + d->particle + ":first difference: step " +
                                     d->step + ", particle " + d->particle + ", " + d->field +
                                     ": expected " + d->expected + ", got " + d->actual});
      } else {
        std::printf("the two outputs are equal\n");
      }
      args.insert(args.end(), {"--output", a->diff[0], "--label", "expected: " + a->diff[0],
                               "--output", a->diff[1], "--label", "actual: " + a->diff[1]});
    } else if (!a->from.empty()) {
      if (steps.empty()) steps = "0:" + std::to_string(std::min(scene.steps, 20LL));
      args.insert(args.end(), {"--output", a->from, "--label", a->from});
    } else {
      const std::string impl = a->impl.empty() ? default_impl() : a->impl;
      check_impl(impl);
      if (steps.empty()) steps = "0:" + std::to_string(std::min(scene.steps, 20LL));
      const long long last = std::stoll(steps.substr(steps.find(':') + 1));
      const std::string output = temp_path("render.out");
      const std::string events = temp_path("render.events");
      const int rc = run_program({require_stage(two_digits(a->stage), impl), a->scene, "--quiet",
                                  "--mode", "print", "--steps", std::to_string(last), "--out",
                                  output, "--events", events});
      if (rc != 0) throw std::runtime_error("stage " + a->stage + " failed on " + a->scene);
      args.insert(args.end(), {"--output", output, "--events", events, "--label",
                               "stage " + two_digits(a->stage) + " (" + impl + "), " +
                                   fs::path(a->scene).filename().string()});
    }
    args.insert(args.end(), {"--steps", steps});
    g_status = run_program(args);
    if (g_status == 0) std::printf("wrote %s (steps %s)\n", out.c_str(), steps.c_str());
  });
}

}  // namespace plab::cli
