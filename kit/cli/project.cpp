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

extern char** environ;

namespace plab::cli {
namespace fs = std::filesystem;

std::string source_dir() { return PLAB_SOURCE_DIR; }
std::string build_dir() { return PLAB_BINARY_DIR; }
std::string bin_dir() { return fs::read_symlink("/proc/self/exe").parent_path().string(); }

std::vector<StageDir> stages(const std::string& impl) {
  const fs::path root = fs::path(source_dir()) / (impl == "solution" ? "solutions" : "stages");
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

int run_program(const std::vector<std::string>& args, const std::string& stdout_path) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (!stdout_path.empty())
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, stdout_path.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::fflush(nullptr);
  pid_t pid = 0;
  auto argv = argv_of(args);
  const int rc = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return 127;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WEXITSTATUS(status);
}

void exec_program(const std::vector<std::string>& args) {
  auto argv = argv_of(args);
  std::fflush(nullptr);
  execvp(argv[0], argv.data());
  std::fprintf(stderr, "error: cannot start %s\n", args[0].c_str());
  std::exit(127);
}

}  // namespace plab::cli
