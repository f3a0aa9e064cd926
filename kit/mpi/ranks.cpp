/// \file mpi/ranks.cpp
/// \brief The kit's MPI plumbing (plab::mpi, stage 08's given part): MPI's start and end, the
/// scatter of the scene and the gather of the output, the count of every rank's messages, and the
/// run as the kit's driver sees it. Rank 0 runs the runner as every stage does; its
/// plab::Stepper tells the other ranks what to do next (start from a scattered state, step,
/// gather, stop), and they serve those commands from plab::dist::serve(), never reading a file or
/// printing anything.
#include "plab/mpi/ranks.hpp"
#include "plab/mpi/where.hpp"
#include "plab/runtime.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <ctime>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace plab::dist {

namespace {

/// What rank 0 asks of the others.
enum Command : int { kStart, kStep, kRead, kTraffic, kStop, kExit };

/// The bytes sent by one MPI function of the stage's (handout 08's question 2: which exercise
/// sends most; the handout's "Calls:" lines say which calls each exercise makes).
struct CallBytes {
  char name[24];  //!< the function, "MPI_Sendrecv" ("" while the slot is free)
  double bytes;   //!< what it sent to other ranks, envelopes included
};

/// Slots of Traffic::by_call: the calls a stage 08 makes are a handful; a ninth and later share
/// the last slot, named "other calls".
constexpr int kCallSlots = 8;

/// This process's messages so far: bytes it sent, seconds in exchanges and reductions (counted
/// by the MPI_ functions at the end of this file).
struct Traffic {
  double bytes_sent = 0;    //!< bytes this rank sent to the others, envelopes included
  double comm_seconds = 0;  //!< seconds in exchanges and reductions (waits included)
  CallBytes by_call[kCallSlots] = {};  //!< bytes_sent split by the stage's MPI function
  const char* call = nullptr;  //!< the stage's MPI function under way (the outermost), or null
};

/// Where this rank's CPU time goes in the stage's steps: the process's CPU time is read at every
/// change of state (a step starts or ends, the stage's first MPI call under way starts or its
/// last ends: account()), and the time since the last reading goes to the state it was spent in:
/// work, time in MPI (a wait that spins uses CPU time too, and a rank that only waits must not
/// look busy), or neither (between steps). A loop of MPI_Test calls counts as time in MPI, not as
/// work. Rank 0 gathers each rank's sums for the runner's report (plab grade's idea test of
/// stage 08 reads them).
///
/// Until 2026-12-07 a profiling timer (ITIMER_PROF) sampled it instead, each ring giving the CPU
/// time since the last ring to the state it found. That was wrong twice over: while a process
/// timer is armed, Linux reads the process's CPU clock from the timer's sums, which advance at the
/// scheduler's ticks and switches only (so between two MPI calls of one tick the clock stood
/// still), and on a loaded machine a rank whose rings fell while it waited for the next step's
/// command lost its steps' work: an honest stage 08 read as 0.384, 0.080 and 0.046 s on
/// random-1000 and failed the grader's share of 10%. No timer is armed now; SIGPROF keeps a
/// handler that reads the clock as a change of state does (on_ring()), so a ring sent to any
/// thread, MPI's own progress thread included, changes no sum. The fields are lock-free atomics
/// (async-signal-safe), and each reading takes the time since the last one with one exchange:
/// two readings at once on two threads never write over each other, and the times they count
/// still add up to the CPU time between them.
struct Sampled {
  std::atomic<int> in_step{0};              //!< the stage's step is running
  std::atomic<int> in_mpi{0};               //!< MPI calls of the stage under way (nested)
  std::atomic<long long> last_ns{0};        //!< the CPU clock at the last account()
  std::atomic<long long> work_ns{0};        //!< CPU time given to work, in steps
  std::atomic<long long> waiting_ns{0};     //!< CPU time given to MPI calls, in steps
};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<long long>::is_always_lock_free,
              "the counts stay lock-free atomics (a SIGPROF handler may run on any thread)");

/// The page size the counts' page is laid out for (x86-64, and most of AArch64's kernels).
constexpr std::size_t kPage = 4096;

/// What the grader reads of a rank (its bytes, its time in messages, where its CPU time went), on
/// a page of its own that the process may only read, but while the kit's own code writes it
/// (Writable): a red-team stage 08 of 2026-12-07 found these counts by scanning its own memory
/// and wrote its own numbers over them (164 of 164 with rank 0 stepping every particle). A
/// stage's code may not call mprotect (plab grade refuses it), so a write of the stage's own to
/// the page ends the run (SIGSEGV). No code of the stage runs while the page is writable: the
/// kit's MPI functions make it so from their start to their end, and MPI calls no function of
/// the stage's (plab grade refuses the calls that would hand it one).
struct alignas(kPage) Counts {
  Traffic traffic;         //!< this rank's messages
  Sampled sampled;         //!< where its CPU time went
  int depth = 0;           //!< Writable guards alive (nested)
  bool protecting = false;  //!< the page is kept read-only (set once, where the page size is kPage)
  long long protect_ns = 0;  //!< CPU time of making the page read-only again (measured at start)
};
Counts counts;
Traffic& traffic_here = counts.traffic;  //!< this rank's messages (on the counts' page)
Sampled& sampled = counts.sampled;       //!< where its CPU time went (on the counts' page)

/// A copy of Counts::depth in ordinary memory, read before the page is made writable: a stage
/// that changes it can only make the kit write to the page while it is read-only (a crash), never
/// leave the page writable.
int writable_hint = 0;

/// Makes the counts' page writable from its making to its end (nested: the outermost guard
/// protects the page again).
class Writable {
 public:
  Writable() {
    if (writable_hint == 0 && counts.protecting)
      mprotect(&counts, sizeof counts, PROT_READ | PROT_WRITE);
    writable_hint = ++counts.depth;
  }
  ~Writable() {
    writable_hint = --counts.depth;
    if (counts.depth == 0 && counts.protecting) mprotect(&counts, sizeof counts, PROT_READ);
  }
  Writable(const Writable&) = delete;
  Writable& operator=(const Writable&) = delete;
};

/// The process's CPU time in ns (async-signal-safe).
long long cpu_ns() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return now.tv_sec * 1000000000LL + now.tv_nsec;
}

/// Gives the process's CPU time since the last reading to the state it was spent in (the state
/// now: call it before changing the state), and reads it again (async-signal-safe).
/// account() with the clock read at `now` (before the page was made writable, so that the
/// mprotect call is not counted as the work before it); an interval that ends before the last
/// reading (the mprotect after an MPI call, charged ahead: Counts::protect_ns) counts nothing.
void account_until(long long now) {
  const Writable writable;
  const long long last = sampled.last_ns.load(std::memory_order_relaxed);
  if (now <= last) return;
  sampled.last_ns.store(now, std::memory_order_relaxed);
  const long long since = now - last;
  if (!sampled.in_step.load(std::memory_order_relaxed)) return;
  if (sampled.in_mpi.load(std::memory_order_relaxed) != 0)
    sampled.waiting_ns.fetch_add(since, std::memory_order_relaxed);
  else
    sampled.work_ns.fetch_add(since, std::memory_order_relaxed);
}

void account() { account_until(cpu_ns()); }

/// SIGPROF's handler: nothing (until 2026-12-07 a profiling timer's ring read the clock here; the
/// handler stays so that a stray SIGPROF does not end the process).
void on_ring(int) {}

/// Installs the SIGPROF handler and reads the CPU clock (once a process; SA_RESTART: a system call
/// a ring interrupts goes on).
void start_sampling() {
  static bool started = false;
  if (started) return;
  started = true;
  struct sigaction act {};
  act.sa_handler = on_ring;
  act.sa_flags = SA_RESTART;
  sigemptyset(&act.sa_mask);
  sigaction(SIGPROF, &act, nullptr);
  {
    const Writable writable;
    counts.protecting = sysconf(_SC_PAGESIZE) == static_cast<long>(kPage);  // read-only from now on
  }
  // What making the page read-only costs this process (the median of 15): charged to an MPI
  // call's time ahead of the call that does it (InMpi).
  long long cost[15];
  for (long long& c : cost) {
    mprotect(&counts, sizeof counts, PROT_READ | PROT_WRITE);
    const long long t0 = cpu_ns();
    mprotect(&counts, sizeof counts, counts.protecting ? PROT_READ : PROT_READ | PROT_WRITE);
    c = cpu_ns() - t0;
  }
  std::sort(cost, cost + 15);
  const Writable writable;
  counts.protect_ns = cost[7];
  sampled.last_ns = cpu_ns();
}

/// This rank's line for a watcher of a stalled run (plab/mpi/where.hpp): a shared mapping of
/// $PLAB_MPI_WHERE/rank-K, written with no system call; null when no watcher asked for it.
char* where_page = nullptr;
long long where_steps = 0;  //!< the steps this rank has begun

/// Maps this rank's file when PLAB_MPI_WHERE names a folder (once, as MPI starts).
void where_open(int rank) {
  const char* dir = std::getenv(kWhereVariable);
  if (dir == nullptr || *dir == '\0' || where_page != nullptr) return;
  const int fd = open(where_file(dir, rank).c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return;
  if (ftruncate(fd, kWhereBytes) == 0) {
    void* page = mmap(nullptr, kWhereBytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (page != MAP_FAILED) where_page = static_cast<char*>(page);
  }
  close(fd);
}

/// Writes "`what``call` (step N)" as this rank's line.
void where_say(const char* what, const char* call) {
  if (where_page == nullptr) return;
  char line[kWhereBytes] = {};
  std::snprintf(line, sizeof line, "%s%s (step %lld)", what, call, where_steps);
  std::memcpy(where_page, line, sizeof line);
}

/// Marks the time from its making to its end as the stage's time in an MPI call (the CPU clock
/// read around it: account()).
class InMpi {
 public:
  // The stage's MPI calls are made by its one thread (a stage 08 starts none: plab grade refuses
  // it), so the outermost call is the one that finds the counter at 0 (or leaves it at 1).
  // The page's two mprotect calls count as time in MPI, not as work (a loop of MPI_Test calls
  // must not look busy): the clock is read before the page is made writable (entered_), and the
  // call that protects it again after is charged ahead at its measured cost.
  /// `call`: the MPI function's name, for a watcher of a stalled run (where.hpp).
  explicit InMpi(const char* call) {  // (entered_, then writable_: writable until the call's end)
    if (sampled.in_step.load(std::memory_order_relaxed) &&
        sampled.in_mpi.load(std::memory_order_relaxed) == 0)
      account_until(entered_);  // the work until the call
    if (sampled.in_mpi.fetch_add(1, std::memory_order_relaxed) == 0) {
      where_say("in ", call);
      counts.traffic.call = call;
    }
  }
  ~InMpi() {
    if (sampled.in_step.load(std::memory_order_relaxed) &&
        sampled.in_mpi.load(std::memory_order_relaxed) == 1) {
      account();  // the time in MPI until now
      sampled.waiting_ns.fetch_add(counts.protect_ns, std::memory_order_relaxed);
      sampled.last_ns.fetch_add(counts.protect_ns, std::memory_order_relaxed);
    }
    if (sampled.in_mpi.fetch_sub(1, std::memory_order_relaxed) == 1) {
      counts.traffic.call = nullptr;
      where_say(sampled.in_step.load(std::memory_order_relaxed)
                    ? "in its step, between the stage's MPI calls" : "between steps", "");
    }
  }
  InMpi(const InMpi&) = delete;
  InMpi& operator=(const InMpi&) = delete;

 private:
  long long entered_ = cpu_ns();  //!< the CPU clock as the call started
  Writable writable_;             //!< the counts' page, writable for the call
};

/// Counts the time from its making to its end as time in messages (and in MPI, sampled).
class InMessages {
 public:
  explicit InMessages(const char* call) : in_mpi_(call), t0_(PMPI_Wtime()) {}
  ~InMessages() { traffic_here.comm_seconds += PMPI_Wtime() - t0_; }
  InMessages(const InMessages&) = delete;
  InMessages& operator=(const InMessages&) = delete;

 private:
  InMpi in_mpi_;
  double t0_;
};

/// Bytes counted for every message to another rank besides its data: its envelope (a tag, a
/// count, a source) carries information too. A red-team stage 08 sent every particle as some
/// two million empty messages whose tags held the data, counted as nothing.
constexpr double kEnvelopeBytes = 16;

/// Adds `bytes` to this rank's sum and to the slot of the stage's MPI function under way
/// (Traffic::call; "other calls" once the slots are full).
void add_sent(double bytes) {
  const Writable writable;
  traffic_here.bytes_sent += bytes;
  const char* call = traffic_here.call != nullptr ? traffic_here.call : "other calls";
  CallBytes* slot = &traffic_here.by_call[kCallSlots - 1];
  for (CallBytes& c : traffic_here.by_call) {
    if (c.name[0] == '\0') std::snprintf(c.name, sizeof c.name, "%s", call);
    if (std::strncmp(c.name, call, sizeof c.name - 1) == 0) {
      slot = &c;
      break;
    }
  }
  if (slot == &traffic_here.by_call[kCallSlots - 1] &&
      std::strncmp(slot->name, call, sizeof slot->name - 1) != 0)
    std::snprintf(slot->name, sizeof slot->name, "%s", "other calls");
  slot->bytes += bytes;
}

/// Counts `count` items of `type` sent to rank `to` of `comm`, and the message's envelope
/// (nothing to this rank itself).
void count_sent(int count, MPI_Datatype type, int to, MPI_Comm comm) {
  int me = 0, size = 0;
  PMPI_Comm_rank(comm, &me);
  PMPI_Type_size(type, &size);
  if (to != me && to != MPI_PROC_NULL) add_sent(1.0 * count * size + kEnvelopeBytes);
}

/// The ranks of this process (set by start_mpi()).
Ranks the_ranks;

/// The stage's step (set by mpi_stage() on rank 0 and serve() on the others).
DistStepFn the_step = nullptr;

/// Where rank 0's scatter sends each particle (mpi_stage_any_cut()'s `owner`); nullptr: the kit's
/// slabs (Ranks::owner_of()).
OwnerFn the_owner = nullptr;

/// Rank 0 tells every rank the next command (a non-blocking broadcast, which next_command()
/// receives).
void send_command(int command, MPI_Comm comm) {
  MPI_Request request;
  PMPI_Ibcast(&command, 1, MPI_INT, 0, comm, &request);
  PMPI_Wait(&request, MPI_STATUS_IGNORE);
}

/// The next command from rank 0, on every other rank. It waits asleep, testing every 100 us:
/// MPI's own waits spin, and a rank that spins between commands would use a core's time while
/// rank 0 works alone, so that each rank's CPU time (measured from outside: /proc/PID/stat,
/// `time`) shows the work it does in its steps, waits for the other ranks inside a step included.
int next_command(MPI_Comm comm) {
  int command = kExit, done = 0;
  MPI_Request request;
  PMPI_Ibcast(&command, 1, MPI_INT, 0, comm, &request);
  for (PMPI_Test(&request, &done, MPI_STATUS_IGNORE); !done;
       PMPI_Test(&request, &done, MPI_STATUS_IGNORE))
    usleep(100);
  return command;
}

/// Ends MPI on rank 0 when the program ends: the other ranks leave serve() and end too.
void finish() {
  send_command(kExit, the_ranks.comm);
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
    where_open(the_ranks.rank);
    where_say("between steps", "");
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
  else {  // "stage 08, rank 2: after a step ...", not "stage 08, rank 2: stage 08: after ..."
    const char* what = e.what();
    if (std::strncmp(what, "stage 08: ", 10) == 0) what += 10;
    std::fprintf(stderr, "stage 08, rank %d: %s\n", r.rank, what);
  }
  std::fflush(stderr);
  MPI_Abort(r.comm, status_of(e));
  std::abort();
}

/// The kit's own messages between ranks (the scatter), on a communicator of their own: no
/// message that a stage leaves unreceived on Ranks::comm can match them.
MPI_Comm kit_comm = MPI_COMM_NULL;
constexpr int kScatterTag = 1;  //!< rank 0's particles for rank q, on kit_comm

/// Scatters rank 0's particles to their owners (each rank's part of `all`): the kit's slabs, or
/// the_owner's parts (a rank outside [0, R) read as the nearest). Rank 0 sends each rank its
/// part in one message, whose size the rank learns by probing it.
void scatter(const Ranks& r, const Particles* all, Local& s) {
  if (kit_comm == MPI_COMM_NULL) PMPI_Comm_dup(r.comm, &kit_comm);  // every rank, at once
  std::vector<Record> mine;
  if (r.rank == 0) {
    const auto owner = [&](int i) {
      if (!the_owner) return r.owner_of(all->x[i]);
      return std::clamp(the_owner(all->x[i], all->y[i], r.L, r.ranks), 0, r.ranks - 1);
    };
    std::vector<std::vector<Record>> out(r.ranks);
    for (int i = 0; i < static_cast<int>(all->size()); ++i)
      out[owner(i)].push_back(
          {all->x[i], all->y[i], all->vx[i], all->vy[i], all->pc[i], all->wc[i], i});
    for (int q = 1; q < r.ranks; ++q)
      PMPI_Send(out[q].data(), static_cast<int>(out[q].size() * sizeof(Record)), MPI_BYTE, q,
                kScatterTag, kit_comm);
    mine = std::move(out[0]);
  } else {
    MPI_Status status;
    PMPI_Probe(0, kScatterTag, kit_comm, &status);
    int bytes = 0;
    PMPI_Get_count(&status, MPI_BYTE, &bytes);
    mine.resize(bytes / sizeof(Record));
    PMPI_Recv(mine.data(), bytes, MPI_BYTE, 0, kScatterTag, kit_comm, MPI_STATUS_IGNORE);
  }
  s = Local{};
  for (const Record& rec : mine) s.push(rec);
  s.owned = s.size();
}

/// Ends the run when this rank owns a particle of another rank's slab (mpi_stage()'s check at
/// every gather; the instructor's engine, whose ranks own blocks, skips it).
void check_owners(const Ranks& r, const Local& s) {
  for (int k = 0; k < s.owned; ++k) {
    const int q = r.owner_of(s.p.x[k]);
    if (q == r.rank) continue;
    char text[512];
    std::snprintf(text, sizeof text,
                  "stage 08: rank %d owns particle %d, whose centre (x = %.8f) lies in rank %d's "
                  "slab [%.8f, %.8f): at the end of a step each rank owns exactly the particles "
                  "of its own slab (exercise 3, migration: leaving() hands the others to their "
                  "owners)", r.rank, s.id[k], s.p.x[k], q, r.slab_lo(q), r.slab_hi(q));
    throw std::runtime_error(text);
  }
}

/// Ends the run when a step left this rank holding particles it does not count as owned
/// (mpi_stage()'s check after every step): a step ends with the ghosts dropped and every particle
/// that arrived in the migration owned, so that the next step's halo starts from its own slab.
void check_owned_after_step(const Ranks& r, const Local& s) {
  if (s.owned == s.size()) return;
  char text[512];
  std::snprintf(text, sizeof text,
                "stage 08: after a step rank %d holds %d particles but owns %d of them (s.owned): "
                "at the end of a step every particle a rank holds is its own, those that arrived "
                "in the migration too (exercise 3, migrate(): count them all as owned)",
                r.rank, s.size(), s.owned);
  throw std::runtime_error(text);
}

/// Gathers every rank's owned particles into `all` on rank 0, in index order.
void gather(const Ranks& r, const Local& s, Particles* all_on_0) {
  std::vector<Record> mine;
  for (int k = 0; k < s.owned; ++k) mine.push_back(s.record(k));
  const int bytes = static_cast<int>(mine.size() * sizeof(Record));
  std::vector<int> counts(r.ranks), at(r.ranks);
  PMPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, r.comm);
  int total = 0;
  for (int q = 0; q < r.ranks; ++q) {
    at[q] = total;
    total += counts[q];
  }
  std::vector<Record> got(r.rank == 0 ? total / sizeof(Record) : 0);
  PMPI_Gatherv(mine.data(), bytes, MPI_BYTE, got.data(), counts.data(), at.data(), MPI_BYTE, 0,
              r.comm);
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
  bool slabs = true;         //!< each rank must own its slab's particles (mpi_stage())
  Local s;                   //!< this rank's particles
  Stepper::Traffic traffic;  //!< on rank 0, after kTraffic: every rank's messages
};

/// Acts on one command (every rank, in the same order).
void act(int command, const Ranks& r, Run& run, Particles* all) {
  switch (command) {
    case kStart: {
      start_sampling();
      {
        const Writable writable;
        traffic_here = {};
        sampled.work_ns = 0;
        sampled.waiting_ns = 0;
      }
      double head[4] = {run.box.L, run.box.r, the_ranks.gpu ? 1.0 : 0.0, run.slabs ? 1.0 : 0.0};
      PMPI_Bcast(head, 4, MPI_DOUBLE, 0, r.comm);
      run.box = {head[0], head[1]};
      run.slabs = head[3] != 0;
      the_ranks.L = run.box.L;
      the_ranks.gpu = head[2] != 0;
      scatter(r, all, run.s);
      break;
    }
    case kStep:
      {
        const Writable writable;
        account();  // the time before the step: neither
        sampled.in_step = 1;
      }
      ++where_steps;
      where_say("in its step, between the stage's MPI calls", "");
      the_step(run.box, r, run.s);
      where_say("between steps", "");
      {
        const Writable writable;
        account();  // the step's last stretch
        sampled.in_step = 0;
      }
      if (run.slabs) check_owned_after_step(r, run.s);
      break;
    case kRead:
      if (run.slabs) check_owners(r, run.s);
      gather(r, run.s, all);
      break;
    case kTraffic: {  // the sum of the bytes, the most seconds, on rank 0
      double bytes = 0, seconds = 0;
      PMPI_Reduce(&traffic_here.bytes_sent, &bytes, 1, MPI_DOUBLE, MPI_SUM, 0, r.comm);
      PMPI_Reduce(&traffic_here.comm_seconds, &seconds, 1, MPI_DOUBLE, MPI_MAX, 0, r.comm);
      run.traffic = {bytes, seconds, r.ranks, {}, {}, {}};
      std::vector<CallBytes> calls(r.rank == 0 ? kCallSlots * r.ranks : 0);
      PMPI_Gather(traffic_here.by_call, sizeof traffic_here.by_call, MPI_BYTE, calls.data(),
                  sizeof traffic_here.by_call, MPI_BYTE, 0, r.comm);
      for (const CallBytes& c : calls) {  // rank 0: every rank's slots, summed by name
        if (c.name[0] == '\0') continue;
        const std::string name(c.name, strnlen(c.name, sizeof c.name));
        auto& by = run.traffic.bytes_by_call;
        auto it = std::find_if(by.begin(), by.end(),
                               [&](const auto& b) { return b.first == name; });
        if (it == by.end()) by.emplace_back(name, c.bytes);
        else it->second += c.bytes;
      }
      std::sort(run.traffic.bytes_by_call.begin(), run.traffic.bytes_by_call.end(),
                [](const auto& a, const auto& b) { return a.second > b.second; });
      const double mine[2] = {1e-9 * sampled.work_ns, 1e-9 * sampled.waiting_ns};
      std::vector<double> all(r.rank == 0 ? 2 * r.ranks : 0);
      PMPI_Gather(mine, 2, MPI_DOUBLE, all.data(), 2, MPI_DOUBLE, 0, r.comm);
      for (int q = 0; r.rank == 0 && q < r.ranks; ++q) {
        run.traffic.work_seconds.push_back(all[2 * q]);
        run.traffic.mpi_seconds.push_back(all[2 * q + 1]);
      }
      break;
    }
    default:
      break;
  }
}

/// Rank 0's view of the run: each call tells the other ranks to do the same.
class DistStepper final : public Stepper {
 public:
  DistStepper(const Box& box, Particles& p, std::string gpu, bool slabs)
      : r_(start_mpi()), gpu_(std::move(gpu)) {
    run_.box = box;
    run_.slabs = slabs;
    the_ranks.gpu = !gpu_.empty();
    command(kStart, &p);
  }
  ~DistStepper() override {
    send_command(kStop, r_.comm);
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
      send_command(c, r_.comm);
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

int serve(DistStepFn step) {
  the_step = step;
  const Ranks& r = start_mpi();
  if (r.rank == 0) return -1;  // rank 0 goes on as the runner
  keep_stdout_for_output();    // the other ranks print no output: their stdout goes to stderr
  Run run;
  for (;;) {
    const int command = next_command(r.comm);
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
  the_owner = nullptr;
  return std::make_unique<DistStepper>(box, p, gpu, true);
}

std::unique_ptr<Stepper> mpi_stage_any_cut(const Box& box, Particles& p, DistStepFn step,
                                           const std::string& gpu, OwnerFn owner) {
  the_step = step;
  the_owner = owner;
  return std::make_unique<DistStepper>(box, p, gpu, false);
}

}  // namespace plab::dist

// -- The count of the stage's messages: MPI's profiling interface --------------------------------
// These definitions take the place of the MPI library's for every call of the program (the
// library's own is PMPI_...). The kit's plumbing above (commands, scatter, gather, the traffic's
// reduction) calls PMPI_ directly: not counted. Every call that moves a rank's data to another
// is counted (point to point in every send mode, the collectives, rooted or not, blocking or
// not); what could move data past the count (one-sided windows, persistent requests,
// neighbourhood collectives, MPI I/O) is refused with a message (refuse(), below).

using plab::dist::count_sent;
using plab::dist::InMessages;
using plab::dist::InMpi;
using plab::dist::traffic_here;
using plab::dist::kEnvelopeBytes;

namespace {

/// Ends the run on every rank: stage 08 may not use `call` (the kit could not count its bytes).
[[noreturn]] void refuse(const char* call) {
  std::fprintf(stderr, "stage 08: %s is not allowed here: the kit counts every byte the ranks send "
               "(plab grade's idea test), and this call would move data past the count. Use "
               "point-to-point messages or collectives.\n", call);
  std::fflush(stderr);
  PMPI_Abort(MPI_COMM_WORLD, 2);
  std::abort();
}

/// This process's rank in `comm` and the size of `comm`.
std::pair<int, int> rank_size(MPI_Comm comm) {
  int me = 0, size = 0;
  PMPI_Comm_rank(comm, &me);
  PMPI_Comm_size(comm, &size);
  return {me, size};
}

/// Counts `count` items of `type` sent to every rank of `comm` but this one (a root's broadcast).
void count_to_all(int count, MPI_Datatype type, MPI_Comm comm) {
  const auto [me, size] = rank_size(comm);
  for (int q = 0; q < size; ++q) count_sent(count, type, q, comm);
}

/// Counts a root's scatter: counts[q] items (or `count` each, when counts is null) to rank q.
void count_scatter(const int* counts, int count, MPI_Datatype type, int root, MPI_Comm comm) {
  const auto [me, size] = rank_size(comm);
  if (me != root) return;
  for (int q = 0; q < size; ++q) count_sent(counts ? counts[q] : count, type, q, comm);
}

/// Whether a collective's send buffer is MPI_IN_PLACE: its send count and type are then ignored,
/// and what a rank contributes is read from its receive buffer, as its receive counts say (a
/// red-team stage 08 all-gathered every particle so, counted as nothing).
bool in_place(const void* sendbuf) { return sendbuf == MPI_IN_PLACE; }

/// Counts what this rank contributes to an all-gather: `sendcount` of `sendtype` to every other
/// rank, or with MPI_IN_PLACE its own block of the receive buffer (recvcounts[me], or `recvcount`
/// when recvcounts is null, of `recvtype`).
void count_allgather(const void* sendbuf, int sendcount, MPI_Datatype sendtype,
                     const int* recvcounts, int recvcount, MPI_Datatype recvtype, MPI_Comm comm) {
  const auto [me, size] = rank_size(comm);
  const int count = !in_place(sendbuf) ? sendcount : recvcounts ? recvcounts[me] : recvcount;
  const MPI_Datatype type = in_place(sendbuf) ? recvtype : sendtype;
  for (int q = 0; q < size; ++q) count_sent(count, type, q, comm);
}

/// Counts an all-to-all: to rank q, sendcounts[q] (or `sendcount`) of sendtypes[q] (or
/// `sendtype`); with MPI_IN_PLACE, the receive side's counts and types, which are then what is
/// sent.
void count_alltoall(const void* sendbuf, const int* sendcounts, int sendcount,
                    const MPI_Datatype* sendtypes, MPI_Datatype sendtype, const int* recvcounts,
                    int recvcount, const MPI_Datatype* recvtypes, MPI_Datatype recvtype,
                    MPI_Comm comm) {
  const auto [me, size] = rank_size(comm);
  const bool inplace = in_place(sendbuf);
  const int* counts = inplace ? recvcounts : sendcounts;
  const MPI_Datatype* types = inplace ? recvtypes : sendtypes;
  for (int q = 0; q < size; ++q)
    count_sent(counts ? counts[q] : inplace ? recvcount : sendcount,
               types ? types[q] : inplace ? recvtype : sendtype, q, comm);
}

}  // namespace

extern "C" {

int MPI_Send(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Send(buf, count, type, dest, tag, comm);
}

int MPI_Isend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm,
              MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Isend(buf, count, type, dest, tag, comm, request);
}

int MPI_Sendrecv(const void* sendbuf, int sendcount, MPI_Datatype sendtype, int dest, int sendtag,
                 void* recvbuf, int recvcount, MPI_Datatype recvtype, int source, int recvtag,
                 MPI_Comm comm, MPI_Status* status) {
  const InMessages timed(__func__);
  count_sent(sendcount, sendtype, dest, comm);
  return PMPI_Sendrecv(sendbuf, sendcount, sendtype, dest, sendtag, recvbuf, recvcount, recvtype,
                       source, recvtag, comm, status);
}

int MPI_Recv(void* buf, int count, MPI_Datatype type, int source, int tag, MPI_Comm comm,
             MPI_Status* status) {
  const InMessages timed(__func__);
  return PMPI_Recv(buf, count, type, source, tag, comm, status);
}

int MPI_Wait(MPI_Request* request, MPI_Status* status) {
  const InMessages timed(__func__);
  return PMPI_Wait(request, status);
}

int MPI_Waitall(int count, MPI_Request requests[], MPI_Status statuses[]) {
  const InMessages timed(__func__);
  return PMPI_Waitall(count, requests, statuses);
}

int MPI_Alltoall(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                 int recvcount, MPI_Datatype recvtype, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_alltoall(sendbuf, nullptr, sendcount, nullptr, sendtype, nullptr, recvcount, nullptr,
                 recvtype, comm);
  return PMPI_Alltoall(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, comm);
}

int MPI_Alltoallv(const void* sendbuf, const int sendcounts[], const int sdispls[],
                  MPI_Datatype sendtype, void* recvbuf, const int recvcounts[],
                  const int rdispls[], MPI_Datatype recvtype, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_alltoall(sendbuf, sendcounts, 0, nullptr, sendtype, recvcounts, 0, nullptr, recvtype,
                 comm);
  return PMPI_Alltoallv(sendbuf, sendcounts, sdispls, sendtype, recvbuf, recvcounts, rdispls,
                        recvtype, comm);
}

int MPI_Allreduce(const void* sendbuf, void* recvbuf, int count, MPI_Datatype type, MPI_Op op,
                  MPI_Comm comm) {
  const InMessages timed(__func__);
  int size = 0, bytes = 0;
  PMPI_Comm_size(comm, &size);
  PMPI_Type_size(type, &bytes);
  if (size > 1) plab::dist::add_sent(1.0 * count * bytes + kEnvelopeBytes);
  return PMPI_Allreduce(sendbuf, recvbuf, count, type, op, comm);
}

int MPI_Allgather(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                  int recvcount, MPI_Datatype recvtype, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_allgather(sendbuf, sendcount, sendtype, nullptr, recvcount, recvtype, comm);
  return PMPI_Allgather(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, comm);
}

int MPI_Allgatherv(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                   const int recvcounts[], const int displs[], MPI_Datatype recvtype,
                   MPI_Comm comm) {
  const InMessages timed(__func__);
  count_allgather(sendbuf, sendcount, sendtype, recvcounts, 0, recvtype, comm);
  return PMPI_Allgatherv(sendbuf, sendcount, sendtype, recvbuf, recvcounts, displs, recvtype,
                         comm);
}

// Rooted collectives: the root sends to the others (broadcast, scatter), the others to the root
// (gather, reduce).
int MPI_Bcast(void* buf, int count, MPI_Datatype type, int root, MPI_Comm comm) {
  const InMessages timed(__func__);
  if (rank_size(comm).first == root) count_to_all(count, type, comm);
  return PMPI_Bcast(buf, count, type, root, comm);
}

int MPI_Ibcast(void* buf, int count, MPI_Datatype type, int root, MPI_Comm comm,
               MPI_Request* request) {
  const InMpi in_mpi(__func__);
  if (rank_size(comm).first == root) count_to_all(count, type, comm);
  return PMPI_Ibcast(buf, count, type, root, comm, request);
}

int MPI_Scatter(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                int recvcount, MPI_Datatype recvtype, int root, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_scatter(nullptr, sendcount, sendtype, root, comm);
  return PMPI_Scatter(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, root, comm);
}

int MPI_Iscatter(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                 int recvcount, MPI_Datatype recvtype, int root, MPI_Comm comm,
                 MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_scatter(nullptr, sendcount, sendtype, root, comm);
  return PMPI_Iscatter(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, root, comm,
                       request);
}

int MPI_Scatterv(const void* sendbuf, const int sendcounts[], const int displs[],
                 MPI_Datatype sendtype, void* recvbuf, int recvcount, MPI_Datatype recvtype,
                 int root, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_scatter(sendcounts, 0, sendtype, root, comm);
  return PMPI_Scatterv(sendbuf, sendcounts, displs, sendtype, recvbuf, recvcount, recvtype, root,
                       comm);
}

int MPI_Iscatterv(const void* sendbuf, const int sendcounts[], const int displs[],
                  MPI_Datatype sendtype, void* recvbuf, int recvcount, MPI_Datatype recvtype,
                  int root, MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_scatter(sendcounts, 0, sendtype, root, comm);
  return PMPI_Iscatterv(sendbuf, sendcounts, displs, sendtype, recvbuf, recvcount, recvtype, root,
                        comm, request);
}

int MPI_Gather(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
               int recvcount, MPI_Datatype recvtype, int root, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(sendcount, sendtype, root, comm);
  return PMPI_Gather(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, root, comm);
}

int MPI_Igather(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                int recvcount, MPI_Datatype recvtype, int root, MPI_Comm comm,
                MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(sendcount, sendtype, root, comm);
  return PMPI_Igather(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, root, comm,
                      request);
}

int MPI_Gatherv(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                const int recvcounts[], const int displs[], MPI_Datatype recvtype, int root,
                MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(sendcount, sendtype, root, comm);
  return PMPI_Gatherv(sendbuf, sendcount, sendtype, recvbuf, recvcounts, displs, recvtype, root,
                      comm);
}

int MPI_Igatherv(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                 const int recvcounts[], const int displs[], MPI_Datatype recvtype, int root,
                 MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(sendcount, sendtype, root, comm);
  return PMPI_Igatherv(sendbuf, sendcount, sendtype, recvbuf, recvcounts, displs, recvtype, root,
                       comm, request);
}

int MPI_Reduce(const void* sendbuf, void* recvbuf, int count, MPI_Datatype type, MPI_Op op,
               int root, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(count, type, root, comm);
  return PMPI_Reduce(sendbuf, recvbuf, count, type, op, root, comm);
}

int MPI_Ireduce(const void* sendbuf, void* recvbuf, int count, MPI_Datatype type, MPI_Op op,
                int root, MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(count, type, root, comm);
  return PMPI_Ireduce(sendbuf, recvbuf, count, type, op, root, comm, request);
}

// Everyone to everyone, the forms not counted above.
int MPI_Iallreduce(const void* sendbuf, void* recvbuf, int count, MPI_Datatype type, MPI_Op op,
                   MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_to_all(count, type, comm);
  return PMPI_Iallreduce(sendbuf, recvbuf, count, type, op, comm, request);
}

int MPI_Reduce_scatter_block(const void* sendbuf, void* recvbuf, int recvcount, MPI_Datatype type,
                             MPI_Op op, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_to_all(recvcount, type, comm);
  return PMPI_Reduce_scatter_block(sendbuf, recvbuf, recvcount, type, op, comm);
}

int MPI_Reduce_scatter(const void* sendbuf, void* recvbuf, const int recvcounts[],
                       MPI_Datatype type, MPI_Op op, MPI_Comm comm) {
  const InMessages timed(__func__);
  const auto [me, size] = rank_size(comm);
  for (int q = 0; q < size; ++q) count_sent(recvcounts[q], type, q, comm);
  return PMPI_Reduce_scatter(sendbuf, recvbuf, recvcounts, type, op, comm);
}

int MPI_Scan(const void* sendbuf, void* recvbuf, int count, MPI_Datatype type, MPI_Op op,
             MPI_Comm comm) {
  const InMessages timed(__func__);
  count_to_all(count, type, comm);
  return PMPI_Scan(sendbuf, recvbuf, count, type, op, comm);
}

int MPI_Exscan(const void* sendbuf, void* recvbuf, int count, MPI_Datatype type, MPI_Op op,
               MPI_Comm comm) {
  const InMessages timed(__func__);
  count_to_all(count, type, comm);
  return PMPI_Exscan(sendbuf, recvbuf, count, type, op, comm);
}

int MPI_Ialltoall(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                  int recvcount, MPI_Datatype recvtype, MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_alltoall(sendbuf, nullptr, sendcount, nullptr, sendtype, nullptr, recvcount, nullptr,
                 recvtype, comm);
  return PMPI_Ialltoall(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, comm, request);
}

int MPI_Ialltoallv(const void* sendbuf, const int sendcounts[], const int sdispls[],
                   MPI_Datatype sendtype, void* recvbuf, const int recvcounts[],
                   const int rdispls[], MPI_Datatype recvtype, MPI_Comm comm,
                   MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_alltoall(sendbuf, sendcounts, 0, nullptr, sendtype, recvcounts, 0, nullptr, recvtype,
                 comm);
  return PMPI_Ialltoallv(sendbuf, sendcounts, sdispls, sendtype, recvbuf, recvcounts, rdispls,
                         recvtype, comm, request);
}

int MPI_Iallgather(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                   int recvcount, MPI_Datatype recvtype, MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_allgather(sendbuf, sendcount, sendtype, nullptr, recvcount, recvtype, comm);
  return PMPI_Iallgather(sendbuf, sendcount, sendtype, recvbuf, recvcount, recvtype, comm,
                         request);
}

int MPI_Iallgatherv(const void* sendbuf, int sendcount, MPI_Datatype sendtype, void* recvbuf,
                    const int recvcounts[], const int displs[], MPI_Datatype recvtype,
                    MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_allgather(sendbuf, sendcount, sendtype, recvcounts, 0, recvtype, comm);
  return PMPI_Iallgatherv(sendbuf, sendcount, sendtype, recvbuf, recvcounts, displs, recvtype,
                          comm, request);
}

int MPI_Alltoallw(const void* sendbuf, const int sendcounts[], const int sdispls[],
                  const MPI_Datatype sendtypes[], void* recvbuf, const int recvcounts[],
                  const int rdispls[], const MPI_Datatype recvtypes[], MPI_Comm comm) {
  const InMessages timed(__func__);
  count_alltoall(sendbuf, sendcounts, 0, sendtypes, MPI_DATATYPE_NULL, recvcounts, 0, recvtypes,
                 MPI_DATATYPE_NULL, comm);
  return PMPI_Alltoallw(sendbuf, sendcounts, sdispls, sendtypes, recvbuf, recvcounts, rdispls,
                        recvtypes, comm);
}

// The other send modes (synchronous, buffered, ready), blocking or not.
int MPI_Ssend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Ssend(buf, count, type, dest, tag, comm);
}

int MPI_Bsend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Bsend(buf, count, type, dest, tag, comm);
}

int MPI_Rsend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm) {
  const InMessages timed(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Rsend(buf, count, type, dest, tag, comm);
}

int MPI_Issend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm,
               MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Issend(buf, count, type, dest, tag, comm, request);
}

int MPI_Ibsend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm,
               MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Ibsend(buf, count, type, dest, tag, comm, request);
}

int MPI_Irsend(const void* buf, int count, MPI_Datatype type, int dest, int tag, MPI_Comm comm,
               MPI_Request* request) {
  const InMpi in_mpi(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Irsend(buf, count, type, dest, tag, comm, request);
}

int MPI_Sendrecv_replace(void* buf, int count, MPI_Datatype type, int dest, int sendtag,
                         int source, int recvtag, MPI_Comm comm, MPI_Status* status) {
  const InMessages timed(__func__);
  count_sent(count, type, dest, comm);
  return PMPI_Sendrecv_replace(buf, count, type, dest, sendtag, source, recvtag, comm, status);
}

// Refused: data could move past the count (one-sided windows, including shared memory ones;
// persistent sends, started later by MPI_Start; neighbourhood collectives; files).
int MPI_Win_create(void*, MPI_Aint, int, MPI_Info, MPI_Comm, MPI_Win*) { refuse("MPI_Win_create"); }
int MPI_Win_allocate(MPI_Aint, int, MPI_Info, MPI_Comm, void*, MPI_Win*) {
  refuse("MPI_Win_allocate");
}
int MPI_Win_allocate_shared(MPI_Aint, int, MPI_Info, MPI_Comm, void*, MPI_Win*) {
  refuse("MPI_Win_allocate_shared");
}
int MPI_Win_create_dynamic(MPI_Info, MPI_Comm, MPI_Win*) { refuse("MPI_Win_create_dynamic"); }
int MPI_Send_init(const void*, int, MPI_Datatype, int, int, MPI_Comm, MPI_Request*) {
  refuse("MPI_Send_init");
}
int MPI_Ssend_init(const void*, int, MPI_Datatype, int, int, MPI_Comm, MPI_Request*) {
  refuse("MPI_Ssend_init");
}
int MPI_Bsend_init(const void*, int, MPI_Datatype, int, int, MPI_Comm, MPI_Request*) {
  refuse("MPI_Bsend_init");
}
int MPI_Rsend_init(const void*, int, MPI_Datatype, int, int, MPI_Comm, MPI_Request*) {
  refuse("MPI_Rsend_init");
}
int MPI_Neighbor_alltoall(const void*, int, MPI_Datatype, void*, int, MPI_Datatype, MPI_Comm) {
  refuse("MPI_Neighbor_alltoall");
}
int MPI_Neighbor_alltoallv(const void*, const int[], const int[], MPI_Datatype, void*, const int[],
                           const int[], MPI_Datatype, MPI_Comm) {
  refuse("MPI_Neighbor_alltoallv");
}
int MPI_Neighbor_allgather(const void*, int, MPI_Datatype, void*, int, MPI_Datatype, MPI_Comm) {
  refuse("MPI_Neighbor_allgather");
}
int MPI_File_open(MPI_Comm, const char*, int, MPI_Info, MPI_File*) { refuse("MPI_File_open"); }

// Calls that move no data of the stage (symbols.py's NO_DATA) but wait or poll: not counted in
// bytes, only marked as time in MPI (InMpi), so that a rank that waits, spinning, for another
// rank's work does not look as if it worked (the sampled work of each rank).
int MPI_Barrier(MPI_Comm comm) {
  const InMessages timed(__func__);
  return PMPI_Barrier(comm);
}
int MPI_Ibarrier(MPI_Comm comm, MPI_Request* request) {
  const InMpi in_mpi(__func__);
  return PMPI_Ibarrier(comm, request);
}
int MPI_Irecv(void* buf, int count, MPI_Datatype type, int source, int tag, MPI_Comm comm,
              MPI_Request* request) {
  const InMpi in_mpi(__func__);
  return PMPI_Irecv(buf, count, type, source, tag, comm, request);
}
int MPI_Probe(int source, int tag, MPI_Comm comm, MPI_Status* status) {
  const InMessages timed(__func__);
  return PMPI_Probe(source, tag, comm, status);
}
int MPI_Iprobe(int source, int tag, MPI_Comm comm, int* flag, MPI_Status* status) {
  const InMpi in_mpi(__func__);
  return PMPI_Iprobe(source, tag, comm, flag, status);
}
int MPI_Mprobe(int source, int tag, MPI_Comm comm, MPI_Message* message, MPI_Status* status) {
  const InMessages timed(__func__);
  return PMPI_Mprobe(source, tag, comm, message, status);
}
int MPI_Improbe(int source, int tag, MPI_Comm comm, int* flag, MPI_Message* message,
                MPI_Status* status) {
  const InMpi in_mpi(__func__);
  return PMPI_Improbe(source, tag, comm, flag, message, status);
}
int MPI_Mrecv(void* buf, int count, MPI_Datatype type, MPI_Message* message, MPI_Status* status) {
  const InMessages timed(__func__);
  return PMPI_Mrecv(buf, count, type, message, status);
}
int MPI_Imrecv(void* buf, int count, MPI_Datatype type, MPI_Message* message,
               MPI_Request* request) {
  const InMpi in_mpi(__func__);
  return PMPI_Imrecv(buf, count, type, message, request);
}
int MPI_Waitany(int count, MPI_Request requests[], int* index, MPI_Status* status) {
  const InMessages timed(__func__);
  return PMPI_Waitany(count, requests, index, status);
}
int MPI_Waitsome(int incount, MPI_Request requests[], int* outcount, int indices[],
                 MPI_Status statuses[]) {
  const InMessages timed(__func__);
  return PMPI_Waitsome(incount, requests, outcount, indices, statuses);
}
int MPI_Test(MPI_Request* request, int* flag, MPI_Status* status) {
  const InMpi in_mpi(__func__);
  return PMPI_Test(request, flag, status);
}
int MPI_Testall(int count, MPI_Request requests[], int* flag, MPI_Status statuses[]) {
  const InMpi in_mpi(__func__);
  return PMPI_Testall(count, requests, flag, statuses);
}
int MPI_Testany(int count, MPI_Request requests[], int* index, int* flag, MPI_Status* status) {
  const InMpi in_mpi(__func__);
  return PMPI_Testany(count, requests, index, flag, status);
}
int MPI_Testsome(int incount, MPI_Request requests[], int* outcount, int indices[],
                 MPI_Status statuses[]) {
  const InMpi in_mpi(__func__);
  return PMPI_Testsome(incount, requests, outcount, indices, statuses);
}

}  // extern "C"
