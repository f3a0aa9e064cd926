"""Shortcuts for stage 02's heap that the kit's heap probe must stop (tests/heap_probe_check.py
checks the probe's message for each; tests/grader_redteam.py grades some). Instructor-only: it
edits the kit's solved heap.hpp.
"""


def shortcut_heaps(solution):
    """{name: (heap.hpp text, what the probe must say)}: the kit's solved heap.hpp (`solution`)
    with MinHeap's push and pop replaced by each shortcut, or slipped."""
    push_at, end_at = solution.index("  void push(const T& x) {"), solution.index(" private:")
    SHORTCUTS = {
        "library heap": ("""  void push(const T& x) {
        items_.push_back(x);
        std::push_heap(items_.begin(), items_.end(), [this](const T& a, const T& b) { return less_(b, a); });
      }
      void pop() {
        std::pop_heap(items_.begin(), items_.end(), [this](const T& a, const T& b) { return less_(b, a); });
        items_.pop_back();
      }
    """, "fewer than the binary heap's moves make"),
        "library heap padded": ("""  void push(const T& x) {
        items_.push_back(x);
        std::push_heap(items_.begin(), items_.end(), [this](const T& a, const T& b) { return less_(b, a); });
      }
      void pop() {
        std::pop_heap(items_.begin(), items_.end(), [this](const T& a, const T& b) { return less_(b, a); });
        items_.pop_back();
        for (std::size_t n = items_.size(); n > 1; n /= 2) (void)less_(items_[0], items_[0]);
      }
    """, "more than the binary heap's moves need"),
        "multiset": ("""  void push(const T& x) { set_.insert(x); items_.assign(set_.begin(), set_.end()); }
      void pop() { set_.erase(set_.begin()); items_.assign(set_.begin(), set_.end()); }
      struct Order {
        Less less;
        bool operator()(const T& a, const T& b) const { return less(a, b); }
      };
      std::multiset<T, Order> set_;  // (EventOrder holds nothing: a default one is the same)
    """, "items() holds the times [1, 3, 5, 8]"),
        "sorted array": ("""  void push(const T& x) { items_.insert(std::upper_bound(items_.begin(), items_.end(), x, less_), x); }
      void pop() { items_.erase(items_.begin()); }
    """, "items() holds the times [1, 3, 5, 8]"),
        "least in front, a scan per pop": ("""  void push(const T& x) {
        items_.push_back(x);
        if (less_(items_.back(), items_.front())) std::swap(items_.back(), items_.front());
      }
      void pop() {
        std::swap(items_.front(), items_.back());
        items_.pop_back();
        for (std::size_t k = 1; k < items_.size(); ++k)
          if (less_(items_[k], items_.front())) std::swap(items_[k], items_.front());
      }
    """, "items() holds the times [1, 5, 8, 3]"),
        "sinks towards the greater child": (
            solution[push_at:end_at].replace("less_(items_[right], items_[left]) ? right : left", "less_(items_[left], items_[right]) ? right : left"),
            "and popping once, items() holds the times [5, 3, 8]"),
        "parent at k / 2": (
            solution[push_at:end_at].replace("const std::size_t parent = (k - 1) / 2;",
                                             "const std::size_t parent = k / 2;"),
            "is earlier than its parent"),
        "a child's bound off by one": (
            solution[push_at:end_at].replace("if (left >= n) break;", "if (left > n) break;")
            .replace("right < n &&", "right <= n &&"), "an index past the array's end"),
        "CLRS's sink (the same heap, other comparisons)": (
            solution[push_at:solution.index("  void pop() {")] + """  void pop() {
        if (items_.size() > 1) items_.front() = std::move(items_.back());
        items_.pop_back();
        const std::size_t n = items_.size();
        for (std::size_t k = 0;;) {
          const std::size_t left = 2 * k + 1, right = left + 1;
          std::size_t least = k;
          if (left < n && less_(items_[left], items_[least])) least = left;
          if (right < n && less_(items_[right], items_[least])) least = right;
          if (least == k) break;
          std::swap(items_[k], items_[least]);
          k = least;
        }
      }
    """, "not the comparisons of the binary heap's moves"),
        "push one level at most": (
            solution[push_at:end_at].replace("      k = parent;\n", "      break;\n"),
            "items() holds the times [3, 1, 8, 5]"),
    }
    return {name: ((solution[:push_at] + body + "\n" + solution[end_at:]).replace(
        "#include <vector>", "#include <vector>\n#include <algorithm>\n#include <set>"), said)
        for name, (body, said) in SHORTCUTS.items()}


def sorting_step(solution_step):
    """The kit's solved step.cpp with its candidates kept in a vector and sorted (std::sort, in
    model.md's order through plab::EventOrder) instead of a heap: the right output, no heap."""
    edits = (("  MinHeap<model::Event, EventOrder> heap;", "  std::vector<model::Event> all;"),
             ("heap.push(w)", "all.push_back(w)"), ("heap.push(e)", "all.push_back(e)"),
             ("""  while (!heap.empty()) {
    const model::Event e = heap.top();
    heap.pop();
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
  }""", """  std::sort(all.begin(), all.end(), EventOrder{});
  for (const model::Event& e : all)
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);"""))
    for old, new in edits:
        assert old in solution_step, f"the kit's step.cpp changed shape (no {old[:40]!r})"
        solution_step = solution_step.replace(old, new)
    return "#include <algorithm>\n#include <vector>\n" + solution_step


def honest_heaps(solution):
    """{name: heap.hpp text}: the kit's solved heap.hpp written other honest ways that the probe
    must pass: each comparison asked the other way round (`less(parent, item)` to stop a climb,
    the left child against the right)."""
    other_way = (solution
                 .replace("if (!less_(items_[k], items_[parent])) break;",
                          "if (less_(items_[parent], items_[k])) break;")
                 .replace("less_(items_[right], items_[left]) ? right : left",
                          "!less_(items_[left], items_[right]) ? right : left")
                 .replace("if (!less_(items_[child], items_[k])) break;",
                          "if (less_(items_[k], items_[child])) break;"))
    assert other_way.count("less_(") == solution.count("less_("), "the solved heap changed shape"
    return {"each comparison the other way round": other_way}
