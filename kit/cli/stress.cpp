/// \file cli/stress.cpp
/// \brief `plab stress`: hostile scenes, invariants, pair-time ulps. The options are
/// kit/python/plab/stress.py's own (`plab stress --help` prints them); the script finds the stage
/// programs with `plab built --json`.
#include "common.hpp"

namespace plab::cli {

void add_stress(CLI::App& app) {
  add_python_command(app, "stress",
                     "Numerical stress suite: hostile scenes (corner hits, grazing, extreme speeds "
                     "and radii, resting and touching disks, near jamming, a long run) on every "
                     "stage, invariants checked at every step, all stages bit-identical; then the "
                     "pair-time formula's error in ulps. Exits 1 on any violation. --help for the "
                     "options.",
                     "plab.stress", [] {
                       return std::vector<std::string>{"--plab", bin_dir() + "/plab"};
                     });
}

}  // namespace plab::cli
