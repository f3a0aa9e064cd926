/// \file cli/stress.cpp
/// \brief `plab stress`: hostile scenes, invariants, pair-time ulps.
#include "common.hpp"

namespace plab::cli {

void add_stress(CLI::App& app) {
  struct Args {
    std::vector<std::string> stages, only;
    std::string impl, csv, ulps_csv, plot;
    long long long_steps = 100000;
    long long pairs = 200000;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "stress", "Numerical stress suite: hostile scenes (corner hits, grazing, speeds 1e9 and "
                "1e-9, tiny and huge radii, disks resting on walls, equal velocities, coincident "
                "centres, overlapping starts, a line of touching disks, near jamming, a long run) on "
                "every stage, invariants checked at every step, all stages bit-identical; then the "
                "pair-time formula's error in ulps. Exits 1 on any violation.");
  c->add_option("--stages", a->stages, "stages (default: every stepped stage built; a CUDA stage "
                                       "is skipped without a GPU)")->delimiter(',');
  c->add_option("--impl", a->impl, "solution, student or engine (default as for run)");
  c->add_option("--only", a->only, "only these scenes")->delimiter(',');
  c->add_option("--long-steps", a->long_steps, "steps of the long run")->capture_default_str();
  c->add_option("--pairs", a->pairs, "pairs of each kind for the pair-time check")
      ->capture_default_str();
  c->add_option("--csv", a->csv, "write the scene table as CSV here");
  c->add_option("--ulps-csv", a->ulps_csv, "write the pair-time error histograms as CSV here");
  c->add_option("--plot", a->plot, "draw the pair-time error distribution here (PNG or SVG)");
  c->callback([a] {
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    const Manifest m = load_manifest(source_dir() + "/datasets");
    std::vector<std::string> ids = a->stages;
    if (ids.empty())
      for (const StageDir& s : stages(impl))
        if (s.id != m.exact_stage && fs::exists(stage_program(s.id, impl))) ids.push_back(s.id);
    std::vector<std::string> args{"python3", "-m", "plab.stress",
                                  "--plab", bin_dir() + "/plab",
                                  "--ulps-program", bin_dir() + "/plab-pairtime-ulps",
                                  "--work", build_dir() + "/stress",
                                  "--long-steps", std::to_string(a->long_steps),
                                  "--pairs", std::to_string(a->pairs),
                                  "--figures", source_dir() + "/handouts/figures"};
    for (const auto& id : ids) {
      const std::string sid = two_digits(id);
      if (sid == m.exact_stage)
        throw std::runtime_error("stage " + sid + " is the exact event-driven stage: its tests "
                                 "check it (./plab test --stage " + sid + "), not the stepped "
                                 "model's invariants");
      args.insert(args.end(), {"--stage", sid + "=" + require_stage(sid, impl)});
    }
    if (!a->only.empty()) {
      std::string only;
      for (const auto& o : a->only) only += (only.empty() ? "" : ",") + o;
      args.insert(args.end(), {"--only", only});
    }
    if (!a->csv.empty()) args.insert(args.end(), {"--csv", a->csv});
    if (!a->ulps_csv.empty()) args.insert(args.end(), {"--ulps-csv", a->ulps_csv});
    if (!a->plot.empty()) args.insert(args.end(), {"--plot", a->plot});
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
