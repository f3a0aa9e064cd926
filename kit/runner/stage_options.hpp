/// \file runner/stage_options.hpp
/// \brief The stage's own options (stage.hpp's StageOptions) on a command line: the runner's
/// (options.cpp, which reads them) and `plab run`'s (cli/run.cpp, which passes them on), so
/// that both say the same.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace plab::runner {

/// Adds --device, --simd, --off and --sweep-alpha to `app` (an option group too), bound to the
/// given values: `device` auto, cpu or gpu; `simd` portable or avx2; `off` A,B; `sweep_alpha`
/// stage 06's slabs per sqrt(N) v / L.
inline void add_stage_options(CLI::App& app, std::string& device, std::string& simd,
                              std::string& off, double& sweep_alpha) {
  app.add_option("--device", device,
                 "auto: the GPU path when a GPU can be used (stages 04-06); cpu or gpu to choose "
                 "(default: PLAB_DEVICE, else auto)")
      ->check(CLI::IsMember({"auto", "cpu", "gpu"}));
  app.add_option("--simd", simd,
                 "narrower vectors than the widest the CPU has (portable, avx2; stages that "
                 "declare them: 06)");
  app.add_option("--off", off,
                 "turn these changes off to measure what each buys (stages that declare "
                 "switches: 05's graph, streams, branchless)")
      ->type_name("A,B");
  app.add_option("--sweep-alpha", sweep_alpha,
                 "stage 06's grid (the engine's CPU path too): slabs per sqrt(N) v/L (0: the "
                 "measured best)");
}

}  // namespace plab::runner
