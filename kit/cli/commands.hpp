/// \file cli/commands.hpp
/// \brief The `plab` subcommands, each registered on the CLI11 app by one function, each in a
/// file of its own: `plab NAME` is kit/cli/NAME.cpp (helpers they share: common.hpp).
#pragma once

#include <CLI/CLI.hpp>

namespace plab::cli {

void add_run(CLI::App& app);     //!< `plab run`: simulate a scene with one stage
void add_built(CLI::App& app);   //!< `plab built`: is a stage built from its current code?
void add_render(CLI::App& app);  //!< `plab render`: animate a run, or two outputs side by side
void add_view(CLI::App& app);    //!< `plab view`: a run (or two compared) as one offline HTML page
void add_grade(CLI::App& app);   //!< `plab grade`: the autograder
void add_release(CLI::App& app);  //!< `plab release`: the student version of the kit
void add_gradescope(CLI::App& app);  //!< `plab gradescope`: the autograder zip
void add_accuracy(CLI::App& app); //!< `plab accuracy`: run time against error (stages 06, 07)
void add_stress(CLI::App& app);   //!< `plab stress`: hostile scenes, invariants, pair-time ulps
void add_gen(CLI::App& app);     //!< `plab gen`: write a reproducible random scene
void add_diff(CLI::App& app);    //!< `plab diff`: where two outputs first differ
void add_read(CLI::App& app);    //!< `plab read`: a scene, output or events file as JSON
void add_golden(CLI::App& app);  //!< `plab golden`: regenerate or check the golden files
void add_test(CLI::App& app);    //!< `plab test`: run the test suite with CTest
void add_docs(CLI::App& app);    //!< `plab docs`: build the HTML docs with Doxygen
void add_demo(CLI::App& app);    //!< `plab demo`: the reference on the course and demo scenes
void add_bench(CLI::App& app);   //!< `plab bench`: timings, medians, speedups, CSV
void add_similar(CLI::App& app); //!< `plab similar`: submissions ranked by shared code
void add_report(CLI::App& app);  //!< `plab report`: the student's report skeleton, figures included

/// The exit status the chosen subcommand asked for.
int exit_status();

}  // namespace plab::cli
