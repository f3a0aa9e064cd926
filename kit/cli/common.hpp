/// \file cli/common.hpp
/// \brief What the `plab` commands share: the exit status they set, and small helpers (each
/// command is one file, kit/cli/NAME.cpp, registered in main.cpp through commands.hpp).
#pragma once

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <nlohmann/json.hpp>
#include <vector>
#include "plab/datasets.hpp"
#include "plab/diff.hpp"
#include "plab/errors.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"
#include "plab/runtime.hpp"
#include "project.hpp"
#include "test_report.hpp"
#include "watch.hpp"
#include "commands.hpp"

namespace plab::cli {
namespace fs = std::filesystem;

/// The exit status the chosen command asks for (main returns it; see exit_status()).
extern int g_status;

/// The kind of a scene, output, digest or events file from its first line ("scene", "output",
/// "digest" or "events"); throws InputError for an empty text.
std::string detect_kind(std::string_view text, const std::string& file);

/// "1" -> "01": a stage number as the kit names its folders and targets.
std::string two_digits(const std::string& stage);
/// Throws unless `impl` is "solution", "student" or "engine" (the kit's instructor-only fast
/// versions in kit/instructor/engine, where a stage has one).
void check_impl(const std::string& impl);
/// Times a stage's OpenMP threads as the grader does: waiting passively at a barrier (asleep,
/// not spinning), unless the environment sets OMP_WAIT_POLICY. Spinning threads take the cores
/// that the others need on a shared machine: two threads could take twice one thread's time.
/// The engine keeps OpenMP's default (what its measurements used). Returns the policy in use.
std::string wait_as_the_grader(const std::string& impl);
/// Throws "there is no stage NN in TREE/ (stages: ...)" unless the stage's folder exists.
void require_stage_folder(const std::string& id, const std::string& impl);
/// The stage program, or a clear error saying why there is none (no such stage, not built, or
/// not built from its current code).
std::string require_stage(const std::string& id, const std::string& impl);
/// Seconds since `t0`.
double wall_seconds(std::chrono::steady_clock::time_point t0);
/// A double as text that reads back to the same value.
std::string fmt_double(double v);
/// A scratch file name in build/tmp/, unique to this process; removed if a signal (Ctrl-C, kill)
/// ends the process.
std::string temp_path(const std::string& stem);
/// Writes `text` to `path` whole or not at all (plab::OutputFile).
void write_text(const std::string& path, const std::string& text);

/// Registers a command whose options are a Python module's own (`plab NAME ARGS...` runs
/// `python3 -m MODULE FIXED... ARGS...`, ARGS untouched, so `plab NAME --help` prints the module's
/// help): the options are declared once, in the module. `fixed` gives, when the command runs, the
/// arguments that only the C++ side knows (the kit's folders and programs); it may throw to refuse.
CLI::App* add_python_command(CLI::App& app, const std::string& name, const std::string& about,
                             const std::string& module,
                             std::function<std::vector<std::string>()> fixed);

}  // namespace plab::cli
