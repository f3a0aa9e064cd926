/// \file cli/accuracy.cpp
/// \brief `plab accuracy`: run time against error (stages 06, 07). The options are
/// kit/python/plab/accuracy.py's own: this command hands them over untouched (`plab accuracy
/// --help` prints them); the script finds the stage programs with `plab built --json`.
#include "common.hpp"

namespace plab::cli {

void add_accuracy(CLI::App& app) {
  auto* c = app.add_subcommand(
      "accuracy", "Run time against error: the exact event-driven stage (07) against the fastest "
                  "stepped stage (06) with K substeps per step, in double and float, on the CPU "
                  "and (with a GPU) the GPU; a table, a CSV, a plot. --help for the options.");
  c->prefix_command();  // everything after `accuracy` goes to the script as it was typed
  c->set_help_flag();
  c->callback([c] {
    std::vector<std::string> args{"python3", "-m", "plab.accuracy", "--plab", bin_dir() + "/plab"};
    for (const std::string& s : c->remaining()) args.push_back(s);
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
