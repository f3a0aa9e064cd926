/// \file cli/release.cpp
/// \brief `plab release`: the student version of the kit. The options are kit/python/plab/grade/
/// release.py's own: this command hands them over untouched (`plab release --help` prints them),
/// with the kit's own folder as the default checkout to release.
#include <stdexcept>

#include "common.hpp"

namespace plab::cli {

void add_release(CLI::App& app) {
  auto* c = app.add_subcommand("release", "Write the student version of the kit into a new folder, "
                                          "from git's HEAD: no solutions/, no CI, a student "
                                          "README, the reference stage as a compiled program, "
                                          "docs built from the copy itself; every stage checked "
                                          "to be its untouched starting point. `plab release "
                                          "--out DIR [--through NN]`; --help for more.");
  c->prefix_command();  // everything after `release` goes to the script as it was typed
  c->set_help_flag();
  c->callback([c] {
    if (default_impl() != "solution")
      throw std::runtime_error("this is already a student copy (it has no solutions/)");
    std::vector<std::string> args{"python3", "-m", "plab.grade.release", "--kit-source",
                                  source_dir()};
    for (const std::string& s : c->remaining()) args.push_back(s);
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
