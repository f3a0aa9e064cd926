/// \file cli/release.cpp
/// \brief `plab release`: the student version of the kit.
#include "common.hpp"

namespace plab::cli {

void add_release(CLI::App& app) {
  struct Args {
    std::string out, kit;
    bool allow_dirty = false;
    int through = 0;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand("release", "Write the student version of the kit into a new folder, "
                                          "from git's HEAD: no solutions/, no CI, a student "
                                          "README, the reference stage as a compiled program, "
                                          "docs built from the copy itself; every stage checked "
                                          "to be its untouched starting point.");
  c->add_option("--out", a->out, "a new (or empty) folder")->required();
  c->add_flag("--allow-dirty", a->allow_dirty,
              "release HEAD's stages/ even when stages/ has uncommitted changes (they are left "
              "out, and named)");
  c->add_option("--through", a->through,
                 "a weekly release: stages 01..NN only, with their handouts (a later stage's "
                 "given files may hold an earlier stage's answer); default: every stage")
      ->check(CLI::Range(1, 99));
  c->add_option("--kit", a->kit, "the kit checkout to release (default: this one)")
      ->check(CLI::ExistingDirectory);
  c->callback([a] {
    if (default_impl() != "solution")
      throw std::runtime_error("this is already a student copy (it has no solutions/)");
    std::vector<std::string> args{"python3", "-m", "plab.grade.release",
                                  "--kit-source", a->kit.empty() ? source_dir() : a->kit,
                                  "--out", a->out};
    if (a->allow_dirty) args.push_back("--allow-dirty");
    if (a->through > 0) args.insert(args.end(), {"--through", std::to_string(a->through)});
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
