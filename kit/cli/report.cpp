/// \file cli/report.cpp
/// \brief `plab report`: the student's report skeleton: their own stage timed on this machine over
/// sizes and thread (or rank) counts, tables and figures, and the handout's questions. The options
/// are kit/python/plab/report.py's own: this command hands them over untouched (`plab report
/// --help` prints them); the script times the stage with `plab bench`.
#include "common.hpp"

namespace plab::cli {

void add_report(CLI::App& app) {
  auto* c = app.add_subcommand(
      "report", "Write your report's skeleton for a stage: runs the stage (yours by default in a "
                "student copy) on this machine over sizes and thread or rank counts, and writes "
                "OUT/report.md with the machine's description, tables, figures (time against N, "
                "speedup, efficiency) and the handout's questions. `plab report --stage NN`; "
                "--help for more.");
  c->prefix_command();  // everything after `report` goes to the script as it was typed
  c->set_help_flag();
  c->callback([c] {
    std::vector<std::string> args{"python3", "-m", "plab.report", "--plab", bin_dir() + "/plab"};
    for (const std::string& s : c->remaining()) args.push_back(s);
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
