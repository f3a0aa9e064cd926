/// \file pairtime_ulps.cpp
/// \brief `plab stress`'s check of the pair-time formula itself: the error, in ulps, of model.md's
/// pair time and of the robust contact time (both in double) against the robust form evaluated in
/// long double (11 more bits), over random pairs, pairs near contact, grazing pairs, and pairs
/// near contact with integer inputs (every coefficient exact in double: what is left is the
/// formula's own rounding).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "plab/model.hpp"

namespace {

/// Ulps of `want` (as a double) between the double `got` and the long double `want`.
double ulps(double got, long double want) {
  const double w = static_cast<double>(want);
  const double ulp = std::nextafter(std::fabs(w), HUGE_VAL) - std::fabs(w);
  return static_cast<double>(std::fabs(static_cast<long double>(got) - want) / ulp);
}

/// One pair: i at the origin moving (vx, vy), j at (x, y) at rest (any pair is one of these up
/// to a translation and a change of frame, which the formulas see only through differences).
struct Pair {
  double x, y, vx, vy, r;
};

/// Histogram buckets of the error: 0, (0, 1], (1, 4], (4, 16], ..., then more.
const std::vector<double> kEdges = {0, 1, 4, 16, 64, 256, 4096, 65536, 1e300};

}  // namespace

int main(int argc, char** argv) {
  long long count = 200000;
  std::uint64_t seed = 1;
  std::string csv;
  CLI::App app{"Error in ulps of the pair time: model.md's form and the robust form, in double, "
               "against the robust form in long double"};
  app.add_option("--pairs", count, "pairs of each kind")->capture_default_str();
  app.add_option("--seed", seed, "random seed")->capture_default_str();
  app.add_option("--csv", csv, "write the histograms here (kind,form,bucket,count)");
  CLI11_PARSE(app, argc, argv);

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const double pi = std::acos(-1.0);
  // Pairs that approach and do not overlap yet (both forms give the same root there).
  auto make = [&](const std::string& kind) {
    for (;;) {
      if (kind == "exact-inputs") {  // integers: a, b, c and b^2 - ac are exact in double
        const double r = std::floor(100 + 900 * u(rng));
        const double x = -(2 * r + std::floor(1 + 10 * u(rng))), y = std::floor(-3 + 7 * u(rng));
        const double vx = std::floor(1 + 30 * u(rng)), vy = std::floor(-30 + 61 * u(rng));
        const Pair p{x, y, -vx, vy, r};
        const double b = -p.x * p.vx + -p.y * p.vy;
        if (b < 0 && b * b - (p.vx * p.vx + p.vy * p.vy) * ((p.x * p.x + p.y * p.y) - 4 * r * r) > 0)
          return p;
        continue;
      }
      const double r = 1;
      const double a = 2 * pi * u(rng), speed = std::pow(10.0, -3 + 6 * u(rng));
      double dist, offset;
      if (kind == "random") {
        dist = 2 * r + 100 * u(rng);
        offset = (2 * u(rng) - 1) * 2 * r;  // impact parameter within 2r: they will meet
      } else if (kind == "near-contact") {
        dist = 2 * r * (1 + std::pow(10.0, -14 + 12 * u(rng)));  // 1e-14 .. 1e-2 apart
        offset = (2 * u(rng) - 1) * 2 * r;
      } else {  // grazing: the impact parameter just under 2r
        dist = 2 * r + 100 * u(rng);
        offset = 2 * r * (1 - std::pow(10.0, -14 + 12 * u(rng)));
      }
      // j sits at distance `dist` along direction a, shifted sideways by the offset; i moves
      // towards a.
      const double along = std::sqrt(std::max(0.0, dist * dist - offset * offset));
      const Pair p{along * std::cos(a) - offset * std::sin(a), along * std::sin(a) + offset * std::cos(a),
                   speed * std::cos(a), speed * std::sin(a), r};
      const double dx = -p.x, dy = -p.y;
      if ((dx * dx + dy * dy) - (2 * r) * (2 * r) > 0 && dx * p.vx + dy * p.vy < 0) return p;
    }
  };

  std::FILE* out = csv.empty() ? nullptr : std::fopen(csv.c_str(), "w");
  if (!csv.empty() && !out) {
    std::fprintf(stderr, "error: cannot write %s\n", csv.c_str());
    return 2;
  }
  if (out) std::fprintf(out, "kind,form,bucket,count\n");
  std::printf("%-13s %-10s %9s %9s %9s %11s %9s\n", "pairs", "form", "median", "99%", "max",
              "no event", "> 16 ulps");
  for (const std::string kind : {"random", "near-contact", "grazing", "exact-inputs"}) {
    std::vector<double> model_err, robust_err;
    long long model_missed = 0, robust_missed = 0;
    for (long long n = 0; n < count; ++n) {
      const Pair p = make(kind);
      const long double want = plab::model::contact_time<long double>(
          -p.x, -p.y, p.vx, p.vy, static_cast<long double>(p.r));
      if (!std::isfinite(static_cast<double>(want))) continue;
      // model.md's form, i at the origin (lower index), j at (x, y) at rest.
      const double t_model = plab::model::pair_time(0.0, 0.0, p.vx, p.vy, p.x, p.y, 0.0, 0.0, p.r);
      const double t_robust = plab::model::contact_time(-p.x, -p.y, p.vx, p.vy, p.r);
      if (std::isfinite(t_model)) model_err.push_back(ulps(t_model, want)); else ++model_missed;
      if (std::isfinite(t_robust)) robust_err.push_back(ulps(t_robust, want)); else ++robust_missed;
    }
    for (auto [form, err, missed] : {std::tuple{"MODEL.md", &model_err, model_missed},
                                     std::tuple{"robust", &robust_err, robust_missed}}) {
      std::sort(err->begin(), err->end());
      // A plain variable: clang before 16 cannot capture a structured binding in a lambda.
      const std::vector<double>& sorted = *err;
      const auto at = [&](double q) { return sorted.empty() ? 0.0 : sorted[static_cast<std::size_t>(q * (sorted.size() - 1))]; };
      const long long over = std::count_if(err->begin(), err->end(), [](double e) { return e > 16; });
      std::printf("%-13s %-10s %9.3g %9.3g %9.3g %11lld %9lld\n", kind.c_str(), form, at(0.5),
                  at(0.99), err->empty() ? 0.0 : err->back(), missed, over);
      if (out) {
        for (std::size_t b = 0; b < kEdges.size(); ++b) {
          const double lo = b == 0 ? -1 : kEdges[b - 1];
          const long long in = std::count_if(err->begin(), err->end(), [&](double e) {
            return e > lo && e <= kEdges[b];
          });
          std::fprintf(out, "%s,%s,%g,%lld\n", kind.c_str(), form, kEdges[b], in);
        }
        std::fprintf(out, "%s,%s,missed,%lld\n", kind.c_str(), form, missed);
      }
    }
  }
  if (out) std::fclose(out);
  return 0;
}
