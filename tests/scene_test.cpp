/// \file scene_test.cpp
/// \brief Reading scenes: every malformed case of model.md gives `FILE:LINE: expected ..., found ...`.
#include <gtest/gtest.h>

#include <string>

#include "plab/errors.hpp"
#include "plab/io.hpp"

namespace {

struct BadCase {
  const char* name;
  const char* text;
  const char* message;  // the exact error after "scene.in:"
};

const BadCase kBad[] = {
    {"empty", "", "1: expected the number of particles N (a whole number, 1 to 1000000000), found end of file"},
    {"n_zero", "0\n10\n1\n5\nprint\n", "1: expected the number of particles N (a whole number, 1 to 1000000000), found '0'"},
    {"n_negative", "-3\n10\n1\n5\nprint\n", "1: expected the number of particles N (a whole number, 1 to 1000000000), found '-3'"},
    {"n_fraction", "2.5\n10\n1\n5\nprint\n", "1: expected the number of particles N (a whole number, 1 to 1000000000), found '2.5'"},
    {"n_word", "two\n10\n1\n5\nprint\n", "1: expected the number of particles N (a whole number, 1 to 1000000000), found 'two'"},
    {"l_missing", "2\n", "2: expected the box side L (a number), found end of file"},
    {"l_word", "2\nten\n1\n5\nprint\n", "2: expected the box side L (a number), found 'ten'"},
    {"r_zero", "2\n10\n0\n5\nprint\n", "3: expected a radius r > 0, found '0'"},
    {"r_nan", "2\n10\nnan\n5\nprint\n", "3: expected the radius r (a number), found 'nan'"},
    {"l_too_small", "2\n2\n1\n5\nprint\n", "2: expected a box side L > 2r = 2.000000, found '2'"},
    {"s_negative", "2\n10\n1\n-1\nprint\n", "4: expected the number of steps S (a whole number >= 0), found '-1'"},
    {"s_fraction", "2\n10\n1\n1.5\nprint\n", "4: expected the number of steps S (a whole number >= 0), found '1.5'"},
    {"mode_unknown", "2\n10\n1\n5\nfast\n", "5: expected the mode 'print' or 'perf', found 'fast'"},
    {"mode_missing", "2\n10\n1\n5\n", "5: expected the mode 'print' or 'perf', found end of file"},
    {"index_out_of_range", "2\n10\n1\n5\nprint\n0 5 5 1 1\n2 3 3 1 1\n", "7: expected a particle index from 0 to 1, found '2'"},
    {"index_negative", "2\n10\n1\n5\nprint\n-1 5 5 1 1\n", "6: expected a particle index from 0 to 1, found '-1'"},
    {"index_repeated", "2\n10\n1\n5\nprint\n0 5 5 1 1\n0 3 3 1 1\n", "7: expected a particle index not used before, found '0'"},
    {"too_few_lines", "3\n10\n1\n5\nprint\n0 5 5 1 1\n1 3 3 1 1\n", "8: expected 3 particle lines (or none), found end of file after 2"},
    {"content_after", "1\n10\n1\n5\nprint\n0 5 5 1 1\n7\n", "7: expected end of file after 1 particle lines, found '7'"},
    {"short_line", "1\n10\n1\n5\nprint\n0 5 5 1\n", "6: expected a particle line 'i x y vx vy' (5 numbers), found 4 words"},
    {"long_line", "1\n10\n1\n5\nprint\n0 5 5 1 1 1\n", "6: expected a particle line 'i x y vx vy' (5 numbers), found 6 words"},
    {"x_word", "1\n10\n1\n5\nprint\n0 five 5 1 1\n", "6: expected a finite number for x, found 'five'"},
    {"vy_inf", "1\n10\n1\n5\nprint\n0 5 5 1 inf\n", "6: expected a finite number for vy, found 'inf'"},
    {"x_outside", "1\n10\n1\n5\nprint\n0 0.5 5 1 1\n", "6: expected a centre x inside [r, L-r] = [1.000000, 9.000000], found '0.5'"},
    {"y_outside", "1\n10\n1\n5\nprint\n0 5 9.0001 1 1\n", "6: expected a centre y inside [r, L-r] = [1.000000, 9.000000], found '9.0001'"},
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class BadScene : public testing::TestWithParam<BadCase> {};

TEST_P(BadScene, NamesFileLineAndWhatWasExpected) {
  const BadCase& c = GetParam();
  try {
    plab::parse_scene(c.text, "scene.in");
    FAIL() << "accepted a malformed scene";
  } catch (const plab::InputError& e) {
    EXPECT_EQ(std::string(e.what()), std::string("scene.in:") + c.message);
  }
}

INSTANTIATE_TEST_SUITE_P(EveryCase, BadScene, testing::ValuesIn(kBad),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(Scene, ReadsParticlesInAnyOrder) {
  const plab::Scene s = plab::parse_scene("2\n10.0\n1\n7\nperf\n1 +2 2 0 1.5\n\n0 8 6 -1 0\n", "s");
  ASSERT_EQ(s.particles.size(), 2u);
  EXPECT_EQ(s.box.L, 10.0);
  EXPECT_EQ(s.box.r, 1.0);
  EXPECT_EQ(s.steps, 7);
  EXPECT_EQ(s.mode, plab::Mode::kPerf);
  EXPECT_FALSE(s.generated);
  EXPECT_EQ(s.particles.x[0], 8.0);
  EXPECT_EQ(s.particles.vx[0], -1.0);
  EXPECT_EQ(s.particles.x[1], 2.0);
  EXPECT_EQ(s.particles.vy[1], 1.5);
  EXPECT_EQ(s.particles.pc[1], 0);
}

TEST(Scene, CentreOnTheBoundaryIsAccepted) {
  const plab::Scene s = plab::parse_scene("1\n10\n1\n0\nprint\n0 1 9 0 0\n", "s");
  EXPECT_EQ(s.particles.x[0], 1.0);
  EXPECT_EQ(s.particles.y[0], 9.0);
}

TEST(Scene, NoParticleLinesMeansGenerate) {
  const plab::Scene s = plab::parse_scene("3\n100\n1\n5\nprint\n", "s");
  EXPECT_TRUE(s.generated);
  EXPECT_EQ(s.particles.size(), 3u);
}

TEST(Scene, MissingFileIsNamed) {
  try {
    plab::load_scene("/nonexistent/scene.in", 1);
    FAIL();
  } catch (const plab::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scene.in"), std::string::npos);
  }
}

TEST(Scene, FormatReadsBackToTheSameBits) {
  plab::Scene s = plab::parse_scene("2\n20000\n1\n3\nperf\n0 4655.713431902161 14052.115471044955 "
                                    "1323.4556886615073 2901.649418239736\n1 5 6 0.1 -0.3\n", "s");
  const plab::Scene t = plab::parse_scene(plab::format_scene(s), "t");
  EXPECT_EQ(plab::digest(s.particles), plab::digest(t.particles));
  EXPECT_EQ(plab::format_scene(s), plab::format_scene(t));
}

}  // namespace
