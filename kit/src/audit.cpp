/// \file audit.cpp
/// \brief The checks of `--audit` (see audit.hpp).
#include "plab/audit.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>


namespace plab {
namespace {

/// How many doubles lie between `a` and `b` (0 when equal).
double ulps_between(double a, double b) {
  if (a == b) return 0;
  const double ulp = std::nextafter(std::max(std::fabs(a), std::fabs(b)), HUGE_VAL) -
                     std::max(std::fabs(a), std::fabs(b));
  return std::fabs(a - b) / ulp;
}

double energy_of(const Particles& p, std::size_t i) {
  return 0.5 * (p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i]);
}

/// Disks overlapping another, and the deepest overlap, by a grid of cells 2r wide (O(N)).
void overlaps(const Box& box, const Particles& p, long long& count, double& deepest) {
  const int n = static_cast<int>(p.size());
  // Cells at least 2r wide (so that overlapping disks are in neighbouring cells), and no more
  // than about 4N of them.
  const double most = 2 * std::sqrt(static_cast<double>(n)) + 1;
  const int cells = static_cast<int>(std::clamp(std::floor(box.L / (2 * box.r)), 1.0, most));
  const double side = box.L / cells;
  auto cell = [&](double v) {
    return std::isfinite(v) ? std::clamp(static_cast<int>(v / side), 0, cells - 1) : 0;
  };
  std::vector<int> head(static_cast<std::size_t>(cells) * cells, -1), next(n);
  for (int i = 0; i < n; ++i) {
    int& h = head[static_cast<std::size_t>(cell(p.y[i])) * cells + cell(p.x[i])];
    next[i] = h;
    h = i;
  }
  std::vector<char> over(n, 0);
  deepest = 0;
  for (int i = 0; i < n; ++i) {
    const int cx = cell(p.x[i]), cy = cell(p.y[i]);
    for (int gy = std::max(0, cy - 1); gy <= std::min(cells - 1, cy + 1); ++gy)
      for (int gx = std::max(0, cx - 1); gx <= std::min(cells - 1, cx + 1); ++gx)
        for (int j = head[static_cast<std::size_t>(gy) * cells + gx]; j >= 0; j = next[j]) {
          if (j <= i) continue;
          const double d = 2 * box.r - std::hypot(p.x[i] - p.x[j], p.y[i] - p.y[j]);
          if (d > 0) {
            over[i] = over[j] = 1;
            deepest = std::max(deepest, d / box.r);
          }
        }
  }
  count = std::count(over.begin(), over.end(), 1);
}

}  // namespace

long double kinetic_energy(const Particles& p) {
  long double e = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    e += 0.5L * (static_cast<long double>(p.vx[i]) * p.vx[i] +
                 static_cast<long double>(p.vy[i]) * p.vy[i]);
  return e;
}

void Audit::state(const Box& box, const Particles& p, long long step_no) {
  long long bad = 0;
  double outside = 0;  // in ulps of L: the rounding of x + t v near L is about that
  const double ulp_of_l = std::nextafter(box.L, HUGE_VAL) - box.L;
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (const double v : {p.x[i], p.y[i], p.vx[i], p.vy[i]}) bad += std::isfinite(v) ? 0 : 1;
    for (const double c : {p.x[i], p.y[i]}) {
      const double lo = box.r, hi = box.L - box.r;
      if (c < lo) outside = std::max(outside, (lo - c) / ulp_of_l);
      if (c > hi) outside = std::max(outside, (c - hi) / ulp_of_l);
    }
  }
  long long over = 0;
  double deep = 0;
  overlaps(box, p, over, deep);
  const double e = static_cast<double>(kinetic_energy(p));
  if (states == 0) energy0 = e;
  const double drift = energy0 > 0 ? std::fabs(e - energy0) / energy0 : std::fabs(e - energy0);
  nonfinite += bad;
  outside_ulps = std::max(outside_ulps, outside);
  overlapping = std::max(overlapping, over);
  deepest_overlap = std::max(deepest_overlap, deep);
  energy_drift = std::max(energy_drift, drift);
  ++states;
  if (log) {
    long long pc = 0, wc = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      pc += p.pc[i];
      wc += p.wc[i];
    }
    const nlohmann::json j = {{"step", step_no},      {"nonfinite", bad},
                              {"outside_ulps", outside}, {"overlapping", over},
                              {"deepest_overlap", deep}, {"energy", e},
                              {"pair_collisions", pc / 2}, {"wall_collisions", wc}};
    std::fprintf(log, "%s\n", j.dump().c_str());
  }
}

void Audit::step(const Box& box, const Particles& before, const Particles& after, bool with_oracle) {
  ++steps;
  long long pair_growth = 0;
  for (std::size_t i = 0; i < after.size(); ++i) {
    const long long dp = after.pc[i] - before.pc[i], dw = after.wc[i] - before.wc[i];
    if (dp < 0 || dw < 0 || dp + dw > 1) ++counter_errors;
    pair_growth += dp;
  }
  if (pair_growth % 2 != 0) ++counter_errors;
  if (!with_oracle || oracle == nullptr) return;
  const Plan plan = oracle(box, before);
  for (std::size_t i = 0; i < after.size(); ++i) {
    const int j = plan.partner[i];
    if (j == Plan::kFree) continue;
    if (j == Plan::kWall) {  // a reflection keeps |v| exactly
      collision_ulps = std::max(collision_ulps, ulps_between(energy_of(before, i), energy_of(after, i)));
      ++collisions_checked;
    } else if (static_cast<int>(i) < j) {
      const double e0 = energy_of(before, i) + energy_of(before, j);
      const double e1 = energy_of(after, i) + energy_of(after, j);
      collision_ulps = std::max(collision_ulps, ulps_between(e0, e1));
      ++collisions_checked;
    }
  }
}

std::string Audit::json() const {
  const nlohmann::json j = {{"states", states},
                            {"steps", steps},
                            {"nonfinite", nonfinite},
                            {"outside_ulps", outside_ulps},
                            {"overlapping", overlapping},
                            {"deepest_overlap", deepest_overlap},
                            {"energy0", energy0},
                            {"energy_drift", energy_drift},
                            {"collision_ulps", collision_ulps},
                            {"collisions_checked", collisions_checked},
                            {"counter_errors", counter_errors}};
  return j.dump(2) + "\n";
}

}  // namespace plab
