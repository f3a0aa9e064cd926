/// \file read_test.cpp
/// \brief Reading outputs and events files (io.hpp): what the writer writes reads back to the same
/// bits, and anything malformed is refused with its line and what was expected.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "plab/errors.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"

namespace {

/// The message of the InputError that reading `text` as an output throws, or "" when none.
std::string output_error(const std::string& text) {
  try {
    plab::parse_output(text, "out.txt");
  } catch (const plab::InputError& e) {
    return e.what();
  }
  return "";
}

std::string events_error(const std::string& text) {
  try {
    plab::parse_events(text, "run.events");
  } catch (const plab::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ParseOutput, ReadsBackWhatTheWriterWrites) {
  plab::Particles p = plab::generate(plab::Box{50, 1}, 7, 5, plab::SpeedRange{1, 3});
  plab::OutputWriter out(nullptr);
  out.block(0, p, false);
  out.block(1, p, false);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.pc[i] = static_cast<long long>(i);
    p.wc[i] = 2;
  }
  out.block(9, p, true);
  const auto blocks = plab::parse_output(out.text(), "out.txt");
  ASSERT_EQ(blocks.size(), 3u);
  EXPECT_EQ(blocks[0].step, 0);
  EXPECT_EQ(blocks[2].step, 9);
  EXPECT_FALSE(blocks[1].counters);
  EXPECT_TRUE(blocks[2].counters);
  for (const auto& b : blocks) {
    ASSERT_EQ(b.particles.size(), p.size());
    for (std::size_t i = 0; i < p.size(); ++i) {
      char text[64];
      std::snprintf(text, sizeof text, "%.8f", p.x[i]);
      EXPECT_EQ(b.particles.x[i], std::strtod(text, nullptr));  // the printed value, exactly
    }
  }
  EXPECT_EQ(blocks[2].particles.pc[6], 6);
  EXPECT_EQ(blocks[2].particles.wc[0], 2);
  EXPECT_EQ(blocks[1].particles.pc[6], 0);
}

TEST(ParseOutput, AcceptsNegativeZeroAndAnyNumberForm) {
  const auto b = plab::parse_output("0 0 -0.00000000 1e1 +2.5 -3\n", "out.txt");
  ASSERT_EQ(b.size(), 1u);
  EXPECT_TRUE(std::signbit(b[0].particles.x[0]));
  EXPECT_EQ(b[0].particles.y[0], 10);
  EXPECT_EQ(b[0].particles.vx[0], 2.5);
}

TEST(ParseOutput, RefusesMalformedOutputsWithLineAndExpectation) {
  const std::string a = "0 0 1.0 2.0 3.0 4.0\n0 1 1.0 2.0 3.0 4.0\n";
  EXPECT_EQ(output_error(a), "");
  EXPECT_EQ(output_error(""), "out.txt:1: expected a line 'step i x y vx vy', found end of file");
  EXPECT_NE(output_error(a + "\n").find("out.txt:3: expected a line 'step i x y vx vy'"),
            std::string::npos);
  EXPECT_NE(output_error(a + "1 0 1.0 2.0 3.0 nan\n").find("out.txt:3: expected a finite number "
                                                         "for vy, found 'nan'"),
            std::string::npos);
  EXPECT_NE(output_error("0 0 1 2 3 4\n0 2 1 2 3 4\n").find("out.txt:2: expected particle 1 of "
                                                            "step 0"),
            std::string::npos);
  EXPECT_NE(output_error(a + "1 0 1 2 3 4\n2 0 1 2 3 4\n").find("out.txt:4: expected particle 1 "
                                                                "of step 1"),
            std::string::npos);
  EXPECT_NE(output_error(a + "1 0 1 2 3 4\n1 1 1 2 3 4\n1 2 1 2 3 4\n")
                .find("out.txt:5: expected a step after 1 (every block has 2 particles)"),
            std::string::npos);
  EXPECT_NE(output_error(a + "1 0 1 2 3 4 0 0\n1 1 1 2 3 4 0 0\n2 0 1 2 3 4 0 0\n")
                .find("out.txt:5: expected end of file after the final block"),
            std::string::npos);
  EXPECT_NE(output_error(a + "1 0 1 2 3 4\n").find("out.txt:3: expected 2 particles in step 1, "
                                                   "found end of file after 1 particle"),
            std::string::npos);
  EXPECT_NE(output_error("3 0 1 2 3 4\n2 0 1 2 3 4\n").find("out.txt:2: expected a step after 3"),
            std::string::npos);
  EXPECT_NE(output_error("0 0 1 2 3 4 5 -1\n").find("expected a counter wc"), std::string::npos);
  EXPECT_NE(output_error("first difference at line 3: step 2\n").find("out.txt:1: expected a line"),
            std::string::npos);
}

TEST(ParseEvents, ReadsLinesAndRefusesTheRest) {
  const auto e = plab::parse_events("0 3 wall\n0 4 pair\n2 4 pair\n", "run.events");
  ASSERT_EQ(e.size(), 3u);
  EXPECT_TRUE(e[0].wall);
  EXPECT_EQ(e[0].particle, 3);
  EXPECT_FALSE(e[2].wall);
  EXPECT_EQ(e[2].step, 2);
  EXPECT_TRUE(plab::parse_events("", "run.events").empty());
  EXPECT_EQ(events_error("0 3 bounce\n"),
            "run.events:1: expected the kind 'wall' or 'pair', found 'bounce'");
  EXPECT_EQ(events_error("0 3 wall\n0 3\n"),
            "run.events:2: expected a line 'step i wall|pair' (3 words), found 2 words");
  EXPECT_EQ(events_error("2 3 wall\n1 3 wall\n"),
            "run.events:2: expected a step >= 2 (events in step order), found '1'");
}

}  // namespace
