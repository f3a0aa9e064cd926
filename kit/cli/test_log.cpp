/// \file cli/test_log.cpp
/// \brief Reading CTest's log (test_log.hpp).
#include "test_log.hpp"

#include <regex>
#include <sstream>

namespace plab::cli {

std::optional<TestResult> parse_result_line(const std::string& line) {
  static const std::regex re(R"(^\s*\d+/\d+ Test\s+#\d+: (\S+) \.*\s*(?:\*\*\*)?(.*?)\s+([0-9.]+) sec\s*$)");
  std::smatch m;
  if (!std::regex_match(line, m, re)) return std::nullopt;
  TestResult r{m[1], m[2], std::stod(m[3]), ""};
  // "Failed  Required regular expression not found. Regex=[...]": the status, then why
  if (r.status.rfind("Failed ", 0) == 0) {
    r.output = r.status.substr(r.status.find_first_not_of(' ', 6)) + "\n";
    r.status = "Failed";
  }
  return r;
}

std::optional<std::string> whole_line(std::string& partial, int& pieces, const std::string& line) {
  static const std::regex head(R"(^\s*\d+/\d+ Test\s+#\d+: \S+ )");
  if (partial.empty() && !std::regex_search(line, head)) return line;
  partial += partial.empty() ? line : " " + line;
  ++pieces;
  if (!parse_result_line(partial) && pieces < 5) return std::nullopt;
  std::string whole;
  whole.swap(partial);
  pieces = 0;
  return whole;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

std::vector<TestResult> parse_log(const std::string& text) {
  std::vector<TestResult> tests;
  bool in_output = false;
  std::string partial;
  int pieces = 0;
  for (const std::string& piece : lines_of(text)) {
    const std::optional<std::string> whole = whole_line(partial, pieces, piece);
    if (!whole) continue;
    const std::string& line = *whole;
    if (auto r = parse_result_line(line)) {
      tests.push_back(*r);
      in_output = r->status != "Passed" && r->status != "Skipped";
      continue;
    }
    if (line.find("% tests passed") != std::string::npos) in_output = false;
    // CTest's "Start N: NAME" of another test, printed amid a failed test's output (ctest -j)
    static const std::regex start_line(R"(^\s*Start\s+\d+: \S+\s*$)");
    if (in_output && !std::regex_match(line, start_line)) tests.back().output += line + "\n";
  }
  return tests;
}

}  // namespace plab::cli
