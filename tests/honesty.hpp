/// \file honesty.hpp
/// \brief What keeps a stage's tests honest: a watchdog that ends a test whose stage stops making
/// progress (naming the scene and the last step), and a line that says so when a test program
/// checked no case at all (every case skipped), which CTest then reports as skipped.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>

#include "plab/driver.hpp"
#include "plab/stepper.hpp"

namespace plab::test {

/// The start of a skip message for a case that does not apply to the stage under test (an
/// engine's switch, a test of ranks on a stage of one process): when every case of a test skips,
/// the line CTest reports gives another case's reason first (a student's stage 04 without a GPU
/// read "PLAB_ENGINE_PHASES on the CPU is stage 06's engine's" instead of "no CUDA device").
inline constexpr const char* kNotThisStage = "not for this stage: ";

/// Starts watching one piece of work: `what` names it ("stage 03, scene course-2"), `steps` is
/// how many steps it will take (0 when unknown). Resets the step count and the clock.
void watch(const std::string& what, long long steps);

/// Starts watching the running test itself (named "test Suite.Name" in the watchdog's messages),
/// which will take `steps` steps: a test that steps a hand-built scene.
void watch_test(long long steps);

/// Records that the watched work finished step `done`.
void stepped(long long done);

/// Ends the watch: between pieces of work only the whole program's limit applies.
void unwatch();

/// Records a child process the watchdog must end with the test (0: none any more).
void set_child(pid_t pid);

/// A folder of its own under the temporary folder ($TMPDIR, which `plab test` points into build/),
/// removed whatever the outcome: when it goes out of scope (a passed or a failed assertion), when
/// the watchdog ends the program (an endless loop), and when the program dies of an uncaught
/// exception, abort() or a crash (the files named through file() and the folder, from a handler).
class ScratchDir {
 public:
  ScratchDir();
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  /// The path of `name` inside the folder (remembered: removed with it, however the program ends).
  [[nodiscard]] std::string file(const std::string& name) const;

 private:
  std::filesystem::path path_;
};

/// A maker of steppers whose steppers report each step to the watchdog.
MakeStepper watched(MakeStepper make);

/// Runs a program (argv[0] found on PATH) and waits, under the watchdog: the child is ended with
/// the test when a limit runs out. Returns its exit status (128 + signal when killed).
int run_watched(const std::string& command_line);

/// run_watched() for a runner that writes its progress to `status_file` (its --status): when no
/// step finishes for `stall` seconds (a deadlock between ranks), its whole process group is
/// ended and -1 returned. `done`: the steps it finished. `what` and `steps` name the run in the
/// watchdog's messages.
int run_watched_steps(const std::string& command_line, const std::string& what, long long steps,
                      const std::string& status_file, double stall, long long& done);

}  // namespace plab::test
