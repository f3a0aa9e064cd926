/// \file cli/commands.cpp
/// \brief The `plab` subcommands.
#include "commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <nlohmann/json.hpp>
#include <vector>

#include "plab/datasets.hpp"
#include "plab/diff.hpp"
#include "plab/errors.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"
#include "plab/runtime.hpp"
#include "project.hpp"
#include "test_report.hpp"
#include "watch.hpp"

namespace plab::cli {
namespace fs = std::filesystem;
namespace {

int g_status = 0;

std::string two_digits(const std::string& stage) {
  return stage.size() == 1 ? "0" + stage : stage;
}

void check_impl(const std::string& impl) {
  if (impl != "solution" && impl != "student")
    throw std::runtime_error("--impl must be 'solution' or 'student', not '" + impl + "'");
}

/// The stage program, or a clear error saying why there is none.
std::string require_stage(const std::string& id, const std::string& impl) {
  bool exists = false;
  std::string known;
  for (const auto& s : stages(impl)) {
    exists = exists || s.id == id;
    known += (known.empty() ? "" : ", ") + s.id;
  }
  const std::string tree = impl == "solution" ? "solutions/" : "stages/";
  if (!exists)
    throw std::runtime_error("there is no stage " + id + " in " + tree + " (stages: " +
                             (known.empty() ? "none" : known) + ")");
  const std::string program = stage_program(id, impl);
  if (!fs::exists(program))
    throw std::runtime_error("stage " + id + " (" + impl + ") is not built: its code in " + tree +
                             " did not compile. See the errors with: cmake --build " + build_dir() +
                             " --target plab-run-" + id + "-" + impl);
  if (const std::string problem = stage_build_problem(id, impl); !problem.empty())
    throw std::runtime_error(problem);
  return program;
}

double wall_seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// A double as text that reads back to the same value.
std::string fmt_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string temp_path(const std::string& stem) {
  const fs::path dir = fs::path(build_dir()) / "tmp";
  fs::create_directories(dir);
  return (dir / (stem + "." + std::to_string(getpid()))).string();
}

void write_text(const std::string& path, const std::string& text) {
  OutputFile f(path);
  std::fwrite(text.data(), 1, text.size(), f.get());
  f.commit();
}

}  // namespace

int exit_status() { return g_status; }

void add_run(CLI::App& app) {
  struct Args {
    std::string stage, impl, scene, out, digest, schedule, explain;
    int threads = 0;
    double timeout = 0;
    std::uint64_t seed = kDefaultSeed;
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand("run", "Simulate SCENE with one stage; output to stdout (or --out), "
                                      "a timing summary to stderr.");
  c->add_option("--stage", a->stage, "stage number, e.g. 01")->required();
  c->add_option("--impl", a->impl,
                "solution (solutions/) or student (stages/); default: solution when solutions/ "
                "exists, otherwise student");
  c->add_option("--threads", a->threads, "threads for stages that use them");
  c->add_option("--schedule", a->schedule, "OpenMP schedule: static, dynamic or guided[,CHUNK]");
  c->add_option("--out", a->out, "write the output to this file (only when the run succeeds)");
  c->add_option("--digest", a->digest, "write one state digest per step to this file");
  c->add_option("--seed", a->seed, "seed for scenes without particle lines")->capture_default_str();
  c->add_flag("--quiet", a->quiet, "no timing summary");
  c->add_option("--timeout", a->timeout,
                "end the run (and everything it started) after this many seconds, saying at which "
                "step it was; exit status 124")->check(CLI::PositiveNumber);
  c->add_option("--explain", a->explain,
                "K:I[,J...]: instead of the output, the events of particles I, J... in step K (the "
                "kit's oracle, from this stage's state at the start of step K)");
  c->add_option("scene", a->scene, "scene file")->required()->check(CLI::ExistingFile);
  c->callback([a] {
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    const std::string id = two_digits(a->stage);
    std::vector<std::string> args{require_stage(id, impl), a->scene, "--seed",
                                  std::to_string(a->seed)};
    if (a->threads > 0) args.insert(args.end(), {"--threads", std::to_string(a->threads)});
    if (!a->schedule.empty()) args.insert(args.end(), {"--schedule", a->schedule});
    if (!a->out.empty()) args.insert(args.end(), {"--out", a->out});
    if (!a->digest.empty()) args.insert(args.end(), {"--digest", a->digest});
    if (!a->explain.empty()) args.insert(args.end(), {"--explain", a->explain});
    if (a->quiet) args.emplace_back("--quiet");
    const std::string status = temp_path("run.status");
    args.insert(args.end(), {"--status", status});
    g_status = run_stage_watched(args, {"stage " + id + " (" + impl + ") on " +
                                            fs::path(a->scene).filename().string(),
                                        a->timeout, status});
    fs::remove(status);
  });
}

void add_built(CLI::App& app) {
  auto id = std::make_shared<std::string>();
  auto impl = std::make_shared<std::string>();
  auto targets = std::make_shared<std::vector<std::string>>();
  auto* c = app.add_subcommand("built", "Check that a stage's programs are built from its current "
                                        "code; otherwise exit 1 saying that it did not compile, "
                                        "with the compiler's first error (every stage test needs "
                                        "this check: a stage is never tested with an old binary).");
  c->add_option("--stage", *id, "stage number, e.g. 01")->required();
  c->add_option("--impl", *impl, "solution or student (default as for run)");
  c->add_option("--target", *targets, "also these build targets (e.g. the stage's test program)");
  c->callback([id, impl, targets] {
    const std::string which = impl->empty() ? default_impl() : *impl;
    check_impl(which);
    const std::string problem = stage_build_problem(two_digits(*id), which, *targets);
    if (problem.empty()) {
      std::printf("stage %s (%s) is built from its current code\n", two_digits(*id).c_str(),
                  which.c_str());
      return;
    }
    std::printf("%s\n", problem.c_str());
    g_status = 1;
  });
}

void add_gen(CLI::App& app) {
  auto g = std::make_shared<GenParams>();
  auto mode = std::make_shared<std::string>("print");
  auto speed = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  g->seed = kDefaultSeed;
  auto* c = app.add_subcommand("gen", "Write a random scene (model.md's Generation): the same bits "
                                      "on every platform for the same arguments.");
  c->add_option("--n", g->n, "number of particles")->required()->check(CLI::PositiveNumber);
  c->add_option("--l", g->L, "box side L")->required()->check(CLI::PositiveNumber);
  c->add_option("--r", g->r, "radius r")->required()->check(CLI::PositiveNumber);
  c->add_option("--steps", g->steps, "steps S")->required()->check(CLI::NonNegativeNumber);
  c->add_option("--mode", *mode, "print or perf")->check(CLI::IsMember({"print", "perf"}))
      ->capture_default_str();
  c->add_option("--seed", g->seed, "generator seed")->capture_default_str();
  c->add_option("--speed", *speed, "speed range MIN:MAX (default: L/(8r) to L/4)");
  c->add_option("--out", *out, "write the scene to this file instead of stdout");
  c->callback([g, mode, speed, out] {
    Scene s;
    s.box = Box{g->L, g->r};
    if (!(s.box.L > 2 * s.box.r)) throw std::runtime_error("--l must be larger than 2 * --r");
    s.steps = g->steps;
    s.mode = *mode == "perf" ? Mode::kPerf : Mode::kPrint;
    SpeedRange range = default_speeds(s.box);
    if (!speed->empty()) {
      const auto colon = speed->find(':');
      try {
        if (colon == std::string::npos) throw std::invalid_argument("no colon");
        range = SpeedRange{std::stod(speed->substr(0, colon)), std::stod(speed->substr(colon + 1))};
      } catch (const std::exception&) {
        throw std::runtime_error("--speed expects MIN:MAX, e.g. 1:5, not '" + *speed + "'");
      }
      if (!(range.min >= 0 && range.max >= range.min))
        throw std::runtime_error("--speed needs 0 <= MIN <= MAX");
    }
    s.particles = generate(s.box, static_cast<std::size_t>(g->n), g->seed, range);
    write_text(*out, format_scene(s));
  });
}

void add_diff(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto* c = app.add_subcommand("diff", "Compare two outputs (or digest files): exit 0 when equal, "
                                       "otherwise show the first differing step, particle and "
                                       "field, and count the differing lines.");
  c->add_option("files", *files, "EXPECTED ACTUAL")->required()->expected(2)
      ->check(CLI::ExistingFile);
  c->callback([files] {
    const auto d = first_difference(read_file((*files)[0]), read_file((*files)[1]));
    if (!d) {
      std::printf("equal\n");
      return;
    }
    std::printf("%s\n", d->describe().c_str());
    g_status = 1;
  });
}

void add_golden(CLI::App& app) {
  auto check = std::make_shared<bool>(false);
  auto only = std::make_shared<std::vector<std::string>>();
  auto* c = app.add_subcommand("golden", "Regenerate every golden file (and generated scene) from "
                                         "the reference solution, or --check that the committed "
                                         "ones are what it produces now.");
  c->add_flag("--check", *check, "compare instead of writing; exit 1 if anything drifted");
  c->add_option("--only", *only, "only these scenes (names from datasets/manifest.json)");
  c->callback([check, only] {
    const Manifest m = load_manifest(source_dir() + "/datasets");
    const std::string ref = require_stage(m.reference_stage, "solution");
    int drifted = 0;
    int done = 0;
    for (const Dataset& d : m.datasets) {
      if (!only->empty() && std::find(only->begin(), only->end(), d.name) == only->end()) continue;
      const auto t0 = std::chrono::steady_clock::now();
      std::printf("%-28s N=%-6lld ", d.name.c_str(), d.particles);
      std::fflush(stdout);
      std::vector<std::string> problems;
      if (d.gen) {
        const std::string scene = format_scene(generate_scene(*d.gen));
        if (!*check) {
          write_text(m.scene_path(d), scene);
        } else if (!fs::exists(m.scene_path(d)) || read_file(m.scene_path(d)) != scene) {
          problems.push_back("scene file differs from what the generator makes now");
        }
      }
      const std::string out = temp_path(d.name + ".out");
      const std::string dig = temp_path(d.name + ".digest");
      const int rc = run_program({ref, m.scene_path(d), "--quiet", "--out", out, "--digest", dig});
      if (rc != 0) throw std::runtime_error("the reference failed on " + m.scene_path(d));
      std::vector<std::pair<std::string, std::string>> made_golden{{out, m.golden_path(d)},
                                                                   {dig, m.digest_path(d)}};
      if (m.has_exact_golden(d)) {  // the exact event-driven stage's own golden file
        const std::string exact = temp_path(d.name + ".exact");
        if (run_program({require_stage(m.exact_stage, "solution"), m.scene_path(d), "--quiet",
                         "--out", exact}) != 0)
          throw std::runtime_error("stage " + m.exact_stage + " failed on " + m.scene_path(d));
        fs::create_directories(fs::path(m.exact_golden_path(d)).parent_path());
        made_golden.emplace_back(exact, m.exact_golden_path(d));
      }
      for (const auto& [made, golden] : made_golden) {
        if (!*check) {
          fs::rename(made, golden);
          continue;
        }
        const std::string want = fs::exists(golden) ? read_file(golden) : std::string();
        if (const auto diff = first_difference(want, read_file(made)))
          problems.push_back(fs::path(golden).filename().string() + ": " + diff->describe());
        fs::remove(made);
      }
      ++done;
      drifted += problems.empty() ? 0 : 1;
      std::printf("%s (%.1f s)\n", problems.empty() ? (*check ? "ok" : "written") : "DRIFTED",
                  wall_seconds(t0));
      for (const auto& p : problems) std::printf("    %s\n", p.c_str());
    }
    std::printf("%d scenes %s, %d drifted (reference: stage %s solution)\n", done,
                *check ? "checked" : "written", drifted, m.reference_stage.c_str());
    g_status = drifted ? 1 : 0;
  });
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
    std::printf("plab test: FAILED: the tests left %zu file(s) in their temporary folder "
                "(TMPDIR=%s), e.g. %s: a test must remove its scratch files\n",
                left.size(), scratch.c_str(), left.front().c_str());
    status = status ? status : 1;
  }
  std::error_code ignored;
  fs::remove_all(scratch, ignored);
  return status;
}

void add_test(CLI::App& app) {
  auto impl = std::make_shared<std::string>();
  auto stage = std::make_shared<std::string>();
  auto long_too = std::make_shared<bool>(false);
  auto* c = app.add_subcommand("test", "Run the test suite (GoogleTest through CTest). Default: "
                                       "the kit, the solutions and the starting-point checks in "
                                       "the instructor's copy; the kit and your stages otherwise.");
  c->add_option("--impl", *impl, "solution or student (default as for run)");
  c->add_option("--stage", *stage, "only this stage's tests, e.g. 01");
  c->add_flag("--long", *long_too, "also the long tests (large scenes, several minutes)");
  auto fuzz = std::make_shared<bool>(false);
  c->add_flag("--fuzz", *fuzz, "also the fuzz tests: stage against stage on scenes from fresh "
                               "random seeds (printed with any failure), not the fixed ones");
  c->callback([impl, stage, long_too, fuzz] {
    const std::string which = impl->empty() ? default_impl() : *impl;
    check_impl(which);
    std::vector<std::string> args{"ctest", "--test-dir", build_dir(), "--output-on-failure",
                                  "-j", "2"};
    const std::string log = build_dir() + "/test-logs/plab-test.log";
    if (!stage->empty()) {
      args.insert(args.end(), {"-L", "^stage" + two_digits(*stage) + "$", "-L", "^" + which + "$"});
    } else if (which == "solution") {
      args.insert(args.end(), {"-L", "^(kit|solution|starting-point)$"});
    } else {
      args.insert(args.end(), {"-L", "^(kit|student)$"});
    }
    if (!*long_too || !*fuzz)
      args.insert(args.end(), {"-LE", !*long_too && !*fuzz ? "^(long|fuzz)$"
                                      : !*long_too         ? "^long$"
                                                           : "^fuzz$"});
    g_status = with_scratch_tmpdir([&] { return run_tests_reported({args, log}); });
  });
}

void add_docs(CLI::App& app) {
  auto* c = app.add_subcommand("docs", "Build the HTML docs (Doxygen with Graphviz; warnings are "
                                       "errors) into build/docs/html.");
  c->callback([] {
    g_status = run_program({"cmake", "--build", build_dir(), "--target", "docs"});
    if (g_status == 0) std::printf("docs: %s/docs/html/index.html\n", build_dir().c_str());
  });
}

void add_demo(CLI::App& app) {
  auto* c = app.add_subcommand("demo", "Run the reference solutions on the course scenes and a "
                                       "random 1000-particle scene, check them against the golden "
                                       "files, and print the timings.");
  c->callback([] {
    const Manifest m = load_manifest(source_dir() + "/datasets");
    std::printf("%-16s %6s %5s  %-6s %10s  %s\n", "scene", "N", "S", "stage", "time (s)",
                "golden");
    int failures = 0;
    int runs = 0;  // runs that checked something (a CUDA stage without a GPU does not count)
    std::vector<std::string> no_device;  // CUDA stages that found no GPU: not run again
    for (const Dataset& d : m.datasets) {
      if (d.origin != "course" && d.name != "random-1000") continue;
      const Scene scene = parse_scene(read_file(m.scene_path(d)), m.scene_path(d));
      for (const StageDir& s : stages("solution")) {
        if (s.id == "01" && d.size != "small") continue;  // O(N^3): the demo keeps it to small scenes
        const std::string program = stage_program(s.id, "solution");
        if (!fs::exists(program)) continue;
        if (std::find(no_device.begin(), no_device.end(), s.id) != no_device.end()) continue;
        const std::string out = temp_path(d.name + ".demo");
        const auto t0 = std::chrono::steady_clock::now();
        const int rc = run_program({program, m.scene_path(d), "--quiet", "--out", out});
        const double t = wall_seconds(t0);
        std::string verdict = "FAILED (exit " + std::to_string(rc) + ")";
        if (rc == 0) {
          const bool exact = s.id == m.exact_stage;  // stage 07: its own golden files
          const auto diff = first_difference(
              read_file(exact ? m.exact_golden_path(d) : m.golden_path(d)), read_file(out));
          verdict = diff ? "DIFFERS: " + diff->describe()
                         : (exact ? "identical (to golden/exact: the exact model)" : "identical");
          fs::remove(out);
        } else if (rc == 4) {  // a CUDA stage on a machine without a GPU (it said so above)
          verdict = "skipped here and below: no CUDA device";
          no_device.push_back(s.id);
        }
        failures += (verdict.rfind("identical", 0) == 0 || rc == 4) ? 0 : 1;
        runs += rc == 4 ? 0 : 1;
        std::printf("%-16s %6lld %5lld  %-6s %10.3f  %s\n", d.name.c_str(), d.particles,
                    scene.steps, s.id.c_str(), t, verdict.c_str());
        std::fflush(stdout);
      }
    }
    if (runs == 0) {
      std::printf("nothing to run: no solution stage is built and usable here (see ./plab test)\n");
      g_status = 1;
      return;
    }
    std::printf(failures ? "%d runs differ from the golden files\n"
                         : "every run is identical to its golden file\n",
                failures);
    g_status = failures ? 1 : 0;
  });
}

void add_bench(CLI::App& app) {
  struct Args {
    std::vector<std::string> stages, schedules{"dynamic,16"};
    std::vector<int> threads{1};
    std::vector<long long> n{1000, 2000, 4000};
    long long steps = 500;
    int runs = 3;
    std::string csv, impl;
    std::uint64_t seed = 1;
    bool fixed_density = false;
    std::string speed;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand("bench", "Time stages on scenes like the 2019 report's (L = 20000, "
                                        "r = 1, model.md's speeds, perf mode): median of several "
                                        "whole-process runs, spread, and speedup over 1 thread.");
  c->add_option("--stage", a->stages, "stages, e.g. 02,03")->required()->delimiter(',');
  c->add_option("--threads", a->threads, "thread counts, e.g. 1,2")->delimiter(',')
      ->capture_default_str();
  c->add_option("--n", a->n, "particle counts")->delimiter(',')->capture_default_str();
  c->add_option("--steps", a->steps, "steps S")->capture_default_str();
  c->add_option("--runs", a->runs, "timed runs per configuration")->capture_default_str()
      ->check(CLI::PositiveNumber);
  c->add_option("--schedule", a->schedules, "OpenMP schedules to compare, e.g. static dynamic,16 "
                                            "guided")->capture_default_str();
  c->add_option("--seed", a->seed, "scene seed")->capture_default_str();
  c->add_flag("--fixed-density", a->fixed_density,
              "scale the box with N (L = 20000 sqrt(N / 10^4)): the report's density at every N, "
              "with the report's speeds (2500 .. 5000) unless --speed says otherwise");
  c->add_option("--speed", a->speed, "MIN:MAX speeds (default: model.md's L/8 .. L/4, or 2500:5000 "
                                     "with --fixed-density)");
  c->add_option("--impl", a->impl, "solution or student (default as for run)");
  c->add_option("--csv", a->csv, "also write the table as CSV to this file");
  c->callback([a] {
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    std::string csv =
        "stage,impl,n,steps,threads,schedule,runs,median_s,min_s,max_s,speedup,step_median_s,"
        "step_min_s,step_max_s,timer,device,device_bytes\n";
    std::printf("%-5s %6s %5s %7s %-11s %10s %9s %8s %10s %9s  %s\n", "stage", "N", "S", "threads",
                "schedule", "median s", "spread", "speedup", "in steps", "ms/step", "device");
    const std::string report = temp_path("bench-report.json");
    for (const long long n : a->n) {
      const std::string scene = temp_path("bench-" + std::to_string(n) + (a->fixed_density ? "-fd-" : "-") +
                                          std::to_string(a->steps) + "-" + std::to_string(a->seed) +
                                          ".in");
      const double L = a->fixed_density ? 20000 * std::sqrt(n / 1e4) : 20000;
      GenParams g{n, L, 1, a->steps, Mode::kPerf, a->seed};
      if (!a->speed.empty()) {
        const auto colon = a->speed.find(':');
        g.speed_min = std::stod(a->speed.substr(0, colon));
        g.speed_max = std::stod(a->speed.substr(colon + 1));
      } else if (a->fixed_density) {
        g.speed_min = 2500;
        g.speed_max = 5000;
      }
      write_text(scene, format_scene(generate_scene(g)));
      for (const std::string& raw : a->stages) {
        const std::string id = two_digits(raw);
        const std::string program = require_stage(id, impl);
        for (const std::string& schedule : a->schedules) {
          double one_thread = 0;
          for (const int threads : a->threads) {
            std::vector<double> t, steps_t;
            nlohmann::json last;
            for (int k = 0; k < a->runs; ++k) {
              if (stderr_is_terminal())
                std::fprintf(stderr, "\r  stage %s N=%lld threads=%d run %d/%d ", id.c_str(), n,
                             threads, k + 1, a->runs);
              const auto t0 = std::chrono::steady_clock::now();
              const int rc = run_program({program, scene, "--quiet", "--out", "/dev/null",
                                          "--threads", std::to_string(threads), "--schedule",
                                          schedule, "--report", report});
              if (rc != 0)
                throw std::runtime_error("stage " + id + " failed (exit " + std::to_string(rc) +
                                         ") on " + scene);
              t.push_back(wall_seconds(t0));
              last = nlohmann::json::parse(read_file(report));
              steps_t.push_back(last.at("step_seconds").get<double>());
            }
            if (stderr_is_terminal()) std::fprintf(stderr, "\r%60s\r", "");
            std::sort(t.begin(), t.end());
            std::sort(steps_t.begin(), steps_t.end());
            const double median = t[t.size() / 2];
            const double step_median = steps_t[steps_t.size() / 2];
            const std::string device = last.at("device").get<std::string>();
            const std::string timer = last.at("timer").get<std::string>();
            const bool gpu = device != "cpu";
            if (threads == a->threads.front()) one_thread = median;
            const double spread = (t.back() - t.front()) / median;
            char speedup[32] = "-";
            if (one_thread > 0 && !gpu)
              std::snprintf(speedup, sizeof speedup, "%.2f", one_thread / median);
            std::printf("%-5s %6lld %5lld %7s %-11s %10.3f %8.1f%% %8s %10.4f %9.4f  %s (%s)\n",
                        id.c_str(), n, a->steps, gpu ? "-" : std::to_string(threads).c_str(),
                        gpu ? "-" : schedule.c_str(), median, 100 * spread, speedup, step_median,
                        a->steps ? 1e3 * step_median / a->steps : 0.0, device.c_str(),
                        timer.c_str());
            std::fflush(stdout);
            char row[512];
            std::snprintf(row, sizeof row,
                          "%s,%s,%lld,%lld,%d,\"%s\",%d,%.6f,%.6f,%.6f,%s,%.6f,%.6f,%.6f,%s,\"%s\",%zu\n",
                          id.c_str(), impl.c_str(), n, a->steps, threads, schedule.c_str(), a->runs,
                          median, t.front(), t.back(), speedup, step_median, steps_t.front(),
                          steps_t.back(), timer.c_str(), device.c_str(),
                          last.value("device_bytes", std::size_t{0}));
            csv += row;
            if (gpu) break;  // threads and schedules are CPU settings
          }
        }
      }
    }
    if (!a->csv.empty()) write_text(a->csv, csv);
    std::printf("median s: whole-process wall seconds (start-up, scene reading and, on a GPU, "
                "context creation included; output to /dev/null); spread = (max - min) / median "
                "over %d runs; speedup: over the first thread count; in steps: the median of the "
                "stage's own time in steps (host clock on the CPU, CUDA events on a GPU)\n",
                a->runs);
  });
}

void add_render(CLI::App& app) {
  struct Args {
    std::string scene, stage = "02", impl, steps, out, mark, from;
    std::vector<std::string> diff;
    int follow = -1;
    double fps = 4;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "render", "Animate a run: the box, the disks at their true radius, one frame per step, "
                "collisions marked (orange: wall, red: pair). With --diff, two outputs side by "
                "side and their first difference ringed.");
  c->add_option("scene", a->scene, "scene file (with --diff: only its L and r are used)")
      ->required()->check(CLI::ExistingFile);
  c->add_option("--stage", a->stage, "stage that runs the scene")->capture_default_str();
  c->add_option("--impl", a->impl, "solution or student (default as for run)");
  c->add_option("--steps", a->steps, "FIRST:LAST steps to draw (default 0:20; with --diff, "
                                     "around the first difference)");
  c->add_option("--follow", a->follow, "highlight this particle and draw its path");
  c->add_option("--from", a->from, "draw this print-mode output (a golden file, yours) instead "
                                   "of running a stage")->check(CLI::ExistingFile);
  c->add_option("--diff", a->diff, "EXPECTED ACTUAL: two print-mode outputs to compare")
      ->expected(2)->check(CLI::ExistingFile);
  c->add_option("--fps", a->fps, "frames per second")->capture_default_str();
  c->add_option("--out", a->out, "FILE.gif or FILE.mp4 (animation), FILE.svg or FILE.png (one "
                                 "frame); default: the scene's name with .gif");
  c->callback([a] {
    const Scene scene = load_scene(a->scene, kDefaultSeed);
    std::string out = a->out;
    if (out.empty()) out = fs::path(a->scene).stem().string() + ".gif";
    std::vector<std::string> args{"python3", source_dir() + "/kit/render/render.py",
                                  "--box", fmt_double(scene.box.L), "--radius",
                                  fmt_double(scene.box.r), "--out", out, "--fps",
                                  fmt_double(a->fps)};
    if (a->follow >= 0) args.insert(args.end(), {"--follow", std::to_string(a->follow)});
    std::string steps = a->steps;
    if (!a->diff.empty()) {
      const auto d = first_difference(read_file(a->diff[0]), read_file(a->diff[1]));
      if (d) {
        std::printf("%s\n", d->describe().c_str());
        const long step = std::stol(d->step);
        if (steps.empty())  // a few steps before, and the next one (to show its collisions)
          steps = std::to_string(std::max(0L, step - 8)) + ":" +
                  std::to_string(step < scene.steps ? step + 1 : step);
        if (!d->particle.empty())
          args.insert(args.end(),
                      {"--mark", d->step + ":" + d->particle + ":first difference: step " +
                                     d->step + ", particle " + d->particle + ", " + d->field +
                                     ": expected " + d->expected + ", got " + d->actual});
      } else {
        std::printf("the two outputs are equal\n");
      }
      args.insert(args.end(), {"--output", a->diff[0], "--label", "expected: " + a->diff[0],
                               "--output", a->diff[1], "--label", "actual: " + a->diff[1]});
    } else if (!a->from.empty()) {
      if (steps.empty()) steps = "0:" + std::to_string(std::min(scene.steps, 20LL));
      args.insert(args.end(), {"--output", a->from, "--label", a->from});
    } else {
      const std::string impl = a->impl.empty() ? default_impl() : a->impl;
      check_impl(impl);
      if (steps.empty()) steps = "0:" + std::to_string(std::min(scene.steps, 20LL));
      const long long last = std::stoll(steps.substr(steps.find(':') + 1));
      const std::string output = temp_path("render.out");
      const std::string events = temp_path("render.events");
      const int rc = run_program({require_stage(two_digits(a->stage), impl), a->scene, "--quiet",
                                  "--mode", "print", "--steps", std::to_string(last), "--out",
                                  output, "--events", events});
      if (rc != 0) throw std::runtime_error("stage " + a->stage + " failed on " + a->scene);
      args.insert(args.end(), {"--output", output, "--events", events, "--label",
                               "stage " + two_digits(a->stage) + " (" + impl + "), " +
                                   fs::path(a->scene).filename().string()});
    }
    args.insert(args.end(), {"--steps", steps});
    g_status = run_program(args);
    if (g_status == 0) std::printf("wrote %s (steps %s)\n", out.c_str(), steps.c_str());
  });
}

void add_grade(CLI::App& app) {
  struct Args {
    std::string submission, stages, out = "results.json", junit, rubric, scratch;
    std::string sandbox = "auto";
    long long seed = -1;
    bool keep = false, no_sandbox = false, races = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "grade", "Grade a submission: builds its stages with the kit's own code in a sandbox, runs "
               "them there under limits against public and hidden scenes, one step at a time and "
               "for speed, and writes Gradescope's results.json, JUnit XML and a summary (with the "
               "hidden scenes' seed). Points: kit/grade/rubric.json.");
  c->add_option("--submission", a->submission,
                "what the student uploaded: the kit folder, a stages/ folder, a zip of either, or "
                "one stage's files flat")
      ->required()->check(CLI::ExistingPath);
  c->add_option("--stages", a->stages,
                "stages to grade, e.g. 01,06 (default: every stage the submission has; 06 means "
                "06 on the CPU and, with a GPU, 06-gpu)");
  c->add_option("--out", a->out, "results.json to write (always written; the summary goes "
                                 "beside it, NAME.summary.txt)")->capture_default_str();
  c->add_option("--junit", a->junit, "JUnit XML to write (default: beside --out, .xml)");
  c->add_option("--seed,--hidden-seed", a->seed,
                "the hidden scenes' seed: replays a grading (default: random, recorded in the "
                "summary and in results.json's extra_data)");
  c->add_option("--rubric", a->rubric, "rubric file (default: kit/grade/rubric.json)");
  c->add_option("--scratch", a->scratch, "where to build and run (default: the system's temp)");
  c->add_option("--sandbox", a->sandbox,
                "auto (bubblewrap where namespaces are allowed, else an unprivileged user), "
                "bwrap or user")
      ->check(CLI::IsMember({"auto", "bwrap", "user"}))->capture_default_str();
  c->add_flag("--no-sandbox", a->no_sandbox,
              "run student code with the grader's own rights (printed on every result)");
  c->add_flag("--keep", a->keep, "keep the scratch folder");
  c->add_flag("--races", a->races,
              "also build the OpenMP stages (03, 06) with ThreadSanitizer in the sandbox and report "
              "the first data race with file and line (a test worth no points)");
  c->callback([a] {
    if (default_impl() != "solution")
      throw std::runtime_error("grading needs the instructor's kit (with solutions/)");
    std::vector<std::string> args{"python3", source_dir() + "/kit/grade/grade.py", "--submission",
                                  a->submission, "--out", a->out, "--rubric",
                                  a->rubric.empty() ? source_dir() + "/kit/grade/rubric.json"
                                                    : a->rubric,
                                  "--kit-source", source_dir(), "--kit-build", build_dir(),
                                  "--sandbox", a->sandbox};
    if (!a->stages.empty()) args.insert(args.end(), {"--stages", a->stages});
    if (!a->junit.empty()) args.insert(args.end(), {"--junit", a->junit});
    // The seed goes through the environment, which other users cannot read (a command line
    // can be read by every process of the machine, student code run as another uid included).
    if (a->seed >= 0) setenv("PLAB_GRADE_SEED", std::to_string(a->seed).c_str(), 1);
    if (!a->scratch.empty()) args.insert(args.end(), {"--scratch", a->scratch});
    if (a->keep) args.emplace_back("--keep");
    if (a->no_sandbox) args.emplace_back("--no-sandbox");
    if (a->races) args.emplace_back("--races");
    g_status = run_program(args);
  });
}

void add_release(CLI::App& app) {
  struct Args {
    std::string out, kit;
    bool allow_dirty = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand("release", "Write the student version of the kit into a new folder, "
                                          "from git's HEAD: no solutions/, no CI, a student "
                                          "README, the reference stage as a compiled program, "
                                          "docs built from the copy itself; every stage checked "
                                          "to be its untouched starting point.");
  c->add_option("--out", a->out, "a new (or empty) folder")->required();
  c->add_flag("--allow-dirty", a->allow_dirty,
              "release HEAD's stages/ even when stages/ has uncommitted changes (they are left "
              "out, and named)");
  c->add_option("--kit", a->kit, "the kit checkout to release (default: this one)")
      ->check(CLI::ExistingDirectory);
  c->callback([a] {
    if (default_impl() != "solution")
      throw std::runtime_error("this is already a student copy (it has no solutions/)");
    std::vector<std::string> args{"python3", source_dir() + "/kit/grade/release.py",
                                  "--kit-source", a->kit.empty() ? source_dir() : a->kit,
                                  "--out", a->out};
    if (a->allow_dirty) args.push_back("--allow-dirty");
    g_status = run_program(args);
  });
}

void add_accuracy(CLI::App& app) {
  struct Args {
    std::vector<std::string> scenes;
    std::string csv, plot, stepped = "06";
    int max_k = 64;
    long long steps = 0;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "accuracy", "Run time against error: the exact event-driven stage (07) against the fastest "
                  "stepped stage (06) with K substeps per step (K = 1, 2, 4, ... 64), in double and "
                  "float, on the CPU and (with a GPU) the GPU: collisions missed, overlaps, "
                  "position error after 1, 2 and 4 steps, energy drift; a table, a CSV, a plot.");
  c->add_option("--scene", a->scenes, "report, dense-gas, cradle (default: all three)")
      ->delimiter(',');
  c->add_option("--max-k", a->max_k, "largest number of substeps (powers of two up to it)")
      ->capture_default_str()->check(CLI::Range(1, 1024));
  c->add_option("--steps", a->steps, "printed steps of the generated scenes (default 8)");
  c->add_option("--csv", a->csv, "write the table as CSV here");
  c->add_option("--plot", a->plot, "draw time against error here (PNG or SVG)");
  c->callback([a] {
    const Manifest m = load_manifest(source_dir() + "/datasets");
    if (m.exact_stage.empty()) throw std::runtime_error("the manifest names no exact stage");
    std::vector<std::string> args{"python3", source_dir() + "/kit/accuracy/accuracy.py",
                                  "--stepped", require_stage(a->stepped, "solution"),
                                  "--exact", require_stage(m.exact_stage, "solution"),
                                  "--plab", bin_dir() + "/plab", "--datasets", source_dir() + "/datasets",
                                  "--work", build_dir() + "/accuracy", "--max-k", std::to_string(a->max_k),
                                  "--figures", source_dir() + "/handouts/figures"};
    for (const auto& s : a->scenes) args.insert(args.end(), {"--scene", s});
    if (a->steps > 0) args.insert(args.end(), {"--steps", std::to_string(a->steps)});
    if (!a->csv.empty()) args.insert(args.end(), {"--csv", a->csv});
    if (!a->plot.empty()) args.insert(args.end(), {"--plot", a->plot});
    g_status = run_program(args);
  });
}

void add_stress(CLI::App& app) {
  struct Args {
    std::vector<std::string> stages, only;
    std::string impl, csv, ulps_csv, plot;
    long long long_steps = 100000;
    long long pairs = 200000;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "stress", "Numerical stress suite: hostile scenes (corner hits, grazing, speeds 1e9 and "
                "1e-9, tiny and huge radii, disks resting on walls, equal velocities, coincident "
                "centres, overlapping starts, a line of touching disks, near jamming, a long run) on "
                "every stage, invariants checked at every step, all stages bit-identical; then the "
                "pair-time formula's error in ulps. Exits 1 on any violation.");
  c->add_option("--stages", a->stages, "stages (default: every stepped stage built; a CUDA stage "
                                       "is skipped without a GPU)")->delimiter(',');
  c->add_option("--impl", a->impl, "solution or student (default as for run)");
  c->add_option("--only", a->only, "only these scenes")->delimiter(',');
  c->add_option("--long-steps", a->long_steps, "steps of the long run")->capture_default_str();
  c->add_option("--pairs", a->pairs, "pairs of each kind for the pair-time check")
      ->capture_default_str();
  c->add_option("--csv", a->csv, "write the scene table as CSV here");
  c->add_option("--ulps-csv", a->ulps_csv, "write the pair-time error histograms as CSV here");
  c->add_option("--plot", a->plot, "draw the pair-time error distribution here (PNG or SVG)");
  c->callback([a] {
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    const Manifest m = load_manifest(source_dir() + "/datasets");
    std::vector<std::string> ids = a->stages;
    if (ids.empty())
      for (const StageDir& s : stages(impl))
        if (s.id != m.exact_stage && fs::exists(stage_program(s.id, impl))) ids.push_back(s.id);
    std::vector<std::string> args{"python3", source_dir() + "/kit/stress/stress.py",
                                  "--plab", bin_dir() + "/plab",
                                  "--ulps-program", bin_dir() + "/plab-pairtime-ulps",
                                  "--work", build_dir() + "/stress",
                                  "--long-steps", std::to_string(a->long_steps),
                                  "--pairs", std::to_string(a->pairs),
                                  "--figures", source_dir() + "/handouts/figures"};
    for (const auto& id : ids) {
      const std::string sid = two_digits(id);
      if (sid == m.exact_stage)
        throw std::runtime_error("stage " + sid + " is the exact event-driven stage: its tests "
                                 "check it (./plab test --stage " + sid + "), not the stepped "
                                 "model's invariants");
      args.insert(args.end(), {"--stage", sid + "=" + require_stage(sid, impl)});
    }
    if (!a->only.empty()) {
      std::string only;
      for (const auto& o : a->only) only += (only.empty() ? "" : ",") + o;
      args.insert(args.end(), {"--only", only});
    }
    if (!a->csv.empty()) args.insert(args.end(), {"--csv", a->csv});
    if (!a->ulps_csv.empty()) args.insert(args.end(), {"--ulps-csv", a->ulps_csv});
    if (!a->plot.empty()) args.insert(args.end(), {"--plot", a->plot});
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
