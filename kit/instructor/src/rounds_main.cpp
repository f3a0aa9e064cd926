/// \file rounds_main.cpp
/// \brief `plab-rounds SCENE`: the mutual-earliest rounds that each step of a scene needs
/// (plan_in_rounds(), oracle.hpp), as JSON on stdout: `{"n": N, "steps": S, "rounds": [r0, ...],
/// "total": R, "comparisons": C, "later_sum": "HEX"}`: C the rounds' comparisons of two events in
/// the step, HEX the sum of their later events (plab::EventOrder), which a stage 03 whose rounds
/// compare with EventOrder makes alike. The grader's idea test of stage 03 reads it (instructor
/// only: it steps the scene).
#include <cstdio>
#include <numeric>
#include <exception>
#include <nlohmann/json.hpp>
#include <vector>

#include "plab/event_order.hpp"
#include "plab/io.hpp"
#include "plab/oracle.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: plab-rounds SCENE\n");
    return 2;
  }
  try {
    plab::Scene scene = plab::load_scene(argv[1], 0);
    plab::Particles& p = scene.particles;
    std::vector<int> rounds;
    long long total = 0;
    for (long long k = 0; k < scene.steps; ++k) {
      int r = 0;
      const plab::Plan plan = plab::plan_in_rounds(scene.box, p, r);
      rounds.push_back(r);
      total += r;
      for (int i = 0; i < static_cast<int>(p.size()); ++i) plab::apply_one(scene.box, p, plan, i);
    }
    const std::vector<long long> made = plab::EventOrder::in_step_by_thread();
    const nlohmann::json j = {{"n", p.size()},
                              {"steps", scene.steps},
                              {"rounds", rounds},
                              {"total", total},
                              {"comparisons", std::accumulate(made.begin(), made.end(), 0LL)},
                              {"later_sum", plab::EventOrder::hex(plab::EventOrder::later_sum())}};
    std::printf("%s\n", j.dump().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "plab-rounds: %s\n", e.what());
    return 2;
  }
  return 0;
}
