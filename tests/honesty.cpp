/// \file honesty.cpp
/// \brief The watchdog and the "no case was checked" line of honesty.hpp, installed in every
/// stage test program before GoogleTest starts.
///
/// Limits (environment, set by tests/CMakeLists.txt): PLAB_STALL_SECONDS (default 20) is the
/// longest a step may take; PLAB_TEST_SECONDS is the whole test program's limit, a little under
/// CTest's TIMEOUT, so that the message comes before CTest kills the program silently.
#include "honesty.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

namespace plab::test {
namespace {

using Clock = std::chrono::steady_clock;

/// What the program is doing now, shared with the watchdog thread.
struct Watched {
  std::mutex mutex;
  std::string what = "the test program, before its first test";
  long long steps = -1;  //!< the watched run's steps (0: not known); -1: no run watched yet
  std::atomic<long long> done{0};
  std::atomic<Clock::rep> last{Clock::now().time_since_epoch().count()};
  std::atomic<pid_t> child{0};
  std::atomic<bool> armed{false};  //!< something is watched: the stall limit applies
};

Watched& state() {
  static Watched w;
  return w;
}

double env_seconds(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atof(v) : fallback;
}

double seconds_since(Clock::rep then) {
  return std::chrono::duration<double>(Clock::now().time_since_epoch() - Clock::duration(then))
      .count();
}

/// The scratch folders alive now and the files named in them (ScratchDir), as fixed C strings,
/// so that they can be removed from a signal handler with unlink() and rmdir() alone, which are
/// async-signal-safe: whatever ends the program, the folders go with it.
struct ScratchRegistry {
  static constexpr int kMax = 64;
  char path[kMax][512] = {};  //!< a registered path per slot ("" once its folder is gone)
  bool folder[kMax] = {};     //!< whether the slot's path is a folder (removed after the files)
  std::atomic<int> count{0};
};

ScratchRegistry& scratch_registry() {
  static ScratchRegistry r;
  return r;
}

/// Records `path` (a folder, or a file inside one) for removal; false when there is no room.
bool register_scratch(const std::string& path, bool is_folder) {
  ScratchRegistry& r = scratch_registry();
  const int slot = r.count.load();
  if (slot >= ScratchRegistry::kMax || path.size() >= sizeof r.path[0]) return false;
  std::memcpy(r.path[slot], path.c_str(), path.size() + 1);
  r.folder[slot] = is_folder;
  r.count = slot + 1;
  return true;
}

/// Removes every registered file, then every registered folder (async-signal-safe).
void remove_scratch() {
  ScratchRegistry& r = scratch_registry();
  const int n = r.count.load();
  for (int k = n - 1; k >= 0; --k)
    if (!r.folder[k] && r.path[k][0] != '\0') unlink(r.path[k]);
  for (int k = n - 1; k >= 0; --k)
    if (r.folder[k] && r.path[k][0] != '\0') rmdir(r.path[k]);
}

/// A fatal signal: the scratch folders are removed, then the signal does what it would have
/// done (SA_RESETHAND restored the default action).
void on_fatal_signal(int signum) {
  remove_scratch();
  raise(signum);
}

std::terminate_handler g_previous_terminate = nullptr;

/// An uncaught exception (a stage's "not done yet" thrown inside an OpenMP region ends up here):
/// the scratch folders are removed, then the usual message and abort().
[[noreturn]] void on_terminate() {
  remove_scratch();
  if (g_previous_terminate) g_previous_terminate();
  std::abort();
}

/// Removes the scratch folders however the program ends: std::terminate, abort, and (where no
/// sanitizer owns these signals for its own reports) a crash.
void install_scratch_cleanup() {
  g_previous_terminate = std::set_terminate(on_terminate);
  std::vector<int> signals{SIGABRT, SIGTERM, SIGINT};
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#if defined(__has_feature)
#if !__has_feature(address_sanitizer) && !__has_feature(thread_sanitizer)
  signals.insert(signals.end(), {SIGSEGV, SIGBUS, SIGFPE, SIGILL});
#endif
#else
  signals.insert(signals.end(), {SIGSEGV, SIGBUS, SIGFPE, SIGILL});
#endif
#endif
  struct sigaction action {};
  action.sa_handler = on_fatal_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;
  for (const int signum : signals) sigaction(signum, &action, nullptr);
}

/// Ends the test program (and its child, if any) with `why` on both streams (CTest keeps both).
[[noreturn]] void stop(const std::string& why) {
  Watched& w = state();
  if (const pid_t child = w.child.load(); child > 0) {
    kill(-child, SIGKILL);  // its process group: mpirun and its ranks too
    kill(child, SIGKILL);
  }
  remove_scratch();  // no destructor runs after _exit()
  std::fprintf(stdout, "\n%s\n", why.c_str());
  std::fprintf(stderr, "\n%s\n", why.c_str());
  std::fflush(nullptr);
  _exit(1);
}

/// "stage 03, scene course-2: finished 12 of 50 steps": where the watched work is.
std::string position() {
  Watched& w = state();
  std::lock_guard lock(w.mutex);
  const long long done = w.done.load();
  if (w.steps < 0) return w.what;  // a test that runs no watched scene (a Spec test)
  std::string at = w.what + ": ";
  at += "finished " + std::to_string(done);
  at += w.steps > 0 ? " of " + std::to_string(w.steps) + " steps" : " steps";
  return at;
}

/// Checks the limits twice a second for the life of the program.
void watchdog() {
  const double stall = env_seconds("PLAB_STALL_SECONDS", 20);
  const double limit = env_seconds("PLAB_TEST_SECONDS", 0);
  const auto start = Clock::now().time_since_epoch().count();
  char buf[64];
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    const double quiet = seconds_since(state().last.load());
    if (state().armed && quiet >= stall) {
      std::snprintf(buf, sizeof buf, "%.0f s", quiet);
      stop(position() + ", then nothing for " + buf + ": an endless loop?");
    }
    if (limit > 0 && seconds_since(start) >= limit) {
      std::snprintf(buf, sizeof buf, "%.0f s", limit);
      stop(position() + " when the test's limit of " + buf + " ran out: too slow, or an endless loop?");
    }
  }
}

/// Names the test that runs now, for the watchdog's message until the test watches a run of its
/// own (watch()): a test that steps no scene (the Spec tests) is named as "test Suite.Name".
class CurrentTest : public testing::EmptyTestEventListener {
 public:
  void OnTestStart(const testing::TestInfo& info) override {
    Watched& w = state();
    std::lock_guard lock(w.mutex);
    w.what = std::string("test ") + info.test_suite_name() + "." + info.name();
    w.steps = -1;
    w.armed = false;  // a stepper the last test left watched does not stall this one
  }
};

/// Says so when a program ends having checked no case: CTest's SKIP_REGULAR_EXPRESSION matches
/// "plab: no case was checked" and reports the test as skipped, with the first reason.
class NoCaseChecked : public testing::EmptyTestEventListener {
 public:
  void OnTestPartResult(const testing::TestPartResult& r) override {
    // the first reason, but one that concerns this stage before one that does not
    const auto not_this_stage = [](const std::string& why) {
      return why.rfind(kNotThisStage, 0) == 0;
    };
    if (r.skipped() && (reason_.empty() || (not_this_stage(reason_) &&
                                            !not_this_stage(r.message()))))
      reason_ = r.message();
  }
  void OnTestIterationEnd(const testing::UnitTest& u, int) override {
    if (u.successful_test_count() > 0 || u.failed_test_count() > 0) return;
    std::string why = reason_.empty() ? "no case is instantiated here" : reason_;
    while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
    std::printf("plab: no case was checked (%d skipped): %s\n", u.skipped_test_count(),
                why.c_str());
    std::fflush(stdout);
  }

 private:
  std::string reason_;
};

/// The stepper of `make`, reporting each finished step to the watchdog.
class WatchedStepper final : public Stepper {
 public:
  explicit WatchedStepper(std::unique_ptr<Stepper> inner) : inner_(std::move(inner)) {}
  void step() override {
    inner_->step();
    stepped(++done_);
  }
  void read(Particles& p) override { inner_->read(p); }
  [[nodiscard]] double own_seconds() const override { return inner_->own_seconds(); }
  [[nodiscard]] std::string device() const override { return inner_->device(); }
  [[nodiscard]] std::size_t device_bytes() const override { return inner_->device_bytes(); }

 private:
  std::unique_ptr<Stepper> inner_;
  long long done_ = 0;
};

/// Installs the listener and starts the watchdog before main() runs.
[[maybe_unused]] const bool installed = [] {
  testing::UnitTest::GetInstance()->listeners().Append(new NoCaseChecked);
  testing::UnitTest::GetInstance()->listeners().Append(new CurrentTest);
  install_scratch_cleanup();
  std::thread(watchdog).detach();
  return true;
}();

}  // namespace

void watch(const std::string& what, long long steps) {
  Watched& w = state();
  {
    std::lock_guard lock(w.mutex);
    w.what = what;
    w.steps = steps;
  }
  stepped(0);
  w.armed = true;
}

void watch_test(long long steps) {
  Watched& w = state();
  {
    std::lock_guard lock(w.mutex);
    w.steps = steps;  // w.what: the test's name, from CurrentTest
  }
  stepped(0);
  w.armed = true;
}

void stepped(long long done) {
  state().done = done;
  state().last = Clock::now().time_since_epoch().count();
}

void unwatch() { state().armed = false; }

void set_child(pid_t pid) { state().child = pid; }

MakeStepper watched(MakeStepper make) {
  return [make](const Box& box, Particles& p) -> std::unique_ptr<Stepper> {
    return std::make_unique<WatchedStepper>(make(box, p));
  };
}

namespace {

/// Starts `command_line` through sh in a process group of its own (what it starts, e.g. mpirun's
/// ranks, can be ended with it), as the watched child.
pid_t start_child(const std::string& command_line) {
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    setpgid(0, 0);
    execl("/bin/sh", "sh", "-c", ("exec " + command_line).c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  if (pid > 0) {
    setpgid(pid, pid);  // (also here: no signal may reach the group before the child set it)
    set_child(pid);
  }
  return pid;
}

int exit_status(int status) {
  return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status);
}

/// The steps done that a runner's status file (`DONE TOTAL`, its --status) says, or -1.
long long steps_done(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "r");
  if (!f) return -1;
  long long done = -1;
  if (std::fscanf(f, "%lld", &done) != 1) done = -1;
  std::fclose(f);
  return done;
}

}  // namespace

int run_watched(const std::string& command_line) {
  const pid_t pid = start_child(command_line);
  if (pid < 0) return 127;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  set_child(0);
  unwatch();
  return exit_status(status);
}

int run_watched_steps(const std::string& command_line, const std::string& what, long long steps,
                      const std::string& status_file, double stall, long long& done) {
  {  // what the program's own limit names, should it run out now (not armed: the stall is here)
    watch(what, steps);
    unwatch();
  }
  const pid_t pid = start_child(command_line);
  if (pid < 0) return 127;
  done = 0;
  auto last = Clock::now();
  int status = 0;
  for (;;) {
    const pid_t ended = waitpid(pid, &status, WNOHANG);
    if (ended == pid) break;
    if (const long long now = steps_done(status_file); now > done) {
      done = now;
      last = Clock::now();
      stepped(done);
    }
    if (std::chrono::duration<double>(Clock::now() - last).count() >= stall) {
      kill(-pid, SIGTERM);  // the whole group: mpirun ends its ranks, then the rest is killed
      std::this_thread::sleep_for(std::chrono::seconds(3));
      kill(-pid, SIGKILL);
      while (waitpid(pid, &status, 0) < 0) {
      }
      set_child(0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // (a short run ends sooner)
  }
  set_child(0);
  return exit_status(status);
}

ScratchDir::ScratchDir() {
  std::string templ = (std::filesystem::temp_directory_path() / "plab-test-XXXXXX").string();
  if (mkdtemp(templ.data()) == nullptr) throw std::runtime_error("cannot create " + templ);
  path_ = templ;
  if (!register_scratch(path_.string(), true))
    throw std::runtime_error("too many scratch folders at once in one test program");
}

ScratchDir::~ScratchDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
  // Forget what was registered for this folder (slots are reused from the end).
  ScratchRegistry& r = scratch_registry();
  int n = r.count.load();
  for (int k = 0; k < n; ++k)
    if (std::strncmp(r.path[k], path_.c_str(), path_.native().size()) == 0) r.path[k][0] = '\0';
  while (n > 0 && r.path[n - 1][0] == '\0') --n;
  r.count = n;
}

std::string ScratchDir::file(const std::string& name) const {
  const std::string path = (path_ / name).string();
  if (!register_scratch(path, false))
    throw std::runtime_error("too many scratch files at once in one test program");
  return path;
}

}  // namespace plab::test
