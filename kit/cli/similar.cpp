/// \file cli/similar.cpp
/// \brief `plab similar`: a class's submissions of one stage ranked by shared code (copydetect),
/// the starting point ignored. The options are kit/python/plab/similar.py's own: this command hands it
/// its arguments untouched (`plab similar --help` prints them).
#include "common.hpp"

namespace plab::cli {

void add_similar(CLI::App& app) {
  auto* c = app.add_subcommand(
      "similar", "Rank the pairs of a class's submissions of one stage by shared code (copydetect: "
                 "names normalised, the starting point ignored) and write an offline HTML page "
                 "with each pair side by side. `plab similar DIR --stage NN`; --help for more.");
  c->prefix_command();  // everything after `similar` goes to the script as it was typed
  c->set_help_flag();
  c->callback([c] {
    std::vector<std::string> args{"python3", "-m", "plab.similar", "--kit",
                                  source_dir()};
    for (const std::string& s : c->remaining()) args.push_back(s);
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
