/// \file cli/gen.cpp
/// \brief `plab gen`: write a reproducible random scene.
#include "common.hpp"

namespace plab::cli {

void add_gen(CLI::App& app) {
  auto g = std::make_shared<GenParams>();
  auto mode = std::make_shared<std::string>("print");
  auto speed = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  g->seed = kDefaultSeed;
  auto* c = app.add_subcommand("gen", "Write a random scene (model.md's Generation): the same bits "
                                      "on every platform for the same arguments.");
  c->add_option("--n", g->n, "number of particles")->required()->check(CLI::PositiveNumber);
  c->add_option("--l", g->L, "box side L")->required()->check(CLI::PositiveNumber);
  c->add_option("--r", g->r, "radius r")->required()->check(CLI::PositiveNumber);
  c->add_option("--steps", g->steps, "steps S")->required()->check(CLI::NonNegativeNumber);
  c->add_option("--mode", *mode, "print or perf")->check(CLI::IsMember({"print", "perf"}))
      ->capture_default_str();
  c->add_option("--seed", g->seed, "generator seed")->capture_default_str();
  c->add_option("--speed", *speed, "speed range MIN:MAX (default: L/(8r) to L/4)");
  c->add_option("--out", *out, "write the scene to this file instead of stdout");
  c->callback([g, mode, speed, out] {
    Scene s;
    s.box = Box{g->L, g->r};
    if (!(s.box.L > 2 * s.box.r)) throw std::runtime_error("--l must be larger than 2 * --r");
    s.steps = g->steps;
    s.mode = *mode == "perf" ? Mode::kPerf : Mode::kPrint;
    SpeedRange range = default_speeds(s.box);
    if (!speed->empty()) range = parse_speed_range(*speed);
    s.particles = generate(s.box, static_cast<std::size_t>(g->n), g->seed, range);
    write_text(*out, format_scene(s));
  });
}

}  // namespace plab::cli
