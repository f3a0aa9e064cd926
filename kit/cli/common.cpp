/// \file cli/common.cpp
/// \brief The helpers the `plab` commands share (common.hpp).
#include "common.hpp"

#include <charconv>

#include <csignal>
#include <cstdlib>
#include <cstring>

#include <signal.h>
#include <unistd.h>

namespace plab::cli {

int g_status = 0;

int exit_status() { return g_status; }

std::string two_digits(const std::string& stage) {
  return stage.size() == 1 ? "0" + stage : stage;
}

void check_impl(const std::string& impl) {
  if (impl != "solution" && impl != "student" && impl != "engine")
    throw std::runtime_error("--impl must be 'solution', 'student' or 'engine', not '" + impl +
                             "'");
}

std::string wait_as_the_grader(const std::string& impl) {
  if (impl != "engine") ::setenv("OMP_WAIT_POLICY", "passive", /*overwrite=*/0);
  const char* policy = std::getenv("OMP_WAIT_POLICY");
  return policy ? policy : "OpenMP's default";
}

void require_stage_folder(const std::string& id, const std::string& impl) {
  bool exists = false;
  std::string known;
  for (const auto& s : stages(impl)) {
    exists = exists || s.id == id;
    known += (known.empty() ? "" : ", ") + s.id;
  }
  if (!exists)
    throw std::runtime_error("there is no stage " + id + " in " + impl_tree(impl) +
                             "/ (stages: " + (known.empty() ? "none" : known) + ")");
}

std::string require_stage(const std::string& id, const std::string& impl) {
  require_stage_folder(id, impl);
  const std::string tree = impl_tree(impl) + "/";
  const std::string program = stage_program(id, impl);
  if (!fs::exists(program))
    throw std::runtime_error("stage " + id + " (" + impl + ") is not built: its code in " + tree +
                             " did not compile. See the errors with: cmake --build " + build_dir() +
                             " --target plab-run-" + id + "-" + impl);
  if (const std::string problem = stage_build_problem(id, impl); !problem.empty())
    throw std::runtime_error(problem);
  return program;
}

double wall_seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string fmt_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

/// The kind of a file from its first line: `STEP INDEX wall|pair` is an events file, `STEP HASH`
/// (16 hex digits) a digest file, 6 or 8 numbers an output, anything else a scene (whose parser
/// then says what is wrong). An empty text has no kind (an events file may be empty: give --kind).
std::string detect_kind(std::string_view text, const std::string& file) {
  const std::string_view first = text.substr(0, text.find('\n'));
  std::vector<std::string_view> words;
  for (std::size_t i = 0; i < first.size();) {
    while (i < first.size() && (first[i] == ' ' || first[i] == '\t' || first[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < first.size() && first[i] != ' ' && first[i] != '\t' && first[i] != '\r') ++i;
    if (i > start) words.push_back(first.substr(start, i - start));
  }
  if (text.find_first_not_of(" \t\r\n") == std::string_view::npos)
    throw InputError(file + ": the file is empty, so its kind is unknown (an events file may be "
                     "empty: give --kind events)");
  if (words.size() == 3 && (words[2] == "wall" || words[2] == "pair")) return "events";
  if (words.size() == 2 && words[1].size() == 16 &&
      words[1].find_first_not_of("0123456789abcdef") == std::string_view::npos)
    return "digest";
  const bool numbers = std::all_of(words.begin(), words.end(), [](std::string_view w) {
    double v = 0;
    const char* b = w.data() + (!w.empty() && w.front() == '+');
    return std::from_chars(b, w.data() + w.size(), v).ec == std::errc();
  });
  if ((words.size() == 6 || words.size() == 8) && numbers) return "output";
  return "scene";
}

namespace {
/// The scratch files temp_path() named, as C strings a signal handler may read (no allocation).
constexpr int kMaxTemps = 256;
constexpr std::size_t kMaxTempPath = 1024;
char g_temps[kMaxTemps][kMaxTempPath];
volatile sig_atomic_t g_temp_count = 0;
/// The programs started and not yet waited for (remember_child()); 0: a free place.
constexpr int kMaxChildren = 64;
volatile pid_t g_children[kMaxChildren] = {};

/// Ctrl-C, `kill` or a closed terminal while a command runs: the programs it started get the same
/// signal (a `kill` of this process alone would leave them running), its scratch files go (kill
/// and unlink are async-signal-safe; a file not made yet, or removed already, is no harm), then
/// the signal ends the process as it would have.
extern "C" void stop_children_remove_temps(int sig) {
  for (int i = 0; i < kMaxChildren; ++i)
    if (g_children[i] > 0) kill(g_children[i], sig);
  for (int i = 0; i < g_temp_count; ++i) unlink(g_temps[i]);
  std::signal(sig, SIG_DFL);
  raise(sig);
}

/// Installs the handler once, for the signals that would end the process (not where they are
/// ignored, as for a command started in the background by a script).
void handle_stop_signals() {
  static bool installed = false;
  if (installed) return;
  installed = true;
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction now {};
    if (sigaction(sig, nullptr, &now) == 0 && now.sa_handler == SIG_DFL)
      std::signal(sig, stop_children_remove_temps);
  }
}

void remember_temp(const std::string& path) {
  handle_stop_signals();
  if (g_temp_count >= kMaxTemps || path.size() >= kMaxTempPath) return;
  std::memcpy(g_temps[g_temp_count], path.c_str(), path.size() + 1);
  g_temp_count = g_temp_count + 1;
}
}  // namespace

void remember_child(pid_t pid) {
  handle_stop_signals();
  for (int i = 0; i < kMaxChildren; ++i)
    if (g_children[i] == 0) {
      g_children[i] = pid;
      return;
    }
}

void forget_child(pid_t pid) {
  for (int i = 0; i < kMaxChildren; ++i)
    if (g_children[i] == pid) g_children[i] = 0;
}

std::string temp_path(const std::string& stem) {
  const fs::path dir = fs::path(build_dir()) / "tmp";
  fs::create_directories(dir);
  const std::string path = (dir / (stem + "." + std::to_string(getpid()))).string();
  remember_temp(path);
  return path;
}

void write_text(const std::string& path, const std::string& text) {
  OutputFile f(path);
  std::fwrite(text.data(), 1, text.size(), f.get());
  f.commit();
}

CLI::App* add_python_command(CLI::App& app, const std::string& name, const std::string& about,
                             const std::string& module,
                             std::function<std::vector<std::string>()> fixed) {
  CLI::App* c = app.add_subcommand(name, about);
  c->prefix_command();  // everything after NAME goes to the module as it was typed
  c->set_help_flag();
  c->callback([c, module, fixed] {
    std::vector<std::string> args{"python3", "-m", module};
    for (std::string& s : fixed()) args.push_back(std::move(s));
    for (const std::string& s : c->remaining()) args.push_back(s);
    // In its place (exec): a signal to this process (Ctrl-C, `kill`, a timeout) reaches Python,
    // which stops its own children, and its exit status is this command's
    exec_program(args);
  });
  return c;
}

}  // namespace plab::cli
