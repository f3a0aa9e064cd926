/// \file stage_test.cpp
/// \brief The tests of every stepped stage, compiled once and linked with each stage's library:
/// golden outputs and per-step digests, the same text as another stage on fresh random scenes,
/// and the invariants of the model. What the stage is (plab::stage_info()) says what runs: a
/// CUDA stage's tests skip without a GPU, its switches are each checked, scene sizes and N are
/// limited as its stage.json says.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <unistd.h>

#include "plab/datasets.hpp"
#include "plab/diff.hpp"
#include "plab/driver.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"
#include "plab/mpi/where.hpp"
#include "plab/runtime.hpp"
#include "plab/stage.hpp"
#include "honesty.hpp"

namespace plab::test {
/// The other stage this one is compared with, and its solution's program ("": none built).
/// Written by tests/CMakeLists.txt for each stage's test program.
extern const char* const kOtherId;
extern const char* const kOtherProgram;
/// This stage's own program (`plab-run-NN-IMPL`): a stage on several processes runs under mpirun.
extern const char* const kThisProgram;
}  // namespace plab::test

/// A CUDA stage's tests skip, with the runtime's reason, where no GPU can be used.
#define PLAB_SKIP_WITHOUT_DEVICE()                                                        \
  if (const std::string why = missing_device(); !why.empty())                           \
  GTEST_SKIP() << why << ": stage " << plab::stage_info().id << " not run"

namespace plab {
// Readable test parameters in GoogleTest's messages.
void PrintTo(const Dataset& d, std::ostream* os) { *os << d.name; }
void PrintTo(const GenParams& g, std::ostream* os) {
  *os << "plab gen --n " << g.n << " --l " << g.L << " --r " << g.r << " --steps " << g.steps;
  if (g.speed_min >= 0) *os << " --speed " << g.speed_min << ":" << g.speed_max;
}
}  // namespace plab

namespace {

using plab::test::kOtherId;

/// The stage's options: the environment's documented overrides (PLAB_SIMD, PLAB_DEVICE: the
/// CTest entries of each vector path), plus what a test sets.
plab::StageOptions stage_options = plab::StageOptions::from_environment();

/// This stage with the test's options.
plab::MakeStepper this_stage() {
  const plab::StageOptions options = stage_options;
  return [options](const plab::Box& box, plab::Particles& p) {
    return plab::make_stepper(box, p, options);
  };
}

/// Why this stage cannot run here ("" when it can): a stage that needs a GPU, or a run that asks
/// for the GPU path (PLAB_DEVICE=gpu), is started once on one particle, and its NoDevice says why
/// not.
std::string missing_device() {
  static const std::string why = [] {
    if (!plab::stage_info().needs_gpu && stage_options.device != plab::Device::kGpu)
      return std::string();
    plab::Particles p;
    p.resize(1);
    p.x[0] = p.y[0] = 5;
    try {
      plab::make_stepper({10, 1}, p, stage_options);
    } catch (const plab::NoDevice& e) {
      return std::string(e.what());
    }
    return std::string();
  }();
  return why;
}

/// "stage NN".
std::string this_name() { return "stage " + plab::stage_info().id; }

/// Output and digests of this stage on a scene.
struct Result {
  std::string output;
  std::string digests;
};

/// Runs this stage on `scene` under the watchdog, which names `what` if it stops making progress.
Result run_here(const plab::Scene& scene, const std::string& what) {
  char* buf = nullptr;
  std::size_t len = 0;
  std::FILE* mem = open_memstream(&buf, &len);
  plab::OutputWriter out(nullptr);
  plab::test::watch(what, scene.steps);
  plab::simulate(scene, plab::test::watched(this_stage()), out, {mem, nullptr, false});
  plab::test::unwatch();
  std::fclose(mem);
  Result r{out.text(), std::string(buf, len)};
  std::free(buf);
  return r;
}

/// What this stage is compared with in the AgainstOtherStage tests: the other stage's solution.
std::string reference_name() {
  return std::string("stage ") + kOtherId + "'s solution (the reference)";
}

/// Fails with `plab diff`'s report when two texts differ (and `note` after it, if any).
void expect_same(const std::string& expected, const std::string& actual, const std::string& what,
                 const std::string& note = "") {
  if (const auto d = plab::first_difference(expected, actual))
    ADD_FAILURE() << this_name() << " differs from " << what << ":\n" << d->describe() << note;
}

std::vector<plab::Dataset> datasets(bool large) {
  std::vector<plab::Dataset> chosen;
  for (const auto& d : plab::load_manifest(PLAB_DATASETS_DIR).datasets)
    if ((d.size == "large") == large) chosen.push_back(d);
  return chosen;
}

std::string test_name(const testing::TestParamInfo<plab::Dataset>& info) {
  std::string s = info.param.name;
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

/// Runs a dataset and compares with its golden output and digests.
void check_golden(const plab::Dataset& d) {
  PLAB_SKIP_WITHOUT_DEVICE();
  const plab::StageInfo& info = plab::stage_info();
  if (d.particles > info.test_max_n)
    GTEST_SKIP() << "N = " << d.particles << " is above this stage's test limit of "
                 << info.test_max_n << " (test_max_n in its stage.json)";
  if (std::find(info.test_sizes.begin(), info.test_sizes.end(), d.size) == info.test_sizes.end())
    GTEST_SKIP() << this_name() << " runs no " << d.size << " scenes (test_sizes in its stage.json)";
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const plab::Scene scene = plab::load_scene(m.scene_path(d), plab::kDefaultSeed);
  const Result r = run_here(scene, this_name() + ", scene " + d.name);
  const std::string golden = plab::read_file(m.golden_path(d));
  const std::string digests = plab::read_file(m.digest_path(d));
  if (plab::first_difference(golden, r.output)) {
    // A perf-mode output prints only the first and the last step: the digests say which step
    // went wrong first (plab's test report reads this line).
    std::string note;
    if (scene.mode == plab::Mode::kPerf)
      if (const auto k = plab::first_difference(digests, r.digests))
        note = "\nthe state first differs after step " + k->step +
               " (the per-step digests; a perf-mode output prints only the first and the last "
               "step)";
    expect_same(golden, r.output, m.golden_path(d), note);
  } else {
    // The digests only locate what the output shows already: checked when the output is equal.
    expect_same(digests, r.digests, m.digest_path(d));
  }
}

class Golden : public testing::TestWithParam<plab::Dataset> {};
TEST_P(Golden, OutputAndDigestsMatch) { check_golden(GetParam()); }

INSTANTIATE_TEST_SUITE_P(Datasets, Golden, testing::ValuesIn(datasets(false)), test_name);

class LongGolden : public testing::TestWithParam<plab::Dataset> {};
TEST_P(LongGolden, OutputAndDigestsMatch) { check_golden(GetParam()); }
// Large scenes are instantiated only for the `long` CTest entry (PLAB_LONG=1).
INSTANTIATE_TEST_SUITE_P(Datasets, LongGolden,
                         testing::ValuesIn(std::getenv("PLAB_LONG") ? datasets(true)
                                                                    : std::vector<plab::Dataset>{}),
                         test_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(LongGolden);

/// Fresh random scenes: this stage must print what another stage's solution prints.
class AgainstOtherStage : public testing::TestWithParam<plab::GenParams> {};

/// Checks this CPU stage's output against `expected`: first with 1 thread, then with 1, 2 and 3
/// threads (an odd count catches chunking bugs) under each OpenMP schedule. One report at most:
/// a difference with 1 thread is the stage's logic, named without threads or schedule (a serial
/// stage never shows them); one that appears only with more threads or another schedule names them.
void expect_same_on_cpu(const std::string& expected, const plab::Scene& scene,
                        const std::string& what, const std::string& how_made) {
  plab::set_schedule("static");
  plab::set_threads(1);
  const std::string serial = run_here(scene, what).output;
  if (plab::first_difference(expected, serial)) {
    expect_same(expected, serial, reference_name() + " on " + how_made);
    return;
  }
  for (const char* schedule : {"static", "dynamic,1", "guided"}) {
    plab::set_schedule(schedule);
    for (int threads : {1, 2, 3}) {
      plab::set_threads(threads);
      const std::string output = run_here(scene, what).output;
      if (!plab::first_difference(expected, output)) continue;
      expect_same(expected, output,
                  reference_name() + " on " + how_made + ", run here with " +
                      std::to_string(threads) + " threads and schedule " + schedule +
                      " (with 1 thread it prints the same)");
      return;
    }
  }
}

/// Whether this run draws fresh random scenes (PLAB_FUZZ=1: the `fuzz` tests).
bool fuzzing() {
  const char* fuzz = std::getenv("PLAB_FUZZ");
  return fuzz != nullptr && std::string(fuzz) == "1";
}

/// The seed of a random scene: its fixed seed, so that a failure comes back when rerun, or a
/// fresh one from the machine's entropy under PLAB_FUZZ=1 (the `fuzz` tests). Either way the
/// failure message prints it as `plab gen ... --seed S`.
std::uint64_t scene_seed(std::uint64_t fixed) {
  return fuzzing() ? std::random_device{}() : fixed;
}

/// Checks this stage's output against `expected` with each of its switches off (none, each alone,
/// all at once: stage 05's graph, streams, branchless), reporting the first variant that differs.
void expect_same_with_switches(const std::string& expected, const plab::Scene& scene,
                               const std::string& what, const std::string& how_made) {
  const std::vector<std::string> switches = plab::stage_info().switches;
  std::vector<std::vector<std::string>> variants{{}};
  for (const std::string& s : switches) variants.push_back({s});
  if (switches.size() > 1) variants.push_back(switches);
  const plab::StageOptions saved = stage_options;
  for (const auto& off : variants) {
    stage_options.off = off;
    const std::string output = run_here(scene, what).output;
    if (!plab::first_difference(expected, output)) continue;
    std::string named;
    for (const std::string& s : off) named += (named.empty() ? "" : ",") + s;
    expect_same(expected, output,
                reference_name() + " on " + how_made + ", run here with --off '" + named + "'");
    break;  // one report: the first variant that differs
  }
  stage_options = saved;
}

/// Writes `scene` into `scratch` as scene.in; returns its path.
std::string write_scene(const plab::test::ScratchDir& scratch, const plab::Scene& scene) {
  const std::string path = scratch.file("scene.in");
  std::FILE* f = std::fopen(path.c_str(), "w");
  const std::string text = plab::format_scene(scene);
  std::fwrite(text.data(), 1, text.size(), f);
  std::fclose(f);
  return path;
}

/// Where a scene built in the test itself is kept when the test fails, so that the failure's
/// commands (`plab test`'s report) can run it: failed-scenes/STAGE-IMPL/SUITE.TEST.in in the
/// test's working folder (the build's tests/), absolute. Generated scenes are not kept (their
/// `plab gen` line makes them again).
std::string kept_scene_path() {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = plab::stage_info().id + "-" + plab::stage_info().impl + "/" +
                     test->test_suite_name() + "." + test->name();
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-' &&
        c != '/')
      c = '_';
  return (std::filesystem::absolute("failed-scenes") / (name + ".in")).string();
}

/// `how_made` of a scene built in the test itself, naming where the scene is kept if it fails;
/// `how_made` as it is for a generated scene.
std::string naming_kept(const std::string& how_made) {
  if (how_made.find("plab gen") != std::string::npos) return how_made;
  return how_made + " (its scene, kept when this test fails: " + kept_scene_path() + ")";
}

/// When a test on a scene built in it ends, however it ends: keeps `scene_file` at
/// kept_scene_path() if the test failed, and removes a copy kept by an earlier failing run if it
/// passed.
struct KeepSceneIfFailed {
  const std::string& how_made;
  const std::string& scene_file;
  ~KeepSceneIfFailed() {
    if (how_made.find("plab gen") != std::string::npos) return;
    const std::filesystem::path kept = kept_scene_path();
    std::error_code ignored;
    if (!::testing::Test::HasFailure()) {
      std::filesystem::remove(kept, ignored);
      for (const auto& folder : {kept.parent_path(), kept.parent_path().parent_path()})
        if (std::filesystem::is_empty(folder, ignored)) std::filesystem::remove(folder, ignored);
      return;
    }
    std::filesystem::create_directories(kept.parent_path(), ignored);
    std::filesystem::copy_file(scene_file, kept, std::filesystem::copy_options::overwrite_existing,
                               ignored);
  }
};

/// Writes `scene` to a file, runs the other stage's solution on it, and checks that this stage
/// prints the same text in each of its variants: threads and schedules on the CPU
/// (expect_same_on_cpu()), each switch of a CUDA stage (expect_same_with_switches()).
void expect_same_as_other(const plab::Scene& scene, const std::string& made) {
  const std::string other = plab::test::kOtherProgram;
  if (other.empty()) GTEST_SKIP() << "no other stage's solution is built to compare with";
  const plab::test::ScratchDir scratch;
  const std::string scene_file = write_scene(scratch, scene);
  const std::string out_file = scratch.file("reference.out");
  const std::string how_made = naming_kept(made);
  const KeepSceneIfFailed keep{how_made, scene_file};
  const std::string command = other + " --quiet --out " + out_file + " " + scene_file;
  plab::test::watch(reference_name() + " on " + how_made, 0);
  ASSERT_EQ(plab::test::run_watched(command), 0) << command;
  const std::string expected = plab::read_file(out_file);
  const std::string what = this_name() + " on " + how_made;
  if (plab::stage_info().needs_gpu)
    expect_same_with_switches(expected, scene, what, how_made);
  else
    expect_same_on_cpu(expected, scene, what, how_made);
}

TEST_P(AgainstOtherStage, SameText) {
  PLAB_SKIP_WITHOUT_DEVICE();
  plab::GenParams g = GetParam();
  g.seed = scene_seed(GetParam().seed);
  expect_same_as_other(plab::generate_scene(g),
                       std::string(fuzzing() ? "a fresh" : "a fixed") +
                           " random scene (plab gen --n " + std::to_string(g.n) + " --l " +
                           std::to_string(g.L) + " --r " + std::to_string(g.r) + " --steps " +
                           std::to_string(g.steps) + " --seed " + std::to_string(g.seed) +
                           (g.speed_min >= 0 ? " --speed " + std::to_string(g.speed_min) + ":" +
                                                   std::to_string(g.speed_max)
                                             : std::string()) +
                           ")");
}

/// One particle at rest with 24 others converging on it from a ring (overlapping each other):
/// 24 pair events for one particle in a step, more than a GPU stage's first allocation of slots.
TEST(AgainstOtherStage, CrowdedParticle) {
  PLAB_SKIP_WITHOUT_DEVICE();
  plab::Scene scene;
  scene.box = {40, 1};
  scene.steps = 6;
  scene.particles.resize(25);
  plab::Particles& p = scene.particles;
  p.x[0] = p.y[0] = 20;
  for (int k = 1; k <= 24; ++k) {
    const double a = 2 * M_PI * k / 24;
    p.x[k] = 20 + 6 * std::cos(a);
    p.y[k] = 20 + 6 * std::sin(a);
    p.vx[k] = -5 * std::cos(a);
    p.vy[k] = -5 * std::sin(a);
  }
  expect_same_as_other(scene, "a crowded particle (24 pair events in one step)");
}

INSTANTIATE_TEST_SUITE_P(
    Random, AgainstOtherStage,
    // Each with its fixed seed (scene_seed() draws a fresh one for the fuzz tests).
    testing::Values(plab::GenParams{60, 600, 1, 60, plab::Mode::kPrint, 20190},  // sparse, fast
                    plab::GenParams{50, 30, 1, 60, plab::Mode::kPrint, 20191},   // dense (0.17)
                    plab::GenParams{90, 40, 1.5, 20, plab::Mode::kPrint, 20192}, // very dense (0.40)
                    plab::GenParams{80, 50, 1, 30, plab::Mode::kPrint, 20193, 1e-3, 1e-2},  // slow
                    plab::GenParams{60, 100, 1, 20, plab::Mode::kPrint, 20194, 400, 1000}), // 4-10 boxes a step
    [](const auto& info) { return "scene" + std::to_string(info.index); });

/// Stage 06's engine's PLAB_ENGINE_PHASES=1 on the CPU (handouts/engine.md): one line of each
/// part's time per thread on stderr when the run ends, and the golden output all the same.
TEST(PhasesInvariants, OneLineOnTheCpu) {
  if (plab::stage_info().id != "06" || plab::stage_info().impl != "engine")
    GTEST_SKIP() << plab::test::kNotThisStage << "PLAB_ENGINE_PHASES on the CPU is stage 06's engine's";
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const std::vector<plab::Dataset> all = datasets(false);
  ASSERT_FALSE(all.empty());
  const plab::Dataset& d = all.front();
  const plab::test::ScratchDir scratch;
  const std::string out = scratch.file("out.txt"), err = scratch.file("stderr.txt");
  plab::test::watch(this_name() + ", scene " + d.name, 0);
  ASSERT_EQ(plab::test::run_watched("env PLAB_ENGINE_PHASES=1 OMP_NUM_THREADS=2 " +
                                    std::string(plab::test::kThisProgram) +
                                    " --device cpu --quiet --out " + out + " " + m.scene_path(d) +
                                    " 2>" + err),
            0);
  expect_same(plab::read_file(m.golden_path(d)), plab::read_file(out),
              m.golden_path(d) + " (PLAB_ENGINE_PHASES=1)");
  const std::string text = plab::read_file(err);
  const std::string head = "stage 06 (engine, CPU) 2 threads, ms a step (mean / slowest thread): walls ";
  const auto at = text.find(head);
  ASSERT_NE(at, std::string::npos) << "no phases in:\n" << text;
  EXPECT_NE(text.find(" select ", at), std::string::npos) << text;
  EXPECT_NE(text.find("; the step ", at), std::string::npos) << text;
  EXPECT_EQ(text.find(head, at + 1), std::string::npos) << "two lines of phases:\n" << text;
}

TEST(Invariants, EnergyConservedFiniteCountersGrow) {
  PLAB_SKIP_WITHOUT_DEVICE();
  const plab::Scene scene = plab::generate_scene({80, 60, 1, 1, plab::Mode::kPerf, 77});
  plab::Particles p = scene.particles;
  const auto stage = plab::make_stepper(scene.box, p, stage_options);
  auto energy = [&p] {
    double e = 0;
    for (std::size_t i = 0; i < p.size(); ++i) e += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i];
    return e;
  };
  const double e0 = energy();
  long long events = 0;
  plab::test::watch(this_name() + ", invariants on 80 generated particles", 100);
  for (int s = 0; s < 100; ++s) {
    stage->step();
    plab::test::stepped(s + 1);
    stage->read(p);
    // Finite, and inside the box: in this scene every wall is taken at its time, so a centre
    // never passes [r, L - r] (a margin of 10^-9 L for rounding).
    const double lo = scene.box.r - 1e-9 * scene.box.L, hi = scene.box.L - lo;
    for (std::size_t i = 0; i < p.size(); ++i) {
      ASSERT_TRUE(std::isfinite(p.x[i]) && std::isfinite(p.y[i]) && std::isfinite(p.vx[i]) &&
                  std::isfinite(p.vy[i]))
          << "particle " << i << " after step " << s + 1 << " is not finite: x " << p.x[i]
          << ", y " << p.y[i] << ", vx " << p.vx[i] << ", vy " << p.vy[i];
      ASSERT_TRUE(p.x[i] >= lo && p.x[i] <= hi && p.y[i] >= lo && p.y[i] <= hi)
          << "particle " << i << " after step " << s + 1 << " is outside the box: (" << p.x[i]
          << ", " << p.y[i] << "), where every centre stays within [r, L - r] = ["
          << scene.box.r << ", " << scene.box.L - scene.box.r << "]";
    }
  }
  plab::test::unwatch();
  for (std::size_t i = 0; i < p.size(); ++i) events += p.pc[i] + p.wc[i];
  EXPECT_NEAR(energy(), e0, 1e-9 * e0);
  EXPECT_GT(events, 100);
}

// -- A stage on several processes (stage.json `needs_mpi`: 08) ---------------------------------
// The tests above run it in this process, on one rank. These start its program under mpirun on
// 2, 3 and 4 ranks (more ranks than this machine's cores: oversubscribed) and compare the text.

/// How long one run under mpirun may take (the kit's scenes take a few seconds on 4 ranks).
constexpr int kRanksSeconds = 240;
/// How long it may go without finishing a step (mpirun's start included) before it is taken for
/// ranks waiting for each other for ever, and ended with all its processes.
constexpr double kRanksStallSeconds = 60;

/// "1 rank", "3 ranks".
std::string ranks_words(int ranks) {
  return std::to_string(ranks) + (ranks == 1 ? " rank" : " ranks");
}

/// The run whose ranks waited for ever, once one has ("" before): after it, the next would too,
/// and each would cost the stall limit, and the test program's own limit would end the rest unseen.
std::string& ranks_stalled() {
  static std::string stalled;
  return stalled;
}

/// An untouched starting point's "stage 08: EXERCISE n (...) is not done yet", once a run on
/// ranks has said it ("" before): every later run would say it again, each after mpirun's start
/// (the 73 cases took 52 s to say it).
std::string& ranks_not_done() {
  static std::string said;
  return said;
}

/// Skips this case when an earlier case's ranks waited for ever (ranks_stalled()), or said that
/// an exercise is not done (ranks_not_done()): it is not run, and `plab test` counts it as such,
/// not as another failure.
#define PLAB_SKIP_AFTER_STALL()                                                              \
  if (!ranks_stalled().empty())                                                              \
    GTEST_SKIP() << "not run, since an earlier run's ranks waited for ever ("                 \
                 << ranks_stalled() << ")";                                                  \
  else if (!ranks_not_done().empty())                                                        \
    GTEST_SKIP() << "not run, since an earlier run said: " << ranks_not_done()

/// Runs this stage's program on `ranks` ranks on `scene_file`; returns its output ("" and a
/// failure when it fails). A case calls PLAB_SKIP_AFTER_STALL() first.
std::string run_on_ranks(const std::string& scene_file, int ranks, const plab::test::ScratchDir& dir,
                         const std::string& what, const std::string& options = "",
                         const std::string& stderr_file = "") {
  if (geteuid() == 0) {  // OpenMPI refuses root unless told twice (containers, CI)
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  }
  std::string& stalled = ranks_stalled();
  if (!stalled.empty()) {  // a second run in a case whose first stalled (PLAB_SKIP_AFTER_STALL)
    ADD_FAILURE() << this_name() << " on " << ranks_words(ranks) << ", " << what
                  << ": not run, since an earlier run's ranks waited for ever (" << stalled << ")";
    return std::string();
  }
  const std::string out = dir.file("ranks-" + std::to_string(ranks) + ".out");
  const std::string status_file = dir.file("ranks-" + std::to_string(ranks) + ".status");
  // mpirun's session files go to the scratch folder (removed with it, however the run ends); rank
  // 0 writes each step it finishes to the status file, so that a stall ends this case alone
  // (and every process of it), and `timeout` bounds the whole run.
  // What the ranks print on stderr goes to a file, shown below as it is (and read for a starting
  // point's "not done yet")
  const std::string err = stderr_file.empty() ? dir.file("ranks-" + std::to_string(ranks) + ".err")
                                              : stderr_file;
  // Each rank says which MPI call it is in (plab/mpi/where.hpp), read below if the run stalls
  const std::string where_dir = dir.file("where");
  std::filesystem::create_directories(where_dir);
  const std::string command = "env TMPDIR=" + dir.file("mpi") + " " +
                              plab::dist::kWhereVariable + "=" + where_dir +
                              " timeout --kill-after=5 " +
                              std::to_string(kRanksSeconds) + " mpirun --oversubscribe -np " +
                              std::to_string(ranks) + " " + plab::test::kThisProgram + " " +
                              options + " --quiet --status " + status_file + " --out " + out +
                              " " + scene_file + " 2> " + err;
  std::filesystem::create_directories(dir.file("mpi"));
  const std::string where = this_name() + " on " + ranks_words(ranks) + ", " + what;
  long long done = 0;
  const int status = plab::test::run_watched_steps(command, where, 0, status_file,
                                                   kRanksStallSeconds, done);
  const std::string said = std::filesystem::exists(err) ? plab::read_file(err) : "";
  if (stderr_file.empty()) std::fputs(said.c_str(), stderr);
  if (const std::size_t at = said.find(" is not done yet"); status != 0 && at != std::string::npos) {
    const std::size_t from = said.rfind('\n', at);
    ranks_not_done() = said.substr(from == std::string::npos ? 0 : from + 1,
                                   at + 16 - (from == std::string::npos ? 0 : from + 1));
  }
  if (status == -1) stalled = where + ", after step " + std::to_string(done);
  // The kit's own diagnosis (the driver's ownership check, the runner's errors) among what the
  // ranks printed: said first, before mpirun's and the C library's lines around it
  std::string kit_said;
  for (std::size_t from = 0; status != 0 && kit_said.empty() && from < said.size();) {
    std::size_t end = said.find('\n', from);
    if (end == std::string::npos) end = said.size();
    const std::string line = said.substr(from, end - from);
    if (line.rfind("stage ", 0) == 0 || line.rfind("plab", 0) == 0) kit_said = "; the kit said: " + line;
    from = end + 1;
  }
  if (status == -1)
  {
    const std::string ranks_at = plab::dist::where_ranks_are(where_dir, ranks);
    ADD_FAILURE() << where << ": no step finished in " << kRanksStallSeconds << " s after step "
                  << done << " (ranks waiting for each other for ever: a send without its "
                  << "receive, a collective some rank skips?); its processes were ended"
                  << (ranks_at.empty() ? "" : ". Where the ranks were: " + ranks_at);
  }
  else if (status == 124)
    ADD_FAILURE() << where << ": not done in " << kRanksSeconds
                  << " s (an endless loop, or a rank waiting for ever?)";
  else if (status > 128)
    ADD_FAILURE() << where << ": a rank crashed (signal " << status - 128 << ", "
                  << strsignal(status - 128) << ") after step " << done << kit_said;
  else  // (not the command line: its scratch folder is gone when the student reads it)
    EXPECT_EQ(status, 0) << where << ": exited with status " << status << kit_said
                         << " (what the ranks printed is above)";
  return status == 0 ? plab::read_file(out) : std::string();
}

/// Dataset `d` on `ranks` ranks (with the runner's `options`, said as `how` in messages): its
/// golden output.
void expect_golden_on_ranks(const plab::Dataset& d, int ranks, const std::string& options = "",
                            const std::string& how = "") {
  PLAB_SKIP_AFTER_STALL();
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const plab::test::ScratchDir scratch;
  const std::string output =
      run_on_ranks(m.scene_path(d), ranks, scratch, "scene " + d.name + how, options);
  if (!output.empty())
    expect_same(plab::read_file(m.golden_path(d)), output,
                m.golden_path(d) + " (" + (options.empty() ? "" : options + ", ") + "on " +
                    ranks_words(ranks) + ")");
}

/// The datasets an MPI stage runs on several ranks (none for other stages).
std::vector<plab::Dataset> rank_datasets() {
  return plab::stage_info().mpi ? datasets(false) : std::vector<plab::Dataset>{};
}

/// A (dataset, ranks) case's name: `course_1_3`.
std::string dataset_ranks_name(
    const testing::TestParamInfo<std::tuple<plab::Dataset, int>>& info) {
  std::string s = std::get<0>(info.param).name + "_" + std::to_string(std::get<1>(info.param));
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

/// The (dataset, ranks) cases of Ranks: every small and medium dataset on 2, 3 and 4 ranks; for a
/// student's stage, each dataset on one of them in turn (2, 3, 4, 2, ...), a third of the runs:
/// each run pays mpirun's start-up (about 0.4 s here), and the stress scenes below run on 1 to 4
/// ranks all the same. The kit's own trees (solution, engine) run the whole matrix.
std::vector<std::tuple<plab::Dataset, int>> rank_cases() {
  const bool student = std::string(plab::test::kThisProgram).find("-student") != std::string::npos;
  std::vector<std::tuple<plab::Dataset, int>> cases;
  int k = 0;
  for (const plab::Dataset& d : rank_datasets()) {
    for (int ranks = 2; ranks <= 4; ++ranks)
      if (!student || ranks == 2 + k % 3) cases.emplace_back(d, ranks);
    ++k;
  }
  return cases;
}

/// Small and medium datasets on 2, 3 and 4 ranks (rank_cases()): their golden outputs.
class Ranks : public testing::TestWithParam<std::tuple<plab::Dataset, int>> {};
TEST_P(Ranks, GoldenOnRanks) {
  const auto& [d, ranks] = GetParam();
  expect_golden_on_ranks(d, ranks);
}
INSTANTIATE_TEST_SUITE_P(Datasets, Ranks, testing::ValuesIn(rank_cases()), dataset_ranks_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(Ranks);

/// The engine's PLAB_ENGINE_PHASES=1 (handouts/engine-08.md): on 3 ranks, one line of phases from
/// each rank on stderr, and the golden output all the same.
TEST(RanksPhases, OneLineEachRank) {
  if (!plab::stage_info().mpi || plab::stage_info().impl != "engine")
    GTEST_SKIP() << plab::test::kNotThisStage << "PLAB_ENGINE_PHASES is the MPI engine's";
  PLAB_SKIP_AFTER_STALL();
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const std::vector<plab::Dataset> all = rank_datasets();
  ASSERT_FALSE(all.empty());
  const plab::Dataset& d = all.front();
  const plab::test::ScratchDir scratch;
  const std::string err = scratch.file("stderr.txt");
  setenv("PLAB_ENGINE_PHASES", "1", 1);
  const std::string output =
      run_on_ranks(m.scene_path(d), 3, scratch, "scene " + d.name + ", PLAB_ENGINE_PHASES=1", "", err);
  unsetenv("PLAB_ENGINE_PHASES");
  expect_same(plab::read_file(m.golden_path(d)), output, m.golden_path(d) + " (phases on 3 ranks)");
  const std::string text = plab::read_file(err);
  for (int rank = 0; rank < 3; ++rank) {
    const std::string head = "stage 08 (engine) rank " + std::to_string(rank) + ", ms a step: scene ";
    const auto at = text.find(head);
    ASSERT_NE(at, std::string::npos) << "no phases from rank " << rank << " in:\n" << text;
    EXPECT_NE(text.find(" ghosts\n", at), std::string::npos) << text;
    EXPECT_EQ(text.find(head, at + 1), std::string::npos) << "two lines from rank " << rank;
  }
}

/// The runner's report on 2 ranks with a status file (as `plab run --ranks` and the tests above
/// start it): the ranks and the bytes they sent, which the grader's idea check reads.
TEST(RanksTraffic, ReportedWithAStatusFile) {
  if (!plab::stage_info().mpi) GTEST_SKIP() << plab::test::kNotThisStage << this_name() << " runs on one process";
  PLAB_SKIP_AFTER_STALL();
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const std::vector<plab::Dataset> all = rank_datasets();
  ASSERT_FALSE(all.empty());
  const plab::test::ScratchDir scratch;
  const std::string report = scratch.file("report.json");
  const std::string output = run_on_ranks(m.scene_path(all.front()), 2, scratch,
                                          "scene " + all.front().name + ", --report",
                                          "--report " + report);
  if (output.empty()) {  // run_on_ranks() said why when the run failed
    if (!HasFailure()) ADD_FAILURE() << "stage 08 on 2 ranks, --report: no output";
    return;
  }
  const nlohmann::json j = nlohmann::json::parse(plab::read_file(report));
  EXPECT_EQ(j.at("ranks").get<int>(), 2) << j.dump();
  EXPECT_GT(j.at("bytes_sent").get<double>(), 0) << j.dump();
  // The same bytes split by the MPI function that sent them (handout 08's question 2): each an
  // MPI_ call of the stage's, adding up to the total.
  double by_call = 0;
  for (const auto& [call, bytes] : j.at("bytes_by_call").items()) {
    EXPECT_EQ(call.rfind("MPI_", 0), 0u) << call << " in " << j.dump();
    EXPECT_GT(bytes.get<double>(), 0) << call << " in " << j.dump();
    by_call += bytes.get<double>();
  }
  EXPECT_DOUBLE_EQ(by_call, j.at("bytes_sent").get<double>()) << j.dump();
  // Each rank's measured CPU seconds in its steps, outside and inside MPI calls (plab grade's
  // idea test of stage 08 reads them)
  for (const char* key : {"rank_work_seconds", "rank_mpi_seconds"}) {
    ASSERT_EQ(j.at(key).size(), 2u) << j.dump();
    for (const auto& seconds : j.at(key)) EXPECT_GE(seconds.get<double>(), 0) << j.dump();
  }
}

/// The engine's ranks start from their own blocks (the kit's scatter by the engine's
/// dist::first_owner()), not from the kit's slabs: its first step sends less than its second,
/// whose cuts have moved with the load (1.4 against 1.9 MB; scattered by slabs, the first step
/// moved half the particles to their blocks and sent 3.6 MB).
TEST(RanksTraffic, EngineStartsInItsBlocks) {
  if (!plab::stage_info().mpi || plab::stage_info().impl != "engine")
    GTEST_SKIP() << plab::test::kNotThisStage << "the engine's ranks own blocks; the stage's own slabs";
  PLAB_SKIP_AFTER_STALL();
  const plab::test::ScratchDir scratch;
  double bytes[2] = {};
  for (int steps = 1; steps <= 2; ++steps) {  // the same first state, 1 and 2 steps
    plab::GenParams g{50000, 44721.4, 1, steps, plab::Mode::kPerf, 31};
    g.speed_min = 2500;  // the report's density and speeds
    g.speed_max = 5000;
    const std::string scene = scratch.file("scene" + std::to_string(steps) + ".in");
    const std::string report = scratch.file("report" + std::to_string(steps) + ".json");
    {
      std::FILE* f = std::fopen(scene.c_str(), "w");
      const std::string text = plab::format_scene(plab::generate_scene(g));
      std::fwrite(text.data(), 1, text.size(), f);
      std::fclose(f);
    }
    const std::string output = run_on_ranks(scene, 4, scratch,
                                            "N = 50000, " + std::to_string(steps) + " steps",
                                            "--report " + report);
    if (output.empty()) return;  // run_on_ranks() said why
    bytes[steps - 1] =
        nlohmann::json::parse(plab::read_file(report)).at("bytes_sent").get<double>();
  }
  const double first = bytes[0], second = bytes[1] - bytes[0];
  EXPECT_GT(second, 0);
  EXPECT_LT(first, second) << "on 4 ranks the first step sent " << first
                                 << " bytes and the second " << second
                                 << ": the first step still moves the particles from the kit's "
                                    "slabs to the engine's blocks?";
}

/// A scene that stresses the cut, on 1 to `most` ranks (with the runner's `options`): the other
/// stage's solution's text.
void expect_same_on_ranks(const plab::Scene& scene, const std::string& made,
                          const std::string& options = "", int most = 4) {
  if (!plab::stage_info().mpi) GTEST_SKIP() << plab::test::kNotThisStage << this_name() << " runs on one process";
  const std::string other = plab::test::kOtherProgram;
  if (other.empty()) GTEST_SKIP() << "no other stage's solution is built to compare with";
  PLAB_SKIP_AFTER_STALL();
  const plab::test::ScratchDir scratch;
  const std::string scene_file = write_scene(scratch, scene);
  const std::string how_made = naming_kept(made);
  const KeepSceneIfFailed keep{how_made, scene_file};  // (a failed run returns early)
  const std::string reference = scratch.file("reference.out");
  plab::test::watch(reference_name() + " on " + how_made, 0);
  ASSERT_EQ(plab::test::run_watched(other + " --quiet --out " + reference + " " + scene_file), 0);
  const std::string expected = plab::read_file(reference);
  for (int ranks = 1; ranks <= most; ++ranks) {
    const std::string output = run_on_ranks(scene_file, ranks, scratch, how_made, options);
    if (output.empty()) return;
    if (plab::first_difference(expected, output)) {
      expect_same(expected, output, reference_name() + " on " + how_made + ", run here on " +
                                        ranks_words(ranks));
      return;
    }
  }
}

/// Particles that start exactly on the borders of 2, 3 and 4 slabs (L = 24: x = 6, 8, 12, 16,
/// 18), moving across them and meeting there.
TEST(RanksScenes, ParticlesOnBorders) {
  plab::Scene scene;
  scene.box = {24, 0.5};
  scene.steps = 30;
  const double xs[] = {6, 8, 12, 16, 18};
  for (int k = 0; k < 5; ++k)
    for (int row = 0; row < 3; ++row) {
      const std::size_t i = scene.particles.size();
      scene.particles.resize(i + 1);
      scene.particles.x[i] = xs[k];
      scene.particles.y[i] = 4 + 7 * row;
      scene.particles.vx[i] = (k + row) % 2 ? 0.75 : -0.5;
      scene.particles.vy[i] = row == 1 ? 0.25 : 0;
    }
  expect_same_on_ranks(scene, "particles on the borders of the slabs");
}

/// A dense scene where many pairs straddle the borders.
plab::Scene dense_scene() {
  return plab::generate_scene({300, 60, 1, 20, plab::Mode::kPrint, 20195});
}

/// Particles faster than a slab is wide: each step they cross several slabs, or the whole box.
plab::Scene fast_scene() {
  return plab::generate_scene({60, 100, 1, 20, plab::Mode::kPrint, 20196, 60, 300});
}

/// Three particles in the first of four slabs: more ranks than particles, and empty slabs.
plab::Scene empty_slabs_scene() {
  plab::Scene scene;
  scene.box = {40, 1};
  scene.steps = 40;
  scene.particles.resize(3);
  plab::Particles& p = scene.particles;
  p.x = {3, 7, 5};
  p.y = {20, 20, 30};
  p.vx = {1, -1, 0.5};
  p.vy = {0, 0, -1};
  return scene;
}

TEST(RanksScenes, DenseAcrossBorders) {
  expect_same_on_ranks(dense_scene(),
                       "a dense scene (plab gen --n 300 --l 60 --r 1 --steps 20 --seed 20195)");
}

TEST(RanksScenes, FasterThanASlab) {
  expect_same_on_ranks(
      fast_scene(),
      "fast particles (plab gen --n 60 --l 100 --r 1 --steps 20 --seed 20196 --speed 60:300)");
}

/// More ranks than particles, and slabs with no particle at all.
TEST(RanksScenes, EmptySlabs) {
  expect_same_on_ranks(empty_slabs_scene(), "3 particles in the first slab of 4");
}

// -- An MPI stage's GPU path (08 with nvcc: --device gpu, one GPU per rank) -----------------------
// The same runs on 1, 2 and 3 ranks with `--device gpu`: each rank's candidate search on its GPU
// (rank % the GPUs there; ranks share one where there are fewer). Skipped, with the reason,
// where the stage has no GPU path or no GPU can be used.

/// Why this stage's GPU path cannot run here ("" when it can): built without one, or what its
/// program says when it ends with NoDevice (exit 4) on a one-particle scene. The program runs
/// alone, not in this process: MPI started here would stop the mpirun of the tests. It runs as an
/// isolated singleton (no OpenMPI daemon: Open MPI 4's singleton otherwise forks an `orted` that
/// outlives the program by up to a second and writes its session files into the scratch folder
/// while it is being removed, which left the folder behind on a loaded CI machine).
std::string missing_gpu_path() {
  static const std::string why = []() -> std::string {
    if (!plab::stage_info().gpu_path) return "built without its GPU path (no CUDA compiler)";
    const plab::test::ScratchDir dir;
    const std::string scene = dir.file("one.in"), err = dir.file("err.txt");
    {
      std::FILE* f = std::fopen(scene.c_str(), "w");
      std::fputs("1\n10\n1\n1\nperf\n0 5 5 1 0\n", f);
      std::fclose(f);
    }
    std::filesystem::create_directories(dir.file("mpi"));
    plab::test::unwatch();
    const int status =
        plab::test::run_watched("env OMPI_MCA_ess_singleton_isolated=1 TMPDIR=" + dir.file("mpi") +
                                " " + plab::test::kThisProgram +
                                " --device gpu --quiet --out /dev/null " + scene + " 2>" + err);
    if (status != 4) return "";  // it runs (or fails, and the tests say how)
    std::string said = plab::read_file(err);
    while (!said.empty() && std::isspace(static_cast<unsigned char>(said.back()))) said.pop_back();
    return said.empty() ? "no CUDA device (exit 4)" : said;
  }();
  return why;
}

/// Skips a test of the GPU path where it cannot run, saying why.
#define PLAB_SKIP_WITHOUT_GPU_PATH()                                                           \
  if (const std::string why = missing_gpu_path(); !why.empty())                                \
  GTEST_SKIP() << why << ": stage " << plab::stage_info().id << "'s GPU path (--device gpu) not run"

/// Every small and medium dataset on 1, 2 and 3 ranks with `--device gpu`: its golden output.
class GpuPath : public testing::TestWithParam<std::tuple<plab::Dataset, int>> {};
TEST_P(GpuPath, GoldenOnRanks) {
  PLAB_SKIP_WITHOUT_GPU_PATH();
  const auto& [d, ranks] = GetParam();
  expect_golden_on_ranks(d, ranks, "--device gpu", " on the GPU");
}
INSTANTIATE_TEST_SUITE_P(Datasets, GpuPath,
                         testing::Combine(testing::ValuesIn(rank_datasets()),
                                          testing::Values(1, 2, 3)),
                         dataset_ranks_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(GpuPath);

/// The scenes that stress the cut, on 1 to 3 ranks with `--device gpu`: the other stage's text.
TEST(GpuPathScenes, CutScenes) {
  if (!plab::stage_info().mpi) GTEST_SKIP() << plab::test::kNotThisStage << this_name() << " runs on one process";
  PLAB_SKIP_WITHOUT_GPU_PATH();
  const std::string gpu = "--device gpu";
  expect_same_on_ranks(dense_scene(), "a dense scene on the GPU", gpu, 3);
  expect_same_on_ranks(fast_scene(), "fast particles on the GPU", gpu, 3);
  expect_same_on_ranks(empty_slabs_scene(), "3 particles in the first slab, on the GPU", gpu, 3);
}

}  // namespace
