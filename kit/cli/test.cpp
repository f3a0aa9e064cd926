/// \file cli/test.cpp
/// \brief `plab test`: run the test suite with CTest.
#include "common.hpp"

#include <fstream>

#include <nlohmann/json.hpp>

namespace plab::cli {
namespace {

/// After a student's stage passes: the tests checked its output; the grader checks its idea too
/// (the rubric's idea test, measured outside the student's code), which a green run says nothing
/// about. One line, from kit/grade/rubric.json.
void say_what_is_graded_too(const std::string& stage) {
  std::ifstream in(fs::path(source_dir()) / "kit" / "grade" / "rubric.json");
  const nlohmann::json rubric = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  const std::string id = two_digits(stage);
  if (!rubric.is_object() || !rubric.contains("stages")) return;
  // The stage's idea: its own entry's, or that of an entry graded from its folder (08's runs on
  // several ranks, "folder": "08")
  std::string what, local;
  bool races = false;
  for (const auto& [key, conf] : rubric["stages"].items()) {
    if (key != id && conf.value("folder", "") != id) continue;
    races |= conf.value("races", false);
    const nlohmann::json idea = conf.value("idea", nlohmann::json::object());
    if (what.empty() && idea.contains("what") && idea.value("kind", "") != "gpu") {
      what = idea["what"].get<std::string>();
      local = idea.value("local_test", "");  // a part of it that a test here checks too
    }
  }
  if (what.empty() && !races) return;
  std::printf("stage %s prints the reference's output. Graded too, outside your code (not by "
              "these tests):", id.c_str());
  if (!what.empty() && local.empty()) std::printf(" its idea (%s)", what.c_str());
  if (!what.empty() && !local.empty())  // a part of the idea that a test here checks too
    std::printf(" its idea (%s; the test stage%s.student.%s above checks a part of it as the grade "
                "does)", what.c_str(), id.c_str(), local.c_str());
  // A race may change no printed bit in the runs above, and the grader looks for it
  if (races)
    std::printf("%s its data races (ThreadSanitizer: ./plab test --impl student --stage %s --races)",
                what.empty() ? "" : ";", id.c_str());
  std::printf("; handouts/working.md, \"How a stage is graded\".\n");
}

/// Runs `body` with TMPDIR pointing at an empty folder of the build, then checks that the tests
/// left nothing there (a test creates its scratch files in a folder it removes, whatever the
/// outcome): anything left is named and fails the run. The folder is removed either way, so the
/// machine's /tmp is never touched by the tests.
template <typename Body>
int with_scratch_tmpdir(Body body) {
  const fs::path scratch = fs::path(build_dir()) / ("test-tmp." + std::to_string(getpid()));
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  fs::permissions(scratch, fs::perms::all | fs::perms::sticky_bit);  // as /tmp: any test's uid
  const char* before = std::getenv("TMPDIR");
  const std::string saved = before ? before : "";
  setenv("TMPDIR", scratch.c_str(), 1);
  int status = body();
  if (before) setenv("TMPDIR", saved.c_str(), 1); else unsetenv("TMPDIR");
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(scratch)) left.push_back(e.path().filename());
  if (!left.empty()) {
    std::sort(left.begin(), left.end());
    // A stage that crashed (a double free, an abort) can end its test before the test's
    // clean-up runs: then the leftover is the crash's, said so, and the crash is what to fix
    if (status != 0)
      std::printf("plab test: the tests left %zu file(s) in their temporary folder (removed "
                  "now), e.g. %s: a test that crashed or was stopped above leaves its scratch "
                  "files behind; fix that failure first\n",
                  left.size(), left.front().c_str());
    else
      std::printf("plab test: FAILED: the tests left %zu file(s) in their temporary folder "
                  "(TMPDIR=%s), e.g. %s: a test must remove its scratch files\n",
                  left.size(), scratch.c_str(), left.front().c_str());
    // What is inside says who left it (a test's scratch folder, a tool's session files).
    std::error_code error;
    int shown = 0;
    for (fs::recursive_directory_iterator it(scratch, error), end; !error && it != end && shown < 8;
         it.increment(error), ++shown)
      std::printf("  left: %s\n", fs::relative(it->path(), scratch).c_str());
    status = status ? status : 1;
  }
  std::error_code ignored;
  fs::remove_all(scratch, ignored);
  return status;
}

}  // namespace

void add_test(CLI::App& app) {
  auto impl = std::make_shared<std::string>();
  auto stage = std::make_shared<std::string>();
  auto long_too = std::make_shared<bool>(false);
  auto* c = app.add_subcommand("test", "Run the test suite (GoogleTest through CTest). Default: "
                                       "the kit, the solutions, the engine and the starting-point "
                                       "checks in the instructor's copy; the kit and your stages "
                                       "otherwise.");
  c->footer("Exit status: 0 when every test asked for passed (skipped ones count as passed), "
            "1 otherwise. The whole log: build/test-logs/plab-test.log.");
  c->add_option("--impl", *impl, "solution, student or engine (default as for run)");
  c->add_option("--stage", *stage, "only this stage's tests, e.g. 01");
  c->add_flag("--long", *long_too, "also the long tests (large scenes, several minutes)");
  auto fuzz = std::make_shared<bool>(false);
  c->add_flag("--fuzz", *fuzz, "also the fuzz tests: stage against stage on scenes from fresh "
                               "random seeds (printed with any failure), not the fixed ones");
  auto races = std::make_shared<bool>(false);
  c->add_flag("--races", *races, "instead of the tests: build the stage (--stage 03 or 06) with "
                                 "ThreadSanitizer and run it with 3 threads; prints the first "
                                 "data race, with the file and line of both accesses");
  c->callback([impl, stage, long_too, fuzz, races] {
    const std::string which = impl->empty() ? default_impl() : *impl;
    check_impl(which);
    if (*races) {
      if (stage->empty()) throw std::runtime_error("--races needs --stage (03 or 06)");
      g_status = run_program({"python3", "-m", "plab.grade.race_check", "--source",
                              source_dir(), "--build", build_dir(), "--stage", two_digits(*stage),
                              "--impl", which});
      return;
    }
    std::vector<std::string> args{"ctest", "--test-dir", build_dir(), "--output-on-failure",
                                  "-j", "2"};
    const std::string log = build_dir() + "/test-logs/plab-test.log";
    if (!stage->empty()) {
      require_stage_folder(two_digits(*stage), which);  // said as `plab run` says it
      args.insert(args.end(), {"-L", "^stage" + two_digits(*stage) + "$", "-L", "^" + which + "$"});
    } else if (which == "solution") {
      args.insert(args.end(), {"-L", "^(kit|solution|starting-point|engine)$"});
    } else {
      args.insert(args.end(), {"-L", "^(kit|student)$"});
    }
    std::string left_out;  // the labels not asked for, as one -LE regular expression
    if (!*long_too) left_out = "long";
    if (!*fuzz) left_out += (left_out.empty() ? "" : "|") + std::string("fuzz");
    if (!left_out.empty()) args.insert(args.end(), {"-LE", "^(" + left_out + ")$"});
    g_status = with_scratch_tmpdir([&] { return run_tests_reported({args, log}); });
    if (g_status == 0 && which == "student" && !stage->empty()) say_what_is_graded_too(*stage);
  });
}

}  // namespace plab::cli
