/// \file datasets.cpp
/// \brief Reading the dataset manifest (JSON, with nlohmann-json).
#include "plab/datasets.hpp"

#include <nlohmann/json.hpp>

#include "plab/errors.hpp"
#include "plab/generate.hpp"
#include "plab/io.hpp"

namespace plab {

std::string Manifest::scene_path(const Dataset& d) const { return root + "/scenes/" + d.name + ".in"; }
std::string Manifest::golden_path(const Dataset& d) const { return root + "/golden/" + d.name + ".out"; }
std::string Manifest::digest_path(const Dataset& d) const {
  return root + "/golden/" + d.name + ".digest";
}

std::string Manifest::exact_golden_path(const Dataset& d) const {
  return root + "/golden/exact/" + d.name + ".out";
}

Manifest load_manifest(const std::string& root) {
  const std::string path = root + "/manifest.json";
  Manifest m;
  m.root = root;
  try {
    const auto j = nlohmann::json::parse(read_file(path));
    m.reference_stage = j.at("reference_stage").get<std::string>();
    m.exact_stage = j.value("exact_stage", std::string());
    for (const auto& e : j.at("scenes")) {
      Dataset d;
      d.name = e.at("name").get<std::string>();
      d.origin = e.at("origin").get<std::string>();
      d.tests = e.at("tests").get<std::string>();
      d.size = e.at("size").get<std::string>();
      if (d.size != "small" && d.size != "medium" && d.size != "large")
        throw InputError(path + ": scene " + d.name + ": size must be small, medium or large");
      if (e.contains("gen")) {
        const auto& g = e.at("gen");
        GenParams p;
        p.n = g.at("n").get<long long>();
        p.L = g.at("L").get<double>();
        p.r = g.at("r").get<double>();
        p.steps = g.at("steps").get<long long>();
        p.mode = g.at("mode").get<std::string>() == "perf" ? Mode::kPerf : Mode::kPrint;
        p.seed = g.at("seed").get<std::uint64_t>();
        d.gen = p;
        d.particles = p.n;
      } else {
        d.particles = static_cast<long long>(
            parse_scene(read_file(m.scene_path(d)), m.scene_path(d)).particles.size());
      }
      m.datasets.push_back(std::move(d));
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": " + e.what());
  }
  return m;
}

Scene generate_scene(const GenParams& g) {
  Scene s;
  s.box = Box{g.L, g.r};
  s.steps = g.steps;
  s.mode = g.mode;
  const SpeedRange speeds =
      g.speed_min < 0 ? default_speeds(s.box) : SpeedRange{g.speed_min, g.speed_max};
  s.particles = generate(s.box, static_cast<std::size_t>(g.n), g.seed, speeds);
  return s;
}

}  // namespace plab
