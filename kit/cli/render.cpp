/// \file cli/render.cpp
/// \brief `plab render`: animate a run, or two outputs side by side. The options are
/// kit/python/plab/render.py's own: this command hands them over untouched (`plab render --help`
/// prints them); the script runs the stage it finds with `plab built --json`.
#include "common.hpp"

namespace plab::cli {

void add_render(CLI::App& app) {
  auto* c = app.add_subcommand(
      "render", "Animate a run: the box, the disks at their true radius, one frame per step, "
                "collisions marked (orange: wall, red: pair). With --diff, two outputs side by "
                "side and their first difference ringed. `plab render SCENE [--stage NN]`; --help "
                "for more.");
  c->prefix_command();  // everything after `render` goes to the script as it was typed
  c->set_help_flag();
  c->callback([c] {
    std::vector<std::string> args{"python3", "-m", "plab.render", "--plab", bin_dir() + "/plab"};
    for (const std::string& s : c->remaining()) args.push_back(s);
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
