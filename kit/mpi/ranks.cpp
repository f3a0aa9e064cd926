/// \file mpi/ranks.cpp
/// \brief The kit's MPI plumbing (plab::mpi, stage 08's given part): MPI's start and end, the
/// exchanges, and the run as the kit's driver sees it. Rank 0 runs the runner as every stage does; its plab::Stepper tells the other
/// ranks what to do next (start from a scattered state, step, gather, stop), and they serve
/// those commands from plab::dist::serve(), never reading a file or printing anything.
#include "plab/mpi/ranks.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <type_traits>
#include <utility>

namespace plab::dist {

namespace {

/// What rank 0 asks of the others.
enum Command : int { kStart, kStep, kRead, kTraffic, kStop, kExit };

/// This process's messages so far: bytes it sent, seconds in exchanges and reductions.
Stepper::Traffic traffic_here;

/// Counts the time from its making to its end as time in messages.
class InMessages {
 public:
  InMessages() : t0_(std::chrono::steady_clock::now()) {}
  ~InMessages() {
    traffic_here.comm_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }
  InMessages(const InMessages&) = delete;
  InMessages& operator=(const InMessages&) = delete;

 private:
  std::chrono::steady_clock::time_point t0_;
};

/// The ranks of this process (set by start_mpi()).
Ranks the_ranks;

/// The stage's step (set by mpi_stage() on rank 0 and serve() on the others).
DistStepFn the_step = nullptr;

/// Ends MPI on rank 0 when the program ends: the other ranks leave serve() and end too.
void finish() {
  int command = kExit;
  MPI_Bcast(&command, 1, MPI_INT, 0, the_ranks.comm);
  MPI_Finalize();
}

/// Starts MPI once (the runner's workers, or a test program on one rank).
const Ranks& start_mpi() {
  int started = 0;
  MPI_Initialized(&started);
  if (!started) {
    MPI_Init(nullptr, nullptr);
    MPI_Comm_rank(MPI_COMM_WORLD, &the_ranks.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &the_ranks.ranks);
    if (the_ranks.rank == 0) std::atexit(finish);
  }
  return the_ranks;
}

/// The exit status the runner gives an exception (NotDone 3, NoDevice 4, others 2).
int status_of(const std::exception& e) {
  if (dynamic_cast<const NotDone*>(&e)) return 3;
  if (dynamic_cast<const NoDevice*>(&e)) return 4;
  return 2;
}

/// Ends every rank after an error on this one: the message, then MPI_Abort (a rank waiting in
/// an exchange would otherwise wait for ever). On one rank the runner handles it as usual.
[[noreturn]] void abort_all(const Ranks& r, const std::exception& e) {
  if (r.rank == 0)
    std::fprintf(stderr, "%s%s\n", status_of(e) == 2 ? "error: " : "", e.what());
  else if (status_of(e) == 3)
    usleep(500000);  // rank 0 meets the same unfinished exercise: let it say so first
  else
    std::fprintf(stderr, "stage 08, rank %d: %s\n", r.rank, e.what());
  std::fflush(stderr);
  MPI_Abort(r.comm, status_of(e));
  std::abort();
}

/// Scatters rank 0's particles to their owners (each rank's part of `all`).
void scatter(const Ranks& r, const Particles* all, Local& s) {
  std::vector<std::vector<Record>> out(r.ranks);
  if (r.rank == 0)
    for (int i = 0; i < static_cast<int>(all->size()); ++i)
      out[r.owner_of(all->x[i])].push_back(
          {all->x[i], all->y[i], all->vx[i], all->vy[i], all->pc[i], all->wc[i], i});
  s = Local{};
  for (const Record& rec : all_to_all(r, out)) s.push(rec);
  s.owned = s.size();
}

/// Gathers every rank's owned particles into `all` on rank 0, in index order.
void gather(const Ranks& r, const Local& s, Particles* all_on_0) {
  std::vector<std::vector<Record>> out(r.ranks);
  for (int k = 0; k < s.owned; ++k) out[0].push_back(s.record(k));
  const std::vector<Record> got = all_to_all(r, out);
  if (r.rank != 0) return;
  Particles& all = *all_on_0;
  all.resize(got.size());
  for (const Record& rec : got) {
    all.x[rec.id] = rec.x;
    all.y[rec.id] = rec.y;
    all.vx[rec.id] = rec.vx;
    all.vy[rec.id] = rec.vy;
    all.pc[rec.id] = rec.pc;
    all.wc[rec.id] = rec.wc;
  }
}

/// One run's state on any rank: what the commands act on.
struct Run {
  Box box;                   //!< the box and radius
  Local s;                   //!< this rank's particles
  Stepper::Traffic traffic;  //!< on rank 0, after kTraffic: every rank's messages
};

/// Acts on one command (every rank, in the same order).
void act(int command, const Ranks& r, Run& run, Particles* all) {
  switch (command) {
    case kStart: {
      traffic_here = {};
      double head[3] = {run.box.L, run.box.r, the_ranks.gpu ? 1.0 : 0.0};
      MPI_Bcast(head, 3, MPI_DOUBLE, 0, r.comm);
      run.box = {head[0], head[1]};
      the_ranks.L = run.box.L;
      the_ranks.gpu = head[2] != 0;
      scatter(r, all, run.s);
      break;
    }
    case kStep:
      the_step(run.box, r, run.s);
      break;
    case kRead:
      gather(r, run.s, all);
      break;
    case kTraffic: {  // the sum of the bytes, the most seconds, on rank 0
      double bytes = 0, seconds = 0;
      MPI_Reduce(&traffic_here.bytes_sent, &bytes, 1, MPI_DOUBLE, MPI_SUM, 0, r.comm);
      MPI_Reduce(&traffic_here.comm_seconds, &seconds, 1, MPI_DOUBLE, MPI_MAX, 0, r.comm);
      run.traffic = {bytes, seconds, r.ranks};
      break;
    }
    default:
      break;
  }
}

/// Rank 0's view of the run: each call tells the other ranks to do the same.
class DistStepper final : public Stepper {
 public:
  DistStepper(const Box& box, Particles& p, std::string gpu)
      : r_(start_mpi()), gpu_(std::move(gpu)) {
    run_.box = box;
    the_ranks.gpu = !gpu_.empty();
    command(kStart, &p);
  }
  ~DistStepper() override {
    int c = kStop;
    MPI_Bcast(&c, 1, MPI_INT, 0, r_.comm);
  }
  void step() override { command(kStep, nullptr); }
  void read(Particles& p) override { command(kRead, &p); }
  /// "cpu", or the GPU's name and how many ranks step on GPUs.
  [[nodiscard]] std::string device() const override {
    return gpu_.empty() ? "cpu" : gpu_ + ", one per rank of " + std::to_string(r_.ranks);
  }
  Traffic traffic() override {
    command(kTraffic, nullptr);
    return run_.traffic;
  }

 private:
  void command(int c, Particles* all) {
    try {
      MPI_Bcast(&c, 1, MPI_INT, 0, r_.comm);
      act(c, r_, run_, all);
    } catch (const std::exception& e) {
      if (r_.ranks == 1) throw;
      abort_all(r_, e);
    }
  }
  const Ranks& r_;
  std::string gpu_;  //!< the GPU's name ("": the CPU)
  Run run_;
};

}  // namespace

void Local::push(const Record& r) {
  p.x.push_back(r.x);
  p.y.push_back(r.y);
  p.vx.push_back(r.vx);
  p.vy.push_back(r.vy);
  p.pc.push_back(r.pc);
  p.wc.push_back(r.wc);
  id.push_back(r.id);
}

void Local::drop_ghosts() {
  p.resize(owned);
  id.resize(owned);
}

template <class T>
std::vector<T> all_to_all(const Ranks& r, const std::vector<std::vector<T>>& out,
                        std::vector<int>* from) {
  static_assert(std::is_trivially_copyable_v<T>);
  const InMessages timed;
  const int n = r.ranks;
  std::vector<int> send_bytes(n), recv_bytes(n), send_at(n), recv_at(n);
  std::vector<char> send;
  for (int q = 0; q < n; ++q) {
    send_at[q] = static_cast<int>(send.size());
    send_bytes[q] = static_cast<int>(out[q].size() * sizeof(T));
    const char* data = reinterpret_cast<const char*>(out[q].data());
    send.insert(send.end(), data, data + send_bytes[q]);
  }
  traffic_here.bytes_sent += static_cast<double>(send.size() - send_bytes[r.rank]);
  MPI_Alltoall(send_bytes.data(), 1, MPI_INT, recv_bytes.data(), 1, MPI_INT, r.comm);
  int total = 0;
  for (int q = 0; q < n; ++q) {
    recv_at[q] = total;
    total += recv_bytes[q];
  }
  std::vector<T> in(total / sizeof(T));
  MPI_Alltoallv(send.data(), send_bytes.data(), send_at.data(), MPI_BYTE, in.data(),
                recv_bytes.data(), recv_at.data(), MPI_BYTE, r.comm);
  if (from) {
    from->assign(n + 1, 0);
    for (int q = 0; q < n; ++q) (*from)[q + 1] = (*from)[q] + recv_bytes[q] / sizeof(T);
  }
  return in;
}

/// \cond
template std::vector<Record> all_to_all(const Ranks&, const std::vector<std::vector<Record>>&,
                                      std::vector<int>*);
template std::vector<model::Event> all_to_all(const Ranks&,
                                            const std::vector<std::vector<model::Event>>&,
                                            std::vector<int>*);
template std::vector<double> all_to_all(const Ranks&, const std::vector<std::vector<double>>&,
                                      std::vector<int>*);
template std::vector<int> all_to_all(const Ranks&, const std::vector<std::vector<int>>&,
                                   std::vector<int>*);
template std::vector<char> all_to_all(const Ranks&, const std::vector<std::vector<char>>&,
                                    std::vector<int>*);
/// \endcond

double max_over_ranks(const Ranks& r, double v) {
  const InMessages timed;
  double m = v;
  MPI_Allreduce(&v, &m, 1, MPI_DOUBLE, MPI_MAX, r.comm);
  return m;
}

bool any_rank(const Ranks& r, bool v) {
  const InMessages timed;
  int mine = v ? 1 : 0, any = 0;
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_LOR, r.comm);
  return any != 0;
}

int serve(DistStepFn step) {
  the_step = step;
  const Ranks& r = start_mpi();
  if (r.rank == 0) return -1;  // rank 0 goes on as the runner
  Run run;
  for (;;) {
    int command = 0;
    MPI_Bcast(&command, 1, MPI_INT, 0, r.comm);
    if (command == kExit) break;
    try {
      if (command == kStop) run = Run{};
      else act(command, r, run, nullptr);
    } catch (const std::exception& e) {
      abort_all(r, e);
    }
  }
  MPI_Finalize();
  return 0;
}

std::unique_ptr<Stepper> mpi_stage(const Box& box, Particles& p, DistStepFn step,
                                   const std::string& gpu) {
  the_step = step;
  return std::make_unique<DistStepper>(box, p, gpu);
}

}  // namespace plab::dist
