/// \file cli/main.cpp
/// \brief `plab`: the kit's command line (run, gen, diff, read, golden, test, docs, demo, bench, render, view).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "commands.hpp"
#include "project.hpp"

int main(int argc, char** argv) {
  // The kit's Python is one package, kit/python/plab: every program a command starts finds it
  // here (`python3 -m plab.grade ...`), without a path of its own.
  const std::string python = plab::cli::source_dir() + "/kit/python";
  const char* given = std::getenv("PYTHONPATH");
  setenv("PYTHONPATH", (given && *given ? python + ":" + given : python).c_str(), 1);
  CLI::App app{"plab: the particle-lab kit. Simulate scenes with any stage, make scenes, compare "
               "outputs, check golden files, run the tests, build the docs."};
  app.name("plab");  // the usage line names the command, not where this machine keeps it
  app.require_subcommand(1);
  plab::cli::add_run(app);
  plab::cli::add_test(app);
  plab::cli::add_diff(app);
  plab::cli::add_render(app);
  plab::cli::add_view(app);
  plab::cli::add_report(app);
  plab::cli::add_bench(app);
  plab::cli::add_gen(app);
  plab::cli::add_read(app);
  plab::cli::add_docs(app);
  plab::cli::add_grade(app);
  plab::cli::add_similar(app);
  plab::cli::add_release(app);
  plab::cli::add_gradescope(app);
  plab::cli::add_golden(app);
  plab::cli::add_demo(app);
  plab::cli::add_built(app);
  plab::cli::add_accuracy(app);
  plab::cli::add_stress(app);
  // The help lists a student's commands first, then the instructor's, then the kit's own tools.
  // A student's copy (no solutions/) lists no instructor's command but `demo` (the compiled
  // reference on the course scenes): the others need the solutions, and say so if called.
  const bool student_copy = plab::cli::default_impl() == "student";
  const char* student = "For students";
  const char* instructor = student_copy ? "" : "For instructors";  // "": not listed
  const char* kit = "The kit's tools";
  for (CLI::App* c : app.get_subcommands({})) {
    const std::string n = c->get_name();
    if (n == "run" || n == "test" || n == "diff" || n == "render" || n == "view" ||
        n == "bench" || n == "report" || n == "gen" || n == "read" || n == "docs" ||
        (n == "demo" && student_copy))
      c->group(student);
    else if (n == "grade" || n == "release" || n == "gradescope" || n == "golden" ||
             n == "similar" || n == "demo")
      c->group(instructor);
    else
      c->group(kit);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help prints and exits 0; a mistake on the command line (a missing file, an unknown
    // option) prints CLI11's message and exits 2, as Python's argparse and the grader's tools do.
    const int printed = app.exit(e);
    return printed == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return plab::cli::exit_status();
}
