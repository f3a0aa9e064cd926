/// \file where.hpp
/// \brief Where each rank of a stalled run is: the stage's MPI call it waits in, or between its
/// calls, or between steps. A diagnosis for a watcher (`plab run`, the Ranks tests), not a
/// measurement.
///
/// A watcher sets PLAB_MPI_WHERE to a folder before it starts mpirun; each rank (kit/mpi's
/// driver) then maps the file DIR/rank-K and writes into it, with no system call, the name of the
/// stage's MPI call it enters and what it does once it leaves it. When no step has finished for a
/// while, the watcher reads every rank's line (where_ranks_are()): ranks in two different
/// collectives, or one rank between steps while another waits in the step, point at the call
/// that some rank skips. No MPI here: the watcher does not link it.
#pragma once

#include <fstream>
#include <string>

namespace plab::dist {

/// The size of a rank's file (one line of text, NUL-padded).
constexpr int kWhereBytes = 128;

/// The environment variable that names the folder of the ranks' files.
constexpr const char* kWhereVariable = "PLAB_MPI_WHERE";

/// The file of rank `rank` in the folder `dir`.
inline std::string where_file(const std::string& dir, int rank) {
  return dir + "/rank-" + std::to_string(rank);
}

/// "rank 0: in MPI_Allreduce (step 25); rank 1: between steps, ..." for ranks 0 .. ranks - 1, or
/// "" when no rank wrote its file (a run whose ranks never started the kit's driver).
inline std::string where_ranks_are(const std::string& dir, int ranks) {
  std::string all, first;
  bool any = false, apart = false;
  for (int k = 0; k < ranks; ++k) {
    std::ifstream in(where_file(dir, k), std::ios::binary);
    std::string line(kWhereBytes, '\0');
    in.read(line.data(), kWhereBytes);
    line.resize(static_cast<std::size_t>(in.gcount()));
    line = line.substr(0, line.find('\0'));
    any |= !line.empty();
    if (k == 0) first = line;
    apart |= line != first;
    all += (k ? "; rank " : "rank ") + std::to_string(k) + ": " +
           (line.empty() ? std::string("unknown") : line);
  }
  if (apart)
    all += " (not all in the same place: the ranks ahead skipped a call, or left a loop, that the "
           "others wait in)";
  return any ? all : std::string();
}

}  // namespace plab::dist
