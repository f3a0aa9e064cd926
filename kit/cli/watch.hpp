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
  int ranks = 0;            //!< processes the stage runs on (above 1: a long wait without a
                            //!< step is said to be, most likely, ranks waiting for each other)
};

/// Runs a stage program in a process group of its own and waits. The whole group is ended when
/// the limit runs out, on Ctrl-C (SIGINT), SIGTERM or SIGHUP, and when the program ends (nothing
/// it started is left running). Progress goes to stderr when it is a terminal, or every 10 s on
/// a run longer than that; on several ranks, once no step has finished for kStallHint seconds,
/// it says the ranks may be waiting for each other. Returns the exit status: 124 at the limit,
/// 128 + signal on a crash or a stop (the message names the signal and the last step finished).
int run_stage_watched(const std::vector<std::string>& args, const RunWatch& watch);

}  // namespace plab::cli
