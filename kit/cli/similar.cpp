/// \file cli/similar.cpp
/// \brief `plab similar`: a class's submissions of one stage ranked by shared code (copydetect),
/// the starting point ignored. The options are kit/python/plab/similar.py's own (`plab similar
/// --help` prints them).
#include "common.hpp"

namespace plab::cli {

void add_similar(CLI::App& app) {
  add_python_command(app, "similar",
                     "Rank the pairs of a class's submissions of one stage by shared code "
                     "(copydetect: names normalised, the starting point ignored) and write an "
                     "offline HTML page with each pair side by side. `plab similar DIR --stage NN`; "
                     "--help for more.",
                     "plab.similar", [] {
                       return std::vector<std::string>{"--kit", source_dir()};
                     });
}

}  // namespace plab::cli
