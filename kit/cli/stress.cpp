/// \file cli/stress.cpp
/// \brief `plab stress`: hostile scenes, invariants, pair-time ulps. The options are
/// kit/python/plab/stress.py's own: this command hands them over untouched (`plab stress --help`
/// prints them); the script finds the stage programs with `plab built --json`.
#include "common.hpp"

namespace plab::cli {

void add_stress(CLI::App& app) {
  auto* c = app.add_subcommand(
      "stress", "Numerical stress suite: hostile scenes (corner hits, grazing, extreme speeds and "
                "radii, resting and touching disks, near jamming, a long run) on every stage, "
                "invariants checked at every step, all stages bit-identical; then the pair-time "
                "formula's error in ulps. Exits 1 on any violation. --help for the options.");
  c->prefix_command();  // everything after `stress` goes to the script as it was typed
  c->set_help_flag();
  c->callback([c] {
    std::vector<std::string> args{"python3", "-m", "plab.stress", "--plab", bin_dir() + "/plab"};
    for (const std::string& s : c->remaining()) args.push_back(s);
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
