/// \file cli/golden.cpp
/// \brief `plab golden`: regenerate or check the golden files.
#include "common.hpp"

namespace plab::cli {

void add_golden(CLI::App& app) {
  auto check = std::make_shared<bool>(false);
  auto only = std::make_shared<std::vector<std::string>>();
  auto* c = app.add_subcommand("golden", "Regenerate every golden file (and generated scene) from "
                                         "the reference solution, or --check that the committed "
                                         "ones are what it produces now.");
  c->add_flag("--check", *check, "compare instead of writing; exit 1 if anything drifted");
  c->add_option("--only", *only, "only these scenes (names from datasets/manifest.json)");
  c->callback([check, only] {
    const Manifest m = load_manifest(source_dir() + "/datasets");
    const std::string ref = require_stage(m.reference_stage, "solution");
    int drifted = 0;
    int done = 0;
    for (const Dataset& d : m.datasets) {
      if (!only->empty() && std::find(only->begin(), only->end(), d.name) == only->end()) continue;
      const auto t0 = std::chrono::steady_clock::now();
      std::printf("%-28s N=%-6lld ", d.name.c_str(), d.particles);
      std::fflush(stdout);
      std::vector<std::string> problems;
      if (d.gen) {
        const std::string scene = format_scene(generate_scene(*d.gen));
        if (!*check) {
          write_text(m.scene_path(d), scene);
        } else if (!fs::exists(m.scene_path(d)) || read_file(m.scene_path(d)) != scene) {
          problems.push_back("scene file differs from what the generator makes now");
        }
      }
      const std::string out = temp_path(d.name + ".out");
      const std::string dig = temp_path(d.name + ".digest");
      const int rc = run_program({ref, m.scene_path(d), "--quiet", "--out", out, "--digest", dig});
      if (rc != 0) throw std::runtime_error("the reference failed on " + m.scene_path(d));
      std::vector<std::pair<std::string, std::string>> made_golden{{out, m.golden_path(d)},
                                                                   {dig, m.digest_path(d)}};
      if (m.has_exact_golden(d)) {  // the exact event-driven stage's own golden file
        const std::string exact = temp_path(d.name + ".exact");
        if (run_program({require_stage(m.exact_stage, "solution"), m.scene_path(d), "--quiet",
                         "--out", exact}) != 0)
          throw std::runtime_error("stage " + m.exact_stage + " failed on " + m.scene_path(d));
        fs::create_directories(fs::path(m.exact_golden_path(d)).parent_path());
        made_golden.emplace_back(exact, m.exact_golden_path(d));
      }
      for (const auto& [made, golden] : made_golden) {
        if (!*check) {
          fs::rename(made, golden);
          continue;
        }
        const std::string want = fs::exists(golden) ? read_file(golden) : std::string();
        if (const auto diff = first_difference(want, read_file(made)))
          problems.push_back(fs::path(golden).filename().string() + ": " + diff->describe());
        fs::remove(made);
      }
      ++done;
      drifted += problems.empty() ? 0 : 1;
      std::printf("%s (%.1f s)\n", problems.empty() ? (*check ? "ok" : "written") : "DRIFTED",
                  wall_seconds(t0));
      for (const auto& p : problems) std::printf("    %s\n", p.c_str());
    }
    std::printf("%d scenes %s, %d drifted (reference: stage %s solution)\n", done,
                *check ? "checked" : "written", drifted, m.reference_stage.c_str());
    g_status = drifted ? 1 : 0;
  });
}

}  // namespace plab::cli
