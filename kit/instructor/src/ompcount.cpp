/// \file ompcount.cpp
/// \brief libplab-ompcount.so: loaded into a stage 03 program by the grader (LD_PRELOAD), it
/// counts the OpenMP synchronisations the program runs, outside the program's own code: every
/// parallel region that libgomp starts, and every barrier and end of a work-sharing loop that
/// thread 0 of a team of more than one passes; and it keeps the loops' clock, plab_omp_epoch, by
/// which the kit's plab::EventOrder tells which comparisons one loop made. The grader's idea test
/// of stage 03 compares them with the mutual-earliest rounds the scene needs (`plab-rounds`): a
/// stage that selects its events in rounds of parallel loops passes at least one a round; one
/// that selects them sequentially after a parallel phase, or keeps a thread busy beside a
/// sequential program, passes a few a step.
///
/// Each entry point is libgomp's own (GCC's OpenMP ABI), found with dlsym(RTLD_NEXT) and called
/// with the same arguments. The grader gives a secret in PLAB_OMP_COUNT and the program's path in
/// PLAB_OMP_COUNT_PROGRAM; in that program's process the library copies the secret and
/// overwrites it in the environment before the program's code runs (so /proc/self/environ no
/// longer shows it), opens omp-count.json in the working folder, and writes the counts and the
/// secret there when the program ends.
#include <dlfcn.h>
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>

/// The loops' clock that plab::EventOrder reads (kit/src/tallies.cpp, a weak reference: absent, it
/// keeps no epochs): one more as each parallel region starts and ends and as thread 0 of a team
/// leaves a barrier or the end of a work-sharing loop, so that the comparisons one loop makes share
/// an epoch and the next loop's, or serial code's after it, do not.
extern "C" {
__attribute__((visibility("default"))) std::atomic<long long> plab_omp_epoch{0};
}

namespace {

std::atomic<long long> regions{0};  //!< parallel regions started (by the thread that forks)
std::atomic<long long> syncs{0};    //!< barriers and loop ends passed by thread 0 of a team
char secret[80];                    //!< the grader's secret, to sign the counts
int out_fd = -1;                    //!< omp-count.json, opened before the program's code runs

/// libgomp's function `name` (the next definition after this library's).
template <class Fn>
Fn next(const char* name) {
  return reinterpret_cast<Fn>(dlsym(RTLD_NEXT, name));
}

/// Whether the calling thread is thread 0 of a team of more than one (libgomp's
/// omp_get_thread_num() and omp_get_num_threads()): a barrier in serial code (orphaned, outside
/// any parallel region) or in a team of one synchronises nothing, and is not counted.
bool first_of_team() {
  static const auto num = next<int (*)()>("omp_get_thread_num");
  static const auto size = next<int (*)()>("omp_get_num_threads");
  return num == nullptr || size == nullptr || (num() == 0 && size() > 1);
}

/// Whether this process runs the program named by PLAB_OMP_COUNT_PROGRAM (the sandbox's own
/// tools that start it, setpriv say, load this library too, and must leave the secret alone).
bool is_the_program() {
  const char* program = std::getenv("PLAB_OMP_COUNT_PROGRAM");
  char exe[4096], want[4096];
  const ssize_t k = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (program == nullptr || k <= 0 || realpath(program, want) == nullptr) return false;
  exe[k] = '\0';
  return std::strcmp(exe, want) == 0;
}

__attribute__((constructor)) void start() {
  if (!is_the_program()) return;
  if (char* s = std::getenv("PLAB_OMP_COUNT")) {
    std::snprintf(secret, sizeof secret, "%s", s);
    for (char* c = s; *c; ++c) *c = 'x';  // in place: the environment's own memory
  }
  out_fd = open("omp-count.json", O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
}

__attribute__((destructor)) void finish() {
  if (out_fd < 0) return;
  char text[256];
  const int len = std::snprintf(text, sizeof text,
                                "{\"secret\": \"%s\", \"regions\": %lld, \"syncs\": %lld}\n",
                                secret, regions.load(), syncs.load());
  if (len > 0 && write(out_fd, text, static_cast<size_t>(len)) < 0) std::perror("omp-count");
  close(out_fd);
  out_fd = -1;
}

void passed() {
  if (first_of_team()) ++syncs;
}

/// After a barrier or a loop's end: the next epoch (thread 0 of the team, as it leaves).
void left() {
  if (first_of_team()) ++plab_omp_epoch;
}

}  // namespace

extern "C" {

using Body = void (*)(void*);

void GOMP_parallel(Body fn, void* data, unsigned threads, unsigned flags) {
  static const auto real = next<void (*)(Body, void*, unsigned, unsigned)>("GOMP_parallel");
  ++regions;
  ++plab_omp_epoch;
  real(fn, data, threads, flags);
  ++plab_omp_epoch;
}

unsigned GOMP_parallel_reductions(Body fn, void* data, unsigned threads, unsigned flags) {
  static const auto real =
      next<unsigned (*)(Body, void*, unsigned, unsigned)>("GOMP_parallel_reductions");
  ++regions;
  ++plab_omp_epoch;
  const unsigned done = real(fn, data, threads, flags);
  ++plab_omp_epoch;
  return done;
}

void GOMP_parallel_start(Body fn, void* data, unsigned threads) {
  static const auto real = next<void (*)(Body, void*, unsigned)>("GOMP_parallel_start");
  ++regions;
  ++plab_omp_epoch;
  real(fn, data, threads);
}

void GOMP_parallel_end() {
  static const auto real = next<void (*)()>("GOMP_parallel_end");
  real();
  ++plab_omp_epoch;
}

// `#pragma omp parallel for` with a schedule other than static: one call starts the region.
#define PLAB_PARALLEL_LOOP(name)                                                               \
  void name(Body fn, void* data, unsigned threads, long start, long end, long incr, long chunk, \
            unsigned flags) {                                                                  \
    static const auto real =                                                                   \
        next<void (*)(Body, void*, unsigned, long, long, long, long, unsigned)>(#name);        \
    ++regions;                                                                                 \
    ++plab_omp_epoch;                                                                          \
    real(fn, data, threads, start, end, incr, chunk, flags);                                   \
    ++plab_omp_epoch;                                                                          \
  }
PLAB_PARALLEL_LOOP(GOMP_parallel_loop_static)
PLAB_PARALLEL_LOOP(GOMP_parallel_loop_dynamic)
PLAB_PARALLEL_LOOP(GOMP_parallel_loop_guided)
PLAB_PARALLEL_LOOP(GOMP_parallel_loop_nonmonotonic_dynamic)
PLAB_PARALLEL_LOOP(GOMP_parallel_loop_nonmonotonic_guided)
#undef PLAB_PARALLEL_LOOP

#define PLAB_PARALLEL_RUNTIME_LOOP(name)                                                       \
  void name(Body fn, void* data, unsigned threads, long start, long end, long incr,            \
            unsigned flags) {                                                                  \
    static const auto real =                                                                   \
        next<void (*)(Body, void*, unsigned, long, long, long, unsigned)>(#name);              \
    ++regions;                                                                                 \
    ++plab_omp_epoch;                                                                          \
    real(fn, data, threads, start, end, incr, flags);                                          \
    ++plab_omp_epoch;                                                                          \
  }
PLAB_PARALLEL_RUNTIME_LOOP(GOMP_parallel_loop_runtime)
PLAB_PARALLEL_RUNTIME_LOOP(GOMP_parallel_loop_nonmonotonic_runtime)
PLAB_PARALLEL_RUNTIME_LOOP(GOMP_parallel_loop_maybe_nonmonotonic_runtime)
#undef PLAB_PARALLEL_RUNTIME_LOOP

// Inside a region: the barriers (`#pragma omp barrier`, the end of a static `omp for`, `single`)
// and the ends of the other work-sharing loops.
void GOMP_barrier() {
  static const auto real = next<void (*)()>("GOMP_barrier");
  passed();
  real();
  left();
}

bool GOMP_barrier_cancel() {
  static const auto real = next<bool (*)()>("GOMP_barrier_cancel");
  passed();
  const bool cancelled = real();
  left();
  return cancelled;
}

void GOMP_loop_end() {
  static const auto real = next<void (*)()>("GOMP_loop_end");
  passed();
  real();
  left();
}

bool GOMP_loop_end_cancel() {
  static const auto real = next<bool (*)()>("GOMP_loop_end_cancel");
  passed();
  const bool cancelled = real();
  left();
  return cancelled;
}

}  // extern "C"
