/// \file oracle.cpp
/// \brief The kit's greedy oracle (oracle.hpp): model.md's step the plainest way, and the events it
/// picks described. Its own library, plab::oracle: linked into the kit's programs, never into a
/// graded build of a submission (the grader's sandbox gets the kit without this file).
#include "plab/oracle.hpp"

#include <cstdio>
#include <sstream>

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
