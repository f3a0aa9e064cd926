/// \file spec.hpp
/// \brief What the stages' spec tests (tests/spec/NN-name.cpp) share: hand-built disks, a run of
/// the stage under test through its entry point plab::make_stepper(), an exact comparison, and
/// the skip of a CUDA stage without a GPU. The expected states are worked out by hand from
/// shared/MODEL.md (integer and dyadic values, so every double is exact).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <string>
#include <vector>

#include "../honesty.hpp"
#include "plab/stage.hpp"

namespace plab::spec {

/// One disk as written in a test: centre and velocity (counters start at 0).
struct Disk {
  double x, y, vx, vy;
};

/// The particles of `disks`, index i being the i-th.
inline Particles disks(const std::vector<Disk>& disks) {
  Particles p;
  p.resize(disks.size());
  int i = 0;
  for (const Disk& d : disks) {
    p.x[i] = d.x;
    p.y[i] = d.y;
    p.vx[i] = d.vx;
    p.vy[i] = d.vy;
    ++i;
  }
  return p;
}

/// The same from a list written in the test.
inline Particles disks(std::initializer_list<Disk> list) { return disks(std::vector<Disk>(list)); }

/// `p` after `steps` steps of the stage under test, started through plab::make_stepper().
inline Particles run(const Box& box, Particles p, int steps = 1,
                     const StageOptions& options = {}) {
  // Under the watchdog: a step that never ends stops the test within the stall limit, naming
  // the test and the steps done, instead of running out the test program's whole limit
  test::watch_test(steps);
  const auto stage = make_stepper(box, p, options);
  for (int s = 0; s < steps; ++s) {
    stage->step();
    test::stepped(s + 1);
  }
  stage->read(p);
  test::unwatch();
  return p;
}

/// Expects `actual` to be `expected` to the bit (EXPECT_EQ on doubles: exact), field by field.
/// A velocity component that is zero must be +0.0 (model.md stores zeros as +0.0).
inline void expect_state(const Particles& expected, const Particles& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE("particle " + std::to_string(i));
    EXPECT_EQ(expected.x[i], actual.x[i]);
    EXPECT_EQ(expected.y[i], actual.y[i]);
    EXPECT_EQ(expected.vx[i], actual.vx[i]);
    EXPECT_EQ(expected.vy[i], actual.vy[i]);
    EXPECT_EQ(expected.pc[i], actual.pc[i]) << "collisions with particles";
    EXPECT_EQ(expected.wc[i], actual.wc[i]) << "collisions with walls";
    EXPECT_EQ(std::signbit(expected.vx[i]), std::signbit(actual.vx[i])) << "sign of vx";
    EXPECT_EQ(std::signbit(expected.vy[i]), std::signbit(actual.vy[i])) << "sign of vy";
  }
}

/// The expected state: `disks` with the given collision counters.
inline Particles state(std::initializer_list<Disk> d, std::initializer_list<long long> pc,
                       std::initializer_list<long long> wc) {
  Particles p = disks(d);
  p.pc.assign(pc);
  p.wc.assign(wc);
  return p;
}

/// Why the stage under test cannot run here ("" when it can): a stage that needs a GPU is
/// started once on one disk, and its NoDevice says why not (as stage_test.cpp does).
inline std::string missing_device() {
  if (!stage_info().needs_gpu) return {};
  Particles p = disks({{5, 5, 0, 0}});
  try {
    make_stepper({10, 1}, p);
  } catch (const NoDevice& e) {
    return e.what();
  }
  return {};
}

}  // namespace plab::spec

/// expect_state() with the calling test's file and line in a failure's "Google Test trace" (the
/// failure itself is reported at the EXPECT in this header): a student reads which test's
/// expected state it was.
#define EXPECT_STATE(...)                                           \
  do {                                                              \
    SCOPED_TRACE("the expected state of the test at this line");   \
    ::plab::spec::expect_state(__VA_ARGS__);                        \
  } while (0)

/// A CUDA stage's spec cases skip, with the runtime's reason, where no GPU can be used.
#define PLAB_SPEC_SKIP_WITHOUT_DEVICE()                                         \
  if (const std::string why = ::plab::spec::missing_device(); !why.empty())     \
  GTEST_SKIP() << why << ": stage " << ::plab::stage_info().id << " not run"
