/// \file cli/built.cpp
/// \brief `plab built`: is a stage built from its current code, and does its compiled code pass the
/// grader's reading of it (plab.grade.symbols)? With `--json`, the kit's stages,
/// their programs and folders as JSON: how the kit's Python commands (`plab stress`, `plab
/// accuracy`) find the programs they run, with the same checks as every other command.
#include "common.hpp"

namespace plab::cli {

namespace {
/// `{impl, source, build, bin, exact_stage, stages: [{id, name, program, exists, problem,
/// needs_openmp, needs_mpi}]}`: `problem` is "" when the stage is built from its current code,
/// else what `plab run` would say; the needs are what the stage's stage.json declares.
nlohmann::json describe(const std::string& impl, const std::vector<std::string>& only) {
  const Manifest m = load_manifest(source_dir() + "/datasets");
  nlohmann::json j{{"impl", impl},          {"source", source_dir()},
                   {"build", build_dir()},  {"bin", bin_dir()},
                   {"exact_stage", m.exact_stage}, {"stages", nlohmann::json::array()}};
  std::vector<std::string> ids;
  for (const std::string& s : only) ids.push_back(two_digits(s));
  if (ids.empty())
    for (const StageDir& s : stages(impl)) ids.push_back(s.id);
  for (const std::string& id : ids) {
    std::string name, problem;
    for (const StageDir& s : stages(impl))
      if (s.id == id) name = s.name;
    try {
      require_stage(id, impl);
    } catch (const std::exception& e) {
      problem = e.what();
    }
    const std::string program = name.empty() ? "" : stage_program(id, impl);
    j["stages"].push_back({{"id", id},
                           {"name", name},
                           {"program", program},
                           {"exists", !program.empty() && fs::exists(program)},
                           {"problem", problem},
                           {"needs_openmp", stage_declares(id, impl, "needs_openmp") == true},
                           {"needs_mpi", stage_declares(id, impl, "needs_mpi") == true}});
  }
  return j;
}
}  // namespace

void add_built(CLI::App& app) {
  auto ids = std::make_shared<std::vector<std::string>>();
  auto impl = std::make_shared<std::string>();
  auto targets = std::make_shared<std::vector<std::string>>();
  auto json = std::make_shared<bool>(false);
  auto* c = app.add_subcommand("built", "Check that a stage's programs are built from its current "
                                        "code; otherwise exit 1 saying that it did not compile, "
                                        "with the compiler's first error (every stage test needs "
                                        "this check: a stage is never tested with an old binary). "
                                        "--json: every stage (or those named) with its program "
                                        "and what stops it from running, as JSON.");
  c->add_option("--stage", *ids, "stage number, e.g. 01 (with --json: any number, comma-separated)")
      ->delimiter(',');
  c->add_option("--impl", *impl, "solution, student or engine (default as for run)");
  c->add_option("--target", *targets, "also these build targets (e.g. the stage's test program)");
  c->add_flag("--json", *json, "print the stages, their programs and the kit's folders as JSON");
  c->callback([ids, impl, targets, json] {
    const std::string which = impl->empty() ? default_impl() : *impl;
    check_impl(which);
    if (*json) {
      std::printf("%s\n", describe(which, *ids).dump(2).c_str());
      return;
    }
    if (ids->size() != 1) throw std::runtime_error("built: name one stage (--stage NN)");
    const std::string id = two_digits(ids->front());
    const std::string problem = stage_build_problem(id, which, *targets);
    if (problem.empty() && which != "engine") {
      // The grader's reading of the stage's objects (plab.grade.symbols): a stage that runs the
      // reference program or another stage, or goes around what the kit measures, is refused
      // here as it is there, before any test runs it.
      const Captured calls =
          capture_program({"python3", "-m", "plab.grade.symbols", "--kit", source_dir(), "--build",
                           build_dir(), "--stage", id, "--impl", which});
      if (calls.status != 0) {
        std::printf("%s", calls.text.c_str());
        g_status = 1;
        return;
      }
    }
    if (problem.empty()) {
      std::printf("stage %s (%s) is built from its current code\n", id.c_str(), which.c_str());
      return;
    }
    std::printf("%s\n", problem.c_str());
    g_status = 1;
  });
}

}  // namespace plab::cli
