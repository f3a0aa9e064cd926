/// \file output_test.cpp
/// \brief Output format: `%.8f` bit for bit (without printf), `-0.00000000` written as `0.00000000`.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
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

// What a stage prints to stdout (a student's printf or std::cout) goes to stderr once the stage
// program has kept stdout for the output: `plab run SCENE > mine.out` holds the output alone.
// Checked in a child process, whose stdout and stderr are pipes read here.
TEST(OutputFile, PrintsOfTheStageGoToStderr) {
  int out[2], err[2];
  ASSERT_EQ(::pipe(out), 0);
  ASSERT_EQ(::pipe(err), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::dup2(out[1], STDOUT_FILENO);
    ::dup2(err[1], STDERR_FILENO);
    ::close(out[0]);
    ::close(err[0]);
    ::close(out[1]);
    ::close(err[1]);
    plab::keep_stdout_for_output();
    std::printf("a student's printf\n");
    std::cout << "a student's cout" << std::endl;
    plab::OutputFile o("");
    std::fputs("0 0 1.00000000 1.00000000 0.00000000 0.00000000\n", o.get());
    o.commit();
    std::fflush(nullptr);
    ::_exit(0);
  }
  ::close(out[1]);
  ::close(err[1]);
  const auto read_all = [](int fd) {
    std::string text;
    char buf[256];
    for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) text.append(buf, n);
    ::close(fd);
    return text;
  };
  const std::string said = read_all(out[0]), errors = read_all(err[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_EQ(said, "0 0 1.00000000 1.00000000 0.00000000 0.00000000\n");
  EXPECT_NE(errors.find("a student's printf\n"), std::string::npos) << errors;
  EXPECT_NE(errors.find("a student's cout\n"), std::string::npos) << errors;
}
