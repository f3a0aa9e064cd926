/// \file datasets_test.cpp
/// \brief The datasets: every scene parses, says what it tests, has golden files, and generated
/// scenes are exactly what the generator makes on this platform.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "plab/datasets.hpp"
#include "plab/io.hpp"

namespace {

TEST(Datasets, ManifestIsComplete) {
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  std::set<std::string> names;
  int hand = 0;
  for (const auto& d : m.datasets) {
    EXPECT_TRUE(names.insert(d.name).second) << "duplicate " << d.name;
    EXPECT_GT(d.tests.size(), 20u) << d.name << ": say what the scene tests";
    EXPECT_TRUE(std::filesystem::exists(m.scene_path(d))) << m.scene_path(d);
    EXPECT_TRUE(std::filesystem::exists(m.golden_path(d))) << m.golden_path(d);
    EXPECT_TRUE(std::filesystem::exists(m.digest_path(d))) << m.digest_path(d);
    hand += d.origin == "hand";
  }
  EXPECT_GE(hand, 12);
  EXPECT_EQ(std::count_if(m.datasets.begin(), m.datasets.end(),
                          [](auto& d) { return d.origin == "course"; }),
            4);
}

TEST(Datasets, GeneratedScenesAreReproducible) {
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  for (const auto& d : m.datasets) {
    if (!d.gen) continue;
    EXPECT_EQ(plab::format_scene(plab::generate_scene(*d.gen)), plab::read_file(m.scene_path(d)))
        << d.name << ": the generator no longer makes the committed scene";
  }
}

TEST(Datasets, EveryScenePasses) {
  const plab::Manifest m = plab::load_manifest(PLAB_DATASETS_DIR);
  for (const auto& d : m.datasets) {
    const plab::Scene s = plab::load_scene(m.scene_path(d), 1);
    EXPECT_FALSE(s.generated) << d.name << ": committed scenes carry their particle lines";
    EXPECT_EQ(static_cast<long long>(s.particles.size()), d.particles);
  }
}

}  // namespace
