/// \file cli/gradescope.cpp
/// \brief `plab gradescope`: Gradescope's autograder zip (setup.sh, run_autograder and the kit).
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "project.hpp"

namespace plab::cli {

void add_gradescope(CLI::App& app) {
  auto out = std::make_shared<std::string>("autograder.zip");
  auto* c = app.add_subcommand(
      "gradescope",
      "Write Gradescope's autograder zip: setup.sh and run_autograder at its root (from "
      "kit/grade/gradescope/) and this kit as git tracks it, solutions included. On Gradescope, "
      "setup.sh installs the Debian packages, builds the kit and makes it readable by root only; "
      "run_autograder grades /autograder/submission (every stage it has, or --stages; a random "
      "hidden seed) "
      "into /autograder/results/results.json. See handouts/instructors.md.");
  c->add_option("--out", *out, "the zip to write")->capture_default_str();
  auto stages = std::make_shared<std::string>();
  c->add_option("--stages", *stages,
                "grade these stages only, e.g. 01,02,03 (one autograder per assignment: a "
                "student who uploads the whole kit is not graded on the untouched later stages); "
                "default: every stage the upload has");
  c->callback([out, stages] {
    if (default_impl() != "solution")
      throw std::runtime_error("the autograder needs the instructor's kit (with solutions/)");
    std::vector<std::string> argv{"python3", "-m", "plab.grade.gradescope", "--kit-source",
                                  source_dir(), "--out", *out};
    if (!stages->empty()) argv.insert(argv.end(), {"--stages", *stages});
    exec_program(argv);
  });
}

}  // namespace plab::cli
