/// \file cli/render.cpp
/// \brief `plab render`: animate a run, or two outputs side by side. The options are
/// kit/python/plab/render.py's own (`plab render --help` prints them); the script runs the stage
/// it finds with `plab built --json`.
#include "common.hpp"

namespace plab::cli {

void add_render(CLI::App& app) {
  add_python_command(app, "render",
                     "Animate a run: the box, the disks at their true radius, one frame per step, "
                     "collisions marked (orange: wall, red: pair). With --diff, two outputs side by "
                     "side and their first difference ringed. `plab render SCENE [--stage NN]`; "
                     "--help for more.",
                     "plab.render", [] {
                       return std::vector<std::string>{"--plab", bin_dir() + "/plab"};
                     });
}

}  // namespace plab::cli
