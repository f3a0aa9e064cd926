/// \file cli/grade.cpp
/// \brief `plab grade`: the autograder. Its options are the grader's own (kit/python/plab/grade/
/// __main__.py declares them, once): this command hands them to `python3 -m plab.grade`
/// untouched, but for the hidden scenes' seed, which it moves into the environment.
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "project.hpp"

namespace plab::cli {

void add_grade(CLI::App& app) {
  auto* c = app.add_subcommand(
      "grade", "Grade a submission (--submission) or a class (--class DIR): builds its stages "
               "with the kit's own code in a sandbox, runs them there under limits against public "
               "and hidden scenes, one step at a time and for speed, and writes Gradescope's "
               "results.json (with a leaderboard of measured times), JUnit XML and a summary. "
               "Points: kit/grade/rubric.json. `plab grade --help` lists the options.");
  c->prefix_command();  // everything after `grade` goes to the grader as it was typed
  c->set_help_flag();
  c->callback([c] {
    if (default_impl() != "solution")
      throw std::runtime_error(
          "grading needs the instructor's kit (with solutions/). In a student's copy, `./plab "
          "test --impl student --stage NN` checks your stage's output (what the grade checks "
          "first, on scenes of its own too), and handouts/working.md, \"How a stage is "
          "graded\", says how the grade measures each stage's idea outside your code");
    std::vector<std::string> args{"python3",      "-m",         "plab.grade",
                                  "--kit-source", source_dir(), "--kit-build",
                                  build_dir()};
    // The seed goes through the environment, which other users cannot read (a command line
    // can be read by every process of the machine, student code run as another uid included).
    const std::vector<std::string> rest = c->remaining();
    for (std::size_t i = 0; i < rest.size(); ++i) {
      const std::string& s = rest[i];
      const std::size_t eq = s.find('=');
      const std::string name = s.substr(0, eq);
      if (name == "--seed" || name == "--hidden-seed") {
        if (eq == std::string::npos && i + 1 == rest.size())
          throw std::runtime_error("grade: " + s + " needs a value (the hidden scenes' seed)");
        const std::string value = eq == std::string::npos ? rest[++i] : s.substr(eq + 1);
        setenv("PLAB_GRADE_SEED", value.c_str(), 1);
        continue;
      }
      args.push_back(s);
    }
    // In its place (exec): a signal to this process (Ctrl-C, `kill`, a timeout) reaches Python,
    // which stops its own children, and its exit status is this command's
    exec_program(args);
  });
}

}  // namespace plab::cli
