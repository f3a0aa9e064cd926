/// \file cli/diff.cpp
/// \brief `plab diff`: where two outputs first differ (with --json, also step by step).
#include "common.hpp"

namespace plab::cli {

namespace {
/// The particles of an output's first block (its lines that share the first line's step).
std::size_t first_block_size(const std::string& text) {
  std::istringstream in(text);
  std::string line, step, first;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    if (!(words >> step)) continue;
    if (n == 0) first = step;
    if (step != first) break;
    ++n;
  }
  return n;
}

/// Why two files cannot be compared line by line, or "": a scene, an events file or a digest
/// against an output, or two outputs of scenes with another N (a student's file mixed up).
std::string not_comparable(const std::string& expected, const std::string& actual,
                           const std::vector<std::string>& paths) {
  // The files by their names alone (the grader's are in its private scratch)
  const std::vector<std::string> names{fs::path(paths[0]).filename().string(),
                                       fs::path(paths[1]).filename().string()};
  const auto kind = [](const std::string& text, const std::string& name) -> std::string {
    try {
      return detect_kind(text, name);
    } catch (const InputError&) {
      return "empty";
    }
  };
  const std::string a = kind(expected, names[0]), b = kind(actual, names[1]);
  const auto article = [](const std::string& k) {
    return k == "empty" ? "an empty file" : (k == "output" || k == "events" ? "an " : "a ") + k +
                                                (k == "events" ? " file" : "");
  };
  if (a != b && a != "empty" && b != "empty")
    return names[0] + " is " + article(a) + " and " + names[1] + " " + article(b) +
           ": plab diff compares two outputs (or two digest files) of the same scene";
  if (a == "scene" && b == "scene")
    return "both are scenes: plab diff compares two outputs (or two digest files) of the same "
           "scene; run each (plab run SCENE --out FILE), then compare the outputs";
  if (a == "output" && b == "output") {
    const std::size_t n = first_block_size(expected), m = first_block_size(actual);
    if (n != m)
      return "these are outputs of different scenes: " + names[0] + " has " + std::to_string(n) +
             " particles a step, " + names[1] + " " + std::to_string(m);
  }
  return "";
}
}  // namespace

void add_diff(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto json = std::make_shared<bool>(false);
  auto* c = app.add_subcommand("diff", "Compare two outputs (or digest files): exit 0 when equal, "
                                       "otherwise show the first differing step, particle and "
                                       "field, and count the differing lines; exit 2 when the "
                                       "two are not outputs of the same scene (a scene, an "
                                       "events file, another N).");
  c->add_option("outputs", *files, "EXPECTED ACTUAL: the two outputs (or digest files)")
      ->required()
      ->expected(2)
      ->check(CLI::ExistingFile);
  c->add_flag("--json", *json,
              "print JSON instead: equal, comparable (false when the two are not outputs of the "
              "same scene, exit 2: text says why, first is null, steps empty), text (the report "
              "above), first (line, step and "
              "particle as numbers or null, field, expected and actual as the printed text, "
              "differing_lines; null when equal) and steps (for every step EXPECTED prints, "
              "whether ACTUAL prints the same lines for it)");
  c->callback([files, json] {
    const std::string expected = read_file((*files)[0]);
    const std::string actual = read_file((*files)[1]);
    if (const std::string why = not_comparable(expected, actual, *files); !why.empty()) {
      // Not a difference: the two files are not what plab diff compares (exit 2, as diff(1)
      // does for trouble).
      if (*json)  // the same keys as a comparison's (callers read text, first and steps)
        std::printf("%s\n", nlohmann::ordered_json{{"equal", false},
                                                   {"comparable", false},
                                                   {"text", why},
                                                   {"first", nullptr},
                                                   {"steps", nlohmann::ordered_json::array()}}
                                 .dump()
                                 .c_str());
      else
        std::fprintf(stderr, "error: %s\n", why.c_str());
      g_status = 2;
      return;
    }
    const auto d = first_difference(expected, actual);
    g_status = d ? 1 : 0;
    if (!*json) {
      std::printf("%s\n", d ? d->describe().c_str() : "equal");
      if (d && d->step == "0")  // step 0 is the scene's own state: no stage has moved it yet
        std::printf("(step 0 is the initial state, before any step: outputs of two different "
                    "scenes, or one printed wrong from the start?)\n");
      return;
    }
    nlohmann::ordered_json out;
    out["equal"] = !d;
    out["comparable"] = true;
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
