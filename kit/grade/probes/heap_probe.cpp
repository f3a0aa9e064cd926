/// \file heap_probe.cpp
/// \brief The kit's probe of stage 02's heap (the student's heap.hpp), measured outside the step:
/// compiled beside heap.hpp by the grader (in its sandbox, plab.grade.heap_probe) and by the
/// local test stageNN.IMPL.Heap, it drives the step's own heap type, MinHeap<model::Event,
/// plab::EventOrder>, alone: the handout's example, then a long random run of pushes and pops of
/// events like a step's, counting the comparisons the heap asks EventOrder for, and prints what
/// it sees; plab.grade.heap_probe judges the text against the kit's own heap's.
///
/// Output, one line each: `example-push T...` and `example-pop T...` (the array's times after
/// pushing events at 5, 3, 8, 1, then after one pop); `pop T` for each pop of the run (the time of
/// the event it removed); `layout OPS T...` every 2000 operations and at the end; and last
/// `comparisons C PUSHES PUSH_C POPS POP_C LARGEST TRACE` (in all; the pushes and their
/// comparisons; the pops and theirs; the most items held; EventOrder's trace of every comparison of
/// the probe, the example's first: which events were compared, in order). Times are printed exactly
/// (C's %a). A heap.hpp whose exercise is not done throws: its message goes to stderr and the probe
/// exits 3.
///
///   heap_probe SEED OPS
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <initializer_list>

#include "heap.hpp"
#include "plab/event_order.hpp"

namespace {

using Heap = plab::MinHeap<plab::model::Event, plab::EventOrder>;

void print_times(const char* head, const Heap& h) {
  std::fputs(head, stdout);
  for (const plab::model::Event& e : h.items()) std::printf(" %a", e.t);
  std::fputc('\n', stdout);
}

/// The run's next event: a time in [0, 1) (53 random bits), a wall or a pair of particles below
/// 5000, as a step's candidates are (plab.grade.heap_probe.events() makes the same).
plab::model::Event next_event(std::uint64_t state) {
  const double t = static_cast<double>(state >> 11) * 0x1p-53;
  const int lo = static_cast<int>((state >> 3) % 4999);
  if ((state >> 2) & 1) return plab::model::wall_event_key(t, lo);
  return plab::model::pair_event_key(t, lo, lo + 1 + static_cast<int>((state >> 40) % (4999 - lo)));
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t seed = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1;
  const long ops = argc > 2 ? std::strtol(argv[2], nullptr, 10) : 20000;
  if (ops < 1 || ops >= (1L << 20)) {
    std::fprintf(stderr, "heap_probe: OPS must be 1 to 2^20 - 1\n");
    return 2;
  }
  // This thread's comparisons since the probe's own heap began (the tallies only grow)
  long long start = 0;
  const auto count = [&start] { return plab::EventOrder::count() - start; };
  try {
    {
      Heap h;
      for (int k : {5, 3, 8, 1}) h.push(plab::model::wall_event_key(k, k));
      print_times("example-push", h);
      h.pop();
      print_times("example-pop", h);
    }
    start = plab::EventOrder::count();
    Heap h;
    std::uint64_t state = seed;
    long long pushes = 0, pops = 0, push_count = 0, pop_count = 0;
    std::size_t largest = 0;
    char head[32];
    for (long op = 0; op < ops; ++op) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      const long long before = count();
      if (h.empty() || (state >> 33) % 3 != 0) {
        h.push(next_event(state));
        ++pushes;
        push_count += count() - before;
      } else {
        std::printf("pop %a\n", h.top().t);
        const long long at_top = count();  // top() compares nothing; the pop's own comparisons:
        h.pop();
        ++pops;
        pop_count += count() - at_top;
      }
      if (h.size() > largest) largest = h.size();
      if ((op + 1) % 2000 == 0 || op + 1 == ops) {
        std::snprintf(head, sizeof head, "layout %ld", op + 1);
        print_times(head, h);
      }
    }
    std::printf("comparisons %lld %lld %lld %lld %lld %zu %016llx\n", count(), pushes, push_count,
                pops, pop_count, largest,
                static_cast<unsigned long long>(plab::EventOrder::trace()));
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "%s\n", e.what());
    return 3;
  }
  return 0;
}
