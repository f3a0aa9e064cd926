/// \file cli/project.hpp
/// \brief Where things are (source tree, build tree, stage programs) and running other programs.
#pragma once

#include <sys/types.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace plab::cli {

/// The project's source folder (where `stages/`, `solutions/`, `datasets/` live).
std::string source_dir();
/// The build folder the CLI was built in.
std::string build_dir();
/// The folder holding the CLI and the stage programs.
std::string bin_dir();

/// One stage found in the source tree.
struct StageDir {
  std::string id;    //!< two digits, e.g. `01`
  std::string name;  //!< e.g. `naive`
};
/// The folder (under the source folder) of one tree's stages: `solutions` (impl `solution`),
/// `stages` (`student`) or `kit/instructor/engine` (`engine`: the kit's instructor-only fast
/// versions, handouts/engine.md).
std::string impl_tree(const std::string& impl);
/// The stages of one tree (`solution`, `student` or `engine`), in order.
std::vector<StageDir> stages(const std::string& impl);
/// A key of a stage's `stage.json` (null when the stage or the key is missing).
nlohmann::json stage_declares(const std::string& id, const std::string& impl, const std::string& key);
/// `program` and its arguments started on `ranks` ranks by mpirun (oversubscribed: more ranks
/// than cores are fine; as root, with OpenMPI's two confirmations; its session files and
/// shared-memory segments in a folder of this process's, removed when it ends). For a stage that
/// declares `needs_mpi`; throws for any other. `bound` false: the ranks not bound to cores
/// (mpirun binds a run of one or two ranks to the first cores, so several such runs at once would
/// all share them).
std::vector<std::string> on_ranks(const std::string& id, const std::string& impl, int ranks,
                                  std::vector<std::string> program_and_args, bool bound = true);

/// `solution` when the kit has `solutions/` (the instructor's copy), `student` otherwise.
std::string default_impl();
/// The program that runs stage `id` of `impl` (it may not exist if the stage did not compile).
std::string stage_program(const std::string& id, const std::string& impl);

/// Why stage `id` of `impl` must not be run or tested now, or nothing when its programs (its
/// runner and the extra `targets`, e.g. its test program) are built from its current code. A stage
/// that stopped compiling keeps its last good programs in the build tree: this is what tells them
/// apart ("stage 01 did not compile: stages/01-naive/step.cpp:12:3: error: ..."). It asks the
/// build tool for a dry run (Ninja builds only; other generators are not checked).
std::string stage_build_problem(const std::string& id, const std::string& impl,
                                const std::vector<std::string>& targets = {});

/// The compiler's first error about stage `id` of `impl` in the last build's log
/// (`build/last-build.log`, written by `./plab`), as FILE:LINE:COL: error: ..., or nothing.
std::string first_compiler_error(const std::string& id, const std::string& impl);

/// Runs a program and waits, its stdout and stderr together in the returned text.
struct Captured {
  int status = 0;    //!< the exit status, as run_program() gives it
  std::string text;  //!< what it printed
};
/// Runs a program and waits, capturing what it prints (see Captured).
Captured capture_program(const std::vector<std::string>& args);

/// Runs a program and waits; stdout goes to `stdout_path` when given. Returns the exit status
/// (128 + signal when killed by a signal, 127 when it could not be started).
int run_program(const std::vector<std::string>& args, const std::string& stdout_path = "");
/// Runs the programs at once, each as run_program() runs one (stdout not redirected), and waits
/// for them all: their exit statuses, in order.
std::vector<int> run_programs(const std::vector<std::vector<std::string>>& programs);
/// Replaces this process with the program (does not return unless it fails).
[[noreturn]] void exec_program(const std::vector<std::string>& args);
/// A program this command started (its process id): a signal that ends the command (Ctrl-C,
/// `kill`) is passed on to it until forget_child() (once it has been waited for). In common.cpp.
void remember_child(pid_t pid);
void forget_child(pid_t pid);

}  // namespace plab::cli
