/// \file cli/watch.cpp
/// \brief run_stage_watched(): a stage program under a limit, its whole process group ended.
#include "watch.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "plab/mpi/where.hpp"

namespace plab::cli {
namespace {

using Clock = std::chrono::steady_clock;

volatile sig_atomic_t g_stop_signal = 0;

void on_stop_signal(int sig) { g_stop_signal = sig; }

/// Steps finished and in all, as the program last reported them (its --status file).
struct Steps {
  long long done = 0;
  long long total = 0;
};

Steps read_steps(const std::string& path) {
  Steps s;
  std::ifstream in(path);
  in >> s.done >> s.total;
  return s;
}

std::string where(const Steps& s) {
  if (s.total <= 0) return "before its first step";
  return "after step " + std::to_string(s.done) + " of " + std::to_string(s.total);
}

/// Starts the program in a new process group that dies with this process.
pid_t start(const std::vector<std::string>& args) {
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid != 0) {
    if (pid > 0) setpgid(pid, pid);
    return pid;
  }
  setpgid(0, 0);
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  execvp(argv[0], argv.data());
  std::fprintf(stderr, "error: cannot start %s\n", args[0].c_str());
  _exit(127);
}

/// Seconds without a finished step after which a run on several ranks is said to be, most
/// likely, ranks waiting for each other.
constexpr double kStallHint = 30;

/// What a run on several ranks that has finished no step for `quiet` seconds is most likely
/// doing; with `advice`, how to end it.
/// The folder where the ranks say which MPI call each is in (plab/mpi/where.hpp), for a run on
/// several ranks; empty otherwise.
std::string g_where_dir;
int g_where_ranks = 0;

std::string stall_hint(double quiet, bool advice) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f s", quiet);
  const std::string where = g_where_dir.empty()
                                ? std::string()
                                : dist::where_ranks_are(g_where_dir, g_where_ranks);
  return std::string(" (no step finished in the last ") + buf +
         ": ranks waiting for each other for ever? a send without its receive, or a collective "
         "some rank skips" + (where.empty() ? "" : "; " + where) +
         (advice ? "; Ctrl-C ends every rank, --timeout does it for you)" : ")");
}

/// Removes the ranks' folder of where.hpp (and its files) at the end of a run.
void remove_where_dir() {
  if (g_where_dir.empty()) return;
  std::error_code ignored;
  std::filesystem::remove_all(g_where_dir, ignored);
  g_where_dir.clear();
}

/// Shows where a long run is: a line kept in place on a terminal after 1 s, otherwise one line
/// every 10 s once the run has taken that long.
class Progress {
 public:
  Progress(std::string label, int ranks)
      : label_(std::move(label)), ranks_(ranks), tty_(isatty(STDERR_FILENO)) {}
  /// `t`: seconds since the start; `quiet`: since the last step finished.
  void show(double t, double quiet, const Steps& s) {
    if (s.total <= 0) return;
    const bool stalled = ranks_ > 1 && quiet >= kStallHint;
    if (tty_ && t >= 1.0 && t - last_ >= 0.25) {
      const int n = std::fprintf(
          stderr, "\r  step %lld/%lld, %.1f s%s ", s.done, s.total, t,
          stalled ? " (no step for a while: ranks waiting for each other? Ctrl-C ends them all)"
                  : "");
      shown_ = std::max(shown_, n);
      last_ = t;
    } else if (!tty_ && t - last_ >= 10.0) {
      std::fprintf(stderr, "plab run: %s: step %lld of %lld after %.0f s%s\n", label_.c_str(),
                   s.done, s.total, t, stalled ? stall_hint(quiet, true).c_str() : "");
      last_ = t;
    }
  }
  void clear() {
    if (shown_ > 0) std::fprintf(stderr, "\r%*s\r", shown_, "");
    shown_ = 0;
  }

 private:
  std::string label_;
  int ranks_;
  bool tty_;
  double last_ = 0;
  int shown_ = 0;  //!< the longest line shown in place (0: none)
};

/// The exit status, with a message when a signal ended the program.
int report_end(int status, const RunWatch& w, const Steps& s) {
  if (!WIFSIGNALED(status)) {
    const int code = WEXITSTATUS(status);
    // mpirun passes a rank's death by a signal on as 128 + its number, after its own report
    // (a backtrace a rank): the kit's one line says what it was and when.
    if (w.ranks > 1 && code > 128 && code < 128 + NSIG && code - 128 != SIGPIPE) {
      const char* abbrev = sigabbrev_np(code - 128);
      std::fprintf(stderr, "plab run: %s: a rank crashed: SIG%s (%s) %s (mpirun's report of it "
                   "above)\n", w.label.c_str(), abbrev ? abbrev : "?", strsignal(code - 128),
                   where(s).c_str());
    }
    return code;
  }
  const int sig = WTERMSIG(status);
  if (sig == SIGPIPE) return 128 + sig;  // its reader stopped reading (`| head`): not a crash
  const char* abbrev = sigabbrev_np(sig);
  std::fprintf(stderr, "plab run: %s crashed: SIG%s (%s) %s\n", w.label.c_str(),
               abbrev ? abbrev : "?", strsignal(sig), where(s).c_str());
  return 128 + sig;
}

/// Ends the program `pid` and its process group: SIGTERM first, so that mpirun can end the ranks
/// it started (they are not all in its group, and outlived a SIGKILL by seconds), then SIGKILL
/// after at most 3 s for whatever is left. Returns its wait status.
int end_group(pid_t pid) {
  kill(-pid, SIGTERM);
  int status = 0;
  const auto t0 = Clock::now();
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::duration<double>(Clock::now() - t0).count() >= 3) {
      kill(-pid, SIGKILL);
      waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(-pid, SIGKILL);  // anything left in the group
  return status;
}

}  // namespace

int run_stage_watched(const std::vector<std::string>& args, const RunWatch& w) {
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, on_stop_signal);
  if (!w.status_path.empty()) std::remove(w.status_path.c_str());
  if (w.ranks > 1) {  // each rank says where it is (plab/mpi/where.hpp), read on a stall
    std::string dir = (std::filesystem::temp_directory_path() / "plab-where-XXXXXX").string();
    if (mkdtemp(dir.data()) != nullptr) {
      g_where_dir = dir;
      g_where_ranks = w.ranks;
      setenv(dist::kWhereVariable, dir.c_str(), 1);
    }
  }
  struct Cleanup {
    ~Cleanup() { remove_where_dir(); }
  } cleanup;
  const pid_t pid = start(args);
  if (pid < 0) return 127;
  const auto t0 = Clock::now();
  auto last_change = t0;
  Steps steps;
  Progress progress(w.label, w.ranks);
  for (;;) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) {
      kill(-pid, SIGKILL);  // anything the program left behind in its group
      progress.clear();
      if (!w.status_path.empty()) steps = read_steps(w.status_path);
      return report_end(status, w, steps);
    }
    const auto now = Clock::now();
    const double t = std::chrono::duration<double>(now - t0).count();
    if (!w.status_path.empty()) {
      const Steps s = read_steps(w.status_path);
      if (s.done != steps.done) last_change = now;
      steps = s;
    }
    const double quiet = std::chrono::duration<double>(now - last_change).count();
    progress.show(t, quiet, steps);
    const bool limit = w.timeout > 0 && t >= w.timeout;
    if (limit || g_stop_signal) {
      end_group(pid);
      progress.clear();
      const bool stalled = w.ranks > 1 && quiet >= kStallHint;
      if (!limit) {
        const char* abbrev = sigabbrev_np(g_stop_signal);
        std::fprintf(stderr, "plab run: %s: stopped (SIG%s), %s%s\n", w.label.c_str(),
                     abbrev ? abbrev : "?", where(steps).c_str(),
                     stalled ? stall_hint(quiet, false).c_str() : "");
        return 128 + g_stop_signal;
      }
      const std::string ranks_at =
          g_where_dir.empty() ? std::string() : dist::where_ranks_are(g_where_dir, w.ranks);
      std::fprintf(stderr,
                   "plab run: %s: stopped at the --timeout of %g s, %s (no step finished in the "
                   "last %.0f s): %san endless loop?%s%s\n",
                   w.label.c_str(), w.timeout, where(steps).c_str(), quiet,
                   w.ranks > 1 ? "ranks waiting for each other for ever (a send without its "
                                 "receive, a collective some rank skips?), or "
                               : "",
                   ranks_at.empty() ? "" : " Where the ranks were: ", ranks_at.c_str());
      return 124;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

}  // namespace plab::cli
