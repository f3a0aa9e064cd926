/// \file cli/release.cpp
/// \brief `plab release`: the student version of the kit. The options are kit/python/plab/grade/
/// release.py's own (`plab release --help` prints them), with the kit's own folder as the default
/// checkout to release.
#include <stdexcept>
#include "common.hpp"

namespace plab::cli {

void add_release(CLI::App& app) {
  add_python_command(app, "release",
                     "Write the student version of the kit into a new folder, from git's HEAD: no "
                     "solutions/, no CI, a student README, the reference stage as a compiled "
                     "program, docs built from the copy itself; every stage checked to be its "
                     "untouched starting point. `plab release --out DIR [--through NN]`; --help for "
                     "more.",
                     "plab.grade.release", [] {
    if (default_impl() != "solution")
      throw std::runtime_error("this is already a student copy (it has no solutions/)");
    return std::vector<std::string>{"--kit-source", source_dir()};
  });
}

}  // namespace plab::cli
