/// \file cli/accuracy.cpp
/// \brief `plab accuracy`: run time against error (stages 06, 07).
#include "common.hpp"

namespace plab::cli {

void add_accuracy(CLI::App& app) {
  struct Args {
    std::vector<std::string> scenes;
    std::string csv, plot, stepped = "06";
    int max_k = 64;
    long long steps = 0;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "accuracy", "Run time against error: the exact event-driven stage (07) against the fastest "
                  "stepped stage (06) with K substeps per step (K = 1, 2, 4, ... 64), in double and "
                  "float, on the CPU and (with a GPU) the GPU: collisions missed, overlaps, "
                  "position error after 1, 2 and 4 steps, energy drift; a table, a CSV, a plot.");
  c->add_option("--scene", a->scenes, "report, dense-gas, cradle (default: all three)")
      ->delimiter(',');
  c->add_option("--max-k", a->max_k, "largest number of substeps (powers of two up to it)")
      ->capture_default_str()->check(CLI::Range(1, 1024));
  c->add_option("--steps", a->steps, "printed steps of the generated scenes (default 8)");
  c->add_option("--csv", a->csv, "write the table as CSV here");
  c->add_option("--plot", a->plot, "draw time against error here (PNG or SVG)");
  c->callback([a] {
    // The stepped stage's float path: the kit's engine (kit/instructor/engine) where it has that
    // stage, else its solution.
    bool engine = false;
    for (const StageDir& s : stages("engine")) engine = engine || s.id == a->stepped;
    const Manifest m = load_manifest(source_dir() + "/datasets");
    if (m.exact_stage.empty()) throw std::runtime_error("the manifest names no exact stage");
    std::vector<std::string> args{"python3", "-m", "plab.accuracy",
                                  "--stepped",
                                  require_stage(a->stepped, engine ? "engine" : "solution"),
                                  "--exact", require_stage(m.exact_stage, "solution"),
                                  "--plab", bin_dir() + "/plab", "--datasets", source_dir() + "/datasets",
                                  "--work", build_dir() + "/accuracy", "--max-k", std::to_string(a->max_k),
                                  "--figures", source_dir() + "/handouts/figures"};
    for (const auto& s : a->scenes) args.insert(args.end(), {"--scene", s});
    if (a->steps > 0) args.insert(args.end(), {"--steps", std::to_string(a->steps)});
    if (!a->csv.empty()) args.insert(args.end(), {"--csv", a->csv});
    if (!a->plot.empty()) args.insert(args.end(), {"--plot", a->plot});
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
