/// \file candidates.hpp
/// \brief Sparse candidate pair events, filed under each of their particles (compressed rows).
#pragma once

#include <vector>

namespace plab {

/// A pair event found while scanning pairs, before it is filed under both of its particles.
struct FoundPair {
  double t;  //!< pair time, in [0, 1)
  int i;     //!< lower index
  int j;     //!< higher index
};

/// Each particle's candidate pair events in compressed rows: particle `i`'s entries are
/// `[start[i], start[i + 1])`. Memory O(N + K) for K candidates, instead of an N x N matrix.
struct CandidateLists {
  std::vector<int> start;    //!< N + 1 row offsets
  std::vector<int> other;    //!< the other particle of each entry
  std::vector<double> time;  //!< the pair time of each entry

  /// Files every found pair (from any number of per-thread lists) under both of its particles.
  /// Sequential, O(N + K); the order of entries does not matter to the event key.
  void build(int n, const std::vector<std::vector<FoundPair>>& found) {
    start.assign(n + 1, 0);
    for (const auto& list : found)
      for (const FoundPair& f : list) {
        ++start[f.i + 1];
        ++start[f.j + 1];
      }
    for (int i = 0; i < n; ++i) start[i + 1] += start[i];
    other.resize(start[n]);
    time.resize(start[n]);
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (const auto& list : found)
      for (const FoundPair& f : list) {
        other[fill[f.i]] = f.j;
        time[fill[f.i]++] = f.t;
        other[fill[f.j]] = f.i;
        time[fill[f.j]++] = f.t;
      }
  }
  /// Bytes held (for the memory comparison with an N x N matrix).
  [[nodiscard]] std::size_t bytes() const {
    return start.size() * sizeof(int) + other.size() * sizeof(int) + time.size() * sizeof(double);
  }
};

}  // namespace plab
