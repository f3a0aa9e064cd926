/// \file cli/report.cpp
/// \brief `plab report`: the student's report skeleton: their own stage timed on this machine over
/// sizes and thread (or rank) counts, tables and figures, and the handout's questions. The options
/// are kit/python/plab/report.py's own (`plab report --help` prints them); the script times the
/// stage with `plab bench`.
#include "common.hpp"

namespace plab::cli {

void add_report(CLI::App& app) {
  add_python_command(app, "report",
                     "Write your report's skeleton for a stage: runs the stage (yours by default in "
                     "a student copy) on this machine over sizes and thread or rank counts, and "
                     "writes OUT/report.md with the machine's description, tables, figures (time "
                     "against N, speedup, efficiency) and the handout's questions. `plab report "
                     "--stage NN`; --help for more.",
                     "plab.report", [] {
                       return std::vector<std::string>{"--plab", bin_dir() + "/plab"};
                     });
}

}  // namespace plab::cli
