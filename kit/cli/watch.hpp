/// \file cli/watch.hpp
/// \brief Running a stage program under a limit (`plab run --timeout`), with progress on long runs
/// and a message that names what stopped it: the limit, a signal, and the last step finished.
#pragma once

#include <string>
#include <vector>

namespace plab::cli {

/// How to watch one run of a stage program.
struct RunWatch {
  std::string label;        //!< what runs, for messages: "stage 01 (student) on course-1.in"
  double timeout = 0;       //!< seconds before the run is ended (0: no limit)
  std::string status_path;  //!< the file the program reports its steps in (its --status)
};

/// Runs a stage program in a process group of its own and waits. The whole group is ended when
/// the limit runs out, on Ctrl-C (SIGINT), SIGTERM or SIGHUP, and when the program ends (nothing
/// it started is left running). Progress goes to stderr when it is a terminal, or every 10 s on
/// a run longer than that. Returns the exit status: 124 at the limit, 128 + signal on a crash
/// (the message names the signal and the last step finished).
int run_stage_watched(const std::vector<std::string>& args, const RunWatch& watch);

}  // namespace plab::cli
