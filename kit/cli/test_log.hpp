/// \file cli/test_log.hpp
/// \brief Reading CTest's log for `plab test` (test_report.cpp): each test's result line and the
/// output printed after it. No dependency on the rest of the command line, so that the kit's
/// tests read logs with it too.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace plab::cli {

/// One CTest test as its result line and log give it.
struct TestResult {
  std::string name;    //!< e.g. stage01.student.Golden
  std::string status;  //!< Passed, Failed, Skipped, Not Run, Timeout, Exception: ...
  double seconds = 0;
  std::string output;  //!< what it printed (failed tests: from --output-on-failure)
};

/// The test of one CTest result line ("12/199 Test #264: accuracy.short ...   Passed  0.23 sec").
std::optional<TestResult> parse_result_line(const std::string& line);

/// The lines of `text`.
std::vector<std::string> lines_of(const std::string& text);

/// Joins CTest's result lines that its message broke (a failed pass regular expression ending in
/// a newline puts "0.23 sec" on the next line): `line` is added to `partial`, and the whole
/// result line is returned once it is complete. A line that starts no result and continues none
/// comes back as it is; a result still open after five lines is given up and returned as read.
std::optional<std::string> whole_line(std::string& partial, int& pieces, const std::string& line);

/// The tests of CTest's log, each with the output printed after its result line.
std::vector<TestResult> parse_log(const std::string& text);

}  // namespace plab::cli
