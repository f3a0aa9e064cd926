// My OpenMP stage (dee). Three phases written as separate functions.
#include <omp.h>

#include <vector>

#include "plab/candidates.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

struct Pick {
  model::Event what;
};

// Accept the choices that agree, count the particles left
int settle(const std::vector<Pick>& chosen, std::vector<char>& fixed, Plan& out, int n) {
  int left = 0;
#pragma omp parallel for reduction(+ : left)
  for (int q = 0; q < n; ++q) {
    if (fixed[q]) continue;
    const model::Event& ev = chosen[q].what;
    bool good = !model::in_step(ev.t) || ev.kind == model::kWall;
    if (!good) {
      const model::Event& other = chosen[ev.lo == q ? ev.hi : ev.lo].what;
      good = other.kind == model::kPair && other.lo == ev.lo && other.hi == ev.hi;
    }
    if (good) {
      if (model::in_step(ev.t)) out.accept_for(q, ev);
      fixed[q] = 1;
    } else {
      ++left;
    }
  }
  return left;
}

// Each open particle picks its soonest event
void pick_soonest(const CandidateLists& cl, const std::vector<double>& wt,
                  const std::vector<char>& fixed, std::vector<Pick>& chosen, int n) {
  const model::Event empty = model::pair_event_key(model::never(), n, n);
#pragma omp parallel for
  for (int q = 0; q < n; ++q) {
    if (fixed[q]) continue;
    model::Event best = empty;
    if (model::in_step(wt[q])) best = model::wall_event_key(wt[q], q);
    for (int s = cl.start[q]; s < cl.start[q + 1]; ++s) {
      const int r = cl.other[s];
      if (fixed[r]) continue;
      const model::Event ev = q < r ? model::pair_event_key(cl.time[s], q, r)
                                    : model::pair_event_key(cl.time[s], r, q);
      if (model::key_less(ev, best)) best = ev;
    }
    chosen[q].what = best;
  }
}

// Find all the candidate pairs in parallel
CandidateLists find_all(const Box& bx, const Particles& ps, std::vector<double>& wt) {
  const int n = static_cast<int>(ps.size());
  std::vector<std::vector<FoundPair>> lists(omp_get_max_threads());
#pragma omp parallel
  {
    auto& mine = lists[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 16)
    for (int q = 0; q < n; ++q) {
      wt[q] = model::wall_time(ps.x[q], ps.y[q], ps.vx[q], ps.vy[q], bx.L, bx.r);
      for (int r = q + 1; r < n; ++r) {
        const model::Event c = pair_candidate(bx, ps, q, r);
        if (model::in_step(c.t)) mine.push_back(FoundPair{c.t, q, r});
      }
    }
  }
  CandidateLists cl;
  cl.build(n, lists);
  return cl;
}

}  // namespace

void step(const Box& bx, Particles& ps) {
  const int n = static_cast<int>(ps.size());
  std::vector<double> wt(n);
  const CandidateLists cl = find_all(bx, ps, wt);
  Plan out;
  out.reset(n);
  std::vector<char> fixed(n, 0);
  std::vector<Pick> chosen(n);
  do {
    pick_soonest(cl, wt, fixed, chosen, n);
  } while (settle(chosen, fixed, out, n) != 0);
#pragma omp parallel for
  for (int q = 0; q < n; ++q) apply_one(bx, ps, out, q);
}

std::unique_ptr<Stepper> make_stepper(const Box& bx, Particles& ps, const StageOptions& o) {
  return cpu_stage(bx, ps, o, {step});
}

}  // namespace plab
