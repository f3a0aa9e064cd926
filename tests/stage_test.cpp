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

namespace plab {
// Readable test parameters in GoogleTest's messages.
void PrintTo(const Dataset& d, std::ostream* os) { *os << d.name; }
void PrintTo(const GenParams& g, std::ostream* os) {
  *os << "plab gen --n " << g.n << " --l " << g.L << " --r " << g.r << " --steps " << g.steps;
}
}  // namespace plab

namespace {

/// Output and digests of this stage on a scene.
struct Result {
  std::string output;
  std::string digests;
};

Result run_here(const plab::Scene& scene) {
  char* buf = nullptr;
  std::size_t len = 0;
  std::FILE* mem = open_memstream(&buf, &len);
  plab::OutputWriter out(nullptr);
  plab::simulate(scene, plab::step, out, {mem, false});
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
  if (d.particles > PLAB_TEST_MAX_N)
    GTEST_SKIP() << "N = " << d.particles << " is above this stage's test limit of "
                 << PLAB_TEST_MAX_N << " (see its CMakeLists.txt)";
  if (std::string(PLAB_STAGE_ID) == "01" && d.size != "small")
    GTEST_SKIP() << "stage 01 is O(N^3) per step: small scenes only";
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  const Result r = run_here(plab::load_scene(m.scene_path(d), plab::kDefaultSeed));
  expect_same(plab::read_file(m.golden_path(d)), r.output, m.golden_path(d));
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

TEST_P(AgainstOtherStage, SameText) {
  const std::string other = PLAB_OTHER_PROGRAM;
  if (other.empty()) GTEST_SKIP() << "no other stage's solution is built to compare with";
  plab::GenParams g = GetParam();
  g.seed = std::random_device{}();
  const plab::Scene scene = plab::generate_scene(g);
  const auto dir = std::filesystem::temp_directory_path();
  const std::string stem = (dir / ("plab-" + std::to_string(getpid()) + "-" + std::to_string(g.seed))).string();
  const std::string scene_file = stem + ".in";
  const std::string out_file = stem + ".out";
  {
    std::FILE* f = std::fopen(scene_file.c_str(), "w");
    const std::string text = plab::format_scene(scene);
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
  }
  const std::string command = other + " --quiet --out " + out_file + " " + scene_file;
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const std::string expected = plab::read_file(out_file);
  // 1, 2 and 3 threads (an odd count catches chunking bugs), and each OpenMP schedule.
  for (const char* schedule : {"static", "dynamic,1", "guided"}) {
    plab::set_schedule(schedule);
    for (int threads : {1, 2, 3}) {
      plab::set_threads(threads);
      expect_same(expected, run_here(scene).output,
                  "stage " PLAB_OTHER_ID " on a fresh scene with " + std::to_string(threads) +
                      " threads, schedule " + schedule + " (plab gen --n " + std::to_string(g.n) +
                      " --l " + std::to_string(g.L) + " --r " + std::to_string(g.r) +
                      " --steps " + std::to_string(g.steps) + " --seed " + std::to_string(g.seed) +
                      ")");
    }
  }
  std::filesystem::remove(scene_file);
  std::filesystem::remove(out_file);
}

INSTANTIATE_TEST_SUITE_P(
    Random, AgainstOtherStage,
    testing::Values(plab::GenParams{60, 600, 1, 60, plab::Mode::kPrint, 0},     // sparse, fast
                    plab::GenParams{50, 30, 1, 60, plab::Mode::kPrint, 0},      // dense (0.17)
                    plab::GenParams{90, 40, 1.5, 20, plab::Mode::kPrint, 0}),   // very dense (0.40)
    [](const auto& info) { return "scene" + std::to_string(info.index); });

TEST(Invariants, EnergyConservedFiniteCountersGrow) {
  const plab::Scene scene = plab::generate_scene({80, 60, 1, 1, plab::Mode::kPerf, 77});
  plab::Particles p = scene.particles;
  auto energy = [&p] {
    double e = 0;
    for (std::size_t i = 0; i < p.size(); ++i) e += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i];
    return e;
  };
  const double e0 = energy();
  long long events = 0;
  for (int s = 0; s < 100; ++s) {
    plab::step(scene.box, p);
    for (std::size_t i = 0; i < p.size(); ++i)
      ASSERT_TRUE(std::isfinite(p.x[i]) && std::isfinite(p.y[i]) && std::isfinite(p.vx[i]) &&
                  std::isfinite(p.vy[i]))
          << "particle " << i << " at step " << s;
  }
  for (std::size_t i = 0; i < p.size(); ++i) events += p.pc[i] + p.wc[i];
  EXPECT_NEAR(energy(), e0, 1e-9 * e0);
  EXPECT_GT(events, 100);
}

}  // namespace
