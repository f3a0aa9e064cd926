/// \file heap_probe.cpp
/// \brief The kit's probe of stage 02's heap (the student's heap.hpp), measured outside the step:
/// compiled beside heap.hpp by the grader (in its sandbox, plab.grade.heap_probe) and by the
/// local test stageNN.IMPL.Heap, it drives a MinHeap of plain keys through a fixed example and a
/// long random run of pushes and pops, counting the comparisons its order makes, and prints what
/// it sees; plab.grade.heap_probe judges the text against the textbook binary heap.
///
/// Output, one line each: `example-push K...` and `example-pop K...` (the array after pushing
/// 5, 3, 8, 1, then after one pop); `pop K` for each pop of the run (the top it removed);
/// `layout OPS K...` every 2000 operations and at the end; `comparisons C` last. A heap.hpp whose
/// exercise is not done throws: its message goes to stderr and the probe exits 3.
///
///   heap_probe SEED OPS
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <initializer_list>

#include "heap.hpp"

namespace {

/// A key of the run: distinct, so that exactly one array is the textbook heap's.
struct Item {
  std::uint64_t key;
};

/// The heap's order, counting every comparison it is asked for.
struct Counted {
  long long* count;
  bool operator()(const Item& a, const Item& b) const {
    ++*count;
    return a.key < b.key;
  }
};

using Heap = plab::MinHeap<Item, Counted>;

void print_items(const char* head, const Heap& h) {
  std::fputs(head, stdout);
  for (const Item& x : h.items()) std::printf(" %llu", static_cast<unsigned long long>(x.key));
  std::fputc('\n', stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t seed = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1;
  const long ops = argc > 2 ? std::strtol(argv[2], nullptr, 10) : 20000;
  if (ops < 1 || ops >= (1L << 20)) {
    std::fprintf(stderr, "heap_probe: OPS must be 1 to 2^20 - 1\n");
    return 2;
  }
  long long count = 0;
  try {
    {
      Heap h(Counted{&count});
      for (std::uint64_t k : {5, 3, 8, 1}) h.push(Item{k});
      print_items("example-push", h);
      h.pop();
      print_items("example-pop", h);
    }
    count = 0;
    Heap h(Counted{&count});
    std::uint64_t state = seed;
    char head[32];
    for (long op = 0; op < ops; ++op) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      if (h.empty() || (state >> 33) % 3 != 0) {
        h.push(Item{((state >> 24) << 20) | static_cast<std::uint64_t>(op)});
      } else {
        std::printf("pop %llu\n", static_cast<unsigned long long>(h.top().key));
        h.pop();
      }
      if ((op + 1) % 2000 == 0 || op + 1 == ops) {
        std::snprintf(head, sizeof head, "layout %ld", op + 1);
        print_items(head, h);
      }
    }
    std::printf("comparisons %lld\n", count);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "%s\n", e.what());
    return 3;
  }
  return 0;
}
