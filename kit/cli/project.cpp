/// \file cli/project.cpp
/// \brief Finding the project's folders and stage programs; starting processes.
#include "project.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

extern char** environ;

namespace plab::cli {
namespace fs = std::filesystem;

std::string source_dir() { return PLAB_SOURCE_DIR; }
std::string build_dir() { return PLAB_BINARY_DIR; }
std::string bin_dir() { return fs::read_symlink("/proc/self/exe").parent_path().string(); }

std::string impl_tree(const std::string& impl) {
  if (impl == "solution") return "solutions";
  if (impl == "engine") return "kit/instructor/engine";
  return "stages";
}

std::vector<StageDir> stages(const std::string& impl) {
  const fs::path root = fs::path(source_dir()) / impl_tree(impl);
  std::vector<StageDir> found;
  if (!fs::is_directory(root)) return found;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string n = entry.path().filename().string();
    if (entry.is_directory() && n.size() > 3 && std::isdigit(n[0]) && std::isdigit(n[1]) && n[2] == '-')
      found.push_back({n.substr(0, 2), n.substr(3)});
  }
  std::sort(found.begin(), found.end(), [](auto& a, auto& b) { return a.id < b.id; });
  return found;
}

nlohmann::json stage_declares(const std::string& id, const std::string& impl,
                              const std::string& key) {
  for (const StageDir& s : stages(impl)) {
    if (s.id != id) continue;
    const fs::path file = fs::path(source_dir()) / impl_tree(impl) /
                          (s.id + "-" + s.name) / "stage.json";
    std::ifstream in(file);
    if (!in) return nullptr;
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    return j.is_object() && j.contains(key) ? j[key] : nlohmann::json();
  }
  return nullptr;
}

namespace {
/// Where this process's runs on ranks keep Open MPI's session files and shared-memory segments:
/// one folder, made on the first run and removed when plab ends. Left to Open MPI, a run that is
/// ended (--timeout, Ctrl-C, a crash) leaves /tmp/ompi.* and /dev/shm/vader_segment.* behind.
/// Under the system's temporary folder, not build/: Open MPI's sockets need a short path.
struct MpiScratch {
  std::string path;
  ~MpiScratch() {
    std::error_code ignored;
    if (!path.empty()) fs::remove_all(path, ignored);
  }
} g_mpi_scratch;
}  // namespace

std::vector<std::string> on_ranks(const std::string& id, const std::string& impl, int ranks,
                                  std::vector<std::string> program_and_args, bool bound) {
  if (stage_declares(id, impl, "needs_mpi") != true)
    throw std::runtime_error("stage " + id + " runs on one process: --ranks is for the stages "
                             "that declare needs_mpi in their stage.json (08)");
  if (geteuid() == 0) {  // OpenMPI refuses root unless told twice (containers, CI)
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  }
  if (g_mpi_scratch.path.empty()) {
    std::string templ = (fs::temp_directory_path() / "plab-mpi-XXXXXX").string();
    if (mkdtemp(templ.data()) == nullptr)
      throw std::runtime_error("cannot create a folder for mpirun's files: " + templ);
    g_mpi_scratch.path = templ;
    setenv("TMPDIR", templ.c_str(), 1);
    setenv("OMPI_MCA_btl_vader_backing_directory", templ.c_str(), 1);
  }
  // Each run its own folder for Open MPI's session files: runs at once in one folder (plab
  // bench --ceiling's copies) race as one removes the session folder another is making
  // ("ORTE_ERROR_LOG: Error in file ../../../orte/util/session_dir.c", seen in CI).
  static int runs = 0;
  const std::string own = g_mpi_scratch.path + "/" + std::to_string(++runs);
  fs::create_directories(own);
  std::vector<std::string> args{"env", "TMPDIR=" + own, "mpirun", "--quiet", "--oversubscribe",
                                "-np", std::to_string(ranks)};
  if (!bound) args.insert(args.begin() + 3, {"--bind-to", "none"});
  args.insert(args.end(), program_and_args.begin(), program_and_args.end());
  return args;
}

std::string default_impl() {
  return fs::is_directory(fs::path(source_dir()) / "solutions") ? "solution" : "student";
}

std::string stage_program(const std::string& id, const std::string& impl) {
  return bin_dir() + "/plab-run-" + id + "-" + impl;
}

namespace {
std::vector<char*> argv_of(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  return argv;
}
}  // namespace

namespace {
/// Starts a program (stdout to `stdout_path` when given, and stderr with it when `and_stderr`)
/// and returns its process id, or -1 when it could not be started.
pid_t start_program(const std::vector<std::string>& args, const std::string& stdout_path,
                    bool and_stderr = false) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (!stdout_path.empty())
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, stdout_path.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (and_stderr) posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::fflush(nullptr);
  pid_t pid = 0;
  auto argv = argv_of(args);
  const int rc = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  remember_child(pid);
  return pid;
}

/// Waits for a program start_program() started: its exit status as run_program() gives it.
int wait_program(pid_t pid) {
  if (pid < 0) return 127;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  forget_child(pid);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WEXITSTATUS(status);
}
}  // namespace

int run_program(const std::vector<std::string>& args, const std::string& stdout_path) {
  return wait_program(start_program(args, stdout_path));
}

std::vector<int> run_programs(const std::vector<std::vector<std::string>>& programs) {
  std::vector<pid_t> pids;
  for (const auto& args : programs) pids.push_back(start_program(args, ""));
  std::vector<int> status;
  for (const pid_t pid : pids) status.push_back(wait_program(pid));
  return status;
}

Captured capture_program(const std::vector<std::string>& args) {
  const fs::path dir = fs::path(build_dir()) / "tmp";
  fs::create_directories(dir);
  const std::string path = (dir / ("capture." + std::to_string(getpid()))).string();
  Captured c;
  c.status = wait_program(start_program(args, path, true));
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  c.text = text.str();
  fs::remove(path);
  return c;
}

namespace {
/// Whether a FAILED line of Ninja's log is about stage `id` of `impl`'s targets.
bool names_stage(const std::string& line, const std::string& id, const std::string& impl) {
  for (const std::string& t : {"plab_stage_" + id + "_" + impl, "plab-run-" + id + "-" + impl,
                               "stage" + id + "_" + impl + "_tests"})
    if (line.find(t) != std::string::npos) return true;
  return false;
}

/// A compiler message's file name relative to the source folder: the compiler names it in full,
/// or (ccache with CCACHE_BASEDIR) relative to the build folder, "../stages/...".
std::string path_from_source_dir(const std::string& line) {
  const std::string root = source_dir() + "/";
  if (line.rfind(root, 0) == 0) return line.substr(root.size());
  const std::size_t colon = line.find(':');
  if (colon == std::string::npos || colon == 0 || line[0] == '/') return line;
  const fs::path file = (fs::path(build_dir()) / line.substr(0, colon)).lexically_normal();
  const fs::path relative = file.lexically_relative(fs::path(source_dir()).lexically_normal());
  if (relative.empty() || *relative.begin() == "..") return line;
  return relative.generic_string() + line.substr(colon);
}
}  // namespace

std::string first_compiler_error(const std::string& id, const std::string& impl) {
  std::ifstream log(build_dir() + "/last-build.log");
  std::string line;
  bool in_stage = false;
  while (std::getline(log, line)) {
    if (line.rfind("FAILED:", 0) == 0) {
      in_stage = names_stage(line, id, impl);
      continue;
    }
    if (line.rfind("[", 0) == 0 || line.rfind("ninja:", 0) == 0) in_stage = false;
    if (!in_stage || (line.find("error:") == std::string::npos &&
                      line.find("undefined reference") == std::string::npos))
      continue;
    return path_from_source_dir(line);
  }
  return "";
}

std::string stage_build_problem(const std::string& id, const std::string& impl,
                                const std::vector<std::string>& targets) {
  if (std::string(PLAB_GENERATOR) != "Ninja") return "";
  std::vector<std::string> args{PLAB_MAKE_PROGRAM, "-C", build_dir(), "-n",
                                "plab-run-" + id + "-" + impl};
  args.insert(args.end(), targets.begin(), targets.end());
  const Captured dry = capture_program(args);
  if (dry.status == 0 && dry.text.find("no work to do") != std::string::npos) return "";
  if (const std::string error = first_compiler_error(id, impl); !error.empty())
    return "stage " + id + " did not compile: " + error;
  return "stage " + id + " (" + impl + ") is not built from its current code: it did not compile, "
         "or it changed since the last build (./plab builds it; the compiler's errors: cmake "
         "--build " + build_dir() + " --target plab-run-" + id + "-" + impl + ")";
}

void exec_program(const std::vector<std::string>& args) {
  auto argv = argv_of(args);
  std::fflush(nullptr);
  execvp(argv[0], argv.data());
  std::fprintf(stderr, "error: cannot start %s\n", args[0].c_str());
  std::exit(127);
}

}  // namespace plab::cli
