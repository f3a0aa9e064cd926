/// \file cli/bench.cpp
/// \brief `plab bench`: timings, medians, speedups, CSV.
#include <algorithm>
#include <cstring>
#include <functional>
#include <memory>
#include <set>
#include <thread>
#include <utility>

#include "common.hpp"

#include <map>

namespace plab::cli {
namespace {

/// Bytes a particle's state takes (x, y, vx, vy, pc, wc); a step reads and writes it at least
/// once, so twice this is the memory floor of a particle-step.
constexpr double kStateBytes = 4 * sizeof(double) + 2 * sizeof(long long);

/// The host's memory bandwidth on `threads` threads, in bytes a second: the best of three
/// copies of 256 MiB split among them (each byte read once and written once, each thread's part
/// first touched by that thread). About half a second.
double host_bandwidth(int threads) {
  constexpr std::size_t kBytes = std::size_t{256} << 20;
  threads = std::max(threads, 1);
  const std::size_t part = kBytes / threads;
  std::unique_ptr<char[]> from(new char[kBytes]), to(new char[kBytes]);
  const auto on_all = [&](auto&& work) {
    std::vector<std::thread> team;
    for (int t = 0; t < threads; ++t) team.emplace_back(work, t);
    for (auto& th : team) th.join();
  };
  on_all([&](int t) {
    std::memset(from.get() + t * part, 1, part);
    std::memset(to.get() + t * part, 0, part);
  });
  double best = 0;
  for (int k = 0; k < 3; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    on_all([&](int t) { std::memcpy(to.get() + t * part, from.get() + t * part, part); });
    const double s = wall_seconds(t0);
    if (k == 0 || s < best) best = s;
  }
  return best > 0 ? 2.0 * part * threads / best : 0;
}

/// The copies' time in steps: the median over the repetitions of their mean and of their slowest.
struct Copies {
  double mean = 0, slowest = 0;
};

/// Runs `programs` at once, `runs` times, each writing its run report to the matching `reports`
/// entry; `ran` checks each exit status (and throws on a failure).
Copies time_at_once(const std::vector<std::vector<std::string>>& programs,
                    const std::vector<std::string>& reports, int runs,
                    const std::function<void(int)>& ran, const std::string& progress) {
  std::vector<double> mean, slowest;
  for (int k = 0; k < runs; ++k) {
    if (stderr_is_terminal())
      std::fprintf(stderr, "\r  %s, run %d/%d ", progress.c_str(), k + 1, runs);
    double sum = 0, most = 0;
    const std::vector<int> status = run_programs(programs);
    for (std::size_t u = 0; u < reports.size(); ++u) {
      ran(status[u]);
      const double at =
          nlohmann::json::parse(read_file(reports[u])).at("step_seconds").get<double>();
      sum += at;
      most = std::max(most, at);
    }
    mean.push_back(sum / static_cast<double>(reports.size()));
    slowest.push_back(most);
  }
  if (stderr_is_terminal()) std::fprintf(stderr, "\r%70s\r", "");
  std::sort(mean.begin(), mean.end());
  std::sort(slowest.begin(), slowest.end());
  return {mean[mean.size() / 2], slowest[slowest.size() / 2]};
}

}  // namespace

void add_bench(CLI::App& app) {
  struct Args {
    std::vector<std::string> stages, schedules{"dynamic,16"};
    std::vector<int> threads{1};
    std::vector<int> ranks;
    std::vector<long long> n{1000, 2000, 4000};
    long long steps = 500;
    int runs = 3;
    std::string csv, impl;
    std::uint64_t seed = 1;
    bool fixed_density = false;
    bool ceiling = false;
    std::string speed;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand("bench", "Time stages on scenes like the 2019 report's (L = 20000, "
                                        "r = 1, model.md's speeds, perf mode): median of several "
                                        "whole-process runs, spread, and speedup over 1 thread. "
                                        "A stage's rows take their runs in turn (every row's first "
                                        "run, then every row's second, ...), so that other work on "
                                        "the machine falls on all rows alike; a stage without "
                                        "OpenMP loops (02, 07) is timed at the first thread count "
                                        "and schedule only.");
  c->add_option("--stage", a->stages, "stages, e.g. 02,03")->required()->delimiter(',');
  c->add_option("--threads", a->threads,
                "thread counts, e.g. 1,2 (a student's or solution's threads wait passively at "
                "barriers, as when graded, unless OMP_WAIT_POLICY is set)")->delimiter(',')
      ->capture_default_str();
  c->add_option("--ranks", a->ranks,
                "rank counts for a stage on several processes (08), e.g. 1,2,4: mpirun starts "
                "them (one thread each); adds bytes sent per step and the share of time in "
                "exchanges")->delimiter(',')->check(CLI::Range(1, 4096));
  c->add_option("--n", a->n, "particle counts")->delimiter(',')->capture_default_str();
  c->add_option("--steps", a->steps, "steps S")->capture_default_str();
  c->add_option("--runs", a->runs, "timed runs per configuration")->capture_default_str()
      ->check(CLI::PositiveNumber);
  c->add_option("--schedule", a->schedules, "OpenMP schedules to compare, e.g. static dynamic,16 "
                                            "guided")->capture_default_str();
  c->add_option("--seed", a->seed, "scene seed")->capture_default_str();
  c->add_flag("--fixed-density", a->fixed_density,
              "scale the box with N (L = 20000 sqrt(N / 10^4)): the report's density at every N, "
              "with the report's speeds (2500 .. 5000) unless --speed says otherwise");
  c->add_option("--speed", a->speed, "MIN:MAX speeds (default: model.md's L/8 .. L/4, or 2500:5000 "
                                     "with --fixed-density)");
  c->add_option("--impl", a->impl, "solution, student or engine (default as for run)");
  c->add_option("--csv", a->csv, "also write the table as CSV to this file");
  c->add_flag("--ceiling", a->ceiling,
              "also measure what this machine allows: for each thread (or rank) count T above the "
              "first count F, run T / F copies of the F run at once (independent processes, "
              "--runs times) and compare their time in steps with the F run's alone: work that "
              "shares nothing reaches T / F times that ratio here, the machine's own ceiling for "
              "the speedup (CSV: ceiling, and ceiling_slowest when the slowest copy sets the "
              "pace)");
  c->callback([a] {
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    const std::string policy = wait_as_the_grader(impl);
    std::string csv =
        "stage,impl,n,steps,threads,schedule,runs,median_s,min_s,max_s,speedup,step_median_s,"
        "step_min_s,step_max_s,timer,device,device_bytes,bandwidth,floor_s\n";
    const bool by_ranks = !a->ranks.empty();
    if (by_ranks) {
      a->threads = a->ranks;  // the loop below runs over rank counts, one thread each
      csv.pop_back();
      csv += ",ranks,bytes_per_step,comm_share,bytes_by_call\n";
    }
    csv.pop_back();
    csv += ",ceiling,ceiling_slowest\n";
    // A stage that is not there or not built is said before the table starts (not under its head),
    // and so is a size far past what the stage is tested at (stage 01's step is O(N^3) by design:
    // the default sizes would take minutes a run, with nothing printed).
    std::map<std::string, std::string> programs;  // each stage's program, checked once
    for (const std::string& raw : a->stages) {
      const std::string id = two_digits(raw);
      programs[id] = require_stage(id, impl);
      const nlohmann::json most = stage_declares(id, impl, "test_max_n");
      const long long largest = *std::max_element(a->n.begin(), a->n.end());
      // A stage on MPI (08) bounds its tests for the time mpirun takes to start its many runs,
      // not for its step's cost: 10^6 particles take seconds a step there.
      const bool on_ranks = stage_declares(id, impl, "needs_mpi") == true;
      if (!on_ranks && most.is_number_integer() && largest > 2 * most.get<long long>())
        std::fprintf(stderr,
                     "plab bench: stage %s is tested up to N = %lld (test_max_n in its stage.json); "
                     "N = %lld may take minutes a run (--n %lld,%lld,%lld: a quicker table)\n",
                     id.c_str(), most.get<long long>(), largest, most.get<long long>() / 4,
                     most.get<long long>() / 2, most.get<long long>());
    }
    std::printf("%-5s %6s %5s %7s %-11s %10s %9s %8s %10s %9s  %s\n", "stage", "N", "S",
                by_ranks ? "ranks" : "threads",
                "schedule", "median s", "spread", "speedup", "in steps", "ms/step", "device");
    const std::string report = temp_path("bench-report.json");
    // The scenes and the run report are the bench's own: removed however it ends.
    std::vector<std::string> made{report};
    struct RemoveMade {
      const std::vector<std::string>& files;
      ~RemoveMade() {
        std::error_code ignored;
        for (const std::string& f : files) fs::remove(f, ignored);
      }
    } remove_made{made};
    // Rows whose runs differ by more than this share of their median: noise (a shared machine).
    constexpr double kNoisy = 0.2;
    std::vector<std::pair<double, std::string>> noisy;  //!< (spread, which row)
    struct Unfinished {};           //!< a stage that stopped at an exercise not done (exit 3)
    std::set<std::string> unfinished;  //!< those stages: not run again, the others still timed
    for (const long long n : a->n) {
      const std::string scene = temp_path("bench-" + std::to_string(n) + (a->fixed_density ? "-fd-" : "-") +
                                          std::to_string(a->steps) + "-" + std::to_string(a->seed) +
                                          ".in");
      const double L = a->fixed_density ? 20000 * std::sqrt(n / 1e4) : 20000;
      GenParams g{n, L, 1, a->steps, Mode::kPerf, a->seed};
      if (!a->speed.empty()) {
        const auto colon = a->speed.find(':');
        g.speed_min = std::stod(a->speed.substr(0, colon));
        g.speed_max = std::stod(a->speed.substr(colon + 1));
      } else if (a->fixed_density) {
        g.speed_min = 2500;
        g.speed_max = 5000;
      }
      made.push_back(scene);
      write_text(scene, format_scene(generate_scene(g)));
      for (const std::string& raw : a->stages) {
        const std::string id = two_digits(raw);
        const std::string program = programs.at(id);
        if (unfinished.count(id)) continue;
        try {
          // The command line of one run on `count` threads (or ranks) under `schedule`, its report
          // to `report_to`; ranks bound to cores as mpirun chooses unless `bound` is false.
          const auto run_args = [&](const std::string& schedule, int count,
                                    const std::string& report_to, bool bound = true) {
            std::vector<std::string> args{program, scene, "--quiet", "--out", "/dev/null",
                                          "--threads", by_ranks ? "1" : std::to_string(count),
                                          "--schedule", schedule, "--report", report_to};
            return by_ranks ? on_ranks(id, impl, count, args, bound) : args;
          };
          const auto check_ran = [&](int rc) {
            if (rc == 3) throw Unfinished{};  // its "EXERCISE N ... is not done yet" said why
            if (rc != 0)
              throw std::runtime_error("stage " + id + " failed (exit " + std::to_string(rc) +
                                       ") on " + scene);
          };
          // Every row's k-th run before any row's (k+1)-th: a spell of other work on the machine
          // falls on every row alike, not on whole rows (a student's two rankings of the
          // schedules, two minutes apart, disagreed when each row's runs came one after another)
          struct Timed {
            std::vector<double> t, steps_t;
            nlohmann::json last;
          };
          std::map<std::pair<std::string, int>, Timed> timed;
          // A GPU stage (not on ranks) runs its first count only, and a CPU stage without OpenMP
          // loops (02, 07) its first count and schedule: its other rows would time the same run
          bool on_gpu = false, serial = false;
          for (int k = 0; k < a->runs; ++k)
            for (const std::string& schedule : a->schedules)
              for (const int threads : a->threads) {
                if ((on_gpu || serial) && threads != a->threads.front()) continue;
                if (serial && schedule != a->schedules.front()) continue;
                if (stderr_is_terminal())
                  std::fprintf(stderr, "\r  stage %s N=%lld threads=%d %s run %d/%d ", id.c_str(),
                               n, threads, schedule.c_str(), k + 1, a->runs);
                Timed& m = timed[{schedule, threads}];
                const auto t0 = std::chrono::steady_clock::now();
                check_ran(run_program(run_args(schedule, threads, report)));
                m.t.push_back(wall_seconds(t0));
                m.last = nlohmann::json::parse(read_file(report));
                m.steps_t.push_back(m.last.at("step_seconds").get<double>());
                on_gpu = on_gpu || (m.last.at("device").get<std::string>() != "cpu" && !by_ranks);
                serial = serial || (!on_gpu && !by_ranks && !m.last.value("openmp", true));
              }
          if (stderr_is_terminal()) std::fprintf(stderr, "\r%70s\r", "");
          for (const std::string& schedule : a->schedules) {
            double one_thread = 0, one_thread_steps = 0;
            for (const int threads : a->threads) {
              if (!timed.count({schedule, threads})) break;  // (a GPU or serial stage's others)
              Timed& m = timed.at({schedule, threads});
              std::vector<double>& t = m.t;
              std::vector<double>& steps_t = m.steps_t;
              const nlohmann::json& last = m.last;
              std::sort(t.begin(), t.end());
              std::sort(steps_t.begin(), steps_t.end());
              const double median = t[t.size() / 2];
              const double step_median = steps_t[steps_t.size() / 2];
              const std::string device = last.at("device").get<std::string>();
              const std::string timer = last.at("timer").get<std::string>();
              const bool gpu = device != "cpu";
              if (threads == a->threads.front()) {
                one_thread = median;
                one_thread_steps = step_median;
              }
              // A stage without OpenMP loops (02, 07, 08) has no schedule to show
              const bool scheduled = last.value("openmp", true) && !gpu;
              const double spread = (t.back() - t.front()) / median;
              if (a->runs > 1 && spread > kNoisy) {
                char what[128];
                std::snprintf(what, sizeof what, "stage %s N=%lld %s=%d: %.0f%%", id.c_str(), n,
                              by_ranks ? "ranks" : "threads", threads, 100 * spread);
                noisy.emplace_back(spread, what);
              }
              char speedup[32] = "-";
              if (one_thread > 0 && (!gpu || by_ranks))
                std::snprintf(speedup, sizeof speedup, "%.2f", one_thread / median);
              std::printf("%-5s %6lld %5lld %7s %-11s %10.3f %8.1f%% %8s %10.4f %9.4f  %s (%s)\n",
                          id.c_str(), n, a->steps,
                          gpu && !by_ranks ? "-" : std::to_string(threads).c_str(),
                          scheduled ? schedule.c_str() : "-", median, 100 * spread, speedup,
                          step_median,
                          a->steps ? 1e3 * step_median / a->steps : 0.0, device.c_str(),
                          timer.c_str());
              // The memory floor: the state read and written once a step, at the bandwidth the
              // stage measured (a GPU engine) or, for the engine on the CPU, the host's.
              double bandwidth = last.value("bandwidth", 0.0);
              if (bandwidth == 0 && !gpu && !by_ranks && impl == "engine")
                bandwidth = host_bandwidth(threads);
              double floor_s = 0;
              if (bandwidth > 0 && a->steps > 0) {
                floor_s = 2 * kStateBytes * static_cast<double>(n) / bandwidth;
                const double per_step = step_median / static_cast<double>(a->steps);
                std::printf("      memory: %.0f B a particle-step at least (the state read and "
                            "written once) = %.4f ms/step at the measured %.0f GB/s; this step "
                            "takes %.0fx that, the time of %.0f B a particle-step\n",
                            2 * kStateBytes, 1e3 * floor_s, bandwidth / 1e9, per_step / floor_s,
                            per_step * bandwidth / static_cast<double>(n));
              }
              // What a GPU stage held on the device (particles and working arrays, not the CUDA
              // context): how large a scene one GPU can take.
              if (const auto held = last.value("device_bytes", std::size_t{0}); held > 0 && n > 0)
                std::printf("      device memory: %.1f MB held by the stage, %.1f B a particle\n",
                            static_cast<double>(held) / 1e6,
                            static_cast<double>(held) / static_cast<double>(n));
              const double bytes = last.value("bytes_sent", 0.0);
              const double comm = last.value("comm_seconds", 0.0);
              const double steps = a->steps ? static_cast<double>(a->steps) : 1.0;
              // The exchanges' share is of the same run's time in steps (the last run's report):
              // against the median of the runs, a slow last run read as more than 100%.
              const double last_steps = last.value("step_seconds", 0.0);
              if (by_ranks)  // mpirun's start-up is in the whole-process speedup: in steps too
                std::printf("      %.3g bytes sent per step, %.0f%% of the time in steps in "
                            "exchanges (the busiest rank, the last run); speedup in steps %.2f "
                            "over %d rank(s)\n",
                            bytes / steps, last_steps > 0 ? 100 * comm / last_steps : 0.0,
                            step_median > 0 ? one_thread_steps / step_median : 0.0,
                            a->threads.front());
              // Which calls sent them (handout 08's question 2: which exercise sends most); the
              // CSV's bytes_by_call: "MPI_Sendrecv 1.12e+05; MPI_Isend 1e+05" a step, most first.
              std::string by_call_csv;
              if (by_ranks && bytes > 0 && last.contains("bytes_by_call")) {
                std::vector<std::pair<double, std::string>> most;  // the most first
                for (const auto& [call, sent] : last["bytes_by_call"].items())
                  most.emplace_back(sent.get<double>(), call);
                std::sort(most.rbegin(), most.rend());
                std::string calls;
                for (const auto& [sent, call] : most) {
                  char part[96];
                  std::snprintf(part, sizeof part, "%s%s %.3g (%.0f%%)", calls.empty() ? "" : ", ",
                                call.c_str(), sent / steps, 100 * sent / bytes);
                  calls += part;
                  std::snprintf(part, sizeof part, "%s%s %.3g", by_call_csv.empty() ? "" : "; ",
                                call.c_str(), sent / steps);
                  by_call_csv += part;
                }
                std::printf("      by call, per step: %s\n", calls.c_str());
              }
              // This machine's ceiling for the row: copies of the first count's run at once.
              double ceiling = 0, ceiling_slowest = 0;
              const int first = a->threads.front();
              if (a->ceiling && (!gpu || by_ranks) && threads > first && threads % first != 0)
                std::printf("      this machine's ceiling: not measured (%d is not a multiple of "
                            "the first count, %d: copies of that run cannot fill it)\n",
                            threads, first);
              if (a->ceiling && (!gpu || by_ranks) && threads > first && threads % first == 0 &&
                  one_thread_steps > 0 && step_median > 0) {
                const int copies = threads / first;
                std::vector<std::string> reports;
                for (int k = 0; k < copies; ++k) {
                  reports.push_back(temp_path("bench-ceiling-" + std::to_string(k) + ".json"));
                  if (std::find(made.begin(), made.end(), reports.back()) == made.end())
                    made.push_back(reports.back());
                }
                // copies at once, unbound: a run of one rank alone is bound to the first core
                std::vector<std::vector<std::string>> programs;
                for (const std::string& r : reports)
                  programs.push_back(run_args(schedule, first, r, false));
                char progress[128];
                std::snprintf(progress, sizeof progress,
                              "stage %s N=%lld: %d copies of the %d-%s run at once", id.c_str(), n,
                              copies, first, by_ranks ? "rank" : "thread");
                const Copies at_once =
                    time_at_once(programs, reports, a->runs, check_ran, progress);
                const double mean = at_once.mean, slowest = at_once.slowest;
                ceiling = copies * one_thread_steps / mean;
                ceiling_slowest = copies * one_thread_steps / slowest;
                const double in_steps = one_thread_steps / step_median;
                if (mean < 0.9 * one_thread_steps)  // more than the copies themselves can give
                  std::printf("      warning: %d copies at once each took %.2fx the %d-%s run's "
                              "time alone, less than 1: that run was slowed by other work on the "
                              "machine, so this ceiling overstates it; measure again when the "
                              "machine is quiet\n",
                              copies, mean / one_thread_steps, first, by_ranks ? "rank" : "thread");
                std::printf("      this machine's ceiling: %d copies of the %d-%s run at once "
                            "took %.2fx (mean) and %.2fx (slowest) its time in steps alone, so "
                            "work that shares nothing reaches %.2fx here (%.2fx when the slowest "
                            "sets the pace); this row's %.2fx in steps is %.0f%% of that\n",
                            copies, first, by_ranks ? "rank" : "thread", mean / one_thread_steps,
                            slowest / one_thread_steps, ceiling, ceiling_slowest, in_steps,
                            100 * in_steps / ceiling);
              }
              std::fflush(stdout);
              char row[512];
              std::snprintf(row, sizeof row,
                            "%s,%s,%lld,%lld,%d,\"%s\",%d,%.6f,%.6f,%.6f,%s,%.6f,%.6f,%.6f,%s,"
                            "\"%s\",%zu,%.4g,%.4g\n",
                            id.c_str(), impl.c_str(), n, a->steps, threads, schedule.c_str(),
                            a->runs,
                            median, t.front(), t.back(), speedup, step_median, steps_t.front(),
                            steps_t.back(), timer.c_str(), device.c_str(),
                            last.value("device_bytes", std::size_t{0}), bandwidth, floor_s);
              csv += row;
              csv.pop_back();
              if (by_ranks)
                csv += "," + std::to_string(threads) + "," + std::to_string(bytes / steps) + "," +
                       std::to_string(step_median > 0 ? comm / step_median : 0.0) + ",\"" +
                       by_call_csv + "\"";
              const auto or_empty = [](double v) { return v > 0 ? std::to_string(v) : ""; };
              csv += "," + or_empty(ceiling) + "," + or_empty(ceiling_slowest) + "\n";
              if (gpu && !by_ranks) break;  // threads, schedules: CPU settings (ranks are not)
            }
          }
        } catch (const Unfinished&) {  // the other stages are still timed
          unfinished.insert(id);
          std::printf("%-5s not timed: an exercise is not done yet (its message above)\n",
                      id.c_str());
        }
      }
    }
    if (!unfinished.empty()) g_status = 1;
    if (!a->csv.empty()) write_text(a->csv, csv);
    std::printf("median s: whole-process wall seconds (start-up, scene reading and, on a GPU, "
                "context creation included; output to /dev/null); spread = (max - min) / median "
                "over %d runs; speedup: over the first thread (or rank) count; in steps: the median of the "
                "stage's own time in steps (host clock on the CPU, CUDA events on a GPU); memory "
                "(the engine): the step against the time to read and write the state once at the "
                "measured bandwidth (CSV: bandwidth in B/s, floor_s a step); OpenMP's threads "
                "wait at barriers: %s (OMP_WAIT_POLICY%s)%s\n",
                a->runs, policy.c_str(),
                impl == "engine" ? "" : "; passive unless set: the grader's timing",
                a->ceiling ? "; this machine's ceiling (--ceiling): the speedup that independent "
                             "copies of the first count's run reach on as many cores, what the "
                             "machine's shared memory, caches and clocks leave to work that "
                             "shares nothing"
                           : "");
    if (a->runs == 1)
      std::printf("one run per row (--runs 1): no spread to judge the noise by; take 3 or more\n");
    if (!noisy.empty()) {
      std::printf("warning: %zu row(s) whose %d runs differ by more than %.0f%% of their median "
                  "(largest first):", noisy.size(), a->runs, 100 * kNoisy);
      std::sort(noisy.begin(), noisy.end(), std::greater<>());
      for (std::size_t i = 0; i < noisy.size() && i < 5; ++i)
        std::printf("%s %s", i ? "," : "", noisy[i].second.c_str());
      std::printf("%s.\n  Other work on the machine (a shared lab machine, other students' runs) "
                  "slows some runs: the medians are not to be trusted to that much. Measure when "
                  "the machine is quiet (uptime's load average near 0), or with more runs "
                  "(--runs %d).\n",
                  noisy.size() > 5 ? ", ..." : "", std::max(5, 2 * a->runs));
    }
  });
}

}  // namespace plab::cli
