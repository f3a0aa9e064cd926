/// \file runtime.cpp
/// \brief Output files renamed into place, thread control, terminal detection.
#include "plab/runtime.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#if defined(_OPENMP)
#include <omp.h>
#endif

#include "plab/errors.hpp"

namespace plab {

namespace {
std::FILE* g_output = nullptr;  //!< the process's first stdout, kept by keep_stdout_for_output()
}  // namespace

void keep_stdout_for_output() {
  if (g_output) return;
  std::fflush(stdout);
  const int fd = ::dup(STDOUT_FILENO);
  if (fd < 0) return;
  std::FILE* saved = ::fdopen(fd, "w");
  if (!saved) {
    ::close(fd);
    return;
  }
  if (::dup2(STDERR_FILENO, STDOUT_FILENO) < 0) {
    std::fclose(saved);
    return;
  }
  // Line by line, as on a terminal: a print is seen when made, between the kit's own lines.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  g_output = saved;
}

std::FILE* output_stream() { return g_output ? g_output : stdout; }

OutputFile::OutputFile(const std::string& path, bool optional) : path_(path) {
  if (path.empty() || (g_output && path == "/dev/stdout")) {
    file_ = optional ? nullptr : output_stream();
    return;
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    // A device or a pipe (/dev/null, /dev/stdout): written in place. Renaming a file onto it
    // would replace the device itself when run as root.
    file_ = std::fopen(path.c_str(), "wb");
    if (!file_) throw InputError(path + ": cannot open for writing (" + std::strerror(errno) + ")");
    return;
  }
  temp_ = path + ".partial";
  file_ = std::fopen(temp_.c_str(), "wb");
  if (!file_) throw InputError(path + ": cannot create the file (" + std::strerror(errno) + ")");
}

OutputFile::~OutputFile() {
  if (!temp_.empty() && file_) {
    std::fclose(file_);
    std::remove(temp_.c_str());
  } else if (file_ && file_ != output_stream()) {
    std::fclose(file_);  // a device written in place
  }
}

void OutputFile::commit() {
  if (!file_) return;
  if (temp_.empty()) {
    if (std::fflush(file_) != 0) throw InputError("cannot write the output: " + std::string(std::strerror(errno)));
    return;
  }
  const bool ok = std::fflush(file_) == 0 && std::ferror(file_) == 0;
  std::fclose(file_);
  file_ = nullptr;
  if (!ok || std::rename(temp_.c_str(), path_.c_str()) != 0) {
    std::remove(temp_.c_str());
    throw InputError(path_ + ": cannot write the file (" + std::strerror(errno) + ")");
  }
  temp_.clear();
}

void set_threads([[maybe_unused]] int threads) {
#if defined(_OPENMP)
  if (threads > 0) omp_set_num_threads(threads);
#endif
}

void set_schedule(const std::string& schedule) {
  if (schedule.empty()) return;
  const auto comma = schedule.find(',');
  const std::string kind = schedule.substr(0, comma);
  int chunk = 0;
  if (comma != std::string::npos) {
    try {
      chunk = std::stoi(schedule.substr(comma + 1));
    } catch (const std::exception&) {
      chunk = -1;
    }
  }
  if ((kind != "static" && kind != "dynamic" && kind != "guided") || chunk < 0)
    throw InputError("--schedule: expected static, dynamic or guided with an optional ,CHUNK "
                     "(e.g. dynamic,16), found '" + schedule + "'");
#if defined(_OPENMP)
  const omp_sched_t k = kind == "static" ? omp_sched_static
                        : kind == "dynamic" ? omp_sched_dynamic : omp_sched_guided;
  omp_set_schedule(k, chunk);
#endif
}

int get_threads() {
#if defined(_OPENMP)
  return omp_get_max_threads();
#else
  return 1;
#endif
}

bool stderr_is_terminal() { return isatty(STDERR_FILENO) != 0; }

}  // namespace plab
