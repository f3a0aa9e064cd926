/// \file cli/test_report.cpp
/// \brief run_tests_reported(): CTest under `plab test`, its log in a file, a short report.
#include "test_report.hpp"

#include "test_log.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "plab/datasets.hpp"
#include "project.hpp"

namespace plab::cli {
namespace fs = std::filesystem;
namespace {

/// One GoogleTest case inside a test's output.
struct Case {
  std::string name;     //!< the part after the last '/', e.g. course_2
  std::string status;   //!< passed, failed, skipped, or stopped (no end line)
  std::string message;  //!< its failure or skip text
};

/// The first difference as `plab diff` described it inside a failure message.
struct Found {
  std::string step, particle, field, expected, actual, lines;
};

/// Each skipped test's reason ("plab: no case was checked ...") from CTest's LastTest.log.
std::map<std::string, std::string> skip_reasons(const std::vector<TestResult>& tests) {
  std::map<std::string, std::string> reasons;
  std::ifstream in(build_dir() + "/Testing/Temporary/LastTest.log");
  std::ostringstream all;
  all << in.rdbuf();
  const std::string log = all.str();
  for (const TestResult& t : tests) {
    if (t.status != "Skipped") continue;
    const auto at = log.find(" Test: " + t.name + "\n");
    const auto said = at == std::string::npos ? at : log.find("plab: no case was checked", at);
    const auto end = log.find("<end of output>", at == std::string::npos ? 0 : at);
    if (said == std::string::npos || said > end) continue;
    std::string reason = log.substr(said, log.find('\n', said) - said);
    reasons[t.name] = reason.substr(reason.find(": ", 25) + 2);
  }
  return reasons;
}

std::vector<Case> gtest_cases(const std::string& output) {
  std::vector<Case> cases;
  bool open = false;
  for (const std::string& line : lines_of(output)) {
    if (line.rfind("[ RUN      ] ", 0) == 0) {
      const auto slash = line.rfind('/');
      cases.push_back({line.substr(slash == std::string::npos ? 13 : slash + 1), "stopped", ""});
      open = true;
    } else if (open && line.rfind("[       OK ] ", 0) == 0) {
      cases.back().status = "passed";
      open = false;
    } else if (open && line.rfind("[  FAILED  ] ", 0) == 0) {
      cases.back().status = "failed";
      open = false;
    } else if (open && line.rfind("[  SKIPPED ] ", 0) == 0) {
      cases.back().status = "skipped";
      open = false;
    } else if (open && !line.empty() && line[0] != '[' && line.find(": Failure") == std::string::npos &&
               line.find(": Skipped") == std::string::npos) {
      cases.back().message += line + "\n";
    }
  }
  return cases;
}

std::optional<Found> find_difference(const std::string& message) {
  static const std::regex re(
      R"(first difference at line \d+: step (\S+?),(?: particle (\S+?),)? field (\S+)\n\s*expected: (.*)\n\s*actual:\s*(.*)\n(\d+ lines? differs?))");
  std::smatch m;
  if (!std::regex_search(message, m, re)) return std::nullopt;
  return Found{m[1], m[2], m[3], m[4], m[5], m[6]};
}

std::string first_line(const std::string& text) { return text.substr(0, text.find('\n')); }

/// How many ranks a failure message says its run was on (a stage on several processes:
/// tests/stage_test.cpp's "run here on 3 ranks", "(on 3 ranks)"), 0 when it says none.
int ranks_in(const std::string& message) {
  static const std::regex re(R"(\bon (\d+) ranks?\b)");
  std::smatch m;
  return std::regex_search(message, m, re) ? std::atoi(m[1].str().c_str()) : 0;
}

/// ", on 3 ranks" when a failure message says on how many ranks its run was, else "".
std::string ranks_of(const std::string& message) {
  const int ranks = ranks_in(message);
  return ranks ? ", on " + std::to_string(ranks) + (ranks == 1 ? " rank" : " ranks") : "";
}

/// " --ranks 3" when a failure message says its run was on several ranks, else "": the
/// reproduce commands then run the same (on one rank a stage on several processes may print the
/// reference's output, and `plab diff` says `equal`).
std::string ranks_option(const std::string& message) {
  const int ranks = ranks_in(message);
  return ranks > 1 ? " --ranks " + std::to_string(ranks) : "";
}

/// A failing case's lines, the reason first: GoogleTest prints "Failed" before the reason of
/// ADD_FAILURE() << "why" and FAIL() << "why", and what the programs the case ran printed (mpirun's
/// notes on a crashed rank) comes before it. Without that line, the lines as they are.
/// GoogleTest's words around an exception's message ("C++ exception with description "..." thrown
/// in the test body.") are dropped: a starting point's "EXERCISE 1 ... is not done yet" reads as
/// itself.
std::vector<std::string> message_lines(const std::string& message) {
  static const std::regex thrown(R"re(^C\+\+ exception with description "(.*)" thrown in the test body\.$)re");
  std::vector<std::string> lines = lines_of(message);
  for (std::string& line : lines) line = std::regex_replace(line, thrown, "$1");
  const auto at = std::find(lines.begin(), lines.end(), "Failed");
  if (at == lines.end() || at + 1 == lines.end()) return lines;
  std::vector<std::string> ordered(at + 1, lines.end());
  ordered.insert(ordered.end(), lines.begin(), at);
  return ordered;
}

/// A failure message on one line: its first line, and when that line only announces what follows
/// (GoogleTest's "Expected equality of these values:", "Value of: ok" then "Actual: false"), the
/// lines that say which values, joined ("a, which is 3; b, which is 4"): at most 6 lines.
std::string failure_line(const std::string& message) {
  const std::vector<std::string> lines = message_lines(message);
  if (lines.empty()) return "(no message)";
  std::string out = lines[0];
  const bool announces = out.ends_with(':') || out.starts_with("Value of:") ||
                         out.starts_with("Expected:") || out.starts_with("The difference between");
  if (!announces) return out;
  for (std::size_t i = 1; i < lines.size() && i <= 6; ++i) {
    const std::size_t from = lines[i].find_first_not_of(' ');
    if (from == std::string::npos) break;
    const std::string line = lines[i].substr(from);
    if (line.starts_with("Which is: "))
      out += ", which is " + line.substr(10);
    else
      out += (out.ends_with(':') ? " " : "; ") + line;
  }
  return out;
}

/// A path as the student types it: relative to the working folder when inside it.
std::string shown_path(const std::string& path) {
  const fs::path rel = fs::path(path).lexically_relative(fs::current_path());
  return !rel.empty() && rel.begin()->string() != ".." ? rel.string() : path;
}

/// The manifest's scene whose test-name form (non-alphanumerics as '_') is `case_name`.
std::optional<Dataset> scene_of(const Manifest& m, const std::string& case_name) {
  for (const Dataset& d : m.datasets) {
    std::string s = d.name;
    for (char& c : s)
      if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    if (s == case_name) return d;
  }
  return std::nullopt;
}

/// The line a perf-mode golden failure adds (tests/stage_test.cpp): the first step whose digest
/// differs.
const std::regex& first_bad() {
  static const std::regex re(R"(the state first differs after step (\d+))");
  return re;
}

/// One line per case: a scene's name and "passed" or its first difference; skips grouped.
/// When every case that ran failed with the same message and no difference (a starting point's
/// "not done yet", a stage that throws), one line says so instead of one a scene.
void print_cases(const std::vector<Case>& cases, const Manifest& m) {
  std::map<std::string, std::pair<int, std::string>> skipped;
  std::set<std::string> reasons;
  int ran = 0;
  for (const Case& c : cases) {
    if (c.status == "skipped") continue;
    ++ran;
    reasons.insert(c.status == "failed" && !find_difference(c.message) ? failure_line(c.message)
                                                                        : "");
  }
  const bool same = ran > 1 && reasons.size() == 1 && !reasons.begin()->empty();
  if (same)
    std::printf("    all %d scenes failed: %s\n", ran, reasons.begin()->c_str());
  // At most kShown scenes a line (the first failure's page follows); the rest counted
  constexpr int kShown = 12;
  int shown = 0, more_failed = 0, more_passed = 0;
  for (const Case& c : cases) {
    if (same && c.status != "skipped") continue;
    if (c.status != "skipped" && shown == kShown) {
      (c.status == "passed" ? more_passed : more_failed) += 1;
      continue;
    }
    const auto d = scene_of(m, c.name);
    const std::string name = d ? d->name : c.name;
    if (c.status == "skipped") {
      // One line for skips that differ only in their numbers (N = 300, N = 1000, ...).
      auto& [n, example] = skipped[std::regex_replace(first_line(c.message), std::regex("[0-9]+"), "#")];
      if (n++ == 0) example = first_line(c.message);
      continue;
    }
    std::string what = c.status;
    if (const auto f = find_difference(c.message)) {
      what = "step " + f->step + (f->particle.empty() ? "" : ", particle " + f->particle) + ", " +
             f->field + ": expected " + f->expected + ", got " + f->actual;
      if (std::smatch k; std::regex_search(c.message, k, first_bad()) && k[1].str() != f->step)
        what = "wrong from step " + k[1].str() + " (digests); printed " + what;
    }
    else if (c.status == "failed")
      what = "failed: " + failure_line(c.message);
    std::printf("    %-22s %s\n", name.c_str(), what.c_str());
    ++shown;
  }
  if (more_failed + more_passed > 0)
    std::printf("    ... %d more: %d failed, %d passed (each in the whole log)\n",
                more_failed + more_passed, more_failed, more_passed);
  for (const auto& [key, skip] : skipped)
    std::printf("    %d skipped%s: %s\n", skip.first, skip.first > 1 ? ", e.g." : "",
                skip.second.c_str());
}

/// Whether a test compares a stage's output with golden files: a test per scene (`.Golden`) or
/// one over every scene (stage 07's `.ExactGolden`). Its failures name a scene to reproduce, so
/// the first failure's page goes to them before a statistical or invariant test's.
bool is_golden(const std::string& test) {
  return test.find(".Golden") != std::string::npos ||
         test.find(".ExactGolden") != std::string::npos;
}

/// The scenes a test over every scene names before their differences ("dense-box: first
/// difference ..."), in order.
std::vector<std::string> named_scenes(const std::string& message) {
  static const std::regex named(R"((?:^|\n)([\w.-]+): first difference)");
  std::vector<std::string> names;
  for (std::sregex_iterator i(message.begin(), message.end(), named), end; i != end; ++i)
    names.push_back((*i)[1].str());
  return names;
}

/// One line for a test that is not per scene: how many cases failed, and the first one (with
/// its scene, and the other scenes that differ, for a test over every scene).
void print_summary(const std::string& head, const std::vector<Case>& cases) {
  int failed = 0, skipped = 0, after_stall = 0;
  const Case* first = nullptr;
  for (const Case& c : cases) {
    if (c.status == "failed" && failed++ == 0) first = &c;
    skipped += c.status == "skipped";
    // (tests/stage_test.cpp's PLAB_SKIP_AFTER_STALL: the cases after ranks that waited for ever)
    after_stall +=
        c.status == "skipped" && c.message.find("ranks waited for ever") != std::string::npos;
  }
  std::string what;
  if (first) {
    const auto f = find_difference(first->message);
    const std::string why =
        after_stall > 0 ? ", " + std::to_string(after_stall) +
                              " of them not run once ranks had waited for ever"
                        : "";
    what = ": " + std::to_string(failed) + " of " + std::to_string(cases.size()) +
           " cases failed" +
           (skipped ? " (" + std::to_string(skipped) + " skipped" + why + ")" : "") +
           ", first " + first->name + ": " +
           (f ? "step " + f->step + (f->particle.empty() ? "" : ", particle " + f->particle) +
                    ", " + f->field + ranks_of(first->message)
              : failure_line(first->message));
    const std::vector<std::string> scenes = named_scenes(first->message);
    if (f && !scenes.empty()) {
      what.insert(what.find(": step ") + 2, "scene " + scenes[0] + ", ");
      std::string all;
      for (const std::string& name : scenes) all += (all.empty() ? "" : ", ") + name;
      what += " (" + std::to_string(scenes.size()) +
              (scenes.size() == 1 ? " scene differs: " : " scenes differ: ") + all + ")";
    }
    // The other failed cases by name: a spec's names are its rules ("NothingAtOrAfterOneIsPushed"),
    // and the first in the file's order is not always the one that points at the mistake
    std::string others;
    int listed = 0;
    for (const Case& c : cases)
      if (c.status == "failed" && &c != first && listed++ < 5)
        others += (others.empty() ? "" : ", ") + c.name;
    if (failed > 6) others += ", ...";
    if (!others.empty()) what += "; also failed: " + others;
  }
  std::printf("%s%s\n", head.c_str(), what.c_str());
}

/// The test's own explanation when it stopped it (watchdog, build check), or why the program
/// ended (an exception that left an OpenMP region ends it through std::terminate, whose `what():`
/// line holds the message, e.g. a starting point's "EXERCISE 1 ... is not done yet"), or nothing.
std::string stop_message(const std::string& output) {
  static const std::string what = "what():";
  for (const std::string& line : lines_of(output)) {
    if (line.find("an endless loop?") != std::string::npos ||
        line.find("did not compile") != std::string::npos ||
        line.find("is not built from its current code") != std::string::npos ||
        line.find("is refused, as the grader refuses it") != std::string::npos)
      return line;
    const std::size_t at = line.find(what);
    if (at != std::string::npos) {
      const std::size_t from = line.find_first_not_of(' ', at + what.size());
      return "the program ended on an uncaught exception: " +
             (from == std::string::npos ? std::string("(no message)") : line.substr(from));
    }
  }
  return "";
}

/// Where the first failing case of a stage's test can be seen and drawn.
struct FirstFailure {
  std::string id, impl, test;
  Case c;
};

/// What explains a step's events (the kit's oracle), as a command prefix and as a program: the
/// stage's own program in the instructor's copy (its runner links the oracle), the compiled
/// reference in a student copy (kit/reference/bin, built by `plab release`), or nothing.
struct Explainer {
  std::string command;  //!< printed: `... SCENE --explain K:I` follows
  std::string program;  //!< run for the oracle's line ("" when there is none)
};
Explainer explainer(const FirstFailure& f, const std::string& scene) {
  const fs::path kit = source_dir();
  if (fs::is_directory(kit / "kit" / "instructor"))
    return {"./plab run --stage " + f.id + " --impl " + f.impl + " " + scene,
            stage_program(f.id, f.impl)};
  const fs::path reference = kit / "kit" / "reference" / "bin" / "plab-reference";
  if (fs::exists(reference)) return {"kit/reference/bin/plab-reference " + scene, reference};
  return {"", ""};
}

/// The command that plays the failing run against `expected` in the browser (`name`.html): the
/// stage run by plab view on one process, or, for a run on several ranks, the output `mine.out`
/// that the reproduce commands wrote (on one process the stage may print the expected text).
void print_play(const FirstFailure& f, const std::string& scene, const std::string& expected,
                const std::string& name) {
  if (ranks_option(f.c.message).empty())
    std::printf("  play it:  ./plab view %s --stage %s --impl %s --compare %s --out %s.html\n",
                scene.c_str(), f.id.c_str(), f.impl.c_str(), expected.c_str(), name.c_str());
  else
    std::printf("  play it:  ./plab view mine.out --scene %s --compare %s --out %s.html\n",
                scene.c_str(), expected.c_str(), name.c_str());
}

/// The reproduce and draw commands (and the event that should have happened) for a golden scene.
void explain_golden(const FirstFailure& f, const Dataset& d, const Manifest& m, const Found& diff) {
  const std::string scene = shown_path(m.scene_path(d));
  const std::string golden = shown_path(m.golden_path(d));
  const std::string run = "./plab run --stage " + f.id + " --impl " + f.impl +
                          ranks_option(f.c.message) + " " + scene;
  std::printf("  the scene: %s\n", d.tests.c_str());
  // A threaded stage's race changes the output from run to run: the commands below may then
  // print `equal`, which reads as a contradiction without this line.
  if (f.impl != "engine" && stage_declares(f.id, f.impl, "needs_openmp") == true)
    std::printf("  (if the commands below print `equal`, the difference comes and goes between "
                "runs: often a data race, ./plab test --impl %s --stage %s --races)\n",
                f.impl.c_str(), f.id.c_str());
  const long long step = std::atoll(diff.step.c_str());
  const std::string explain = std::to_string(step > 0 ? step - 1 : 0) + ":" + diff.particle;
  const Explainer how = explainer(f, scene);
  if (std::smatch k; std::regex_search(f.c.message, k, first_bad()) && k[1].str() != diff.step) {
    // A perf-mode scene prints its last step only: the oracle's line there would explain the
    // wrong step. The digests name the first wrong one; print mode shows its particle.
    const std::string bad = k[1].str();
    std::printf("  the state first differs after step %s (the per-step digests: this perf-mode "
                "scene prints only its first and last steps)\n", bad.c_str());
    std::printf("  see that step, particle by particle:\n    %s --steps %s --mode print --out "
                "mine.out\n", run.c_str(), bad.c_str());
    // The same steps printed by the reference: its solution here, the compiled one in a student
    // copy (explainer()'s second case).
    const std::string reference =
        fs::is_directory(fs::path(source_dir()) / "solutions")
            ? "./plab run --stage " + m.reference_stage + " --impl solution " + scene
            : how.command;
    if (!reference.empty())
      std::printf("    %s --steps %s --mode print --out expected.out\n    ./plab diff "
                  "expected.out mine.out      # names the particle I\n",
                  reference.c_str(), bad.c_str());
    if (!how.command.empty())
      std::printf("    %s --explain %lld:I\n", how.command.c_str(), std::atoll(bad.c_str()) - 1);
    return;
  }
  if (!diff.particle.empty() && !how.program.empty()) {
    const Captured c = capture_program({how.program, m.scene_path(d), "--explain", explain});
    if (c.status == 0)
      std::printf("  what should happen from step %lld to %s (the kit's oracle): %s\n",
                  step > 0 ? step - 1 : 0, diff.step.c_str(), first_line(c.text).c_str());
  }
  std::printf("  reproduce it:\n    %s --out mine.out\n    ./plab diff %s mine.out\n", run.c_str(),
              golden.c_str());
  if (!diff.particle.empty() && !how.command.empty())
    std::printf("    %s --explain %s\n", how.command.c_str(), explain.c_str());
  // Two lines, a label and a command each (the report stays short): a GIF, and a page to play,
  // click and compare in the browser.
  std::printf("  draw it:  ./plab render %s --diff %s mine.out --out %s-diff.gif\n",
              scene.c_str(), golden.c_str(), d.name.c_str());
  print_play(f, scene, golden, d.name);
}

/// The same for a generated scene of the stage-against-stage test (its `plab gen` line).
void explain_generated(const FirstFailure& f, const Found& diff) {
  static const std::regex gen(R"(\(plab gen ([^)]*)\))"), other(R"(differs from stage (\d+))");
  std::smatch g, o;
  // A difference that shows only with several threads or another schedule (expect_same_on_cpu()
  // in tests/stage_test.cpp names them): reproduced with the same, and the usual causes named.
  static const std::regex threaded(R"(run here with (\d+) threads and schedule ([\w,]+))");
  std::smatch th;
  std::string with;
  if (std::regex_search(f.c.message, th, threaded)) {
    with = " --threads " + th[1].str() + " --schedule " + th[2].str();
    if (f.impl != "engine")  // (the race check builds stages/ or solutions/)
      std::printf("  only with %s threads and schedule %s (with 1 thread your stage prints the "
                  "reference's output):\n  look for a data race (./plab test --impl %s --stage %s "
                  "--races) or a missing barrier (a nowait, a loop that reads what another loop "
                  "still writes)\n",
                  th[1].str().c_str(), th[2].str().c_str(), f.impl.c_str(), f.id.c_str());
  }
  // A scene built in the test itself (tests/stage_test.cpp's naming_kept()): kept on failure.
  static const std::regex kept(R"(\(its scene, kept when this test fails: ([^)]*)\))");
  std::smatch k;
  const bool built = std::regex_search(f.c.message, k, kept);
  if ((!built && !std::regex_search(f.c.message, g, gen)) ||
      !std::regex_search(f.c.message, o, other)) {
    std::printf("  its scene is built in the test itself (%s, in tests/)\n", f.c.name.c_str());
    return;
  }
  if (built && !fs::exists(k[1].str())) {
    std::printf("  its scene is built in the test itself (%s, in tests/); its copy %s is gone\n",
                f.c.name.c_str(), k[1].str().c_str());
    return;
  }
  const std::string run = "./plab run --stage " + f.id + " --impl " + f.impl + with +
                          ranks_option(f.c.message) + " scene.in";
  const long long step = std::atoll(diff.step.c_str());
  if (built) {  // (the build's folder, said from the kit's root where it lies inside it)
    const fs::path at = fs::path(k[1].str()).lexically_relative(source_dir());
    const bool inside = !at.empty() && *at.begin() != "..";
    std::printf("  reproduce it (the test's scene, kept):\n    cp %s scene.in\n",
                inside ? at.string().c_str() : k[1].str().c_str());
  } else {
    std::printf("  reproduce it:\n    ./plab gen %s --out scene.in\n", g[1].str().c_str());
  }
  const Explainer how = explainer(f, "scene.in");
  if (fs::is_directory(fs::path(source_dir()) / "solutions"))
    std::printf("    ./plab run --stage %s --impl solution scene.in --out expected.out\n",
                o[1].str().c_str());
  else  // a student copy: the compiled reference prints the same text as every stage
    std::printf("    kit/reference/bin/plab-reference scene.in --out expected.out\n");
  std::printf("    %s --out mine.out\n    ./plab diff expected.out mine.out\n", run.c_str());
  if (!diff.particle.empty() && !how.command.empty())
    std::printf("    %s --explain %lld:%s\n", how.command.c_str(), step > 0 ? step - 1 : 0,
                diff.particle.c_str());
  std::printf("  draw it:  ./plab render scene.in --diff expected.out mine.out --out diff.gif\n");
  print_play(f, "scene.in", "expected.out", "diff");
}

/// The page about the first failing case: what differs, why the scene exists, and how to see it.
void explain_first(const FirstFailure& f, const Manifest& m) {
  const auto diff = find_difference(f.c.message);
  auto d = scene_of(m, f.c.name);
  // A dataset on several ranks (tests/stage_test.cpp's Ranks: `random_1000_3`, the dataset's
  // name and the ranks)
  if (static const std::regex on_ranks(R"(^(\w+?)_(\d+)$)"); !d) {
    std::smatch r;
    if (std::regex_match(f.c.name, r, on_ranks) && !ranks_option(f.c.message).empty())
      d = scene_of(m, r[1].str());
  }
  // A test over every scene (stage 07's ExactGolden) names the scene before its difference
  std::optional<Dataset> scene;
  if (const auto names = named_scenes(f.c.message); !d && !names.empty())
    for (const Dataset& each : m.datasets)
      if (each.name == names[0]) scene = each;
  std::printf("first failure: %s, %s\n", f.test.c_str(),
              d       ? ("scene " + d->name).c_str()
              : scene ? (f.c.name + ", scene " + scene->name).c_str()
                      : f.c.name.c_str());
  if (!diff) {
    for (const std::string& line : message_lines(f.c.message)) std::printf("  %s\n", line.c_str());
    return;
  }
  std::printf("  step %s%s, field %s: expected %s, got %s (%s%s)\n", diff->step.c_str(),
              diff->particle.empty() ? "" : (", particle " + diff->particle).c_str(),
              diff->field.c_str(), diff->expected.c_str(), diff->actual.c_str(),
              diff->lines.c_str(), ranks_of(f.c.message).c_str());
  // At the first wrong step, a value off by its last printed digit is rounding, not logic: the
  // handouts' "What to steer away from" (a formula typed again, operations in another order).
  char* end_e = nullptr;
  char* end_a = nullptr;
  const double e = std::strtod(diff->expected.c_str(), &end_e);
  const double a = std::strtod(diff->actual.c_str(), &end_a);
  if (end_e && *end_e == '\0' && end_a && *end_a == '\0' && e != a && std::isfinite(e) &&
      std::isfinite(a) && std::fabs(e - a) <= 1e-6 * std::max(std::fabs(e), std::fabs(a)))
    std::printf("  the two differ only in their last digits: rounding, not the logic. A formula "
                "typed again instead of called from kit/include/plab/model.hpp, or its operations "
                "in another order, or contracted into an FMA (handouts/model.md, Why every stage prints the same bits)\n");
  if (d) {
    explain_golden(f, *d, m, *diff);
  } else if (scene && m.has_exact_golden(*scene) && f.c.name.rfind("ExactGolden", 0) == 0) {
    const std::string path = shown_path(m.scene_path(*scene));
    const std::string golden = shown_path(m.exact_golden_path(*scene));
    std::printf("  the scene: %s (%s)\n  reproduce it:\n    ./plab run --stage %s --impl %s %s "
                "--out mine.out\n    ./plab diff %s mine.out\n", scene->name.c_str(),
                scene->tests.c_str(), f.id.c_str(), f.impl.c_str(), path.c_str(), golden.c_str());
    std::printf("  draw it:  ./plab render %s --diff %s mine.out --out %s-diff.gif\n",
                path.c_str(), golden.c_str(), scene->name.c_str());
  } else {
    explain_generated(f, *diff);
  }
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// A test's CTest status as one word for the progress lines: passed, failed, skipped, crashed
/// (CTest's "Subprocess aborted***Exception:", "Exception: SegFault", ...), timeout.
std::string progress_word(const std::string& status) {
  const std::string s = lower(status);
  if (s == "passed" || s == "failed" || s == "skipped" || s == "timeout") return s;
  if (s.find("not run") != std::string::npos) return "not run";
  if (s.find("exception") != std::string::npos || s.find("abort") != std::string::npos ||
      s.find("segfault") != std::string::npos)
    return "crashed";
  return s;
}

/// Starts ctest with its output into `log`; returns its process id.
pid_t start_ctest(const std::vector<std::string>& args, const std::string& log) {
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid != 0) return pid;
  const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  dup2(fd, STDOUT_FILENO);
  dup2(fd, STDERR_FILENO);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  execvp(argv[0], argv.data());
  _exit(127);
}

/// The test a CTest "Start N: NAME" line starts, if it is one.
std::optional<std::string> parse_start_line(const std::string& line) {
  static const std::regex re(R"(^\s*Start\s+\d+: (\S+)\s*$)");
  std::smatch m;
  if (!std::regex_match(line, m, re)) return std::nullopt;
  return m[1].str();
}

/// Follows the log while ctest runs, printing one line per test as it ends, and a line for a
/// test still running after 30 s, 1, 2, 4, ... minutes (a slow stage shows before it ends).
int follow(pid_t pid, const std::string& log) {
  using Clock = std::chrono::steady_clock;
  struct Running {
    Clock::time_point since;
    double notice = 30;  //!< seconds at which the next "still running" line is due
  };
  std::map<std::string, Running> running;
  std::ifstream in;
  std::string pending, partial;  // (partial: a result line CTest broke, whole_line())
  int pieces = 0;
  int status = 0;
  for (bool done = false; !done;) {
    done = waitpid(pid, &status, WNOHANG) == pid;
    if (!in.is_open()) in.open(log);
    char buf[4096];
    while (in.is_open() && in.read(buf, sizeof buf).gcount() > 0) pending.append(buf, in.gcount());
    in.clear();
    for (std::size_t nl; (nl = pending.find('\n')) != std::string::npos; pending.erase(0, nl + 1)) {
      const std::optional<std::string> whole = whole_line(partial, pieces, pending.substr(0, nl));
      if (!whole) continue;
      const std::string& line = *whole;
      if (const auto started = parse_start_line(line)) running[*started] = {Clock::now()};
      if (const auto r = parse_result_line(line)) {
        running.erase(r->name);
        std::printf("  %-8s %s (%.1f s)\n", progress_word(r->status).c_str(), r->name.c_str(),
                    r->seconds);
      }
    }
    for (auto& [name, r] : running) {
      const double for_s = std::chrono::duration<double>(Clock::now() - r.since).count();
      if (done || for_s < r.notice) continue;
      std::printf("  running  %s (%.0f s so far)\n", name.c_str(), for_s);
      r.notice = r.notice < 60 ? 60 : 2 * r.notice;
    }
    std::fflush(stdout);
    if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// "12 passed, 3 skipped, 1 failed" and each skip's reason.
void print_counts(const std::vector<TestResult>& tests, const std::string& log) {
  std::map<std::string, int> n;
  for (const TestResult& t : tests)
    ++n[t.status == "Passed" || t.status == "Skipped" || t.status == "Not Run" ? t.status : "Failed"];
  std::printf("plab test: %d passed, %d skipped, %d failed, %d not run (the whole log: %s)\n",
              n["Passed"], n["Skipped"], n["Failed"], n["Not Run"], shown_path(log).c_str());
  for (const auto& [name, why] : skip_reasons(tests))
    std::printf("  skipped %s: %s\n", name.c_str(), why.c_str());
}

/// For a test the watchdog stopped on a scene, the command that runs that scene under a limit.
void print_stalled_run(const std::string& stopped, const std::string& test, const Manifest& m) {
  static const std::regex scene_stopped(R"(^stage (\d\d), scene ([\w.-]+): )"),
      impl(R"(^stage\d\d\.(\w+)\.)");
  std::smatch where, which;
  if (!std::regex_search(stopped, where, scene_stopped) || !std::regex_search(test, which, impl))
    return;
  for (const Dataset& d : m.datasets)
    if (d.name == where[2].str())
      std::printf("  see it: ./plab run --stage %s --impl %s %s --timeout 30\n",
                  where[1].str().c_str(), which[1].str().c_str(),
                  shown_path(m.scene_path(d)).c_str());
}

/// For a test whose program died (CTest's "Subprocess aborted", "SEGFAULT", "Exception: ...")
/// in the middle of a case: the last thing the program said (glibc's "double free or
/// corruption", a sanitizer's summary) and the command that runs that case's scene, which names
/// the signal and the step.
void print_crash(const TestResult& t, const std::vector<Case>& cases, const Manifest& m) {
  static const std::regex impl(R"(^stage(\d\d)\.(\w+)\.)");
  std::smatch which;
  if (t.status == "Failed" || !std::regex_search(t.name, which, impl)) return;
  // The C library's and the sanitizers' messages (CTest interleaves its own lines with them).
  static const std::regex last_words(
      R"((free|corrupt|malloc|Segmentation|Sanitizer|terminate|Assertion|abort|stack smashing))");
  std::string said;
  for (const std::string& line : lines_of(t.output))
    if (std::regex_search(line, last_words) && line.find("Start ") == std::string::npos)
      said = line;
  if (!said.empty()) std::printf("  the program's last words: %s\n", said.c_str());
  for (const Case& c : cases) {
    if (c.status != "stopped") continue;
    const auto d = scene_of(m, c.name);
    if (d)
      std::printf("  it died on scene %s; see it: ./plab run --stage %s --impl %s %s --out "
                  "mine.out   (names the signal and the step; if that run does not crash, an "
                  "earlier scene of the same test damaged the memory: a write past the end of an "
                  "array, which the AddressSanitizer build of handouts/working.md names)\n",
                  d->name.c_str(), which[1].str().c_str(), which[2].str().c_str(),
                  shown_path(m.scene_path(*d)).c_str());
    else
      std::printf("  it died in case %s\n", c.name.c_str());
    break;
  }
  // A threaded stage: threads that write one vector, or a buffer another thread reads, crash now
  // and then, and not with one thread.
  if (which[2].str() != "engine" &&
      stage_declares(which[1].str(), which[2].str(), "needs_openmp") == true)
    std::printf("  a crash that comes and goes from run to run, or goes away with --threads 1, is "
                "often a data race: ./plab test --impl %s --stage %s --races; one that comes "
                "every run, on one thread too, is more often a write past an array's end (a "
                "count, an offset, a prefix sum off by one), whose line the AddressSanitizer "
                "build of handouts/working.md names\n",
                which[2].str().c_str(), which[1].str().c_str());
}

/// A line per test that did not pass, its cases for a stage's test, the first failure's page.
void print_failures(const std::vector<TestResult>& tests) {
  const Manifest m = load_manifest(source_dir() + "/datasets");
  std::optional<FirstFailure> first;
  static const std::regex stage_test(R"(stage(\d\d)\.(student|solution)\.(\w+).*)");
  for (const TestResult& t : tests) {
    std::smatch s;
    if (t.status == "Passed" || t.status == "Skipped") continue;
    if (t.status == "Not Run") {
      std::printf("%s: not run (the check it needs failed)\n", t.name.c_str());
      continue;
    }
    const std::string stopped = stop_message(t.output);
    const std::string status = t.status == "Failed" ? "FAILED"
                               : t.status.rfind("Subprocess aborted", 0) == 0 ? "CRASHED (aborted)"
                               : t.status == "Exception: SegFault" ? "CRASHED (segmentation fault)"
                                                                   : t.status;
    const std::string head = t.name + ": " + status +
                             (stopped.empty() ? "" : ": " + stopped);
    const std::vector<Case> cases = gtest_cases(t.output);
    if (t.name.find(".Golden") != std::string::npos && stopped.empty()) {
      std::printf("%s\n", head.c_str());
      print_cases(cases, m);
    } else {
      print_summary(head, cases);
    }
    if (cases.empty() && stopped.empty()) {  // a script's check (render, report): its last words
      std::vector<std::string> said;
      for (const std::string& line : lines_of(t.output))
        if (line.find_first_not_of(' ') != std::string::npos) said.push_back(line);
      for (std::size_t i = said.size() > 3 ? said.size() - 3 : 0; i < said.size(); ++i)
        std::printf("  %s\n", said[i].c_str());
    }
    print_stalled_run(stopped, t.name, m);
    if (stopped.empty()) print_crash(t, cases, m);
    // The page goes to the first failing scene of a golden test, else to the first failing case.
    const bool golden = is_golden(t.name);
    if ((first && (!golden || is_golden(first->test))) ||
        !std::regex_match(t.name, s, stage_test))
      continue;
    for (const Case& c : cases)
      if (c.status == "failed") {
        first = FirstFailure{s[1], s[2], t.name, c};
        break;
      }
  }
  if (first) explain_first(*first, m);
}

}  // namespace

int run_tests_reported(const TestRun& run) {
  fs::create_directories(fs::path(run.log_path).parent_path());
  fs::remove(run.log_path);  // follow() must not read the last run's log
  const int rc = follow(start_ctest(run.ctest_args, run.log_path), run.log_path);
  std::ifstream in(run.log_path);
  std::ostringstream text;
  text << in.rdbuf();
  const std::vector<TestResult> tests = parse_log(text.str());
  if (tests.empty()) {  // no test ran (nothing matched, the build folder is missing): a failure
    std::fputs(text.str().c_str(), stdout);
    return 1;
  }
  print_failures(tests);
  print_counts(tests, run.log_path);
  return rc == 0 ? 0 : 1;  // CTest says 8 for a failed test: `plab test --help` promises 1
}

}  // namespace plab::cli
