/// \file cli/read.cpp
/// \brief `plab read`: a scene, an output or an events file read with the kit's own parser
/// (io.hpp) and printed as JSON, or a clear error. The kit's Python tools read every file of
/// these formats through it (kit/python/plab/plabio.py). A leaf: it never starts another program.
#include <charconv>
#include <limits>

#include "common.hpp"

namespace plab::cli {
namespace {

using Json = nlohmann::ordered_json;

/// The fields of particles `p` as arrays, one per field (x, y, vx, vy; pc, wc with `counters`).
void put_particles(Json& j, const Particles& p, bool counters) {
  j["x"] = p.x;
  j["y"] = p.y;
  j["vx"] = p.vx;
  j["vy"] = p.vy;
  if (counters) {
    j["pc"] = p.pc;
    j["wc"] = p.wc;
  }
}

/// `FIRST:LAST` (both inclusive) from --steps, or every step when empty.
std::pair<long long, long long> step_range(const std::string& steps) {
  if (steps.empty()) return {0, std::numeric_limits<long long>::max()};
  const auto colon = steps.find(':');
  try {
    std::size_t a = 0, b = 0;
    if (colon == std::string::npos) throw std::invalid_argument("no colon");
    const long long first = std::stoll(steps.substr(0, colon), &a);
    const long long last = std::stoll(steps.substr(colon + 1), &b);
    if (a != colon || b != steps.size() - colon - 1 || first < 0 || last < first)
      throw std::invalid_argument("not a range");
    return {first, last};
  } catch (const std::exception&) {
    throw std::runtime_error("--steps expects FIRST:LAST with 0 <= FIRST <= LAST, e.g. 0:20, "
                             "not '" + steps + "'");
  }
}

Json scene_json(const Scene& s) {
  Json j{{"n", s.particles.size()}, {"L", s.box.L}, {"r", s.box.r},
         {"steps", s.steps}, {"mode", mode_name(s.mode)}, {"generated", s.generated}};
  if (s.generated) {  // no particle lines: `plab run` generates them from its --seed
    put_particles(j, Particles{}, false);
  } else {
    put_particles(j, s.particles, false);
  }
  return j;
}

std::string scene_summary(const Scene& s) {
  return "a scene: N = " + std::to_string(s.particles.size()) + ", L = " + fmt_double(s.box.L) +
         ", r = " + fmt_double(s.box.r) + ", S = " + std::to_string(s.steps) + ", " +
         mode_name(s.mode) + " mode, " +
         (s.generated ? "no particle lines (generated from the seed when run)"
                      : std::to_string(s.particles.size()) + " particle lines");
}

Json output_json(const std::vector<OutputBlock>& blocks, std::pair<long long, long long> range) {
  Json j{{"n", blocks.front().particles.size()},
         {"first_step", blocks.front().step}, {"last_step", blocks.back().step}};
  j["blocks"] = Json::array();
  for (const OutputBlock& b : blocks) {
    if (b.step < range.first || b.step > range.second) continue;
    Json block{{"step", b.step}, {"counters", b.counters}};
    put_particles(block, b.particles, b.counters);
    j["blocks"].push_back(std::move(block));
  }
  return j;
}

std::string output_summary(const std::vector<OutputBlock>& blocks) {
  return "an output: " + std::to_string(blocks.size()) +
         (blocks.size() == 1 ? " block" : " blocks") + " (steps " +
         std::to_string(blocks.front().step) + " to " + std::to_string(blocks.back().step) + "), " +
         std::to_string(blocks.front().particles.size()) + " particles each" +
         (blocks.back().counters ? ", the last with counters" : ", no counters");
}

Json events_json(const std::vector<EventRecord>& events, std::pair<long long, long long> range) {
  Json j{{"count", events.size()}};
  j["events"] = Json::array();
  for (const EventRecord& e : events)
    if (e.step >= range.first && e.step <= range.second)
      j["events"].push_back(
          {{"step", e.step}, {"particle", e.particle}, {"kind", e.wall ? "wall" : "pair"}});
  return j;
}

std::string events_summary(const std::vector<EventRecord>& events) {
  const auto walls = std::count_if(events.begin(), events.end(),
                                   [](const EventRecord& e) { return e.wall; });
  std::string s = "an events file: " + std::to_string(events.size()) + " collisions (" +
                  std::to_string(walls) + " wall, " +
                  std::to_string(static_cast<long>(events.size()) - walls) + " pair)";
  if (!events.empty())
    s += " in steps " + std::to_string(events.front().step) + " to " +
         std::to_string(events.back().step);
  return s;
}

}  // namespace

void add_read(CLI::App& app) {
  struct Args {
    std::string file, kind = "auto", steps;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "read", "Read a scene, an output or an events file with the kit's own parser: print what it "
              "holds (with --json, all of it as JSON: reals exact, as the shortest text that "
              "reads back to the same double), or say where it is malformed (FILE:LINE: "
              "expected ..., found ...) and exit 1.");
  c->add_option("file", a->file, "the file to read")->required();
  c->add_option("--kind", a->kind,
                "scene, output or events (default: auto, from the first line; an empty file "
                "needs --kind)")
      ->check(CLI::IsMember({"auto", "scene", "output", "events"}))->capture_default_str();
  c->add_flag("--json", a->json,
              "print JSON: a scene as {kind, n, L, r, steps, mode, generated, x, y, vx, vy}; an "
              "output as {kind, n, first_step, last_step, blocks: [{step, counters, x, y, vx, vy"
              "[, pc, wc]}]}; an events file as {kind, count, events: [{step, particle, kind}]}");
  c->add_option("--steps", a->steps,
                "FIRST:LAST: only the blocks or events of these steps (the whole file is still "
                "checked)");
  c->callback([a] {
    const auto range = step_range(a->steps);
    try {
      const std::string text = read_file(a->file);
      const std::string kind = a->kind == "auto" ? detect_kind(text, a->file) : a->kind;
      Json j{{"kind", kind}, {"file", a->file}};
      std::string summary;
      if (kind == "scene") {
        const Scene s = parse_scene(text, a->file);
        j.update(scene_json(s));
        summary = scene_summary(s);
      } else if (kind == "digest") {
        throw InputError(a->file + ": a digest file (one hash a step, from --digest): plab diff "
                         "compares two of them; plab read reads scenes, outputs and events files");
      } else if (kind == "output") {
        const auto blocks = parse_output(text, a->file);
        j.update(output_json(blocks, range));
        summary = output_summary(blocks);
      } else {
        const auto events = parse_events(text, a->file);
        j.update(events_json(events, range));
        summary = events_summary(events);
      }
      if (a->json) {
        std::printf("%s\n", j.dump(-1, ' ', false, Json::error_handler_t::replace).c_str());
      } else {
        std::printf("%s: %s\n", a->file.c_str(), summary.c_str());
      }
    } catch (const InputError& e) {  // the file is not a valid one of its kind: exit 1
      std::fprintf(stderr, "error: %s\n", e.what());
      g_status = 1;
    }
  });
}

}  // namespace plab::cli
