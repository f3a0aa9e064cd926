/// \file oracle.cpp
/// \brief The kit's greedy oracle (oracle.hpp): model.md's step the plainest way, and the events it
/// picks described. Its own library, plab::oracle: linked into the kit's programs, never into a
/// graded build of a submission (the grader's sandbox gets the kit without this file).
#include "plab/oracle.hpp"

#include <cstdio>
#include <sstream>
#include <utility>
#include <vector>

#include "plab/event_order.hpp"
#include "plab/greedy.hpp"
#include "plab/model.hpp"

namespace plab {

Plan plan_step(const Box& box, const Particles& p) {
  const int n = static_cast<int>(p.size());
  std::vector<model::Event> events;
  for (int i = 0; i < n; ++i) {
    const model::Event w = wall_candidate(box, p, i);
    if (model::in_step(w.t)) events.push_back(w);
    for (int j = i + 1; j < n; ++j) {
      const model::Event e = pair_candidate(box, p, i, j);
      if (model::in_step(e.t)) events.push_back(e);
    }
  }
  return greedy_plan(events, p.size());
}

Plan plan_in_rounds(const Box& box, const Particles& p, int& rounds) {
  const int n = static_cast<int>(p.size());
  std::vector<double> wall(n);
  std::vector<std::vector<std::pair<double, int>>> cand(n);  // each particle's pairs (t, other)
  for (int i = 0; i < n; ++i) {
    wall[i] = wall_candidate(box, p, i).t;
    for (int j = i + 1; j < n; ++j) {
      const double t = pair_candidate(box, p, i, j).t;
      if (model::in_step(t)) {
        cand[i].push_back({t, j});
        cand[j].push_back({t, i});
      }
    }
  }
  Plan plan;
  plan.reset(n);
  std::vector<char> resolved(n, 0);
  std::vector<model::Event> best(n);
  const model::Event none = model::pair_event_key(model::never(), n, n);
  const EventOrder earlier;  // counted, as stage 03's rounds are (plab-rounds reads the counts)
  rounds = 0;
  for (bool open = true; open; ++rounds) {
    for (int i = 0; i < n; ++i) {
      if (resolved[i]) continue;
      model::Event b = model::in_step(wall[i]) ? model::wall_event_key(wall[i], i) : none;
      for (const auto& [t, o] : cand[i]) {
        const model::Event e = model::pair_event_key(t, i < o ? i : o, i < o ? o : i);
        if (!resolved[o] && earlier(e, b)) b = e;
      }
      best[i] = b;
    }
    open = false;
    std::vector<int> done;
    for (int i = 0; i < n; ++i) {
      if (resolved[i]) continue;
      const model::Event& e = best[i];
      const int o = (e.lo == i) ? e.hi : e.lo;
      if (!model::in_step(e.t) || e.kind == model::kWall ||
          (best[o].lo == e.lo && best[o].hi == e.hi && best[o].kind == model::kPair)) {
        if (model::in_step(e.t)) plan.accept_for(i, e);
        done.push_back(i);
      } else {
        open = true;
      }
    }
    for (const int i : done) resolved[i] = 1;
  }
  return plan;
}

std::string describe_events(const Box& box, const Particles& p, const std::vector<int>& which) {
  const Plan plan = plan_step(box, p);
  std::ostringstream s;
  char t[64];
  for (const int i : which) {
    if (i < 0 || i >= static_cast<int>(p.size())) continue;
    s << "particle " << i << ": ";
    const int j = plan.partner[i];
    if (j == Plan::kFree) {
      s << "moves freely";
    } else if (j == Plan::kWall) {
      std::snprintf(t, sizeof t, "%.8f", model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r));
      s << "hits a wall at t = " << t;
    } else {
      std::snprintf(t, sizeof t, "%.8f", plan.time[i]);
      s << "pair collision with " << j << " at t = " << t;
    }
    s << "\n";
  }
  return s.str();
}

std::string describe_events_json(const Box& box, const Particles& p,
                                 const std::vector<int>& which) {
  const Plan plan = plan_step(box, p);
  std::ostringstream s;
  char t[64];
  s << "{\"particles\": [";
  const char* sep = "";
  for (const int i : which) {
    if (i < 0 || i >= static_cast<int>(p.size())) continue;
    s << sep << "{\"i\": " << i << ", ";
    sep = ", ";
    const int j = plan.partner[i];
    if (j == Plan::kFree) {
      s << "\"event\": \"free\"}";
      continue;
    }
    // %.17g: the double itself (it reads back bit for bit), never a rounded text
    const double when = j == Plan::kWall
                            ? model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r)
                            : plan.time[i];
    std::snprintf(t, sizeof t, "%.17g", when);
    if (j == Plan::kWall)
      s << "\"event\": \"wall\", \"t\": " << t << "}";
    else
      s << "\"event\": \"pair\", \"partner\": " << j << ", \"t\": " << t << "}";
  }
  s << "]}\n";
  return s.str();
}

}  // namespace plab
