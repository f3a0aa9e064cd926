/// \file runtime.hpp
/// \brief What programs around the stages need: all-or-nothing output files, threads, terminals.
#pragma once

#include <cstdio>
#include <string>

namespace plab {

/// An output file written under a temporary name and renamed into place by commit(), so a run
/// that fails never leaves a partial file that looks complete. An empty path means standard
/// output (output_stream()).
class OutputFile {
 public:
  /// Opens `path` for writing (output_stream() when empty, or nothing when empty and `optional`).
  /// \throws InputError when the file cannot be created
  explicit OutputFile(const std::string& path, bool optional = false);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  /// The stream to write to (null when optional and not asked for).
  [[nodiscard]] std::FILE* get() const { return file_; }
  /// Closes the file and moves it into place.
  /// \throws InputError when writing failed (disk full, ...)
  void commit();

 private:
  std::string path_;
  std::string temp_;
  std::FILE* file_ = nullptr;
};

/// Keeps the process's standard output for the kit's output alone: from here on, what the stage
/// prints to stdout (printf, std::cout: a student's debugging) goes to stderr, so that it never
/// mixes into the output, and an OutputFile to stdout writes to the stream kept (output_stream()).
/// The stage programs call it before the stage runs.
void keep_stdout_for_output();
/// Where the output goes when it goes to standard output: the stream keep_stdout_for_output()
/// kept, or stdout before it is called.
std::FILE* output_stream();

/// Sets the number of OpenMP threads (0: leave the default, all cores). No-op without OpenMP.
void set_threads(int threads);
/// Sets the OpenMP schedule of `schedule(runtime)` loops from `KIND[,CHUNK]` (KIND: static,
/// dynamic, guided; empty: leave it). \throws InputError for anything else.
void set_schedule(const std::string& schedule);
/// The number of threads a parallel region would use now (1 without OpenMP).
int get_threads();
/// Whether stderr is a terminal (progress is shown only there).
bool stderr_is_terminal();

}  // namespace plab
