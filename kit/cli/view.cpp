/// \file cli/view.cpp
/// \brief `plab view`: one self-contained HTML page that plays a run in the browser (play, pause,
/// step, slider, speed, zoom, pan, velocity arrows), says what a clicked disk is doing and, with
/// `--compare`, where two runs first differ. The page is kit/view/viewer.html with the script
/// kit/view/viewer.js and the run's data inlined: nothing is loaded from anywhere when it opens.
///
/// The data are packed as binary (base64 in the page, 4/3 of their size): per kept step and
/// particle the position as two float32 and the velocity as two int16 scaled by the run's largest
/// component (12 bytes; 24 with --compare), the events of the kept steps (particle, partner, time
/// in the step: 10 bytes each) and, with --compare, the particles that differ at each kept step
/// (compared exactly, as doubles, here; at most 2000 named a step). Past --max-mb (default 100)
/// of data the page keeps every k-th step (and always the first differing step, the one before
/// it, and the last); its header says so. The report's scene (N = 10^4, 500 steps, 2.3 million
/// events) fits whole.
#include <cstring>
#include <map>
#include <numeric>

#include "common.hpp"
#include "plab/model.hpp"

namespace plab::cli {
namespace {

using Json = nlohmann::json;

/// Whether a text is an output (its first line is 6 or 8 numbers) rather than a scene.
bool looks_like_output(const std::string& text) {
  std::istringstream first(text.substr(0, text.find('\n')));
  std::string word;
  int words = 0;
  bool numbers = true;
  while (first >> word) {
    ++words;
    char* end = nullptr;
    std::strtod(word.c_str(), &end);
    numbers = numbers && end == word.c_str() + word.size();
  }
  return numbers && (words == 6 || words == 8);
}

/// One event of the page: what `particle` did in `step` (partner -1: a wall, -2: a pair whose
/// partner could not be told from the two printed states) at time `t` from the step's start.
struct ViewEvent {
  long long step;
  std::int32_t particle, partner;
  double t;
};

/// The partner and time of every event of `events`, from the printed states of each step's start
/// and end (`by_step`: the blocks by step). A wall event's time is model.md's wall time; a pair
/// event's partner is the particle with a pair event in the same step whose pair time is in the
/// step and with which the momentum is kept best (the step's end velocities), its time the pair
/// time. Candidates are looked for near in x only (sorted by x): the events of a step are few.
std::vector<ViewEvent> describe(const std::vector<EventRecord>& events,
                                const std::map<long long, const OutputBlock*>& by_step,
                                double L, double r) {
  std::vector<ViewEvent> out;
  for (std::size_t lo = 0; lo < events.size();) {
    std::size_t hi = lo;
    while (hi < events.size() && events[hi].step == events[lo].step) ++hi;
    const long long step = events[lo].step;
    const auto now = by_step.find(step), next = by_step.find(step + 1);
    const Particles* p = now == by_step.end() ? nullptr : &now->second->particles;
    const Particles* q = next == by_step.end() ? nullptr : &next->second->particles;
    std::vector<std::int32_t> pairs;
    double reach = 0;
    for (std::size_t e = lo; e < hi; ++e) {
      const auto i = static_cast<std::size_t>(events[e].particle);
      if (!events[e].wall && p && i < p->x.size()) {
        pairs.push_back(static_cast<std::int32_t>(i));
        reach = std::max(reach, std::abs(p->vx[i]));
      }
    }
    std::sort(pairs.begin(), pairs.end(), [&](int a, int b) { return p->x[a] < p->x[b]; });
    for (std::size_t e = lo; e < hi; ++e) {
      const auto i = static_cast<std::size_t>(events[e].particle);
      ViewEvent v{step, static_cast<std::int32_t>(i), events[e].wall ? -1 : -2, NAN};
      if (p && i < p->x.size()) {
        if (events[e].wall) {
          v.t = model::wall_time(p->x[i], p->y[i], p->vx[i], p->vy[i], L, r);
        } else {
          double best = INFINITY;
          const double x0 = p->x[i] - 2 * r - 2 * reach, x1 = p->x[i] + 2 * r + 2 * reach;
          auto it = std::lower_bound(pairs.begin(), pairs.end(), x0,
                                     [&](int a, double x) { return p->x[a] < x; });
          for (; it != pairs.end() && p->x[*it] <= x1; ++it) {
            const auto j = static_cast<std::size_t>(*it);
            if (j == i) continue;
            const double t = model::pair_time(p->x[i], p->y[i], p->vx[i], p->vy[i], p->x[j],
                                              p->y[j], p->vx[j], p->vy[j], r);
            if (!model::in_step(t)) continue;
            // Without the step's end state, the earliest pair time decides.
            const double miss = q ? std::hypot(p->vx[i] + p->vx[j] - q->vx[i] - q->vx[j],
                                               p->vy[i] + p->vy[j] - q->vy[i] - q->vy[j])
                                  : t;
            if (miss < best) best = miss, v.partner = static_cast<std::int32_t>(j), v.t = t;
          }
        }
      }
      out.push_back(v);
    }
    lo = hi;
  }
  return out;
}

/// Appends the bytes of `values` to `blob` (4-byte aligned) and returns its [offset, count].
template <typename T>
Json pack(std::string& blob, const std::vector<T>& values) {
  while (blob.size() % 4) blob.push_back('\0');
  const std::size_t at = blob.size();
  blob.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  return Json::array({at, values.size()});
}

std::string base64(const std::string& in) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8 |
                       (unsigned char)in[i + 2];
    for (int s = 18; s >= 0; s -= 6) out.push_back(abc[(v >> s) & 63]);
  }
  if (i < in.size()) {
    const unsigned v = (unsigned char)in[i] << 16 |
                       (i + 1 < in.size() ? (unsigned char)in[i + 1] << 8 : 0);
    out.push_back(abc[v >> 18]);
    out.push_back(abc[(v >> 12) & 63]);
    out.push_back(i + 1 < in.size() ? abc[(v >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

/// Replaces the one `marker` of `page` with `text` (the template names each marker once).
void fill(std::string& page, const std::string& marker, const std::string& text) {
  const auto at = page.find(marker);
  if (at == std::string::npos) throw std::runtime_error("kit/view/viewer.html has no " + marker);
  page.replace(at, marker.size(), text);
}

/// The states of the kept steps of one run: positions as float32, velocities as int16 of the
/// run's largest |component| (its `vscale` in the page).
Json pack_run(std::string& blob, const std::vector<const OutputBlock*>& kept, std::size_t n,
              const std::string& label) {
  double vmax = 0;
  for (const OutputBlock* b : kept)
    for (std::size_t i = 0; i < n; ++i)
      vmax = std::max({vmax, std::abs(b->particles.vx[i]), std::abs(b->particles.vy[i])});
  const double scale = vmax > 0 ? vmax / 32767 : 1;
  std::vector<float> pos;
  std::vector<std::int16_t> vel;
  pos.reserve(kept.size() * n * 2);
  vel.reserve(kept.size() * n * 2);
  for (const OutputBlock* b : kept)
    for (std::size_t i = 0; i < n; ++i) {
      pos.push_back(static_cast<float>(b->particles.x[i]));
      pos.push_back(static_cast<float>(b->particles.y[i]));
      vel.push_back(static_cast<std::int16_t>(std::lround(b->particles.vx[i] / scale)));
      vel.push_back(static_cast<std::int16_t>(std::lround(b->particles.vy[i] / scale)));
    }
  return {{"label", label}, {"vscale", scale}, {"pos", pack(blob, pos)}, {"vel", pack(blob, vel)}};
}

/// Checks that `events` (the file `path`) are this run's: every particle an index of its `n`, every
/// step one it printed the start of, and a collision changes the particle's velocity between the
/// step's start and end where both are printed (a grazing pair may not: more than half of them
/// unchanged, and at least 3, are the events of another run).
/// \throws std::runtime_error saying the line and what does not match
void check_events(const std::vector<EventRecord>& events, const std::string& path,
                  const std::map<long long, const OutputBlock*>& by_step, std::size_t n) {
  std::size_t unchanged = 0, compared = 0;
  const EventRecord* example = nullptr;
  for (std::size_t e = 0; e < events.size(); ++e) {
    const EventRecord& v = events[e];
    const std::string where = path + ":" + std::to_string(e + 1) + ": ";
    if (v.particle < 0 || static_cast<std::size_t>(v.particle) >= n)
      throw std::runtime_error(where + "particle " + std::to_string(v.particle) + ", but the run "
                               "has " + std::to_string(n) + " particles: the events of another "
                               "run? (`plab run SCENE --events FILE` writes this run's)");
    if (!by_step.empty() && (v.step < by_step.begin()->first || v.step >= by_step.rbegin()->first))
      throw std::runtime_error(where + "step " + std::to_string(v.step) + ", but the run prints "
                               "steps " + std::to_string(by_step.begin()->first) + " to " +
                               std::to_string(by_step.rbegin()->first) + ": the events of "
                               "another run?");
    const auto now = by_step.find(v.step), next = by_step.find(v.step + 1);
    if (now == by_step.end() || next == by_step.end()) continue;
    const auto i = static_cast<std::size_t>(v.particle);
    const Particles &p = now->second->particles, &q = next->second->particles;
    ++compared;
    if (p.vx[i] == q.vx[i] && p.vy[i] == q.vy[i] && !example) example = &v;
    if (p.vx[i] == q.vx[i] && p.vy[i] == q.vy[i]) ++unchanged;
  }
  if (unchanged >= 3 && 2 * unchanged > compared)
    throw std::runtime_error(path + ": " + std::to_string(unchanged) + " of " +
                             std::to_string(compared) + " collisions leave the particle's "
                             "velocity as it was (step " + std::to_string(example->step) +
                             ", particle " + std::to_string(example->particle) + "): the events "
                             "of another run of this scene? (`plab run SCENE --events FILE` "
                             "writes this run's)");
}

struct Run {
  std::string label;
  std::vector<OutputBlock> blocks;
  std::map<long long, const OutputBlock*> by_step;
  void index() {
    for (const OutputBlock& b : blocks) by_step[b.step] = &b;
  }
};

}  // namespace

void add_view(CLI::App& app) {
  struct Args {
    std::string input, scene, stage = "02", impl, compare, events, out;
    long long steps = -1;
    double max_mb = 100;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "view", "Write one self-contained HTML page that plays a run in the browser: play, pause, "
              "step, slider, speed, zoom and pan, velocity arrows; click a disk for its index, "
              "position, velocity and events. With --compare, two runs overlaid or side by side, "
              "their first difference marked on the slider, the differing disks ringed.");
  c->add_option("input", a->input, "a scene (run with --stage/--impl, its events recorded) or a "
                                   "print-mode output (a golden file, yours)")
      ->required()->check(CLI::ExistingFile);
  c->add_option("--scene", a->scene, "for an output: the scene giving the box (L, r); default "
                                     "datasets/scenes/NAME.in for an output named NAME.out")
      ->check(CLI::ExistingFile);
  c->add_option("--stage", a->stage, "stage that runs a scene")->capture_default_str();
  c->add_option("--impl", a->impl, "solution or student (default as for run)");
  c->add_option("--steps", a->steps, "steps to run a scene for (default: the scene's S)");
  c->add_option("--compare", a->compare, "the expected print-mode output of the same scene (a "
                                         "golden file): what the input is compared with")
      ->check(CLI::ExistingFile);
  c->add_option("--events", a->events, "the events file of the input output (`plab run "
                                       "--events`); a scene's run records its own")
      ->check(CLI::ExistingFile);
  c->add_option("--max-mb", a->max_mb, "most MB of run data in the page; past it, every k-th "
                                       "step is kept")->capture_default_str();
  c->add_option("--out", a->out, "the HTML file (default: the input's name with .html)");
  c->callback([a] {
    const std::string text = read_file(a->input);
    std::string run_text = text;  // the primary run's output
    Run run;
    std::vector<EventRecord> events;
    std::string scene_path = a->scene;
    if (!looks_like_output(text)) scene_path = a->input;
    if (scene_path.empty()) {
      const fs::path guess = fs::path(source_dir()) / "datasets" / "scenes" /
                             (fs::path(a->input).stem().string() + ".in");
      if (!fs::exists(guess))
        throw std::runtime_error(a->input + " is an output: give its scene with --scene (for "
                                 "the box's L and r)");
      scene_path = guess.string();
    }
    const Scene scene = load_scene(scene_path, kDefaultSeed);
    std::string events_path = a->events;
    if (scene_path == a->input && !a->events.empty())
      throw std::runtime_error("--events is for an output: " + a->input + " is a scene, whose "
                               "run records its own events");
    if (scene_path == a->input) {  // run the stage on the scene, in print mode, with its events
      const std::string impl = a->impl.empty() ? default_impl() : a->impl;
      check_impl(impl);
      const std::string output = temp_path("view.out");
      events_path = temp_path("view.events");
      const long long steps = a->steps >= 0 ? a->steps : scene.steps;
      std::printf("running stage %s (%s) on %s: N = %zu, %lld steps, every state printed ...\n",
                  two_digits(a->stage).c_str(), impl.c_str(), a->input.c_str(),
                  scene.particles.size(), steps);
      std::fflush(stdout);
      const int rc = run_program({require_stage(two_digits(a->stage), impl), a->input, "--quiet",
                                  "--mode", "print", "--steps", std::to_string(steps), "--out",
                                  output, "--events", events_path});
      if (rc != 0) throw std::runtime_error("stage " + a->stage + " failed on " + a->input);
      run_text = read_file(output);
      run.blocks = parse_output(run_text, output);
      run.label = "stage " + two_digits(a->stage) + " (" + impl + "), " +
                  fs::path(a->input).filename().string();
      fs::remove(output);
    } else {
      run.blocks = parse_output(text, a->input);
      run.label = a->input;
    }
    run.index();
    const std::size_t n = run.blocks.front().particles.size();
    if (n != scene.particles.size())
      throw std::runtime_error(a->input + " has " + std::to_string(n) + " particles, its scene " +
                               scene_path + " " + std::to_string(scene.particles.size()) +
                               ": give the scene it was run on with --scene");
    if (!events_path.empty()) {
      events = parse_events(read_file(events_path), events_path);
      if (events_path != a->events) fs::remove(events_path);
      else check_events(events, events_path, run.by_step, n);
    }

    Run other;
    Json compare = nullptr;
    std::optional<Difference> first;
    if (!a->compare.empty()) {
      const std::string other_text = read_file(a->compare);
      other.blocks = parse_output(other_text, a->compare);
      other.label = a->compare;
      other.index();
      if (other.blocks.front().particles.size() != n)
        throw std::runtime_error(a->compare + " has " +
                                 std::to_string(other.blocks.front().particles.size()) +
                                 " particles, " + a->input + " " + std::to_string(n));
      first = first_difference(other_text, run_text);  // the compared output is the expected one
    }

    // The steps kept: every k-th printed step (of both runs with --compare) within the budget.
    std::vector<long long> steps;
    for (const OutputBlock& b : run.blocks)
      if (other.blocks.empty() || other.by_step.count(b.step)) steps.push_back(b.step);
    if (steps.empty()) throw std::runtime_error("the two outputs share no step");
    const auto described = describe(events, run.by_step, scene.box.L, scene.box.r);
    const double per_step = double(n) * 12 * (other.blocks.empty() ? 1 : 2) +
                            10.0 * double(described.size()) / double(steps.size());
    const auto budget = static_cast<std::size_t>(std::max(1.0, a->max_mb * 1e6 / per_step));
    const std::size_t k = (steps.size() + budget - 1) / budget;
    long long first_step = first ? std::atoll(first->step.c_str()) : -1;
    std::vector<long long> kept;
    for (std::size_t s = 0; s < steps.size(); ++s)
      if (s % k == 0 || s + 1 == steps.size() || steps[s] == first_step ||
          (s + 1 < steps.size() && steps[s + 1] == first_step))
        kept.push_back(steps[s]);

    std::string blob;
    std::vector<const OutputBlock*> mine, theirs;
    for (long long s : kept) mine.push_back(run.by_step[s]);
    Json meta{{"L", scene.box.L}, {"r", scene.box.r}, {"n", n}, {"steps", kept}, {"every", k},
              {"printed", steps.size()}, {"max_mb", a->max_mb}};
    // An output that stops before its scene's last step (cut short, or run with --steps): said
    if (scene_path != a->input && run.blocks.back().step < scene.steps)
      meta["scene_steps"] = scene.steps;
    // The last printed step of the first run (no step follows it: no collision to show)
    meta["last_step"] = run.blocks.back().step;
    meta["runs"] = Json::array({pack_run(blob, mine, n, run.label)});

    // Events of the kept steps, with partners and times (in 65534ths of the step; 65535: not
    // known), as runs of one frame each: frame f's are ev_start[f] .. ev_start[f + 1] - 1.
    std::vector<std::int32_t> ev_start{0}, ev_particle, ev_partner;
    std::vector<std::uint16_t> ev_time;
    for (std::size_t e = 0, f = 0; f < kept.size(); ++f) {
      while (e < described.size() && described[e].step < kept[f]) ++e;
      for (; e < described.size() && described[e].step == kept[f]; ++e) {
        const ViewEvent& v = described[e];
        ev_particle.push_back(v.particle);
        ev_partner.push_back(v.partner);
        ev_time.push_back(v.t >= 0 && v.t < 1 ? static_cast<std::uint16_t>(std::lround(v.t * 65534))
                                               : std::uint16_t{65535});
      }
      ev_start.push_back(static_cast<std::int32_t>(ev_particle.size()));
    }
    meta["events"] = {{"given", !events_path.empty()}, {"start", pack(blob, ev_start)},
                      {"particle", pack(blob, ev_particle)}, {"partner", pack(blob, ev_partner)},
                      {"time", pack(blob, ev_time)}};

    if (!other.blocks.empty()) {
      for (long long s : kept) theirs.push_back(other.by_step[s]);
      meta["runs"].push_back(pack_run(blob, theirs, n, other.label));
      // The differing particles of each kept step, compared bit for bit (-0 is not 0, as in the
      // texts plab diff compares), at most 2000 named a step.
      const auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
      std::vector<std::int32_t> offsets{0}, which, counts;
      for (std::size_t f = 0; f < kept.size(); ++f) {
        const Particles &p = mine[f]->particles, &q = theirs[f]->particles;
        std::int32_t count = 0;
        for (std::size_t i = 0; i < n; ++i)
          if (!same(p.x[i], q.x[i]) || !same(p.y[i], q.y[i]) || !same(p.vx[i], q.vx[i]) ||
              !same(p.vy[i], q.vy[i]) || p.pc[i] != q.pc[i] || p.wc[i] != q.wc[i])
            if (++count <= 2000) which.push_back(static_cast<std::int32_t>(i));
        counts.push_back(count);
        offsets.push_back(static_cast<std::int32_t>(which.size()));
      }
      compare = {{"offsets", pack(blob, offsets)}, {"which", pack(blob, which)},
                 {"counts", pack(blob, counts)}};
      if (first)
        compare["first"] = {{"step", first_step}, {"particle", first->particle},
                            {"field", first->field}, {"a", first->actual},
                            {"b", first->expected}, {"lines", first->differing_lines}};
    }
    meta["compare"] = compare;

    const std::string dir = source_dir() + "/kit/view/";
    std::string page = read_file(dir + "viewer.html");
    std::string json = meta.dump(-1, ' ', false, Json::error_handler_t::replace);
    for (std::size_t at = 0; (at = json.find("</", at)) != std::string::npos; at += 3)
      json.replace(at, 2, "<\\/");
    fill(page, "PLAB_DATA", base64(blob));  // in this order: no text filled in holds a later marker
    fill(page, "/*PLAB_META*/", json);
    fill(page, "/*PLAB_SCRIPT*/", read_file(dir + "viewer.js"));
    const std::string out =
        a->out.empty() ? fs::path(a->input).stem().string() + ".html" : a->out;
    write_text(out, page);
    if (!other.blocks.empty())
      std::printf("%s\n%s", first ? first->describe().c_str() : "the two outputs are equal",
                  first_step == 0 ? "(step 0 is the initial state, before any step: outputs of "
                                    "two different scenes, or one printed wrong from the start?)\n"
                                  : "");
    std::printf("wrote %s: %zu particles, %zu of %zu steps%s, %.1f MB\n", out.c_str(), n,
                kept.size(), steps.size(),
                k > 1 ? (" (one in " + std::to_string(k) + ", past --max-mb)").c_str() : "",
                page.size() / 1e6);
  });
}

}  // namespace plab::cli
