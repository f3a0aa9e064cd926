/// \file queue_probe.cpp
/// \brief Stage 07's event queue (exercise 1), driven alone: `plab-queue-probe-07-IMPL`.
///
/// The stage's own step.cpp is compiled into this program (its EventQueue is the one the step
/// uses), and the probe changes one particle's predicted time at a time, as the step does: later
/// (a particle that just had its event and was predicted again), earlier, to "never", to a time
/// another particle already has. After every change it asks top() for the earliest event and
/// compares it with the earliest of the times it set, by the queue's own order (the earlier time
/// first; at the same time, the lower particle), and reads the queue's own arrays: heap_ in heap
/// order, each particle in it once with its prediction's time, at_ saying where. The first wrong
/// answer or array is described, with the change that preceded it. Queues of 1 to 1000
/// particles, 20 000 changes each; the library's bounds checks are on, so an index past the heap's
/// end stops the probe with the change it happened in.
///
/// Exit 0: every answer was the earliest; 1: one was not (or the queue stopped: exercise 1 not
/// written, a bounds check, a set() that never returned); the message says which.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

// The queue's own arrays are read too (its heap order, at_ in step): the stage's code is compiled
// with its private members public, after every standard header it uses is in.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#define private public
#include PLAB_STEP_SOURCE
#undef private

namespace {

/// The change being made, for the message of a check that stops the program inside it.
char doing[256] = "";

/// A bounds check (SIGABRT) or a set() that never returns (SIGALRM): says in which change.
void stopped(int sig) {
  const char* what = sig == SIGALRM ? "set() did not return within 20 seconds (a sift loop that "
                                      "never ends?)"
                                    : "the program stopped (a bounds check: an index past the "
                                      "heap's end, a child 2k + 1 or 2k + 2 not compared with the "
                                      "heap's size?)";
  const std::string text = std::string("FAILED: ") + what + " during " + doing + "\n";
  [[maybe_unused]] const auto n = write(STDOUT_FILENO, text.data(), text.size());
  _exit(1);
}

/// Whether particle a's prediction (time ta) comes before b's: the queue's order.
bool first(double ta, int a, double tb, int b) { return ta < tb || (ta == tb && a < b); }

/// "t = 0.25", or "t = never".
std::string time_text(double t) {
  if (t == plab::model::never()) return "t = never";
  char s[64];
  std::snprintf(s, sizeof s, "t = %.17g", t);
  return s;
}

/// What is wrong with the queue's arrays (heap_ in heap order, each particle in it once, at_
/// saying where), or empty.
std::string arrays_broken(const plab::EventQueue& q, int n) {
  char text[512];
  if (static_cast<int>(q.heap_.size()) != n || static_cast<int>(q.at_.size()) != n) {
    std::snprintf(text, sizeof text, "heap_ holds %zu entries and at_ %zu, not one for each of "
                  "the %d particles (an indexed heap stays N long)", q.heap_.size(),
                  q.at_.size(), n);
    return text;
  }
  for (int k = 0; k < n; ++k) {
    const int i = q.heap_[k].i;
    if (i < 0 || i >= n || q.at_[i] != k) {
      std::snprintf(text, sizeof text, "heap_[%d] holds particle %d, but at_[%d] = %d: move "
                    "entries with put(), which keeps at_ in step", k, i, i < 0 || i >= n ? 0 : i,
                    i < 0 || i >= n ? -1 : q.at_[i]);
      return text;
    }
    if (q.heap_[k].t != q.events_[i].t) {
      std::snprintf(text, sizeof text, "heap_[%d] holds particle %d at %s, but its prediction is "
                    "at %s: store the new time in its entry", k, i, time_text(q.heap_[k].t).c_str(),
                    time_text(q.events_[i].t).c_str());
      return text;
    }
    const int parent = (k - 1) / 2;
    if (k > 0 && plab::EventQueue::earlier(q.heap_[k], q.heap_[parent])) {
      std::snprintf(text, sizeof text, "heap_[%d] (particle %d, %s) comes before its parent "
                    "heap_[%d] (particle %d, %s): the heap order is lost (every entry after its "
                    "parent heap_[(k - 1) / 2]; a changed entry moves up while it comes before "
                    "its parent, down while a child comes before it, to the earlier child)",
                    k, i, time_text(q.heap_[k].t).c_str(), parent, q.heap_[parent].i,
                    time_text(q.heap_[parent].t).c_str());
      return text;
    }
  }
  return "";
}

/// Drives a queue of n particles through `changes` changes; empty, or what went wrong.
std::string drive(int n, int changes, std::mt19937_64& rng) {
  plab::EventQueue queue(n);
  std::vector<double> time(n, plab::model::never());
  std::uniform_int_distribution<int> who(0, n - 1), how(0, 9);
  std::uniform_real_distribution<double> when(0.0, 100.0);
  double now = 0;
  for (int k = 1; k <= changes; ++k) {
    const int i = who(rng);
    double t = 0;
    switch (how(rng)) {
      case 0: t = plab::model::never(); break;                 // no event predicted
      case 1: t = time[who(rng)]; break;                       // a time another already has
      case 2: t = now; break;                                  // the time of the last event
      case 3: t = time[i] == plab::model::never() ? now : time[i] + 0.5; break;  // later
      default: t = now + when(rng); break;
    }
    const double old = time[i];
    std::snprintf(doing, sizeof doing, "change %d of a queue of %d particles: set(particle %d, %s; "
                  "it was %s)", k, n, i, time_text(t).c_str(), time_text(old).c_str());
    alarm(20);
    queue.set(plab::Event{t, plab::kCross, i, -1, 0, 0});
    alarm(0);
    time[i] = t;
    const std::string move = t == old ? "the same time again"
                             : first(t, i, old, i)
                                 ? "an earlier time: its entry must move up, towards the root"
                                 : "a later time: its entry must move down, each time to the "
                                   "earlier of its two children";
    int best = 0;
    for (int q = 1; q < n; ++q)
      if (first(time[q], q, time[best], best)) best = q;
    if (const std::string broken = arrays_broken(queue, n); !broken.empty()) {
      char text[1024];
      std::snprintf(text, sizeof text, "after %s (%s): %s", doing, move.c_str(), broken.c_str());
      return text;
    }
    const plab::Event& top = queue.top();
    if (top.i != best || top.t != time[best]) {
      const int got = top.i;
      char text[1024];
      std::snprintf(text, sizeof text,
                    "after %s (%s), top() gave particle %d (%s), but particle %d (%s) comes "
                    "first (the earlier time; at the same time, the lower particle). The heap "
                    "order is lost: no entry may come before its parent heap_[(k - 1) / 2], "
                    "and after a change the entry is moved up or down until that holds again, "
                    "each move through put() so that at_ follows.",
                    doing, move.c_str(), got, got >= 0 && got < n ? time_text(time[got]).c_str()
                                                                 : "not a particle of the queue",
                    best, time_text(time[best]).c_str());
      return text;
    }
    if (t != plab::model::never() && t > now && how(rng) < 3) now = t;
  }
  return "";
}

}  // namespace

int main() {
  std::signal(SIGABRT, stopped);
  std::signal(SIGALRM, stopped);
  std::mt19937_64 rng(20191207);
  try {
    for (const int n : {1, 2, 3, 4, 5, 7, 8, 16, 100, 1000}) {
      const std::string wrong = drive(n, 20000, rng);
      if (!wrong.empty()) {
        std::printf("FAILED: the event queue (exercise 1): %s\n", wrong.c_str());
        return 1;
      }
    }
  } catch (const std::exception& e) {
    std::printf("FAILED: the event queue stopped during %s: %s\n", doing, e.what());
    return 1;
  }
  std::printf("the event queue gave the earliest event after each of 20000 changes of one "
              "particle's time, on queues of 1 to 1000 particles (later, earlier, never, ties)\n");
  return 0;
}
