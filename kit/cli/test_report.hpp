/// \file cli/test_report.hpp
/// \brief `plab test`'s own report: CTest's whole log goes to a file, the screen gets one line per
/// test as it ends, counts that show skips as skips, and for a failing stage a page at most: one
/// line per scene, then the first failure with its step, particle, field, the scene's purpose, the
/// event that should have happened, and the commands that reproduce and draw it.
#pragma once

#include <string>
#include <vector>

namespace plab::cli {

/// What `plab test` ran, for the commands the report prints.
struct TestRun {
  std::vector<std::string> ctest_args;  //!< ctest and its arguments (the tests chosen)
  std::string log_path;                 //!< where CTest's whole log goes
};

/// Runs CTest as `run` says and reports (see the file's brief). Returns 0 when nothing failed.
int run_tests_reported(const TestRun& run);

}  // namespace plab::cli
