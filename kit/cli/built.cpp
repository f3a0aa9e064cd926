/// \file cli/built.cpp
/// \brief `plab built`: is a stage built from its current code?.
#include "common.hpp"

namespace plab::cli {

void add_built(CLI::App& app) {
  auto id = std::make_shared<std::string>();
  auto impl = std::make_shared<std::string>();
  auto targets = std::make_shared<std::vector<std::string>>();
  auto* c = app.add_subcommand("built", "Check that a stage's programs are built from its current "
                                        "code; otherwise exit 1 saying that it did not compile, "
                                        "with the compiler's first error (every stage test needs "
                                        "this check: a stage is never tested with an old binary).");
  c->add_option("--stage", *id, "stage number, e.g. 01")->required();
  c->add_option("--impl", *impl, "solution, student or engine (default as for run)");
  c->add_option("--target", *targets, "also these build targets (e.g. the stage's test program)");
  c->callback([id, impl, targets] {
    const std::string which = impl->empty() ? default_impl() : *impl;
    check_impl(which);
    const std::string problem = stage_build_problem(two_digits(*id), which, *targets);
    if (problem.empty()) {
      std::printf("stage %s (%s) is built from its current code\n", two_digits(*id).c_str(),
                  which.c_str());
      return;
    }
    std::printf("%s\n", problem.c_str());
    g_status = 1;
  });
}

}  // namespace plab::cli
