/// \file kit/instructor/engine/08-mpi/exchange.hpp
/// \brief The engine's exchanges between ranks (instructor-only: they are stage 08's exercises):
/// every rank's lists to every rank (MPI_Alltoall of the counts, then MPI_Alltoallv), and the two
/// reductions its step needs (MPI_Allreduce). The kit counts their bytes and time (ranks.hpp).
#pragma once

#include <mpi.h>

#include <type_traits>
#include <vector>

#include "plab/mpi/ranks.hpp"

namespace plab::dist {

/// Sends out[q] to rank q, for every q, and returns what every rank sent to this one,
/// concatenated in rank order, when this rank knows already how many T's each rank sends it
/// (`recv_count[q]` from rank q, as that rank's out[this rank] holds): one MPI_Alltoallv. Every
/// rank must call it with counts that agree, or MPI's data go wrong. `T` must be trivially
/// copyable.
template <class T>
std::vector<T> all_to_all_known(const Ranks& r, const std::vector<std::vector<T>>& out,
                                const std::vector<int>& recv_count) {
  static_assert(std::is_trivially_copyable_v<T>);
  const int n = r.ranks;
  std::vector<int> send_bytes(n), recv_bytes(n), send_at(n), recv_at(n);
  std::vector<char> send;
  int total = 0;
  for (int q = 0; q < n; ++q) {
    send_at[q] = static_cast<int>(send.size());
    send_bytes[q] = static_cast<int>(out[q].size() * sizeof(T));
    const char* data = reinterpret_cast<const char*>(out[q].data());
    send.insert(send.end(), data, data + send_bytes[q]);
    recv_at[q] = total;
    recv_bytes[q] = static_cast<int>(recv_count[q] * sizeof(T));
    total += recv_bytes[q];
  }
  std::vector<T> in(total / sizeof(T));
  MPI_Alltoallv(send.data(), send_bytes.data(), send_at.data(), MPI_BYTE, in.data(),
                recv_bytes.data(), recv_at.data(), MPI_BYTE, r.comm);
  return in;
}

/// all_to_all_known() when the counts are not known: every rank first tells every rank how many
/// T's it sends it (MPI_Alltoall). `from` (R + 1 entries) gets where each rank's part starts.
template <class T>
std::vector<T> all_to_all(const Ranks& r, const std::vector<std::vector<T>>& out,
                          std::vector<int>* from = nullptr) {
  const int n = r.ranks;
  std::vector<int> send_count(n), recv_count(n);
  for (int q = 0; q < n; ++q) send_count[q] = static_cast<int>(out[q].size());
  MPI_Alltoall(send_count.data(), 1, MPI_INT, recv_count.data(), 1, MPI_INT, r.comm);
  if (from) {
    from->assign(n + 1, 0);
    for (int q = 0; q < n; ++q) (*from)[q + 1] = (*from)[q] + recv_count[q];
  }
  return all_to_all_known(r, out, recv_count);
}

/// The largest of `v` over every rank.
inline double max_over_ranks(const Ranks& r, double v) {
  double m = v;
  MPI_Allreduce(&v, &m, 1, MPI_DOUBLE, MPI_MAX, r.comm);
  return m;
}

/// Whether `v` is true on any rank.
inline bool any_rank(const Ranks& r, bool v) {
  int mine = v ? 1 : 0, any = 0;
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_LOR, r.comm);
  return any != 0;
}

}  // namespace plab::dist
