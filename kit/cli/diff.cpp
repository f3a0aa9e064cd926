/// \file cli/diff.cpp
/// \brief `plab diff`: where two outputs first differ (with --json, also step by step).
#include "common.hpp"

namespace plab::cli {

void add_diff(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto json = std::make_shared<bool>(false);
  auto* c = app.add_subcommand("diff", "Compare two outputs (or digest files): exit 0 when equal, "
                                       "otherwise show the first differing step, particle and "
                                       "field, and count the differing lines.");
  c->add_option("outputs", *files, "EXPECTED ACTUAL: the two outputs (or digest files)")
      ->required()
      ->expected(2)
      ->check(CLI::ExistingFile);
  c->add_flag("--json", *json,
              "print JSON instead: equal, text (the report above), first (line, step and "
              "particle as numbers or null, field, expected and actual as the printed text, "
              "differing_lines; null when equal) and steps (for every step EXPECTED prints, "
              "whether ACTUAL prints the same lines for it)");
  c->callback([files, json] {
    const std::string expected = read_file((*files)[0]);
    const std::string actual = read_file((*files)[1]);
    const auto d = first_difference(expected, actual);
    g_status = d ? 1 : 0;
    if (!*json) {
      std::printf("%s\n", d ? d->describe().c_str() : "equal");
      return;
    }
    nlohmann::ordered_json out;
    out["equal"] = !d;
    out["text"] = d ? d->describe() : "equal";
    out["first"] = nullptr;
    // A step or particle is a number where the line's word is one (a garbled line's is not:
    // null); the values stay text, the exact decimals the outputs print
    const auto number = [](const std::string& word) -> nlohmann::ordered_json {
      if (word.empty() || word.size() > 18 ||
          word.find_first_not_of("0123456789") != std::string::npos)
        return nullptr;
      return std::stoll(word);
    };
    if (d)
      out["first"] = {{"line", d->line}, {"step", number(d->step)},
                      {"particle", number(d->particle)},
                      {"field", d->field}, {"expected", d->expected}, {"actual", d->actual},
                      {"differing_lines", d->differing_lines}};
    out["steps"] = nlohmann::ordered_json::array();
    for (const StepMatch& m : compare_steps(expected, actual))
      out["steps"].push_back({{"step", m.step}, {"equal", m.equal}});
    std::printf("%s\n", out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  });
}

}  // namespace plab::cli
