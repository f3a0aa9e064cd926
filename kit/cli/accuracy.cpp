/// \file cli/accuracy.cpp
/// \brief `plab accuracy`: run time against error (stages 06, 07). The options are
/// kit/python/plab/accuracy.py's own (`plab accuracy --help` prints them); the script finds the
/// stage programs with `plab built --json`.
#include "common.hpp"

namespace plab::cli {

void add_accuracy(CLI::App& app) {
  add_python_command(app, "accuracy",
                     "Run time against error: the exact event-driven stage (07) against the "
                     "fastest stepped stage (06) with K substeps per step, in double and float, on "
                     "the CPU and (with a GPU) the GPU; a table, a CSV, a plot. --help for the "
                     "options.",
                     "plab.accuracy", [] {
                       return std::vector<std::string>{"--plab", bin_dir() + "/plab"};
                     });
}

}  // namespace plab::cli
