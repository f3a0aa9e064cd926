/// \file output_test.cpp
/// \brief Output format: `%.8f` bit for bit (without printf), `-0.00000000` written as `0.00000000`.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "plab/driver.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"
#include "plab/runtime.hpp"

namespace {

std::string fixed8(double v) {
  char buf[512];
  return std::string(buf, plab::format_fixed8(buf, v));
}

std::string printf8(double v) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "%.8f", v);
  std::string s = buf;
  if (s == "-0.00000000") s = "0.00000000";
  return s;
}

TEST(FormatFixed8, NegativeZeroIsWrittenPositive) {
  EXPECT_EQ(fixed8(-0.0), "0.00000000");
  EXPECT_EQ(fixed8(-1e-12), "0.00000000");
  EXPECT_EQ(fixed8(-4.9e-9), "0.00000000");
  EXPECT_EQ(fixed8(-5.1e-9), "-0.00000001");
  EXPECT_EQ(fixed8(-1.0), "-1.00000000");
}

TEST(FormatFixed8, MatchesPrintfEverywhere) {
  // Ties (exact binary halves at the 9th decimal), tiny and huge values, random magnitudes.
  for (double v : {0.0, 0.5, 0.125, 1.000000005, 2.5e-9, 7.5e-9, 1e-300, 1e300, 123456789.123456789,
                   20000.0, 1.0 / 3.0, 0.000000015, -0.000000015})
    EXPECT_EQ(fixed8(v), printf8(v)) << v;
  plab::SplitMix64 rng(11);
  for (int k = 0; k < 200000; ++k) {
    const double mantissa = rng.uniform01() * 2 - 1;
    const double v = std::ldexp(mantissa, static_cast<int>(rng.next() % 80) - 40);
    ASSERT_EQ(fixed8(v), printf8(v)) << v;
  }
}

TEST(OutputWriter, BlockLines) {
  plab::Particles p;
  p.resize(2);
  p.x = {8, 2};
  p.y = {6, 2};
  p.vx = {-1, -0.0};
  p.vy = {0, 1};
  p.pc = {14, 3};
  p.wc = {7, 21};
  plab::OutputWriter out(nullptr);
  out.block(0, p, false);
  out.block(100, p, true);
  EXPECT_EQ(out.text(),
            "0 0 8.00000000 6.00000000 -1.00000000 0.00000000\n"
            "0 1 2.00000000 2.00000000 0.00000000 1.00000000\n"
            "100 0 8.00000000 6.00000000 -1.00000000 0.00000000 14 7\n"
            "100 1 2.00000000 2.00000000 0.00000000 1.00000000 3 21\n");
}

/// A step for the driver's tests: every particle hits a wall (its counter grows), nothing moves.
void count_a_wall(const plab::Box&, plab::Particles& p) {
  for (auto& w : p.wc) ++w;
}

TEST(Simulate, TimeOnlyPrintsNoStateAndCountsTheSame) {
  plab::Scene scene;
  scene.box = plab::Box{100, 1};
  scene.steps = 3;
  scene.mode = plab::Mode::kPerf;
  scene.particles = plab::generate(scene.box, 20, 5, plab::default_speeds(scene.box));
  plab::OutputWriter printed(nullptr);
  const plab::RunStats all = plab::simulate(scene, count_a_wall, printed);
  plab::OutputWriter silent(nullptr);
  plab::RunOptions options;
  options.print = false;
  const plab::RunStats timed = plab::simulate(scene, count_a_wall, silent, options);
  const std::string& text = printed.text();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 40) << "the step-0 and the final block";
  EXPECT_EQ(silent.text(), "");
  EXPECT_EQ(timed.wall_events, 60);
  EXPECT_EQ(timed.wall_events, all.wall_events);
  EXPECT_EQ(timed.particles, 20u);
  EXPECT_EQ(timed.steps, 3);
}

TEST(Digest, SeesEveryField) {
  plab::Particles p;
  p.resize(3);
  const auto base = plab::digest(p);
  for (int field = 0; field < 6; ++field) {
    plab::Particles q = p;
    switch (field) {
      case 0: q.x[2] = 1e-300; break;
      case 1: q.y[1] = -0.0; break;  // -0.0 and +0.0 differ in bits
      case 2: q.vx[0] = 1; break;
      case 3: q.vy[2] = 1; break;
      case 4: q.pc[1] = 1; break;
      default: q.wc[0] = 1;
    }
    EXPECT_NE(plab::digest(q), base) << "field " << field;
  }
  EXPECT_EQ(plab::digest_line(12, 0xabcULL), "12 0000000000000abc\n");
}

}  // namespace

// Output to a device (`--out /dev/null`) is written in place: renaming a finished file onto the
// path, as for a plain file, would replace the device itself when the kit runs as root.
TEST(OutputFile, DeviceIsWrittenInPlace) {
  {
    plab::OutputFile f("/dev/null");
    std::fputs("0 0 1.00000000 1.00000000 0.00000000 0.00000000\n", f.get());
    f.commit();
  }
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "/dev/null is no longer a character device";
  EXPECT_NE(::access("/dev/null.partial", F_OK), 0) << "a /dev/null.partial was left behind";
}
