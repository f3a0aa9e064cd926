/// \file stage_test.cpp
/// \brief The tests of one stage, compiled once per stage and tree against its step():
/// golden outputs and per-step digests, the same text as another stage on fresh random scenes,
/// and the invariants of the model.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <unistd.h>

#include "plab/datasets.hpp"
#include "plab/diff.hpp"
#include "plab/driver.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"
#include "plab/runtime.hpp"
#include "plab/stage.hpp"
#include "honesty.hpp"
#if PLAB_GPU_STAGE
#include "plab/cuda/check.hpp"
/// CUDA stages: every test skips, with the runtime's reason, where no GPU can be used.
#define PLAB_SKIP_WITHOUT_DEVICE()                                                   \
  if (const std::string why = plab::cuda::missing_device(); !why.empty())           \
  GTEST_SKIP() << "no CUDA device (" << why << "): stage " PLAB_STAGE_ID " not run"
#else
#define PLAB_SKIP_WITHOUT_DEVICE() static_cast<void>(0)
#endif

namespace plab {
// Readable test parameters in GoogleTest's messages.
void PrintTo(const Dataset& d, std::ostream* os) { *os << d.name; }
void PrintTo(const GenParams& g, std::ostream* os) {
  *os << "plab gen --n " << g.n << " --l " << g.L << " --r " << g.r << " --steps " << g.steps;
  if (g.speed_min >= 0) *os << " --speed " << g.speed_min << ":" << g.speed_max;
}
}  // namespace plab

namespace {

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
  plab::simulate(scene, plab::test::watched(plab::make_stepper), out, {mem, nullptr, false});
  plab::test::unwatch();
  std::fclose(mem);
  Result r{out.text(), std::string(buf, len)};
  std::free(buf);
  return r;
}

/// Fails with `plab diff`'s report when two texts differ.
void expect_same(const std::string& expected, const std::string& actual, const std::string& what) {
  if (const auto d = plab::first_difference(expected, actual))
    ADD_FAILURE() << "stage " PLAB_STAGE_ID " differs from " << what << ":\n" << d->describe();
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
  if (d.particles > PLAB_TEST_MAX_N)
    GTEST_SKIP() << "N = " << d.particles << " is above this stage's test limit of "
                 << PLAB_TEST_MAX_N << " (see its CMakeLists.txt)";
  if (std::string(PLAB_STAGE_ID) == "01" && d.size != "small")
    GTEST_SKIP() << "stage 01 is O(N^3) per step: small scenes only";
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const Result r = run_here(plab::load_scene(m.scene_path(d), plab::kDefaultSeed),
                            "stage " PLAB_STAGE_ID ", scene " + d.name);
  // The digests only locate what the output shows already: checked when the output is equal.
  if (plab::first_difference(plab::read_file(m.golden_path(d)), r.output))
    expect_same(plab::read_file(m.golden_path(d)), r.output, m.golden_path(d));
  else
    expect_same(plab::read_file(m.digest_path(d)), r.digests, m.digest_path(d));
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
    expect_same(expected, serial, "stage " PLAB_OTHER_ID " on " + how_made);
    return;
  }
  for (const char* schedule : {"static", "dynamic,1", "guided"}) {
    plab::set_schedule(schedule);
    for (int threads : {1, 2, 3}) {
      plab::set_threads(threads);
      const std::string output = run_here(scene, what).output;
      if (!plab::first_difference(expected, output)) continue;
      expect_same(expected, output,
                  "stage " PLAB_OTHER_ID " with " + std::to_string(threads) + " threads, schedule " +
                      schedule + " (with 1 thread it prints the same) on " + how_made);
      return;
    }
  }
}

/// The seed of a random scene: its fixed seed, so that a failure comes back when rerun, or a
/// fresh one from the machine's entropy under PLAB_FUZZ=1 (the `fuzz` tests). Either way the
/// failure message prints it as `plab gen ... --seed S`.
std::uint64_t scene_seed(std::uint64_t fixed) {
  const char* fuzz = std::getenv("PLAB_FUZZ");
  if (fuzz != nullptr && std::string(fuzz) == "1") return std::random_device{}();
  return fixed;
}

/// Writes `scene` to a file, runs the other stage's solution on it, and checks that this stage
/// prints the same text in each of its variants: threads and schedules on the CPU
/// (expect_same_on_cpu()), each PLAB_CUDA_OFF switch on the GPU (the first that differs).
void expect_same_as_other(const plab::Scene& scene, const std::string& how_made) {
  const std::string other = PLAB_OTHER_PROGRAM;
  if (other.empty()) GTEST_SKIP() << "no other stage's solution is built to compare with";
  const plab::test::ScratchDir scratch;
  const std::string scene_file = scratch.file("scene.in");
  const std::string out_file = scratch.file("reference.out");
  {
    std::FILE* f = std::fopen(scene_file.c_str(), "w");
    const std::string text = plab::format_scene(scene);
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
  }
  const std::string command = other + " --quiet --out " + out_file + " " + scene_file;
  plab::test::watch("stage " PLAB_OTHER_ID "'s solution (the reference) on " + how_made, 0);
  ASSERT_EQ(plab::test::run_watched(command), 0) << command;
  const std::string expected = plab::read_file(out_file);
  const std::string what = "stage " PLAB_STAGE_ID " on " + how_made;
#if PLAB_GPU_STAGE
  for (const char* off : {"", "graph", "streams", "branchless", "graph,streams,branchless"}) {
    setenv("PLAB_CUDA_OFF", off, 1);
    const std::string output = run_here(scene, what).output;
    if (!plab::first_difference(expected, output)) continue;
    expect_same(expected, output,
                "stage " PLAB_OTHER_ID " with PLAB_CUDA_OFF=" + std::string(off) + " on " + how_made);
    break;  // one report: the first variant that differs
  }
  unsetenv("PLAB_CUDA_OFF");
#else
  expect_same_on_cpu(expected, scene, what, how_made);
#endif
}

TEST_P(AgainstOtherStage, SameText) {
  PLAB_SKIP_WITHOUT_DEVICE();
  plab::GenParams g = GetParam();
  g.seed = scene_seed(GetParam().seed);
  expect_same_as_other(plab::generate_scene(g),
                       "a fresh scene (plab gen --n " + std::to_string(g.n) + " --l " +
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

TEST(Invariants, EnergyConservedFiniteCountersGrow) {
  PLAB_SKIP_WITHOUT_DEVICE();
  const plab::Scene scene = plab::generate_scene({80, 60, 1, 1, plab::Mode::kPerf, 77});
  plab::Particles p = scene.particles;
  const auto stage = plab::make_stepper(scene.box, p);
  auto energy = [&p] {
    double e = 0;
    for (std::size_t i = 0; i < p.size(); ++i) e += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i];
    return e;
  };
  const double e0 = energy();
  long long events = 0;
  plab::test::watch("stage " PLAB_STAGE_ID ", invariants on 80 generated particles", 100);
  for (int s = 0; s < 100; ++s) {
    stage->step();
    plab::test::stepped(s + 1);
    stage->read(p);
    for (std::size_t i = 0; i < p.size(); ++i)
      ASSERT_TRUE(std::isfinite(p.x[i]) && std::isfinite(p.y[i]) && std::isfinite(p.vx[i]) &&
                  std::isfinite(p.vy[i]))
          << "particle " << i << " at step " << s;
  }
  plab::test::unwatch();
  for (std::size_t i = 0; i < p.size(); ++i) events += p.pc[i] + p.wc[i];
  EXPECT_NEAR(energy(), e0, 1e-9 * e0);
  EXPECT_GT(events, 100);
}

}  // namespace
