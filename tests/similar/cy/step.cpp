/* stage 03, cy's version: all in step(), lambdas, static schedule everywhere */
#include <omp.h>

#include <algorithm>
#include <vector>

#include "plab/candidates.hpp"
#include "plab/stage.hpp"

namespace plab {

void step(const Box& box, Particles& p) {
  const int N = static_cast<int>(p.size());
  std::vector<double> tw(N);
  int T = omp_get_max_threads();
  std::vector<std::vector<FoundPair>> buckets(T);

#pragma omp parallel for schedule(static, 8)
  for (int i = 0; i < N; ++i) {
    tw[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
    std::vector<FoundPair>& mine = buckets[omp_get_thread_num()];
    int j = i + 1;
    while (j < N) {
      double t = model::pair_time(p.x[i], p.y[i], p.vx[i], p.vy[i], p.x[j], p.y[j], p.vx[j],
                                  p.vy[j], box.r);
      if (model::in_step(t)) mine.push_back({t, i, j});
      j++;
    }
  }
  CandidateLists C;
  C.build(N, buckets);

  Plan plan;
  plan.reset(N);
  std::vector<int> state(N, 0);  // 0 open, 1 settled
  std::vector<model::Event> want(N);
  auto earliest = [&](int i) {
    model::Event best{};
    bool have = false;
    if (model::in_step(tw[i])) { best = model::wall_event_key(tw[i], i); have = true; }
    for (int k = C.start[i]; k != C.start[i + 1]; k++) {
      int o = C.other[k];
      if (state[o]) continue;
      model::Event e = model::pair_event_key(C.time[k], std::min(i, o), std::max(i, o));
      if (!have || model::key_less(e, best)) { best = e; have = true; }
    }
    if (!have) best = model::pair_event_key(model::never(), N, N);
    return best;
  };
  bool again = true;
  while (again) {
#pragma omp parallel for schedule(static)
    for (int i = 0; i < N; ++i)
      if (!state[i]) want[i] = earliest(i);
    again = false;
#pragma omp parallel for schedule(static) reduction(|| : again)
    for (int i = 0; i < N; ++i) {
      if (state[i]) continue;
      model::Event w = want[i];
      if (!model::in_step(w.t)) { state[i] = 1; continue; }
      if (w.kind == model::kWall) { plan.accept_for(i, w); state[i] = 1; continue; }
      int o = w.lo == i ? w.hi : w.lo;
      if (want[o].kind == model::kPair && want[o].lo == w.lo && want[o].hi == w.hi) {
        plan.accept_for(i, w);
        state[i] = 1;
      } else {
        again = true;
      }
    }
  }
#pragma omp parallel for schedule(static)
  for (int i = 0; i < N; ++i) apply_one(box, p, plan, i);
}

std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
