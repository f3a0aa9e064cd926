/// \file solutions/08-mpi/step.cpp
/// \brief Stage 08, MPI: the box cut into slabs, one per rank; each rank steps the particles
/// whose centre lies in its slab, with copies of the other ranks' particles that can meet them
/// (the halo), runs stage 03's rounds across the ranks, and hands the particles that left its
/// slab to their new owners. Same bits as stages 01-06 at any rank count.
//
// =================================================================================================
//  GOAL   One step of model.md on R ranks, each holding only its slab's particles. You write
//         the messages; local.hpp gives what a rank does on its own, and the kit's driver
//         (kit/mpi/stage_entry.cpp) calls step() below on every rank, every step.
//         1. the halo: the fastest speed over every rank (MPI_Allreduce), then copies of the
//            particles within reach of each other rank's slab (MPI_Sendrecv, rank by rank);
//         2. the rounds across ranks: each round, the ghosts' values from their owners
//            (MPI_Isend / MPI_Irecv / MPI_Waitall), and whether any rank still has an open
//            particle (MPI_Allreduce);
//         3. migration: particles now in another rank's slab go there (MPI_Alltoall of the
//            counts, then MPI_Alltoallv of the particles).
//  READ   handouts/08-mpi.md             TEST   ./plab test --impl student --stage 08
// =================================================================================================
#include <mpi.h>

#include <vector>

#include "local.hpp"
#include "plab/mpi/ranks.hpp"

namespace plab::dist {

namespace {

/// 1a. The fastest speed of any particle, on any rank (every rank gets it).
double fastest_anywhere(const Ranks& r, const Local& s) {
  const double mine = fastest_here(s);
  double all = mine;
  MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_MAX, r.comm);
  return all;
}

/// 1b. The halo exchange: sends out[q] to every other rank q and returns in[q], what rank q sent
/// here (in[r.rank] stays empty). Rank by rank: at distance d = 1 .. R - 1, to rank + d and from
/// rank - d (modulo R), first how many records, then the records.
std::vector<std::vector<Record>> exchange_halo(const Ranks& r,
                                               const std::vector<std::vector<Record>>& out) {
  std::vector<std::vector<Record>> in(r.ranks);
  for (int d = 1; d < r.ranks; ++d) {
    const int to = (r.rank + d) % r.ranks, from = (r.rank - d + r.ranks) % r.ranks;
    const int count = static_cast<int>(out[to].size());
    int incoming = 0;
    MPI_Sendrecv(&count, 1, MPI_INT, to, 0, &incoming, 1, MPI_INT, from, 0, r.comm,
                 MPI_STATUS_IGNORE);
    in[from].resize(incoming);
    MPI_Sendrecv(out[to].data(), count * static_cast<int>(sizeof(Record)), MPI_BYTE, to, 1,
                 in[from].data(), incoming * static_cast<int>(sizeof(Record)), MPI_BYTE, from, 1,
                 r.comm, MPI_STATUS_IGNORE);
  }
  return in;
}

/// 2a. Gives every ghost its owner's value: sends value[k] of each owned k in s.sent_to[q] to
/// rank q, and receives rank q's values into value[s.ghosts_from[q] .. s.ghosts_from[q + 1]).
/// Both sides know the counts from the halo.
template <class T>
void to_ghosts(const Ranks& r, const Local& s, std::vector<T>& value) {
  std::vector<std::vector<T>> out(r.ranks);
  std::vector<MPI_Request> requests;
  for (int q = 0; q < r.ranks; ++q) {
    if (q == r.rank) continue;
    for (int k : s.sent_to[q]) out[q].push_back(value[k]);
    const int incoming = s.ghosts_from[q + 1] - s.ghosts_from[q];
    if (incoming > 0) {
      requests.emplace_back();
      MPI_Irecv(&value[s.ghosts_from[q]], incoming * static_cast<int>(sizeof(T)), MPI_BYTE, q, 2,
                r.comm, &requests.back());
    }
    if (!out[q].empty()) {
      requests.emplace_back();
      MPI_Isend(out[q].data(), static_cast<int>(out[q].size() * sizeof(T)), MPI_BYTE, q, 2,
                r.comm, &requests.back());
    }
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
}

/// 2b. Whether `left` is true on any rank (every rank gets the answer).
bool any_rank_left(const Ranks& r, bool left) {
  const int mine = left ? 1 : 0;
  int any = 0;
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_LOR, r.comm);
  return any != 0;
}

/// 3. Migration: sends out[q] to rank q (any rank, however far), appends what arrives to the
/// owned particles of `s` and counts them all as owned.
void migrate(const Ranks& r, const std::vector<std::vector<Record>>& out, Local& s) {
  std::vector<int> send_bytes(r.ranks), send_at(r.ranks), recv_bytes(r.ranks), recv_at(r.ranks);
  std::vector<Record> send;
  for (int q = 0; q < r.ranks; ++q) {
    send_at[q] = static_cast<int>(send.size() * sizeof(Record));
    send_bytes[q] = static_cast<int>(out[q].size() * sizeof(Record));
    send.insert(send.end(), out[q].begin(), out[q].end());
  }
  MPI_Alltoall(send_bytes.data(), 1, MPI_INT, recv_bytes.data(), 1, MPI_INT, r.comm);
  int total = 0;
  for (int q = 0; q < r.ranks; ++q) {
    recv_at[q] = total;
    total += recv_bytes[q];
  }
  std::vector<Record> in(total / sizeof(Record));
  MPI_Alltoallv(send.data(), send_bytes.data(), send_at.data(), MPI_BYTE, in.data(),
                recv_bytes.data(), recv_at.data(), MPI_BYTE, r.comm);
  for (const Record& rec : in) s.push(rec);
  s.owned = s.size();
}

/// Stage 03's rounds across ranks: each owned particle's event (`t` = never for none), the same
/// as model.md's greedy over every rank.
std::vector<model::Event> choose_events(const Ranks& r, const Local& s,
                                        const std::vector<double>& wall,
                                        const CandidateLists& cand) {
  const model::Event none = model::pair_event_key(model::never(), -1, -1);
  std::vector<char> resolved(s.size(), 0);
  std::vector<model::Event> best(s.size(), none), chosen(s.owned, none);
  for (bool open = true; open;) {
    to_ghosts(r, s, resolved);  // whom the ghosts' owners resolved last round
    choose_earliest(s, wall, cand, resolved, best);
    to_ghosts(r, s, best);  // what the ghosts chose
    open = any_rank_left(r, accept_mutual(s, cand, best, resolved, chosen));
  }
  return chosen;
}

}  // namespace

/// One step on this rank: the halo, the candidates, the rounds, the events, the migration.
void step(const Box& box, const Ranks& r, Local& s) {
  const double reach = reach_of(box, fastest_anywhere(r, s));
  s.sent_to = halo_lists(box, r, reach, s);
  std::vector<std::vector<Record>> out(r.ranks);
  for (int q = 0; q < r.ranks; ++q)
    for (int k : s.sent_to[q]) out[q].push_back(s.record(k));
  add_ghosts(exchange_halo(r, out), s);
  std::vector<double> wall;
  CandidateLists cand;
  find_candidates(box, reach, s, wall, cand);
  const std::vector<model::Event> chosen = choose_events(r, s, wall, cand);
  apply_events(box, chosen, cand, s);
  migrate(r, leaving(r, s), s);
}

}  // namespace plab::dist

