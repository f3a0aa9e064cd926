/// \file stages/08-mpi/step.cpp
/// \brief Stage 08, MPI: the box cut into slabs, one per rank; each rank steps the particles
/// whose centre lies in its slab, with copies of the other ranks' particles that can meet them
/// (the halo), runs stage 03's rounds across the ranks, and hands the particles that left its
/// slab to their new owners. Same bits as stages 01-06 at any rank count.
//
// =================================================================================================
//  GOAL   One step of model.md on R ranks, each holding only its slab's particles. You write
//         the messages; local.hpp gives what a rank does on its own, and the kit's driver
//         (kit/mpi/stage_entry.cpp) calls step() below on every rank, every step.
//         1. the halo: the fastest speed over every rank, then copies of the particles within
//            reach of each other rank's slab;
//         2. the rounds across ranks: each round, the ghosts' values from their owners, and
//            whether any rank still has an open particle;
//         3. migration: particles now in another rank's slab go there.
//         The handout names the MPI calls of each; how to use them is yours to design.
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
  // EXERCISE 1 (a): every rank needs the same reach, so the fastest speed of the whole scene,
  // from every rank's fastest_here(s), on every rank, in one collective (handout 08, exercise 1).
  (void)r, (void)s;
  PLAB_EXERCISE(1, "the halo: the fastest speed over every rank, with MPI_Allreduce");
}

/// 1b. The halo exchange: sends out[q] to every other rank q and returns in[q], what rank q sent
/// here (in[r.rank] stays empty).
std::vector<std::vector<Record>> exchange_halo(const Ranks& r,
                                               const std::vector<std::vector<Record>>& out) {
  // EXERCISE 1 (b): any rank may need ghosts from any other, and no rank knows beforehand how
  // many will come to it. Every send must meet its receive whatever R is, so that no rank waits
  // for ever (handout 08, exercise 1: the order of the exchanges, and how a receiver learns how
  // many records come).
  (void)r, (void)out;
  PLAB_EXERCISE(1, "the halo exchange, rank by rank, with MPI_Sendrecv");
}

/// 2a. Gives every ghost its owner's value: sends value[k] of each owned k in s.sent_to[q] to
/// rank q, and receives rank q's values into value[s.ghosts_from[q] .. s.ghosts_from[q + 1]).
/// Both sides know the counts from the halo.
template <class T>
void to_ghosts(const Ranks& r, const Local& s, std::vector<T>& value) {
  // EXERCISE 2 (a): rank q needs value[k] of each k in s.sent_to[q], in that order, and q's
  // values for this rank's ghosts land in value[s.ghosts_from[q]] .. value[s.ghosts_from[q + 1]
  // - 1]; both sides know every count from the halo (handout 08, exercise 2: messages that no
  // order of the ranks can deadlock, and what an empty list needs on each side).
  (void)r, (void)s, (void)value;
  PLAB_EXERCISE(2, "the rounds across ranks: the ghosts' values, with MPI_Isend and MPI_Irecv");
}

/// 2b. Whether `left` is true on any rank (every rank gets the answer).
bool any_rank_left(const Ranks& r, bool left) {
  // EXERCISE 2 (b): the rounds end when no rank has an open particle, and every rank must get the
  // same answer. What happens if one rank leaves the loop while another goes on?
  (void)r, (void)left;
  PLAB_EXERCISE(2, "the rounds across ranks: any rank still open, with MPI_Allreduce");
}

/// 3. Migration: sends out[q] to rank q (any rank, however far), appends what arrives to the
/// owned particles of `s` and counts them all as owned.
void migrate(const Ranks& r, const std::vector<std::vector<Record>>& out, Local& s) {
  // EXERCISE 3: a particle may jump any number of slabs, so every rank may send to every rank,
  // and no rank knows how much will arrive (handout 08, exercise 3). Then s.push() each record
  // received and count every particle as owned (s.owned).
  (void)r, (void)out, (void)s;
  PLAB_EXERCISE(3, "migration: particles to their new owners, with MPI_Alltoall and MPI_Alltoallv");
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

