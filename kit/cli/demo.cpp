/// \file cli/demo.cpp
/// \brief `plab demo`: the reference on the course and demo scenes.
#include "common.hpp"

namespace plab::cli {

void add_demo(CLI::App& app) {
  auto* c = app.add_subcommand("demo", "Run the reference solutions (in a student's copy, the "
                                       "compiled reference) on the course scenes and a random "
                                       "1000-particle scene, check them against the golden files, "
                                       "and print the timings.");
  c->callback([] {
    const Manifest m = load_manifest(source_dir() + "/datasets");
    std::printf("%-16s %6s %5s  %-6s %10s  %s\n", "scene", "N", "S", "stage", "time (s)",
                "golden");
    // What runs: every built solution stage; in a student's copy (no solutions/), the compiled
    // reference that `plab release` ships (kit/reference/bin/plab-reference).
    struct Runner {
      std::string id, program;
    };
    std::vector<Runner> runners;
    for (const StageDir& s : stages("solution")) {
      const std::string program = stage_program(s.id, "solution");
      if (fs::exists(program)) runners.push_back({s.id, program});
    }
    const std::string reference = source_dir() + "/kit/reference/bin/plab-reference";
    if (runners.empty() && fs::exists(reference)) runners.push_back({"ref", reference});
    int failures = 0;
    int runs = 0;  // runs that checked something (a CUDA stage without a GPU does not count)
    std::vector<std::string> no_device;  // CUDA stages that found no GPU: not run again
    for (const Dataset& d : m.datasets) {
      if (d.origin != "course" && d.name != "random-1000") continue;
      const Scene scene = parse_scene(read_file(m.scene_path(d)), m.scene_path(d));
      for (const Runner& s : runners) {
        if (s.id == "01" && d.size != "small") continue;  // O(N^3): the demo keeps it to small scenes
        const std::string& program = s.program;
        if (std::find(no_device.begin(), no_device.end(), s.id) != no_device.end()) continue;
        const std::string out = temp_path(d.name + ".demo");
        const auto t0 = std::chrono::steady_clock::now();
        const int rc = run_program({program, m.scene_path(d), "--quiet", "--out", out});
        const double t = wall_seconds(t0);
        std::string verdict = "FAILED (exit " + std::to_string(rc) + ")";
        if (rc == 0) {
          const bool exact = s.id == m.exact_stage;  // stage 07: its own golden files
          const auto diff = first_difference(
              read_file(exact ? m.exact_golden_path(d) : m.golden_path(d)), read_file(out));
          verdict = diff ? "DIFFERS: " + diff->describe()
                         : (exact ? "identical (to golden/exact: the exact model)" : "identical");
          fs::remove(out);
        } else if (rc == 4) {  // a CUDA stage on a machine without a GPU (it said so above)
          verdict = "skipped here and below: no CUDA device";
          no_device.push_back(s.id);
        }
        failures += (verdict.rfind("identical", 0) == 0 || rc == 4) ? 0 : 1;
        runs += rc == 4 ? 0 : 1;
        std::printf("%-16s %6lld %5lld  %-6s %10.3f  %s\n", d.name.c_str(), d.particles,
                    scene.steps, s.id.c_str(), t, verdict.c_str());
        std::fflush(stdout);
      }
    }
    if (runs == 0) {
      std::printf("nothing to run: no solution stage and no compiled reference is built and usable "
                  "here (see ./plab test)\n");
      g_status = 1;
      return;
    }
    std::printf(failures ? "%d runs differ from the golden files\n"
                         : "every run is identical to its golden file\n",
                failures);
    g_status = failures ? 1 : 0;
  });
}

}  // namespace plab::cli
