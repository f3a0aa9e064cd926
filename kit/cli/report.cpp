/// \file cli/report.cpp
/// \brief `plab report`: the student's report skeleton: their own stage timed on this machine over
/// sizes and thread (or rank) counts, tables and figures, and the handout's questions.
#include "common.hpp"

namespace plab::cli {

namespace {
/// Joins numbers with commas, as `plab bench` takes them.
template <class T>
std::string joined(const std::vector<T>& v) {
  std::string s;
  for (const T& x : v) s += (s.empty() ? "" : ",") + std::to_string(x);
  return s;
}

/// Thread (or rank) counts 1, 2, 4, ... up to this machine's cores, and the cores themselves.
std::vector<int> up_to_cores() {
  const int cores = std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  std::vector<int> v;
  for (int t = 1; t < cores; t *= 2) v.push_back(t);
  v.push_back(cores);
  return v;
}

/// Sizes a stage's report runs by default: a few seconds a run on a laptop at 100 steps, growing
/// by 2 so that the slope of time against N (the stage's complexity) shows.
std::vector<long long> default_sizes(const std::string& id) {
  if (id == "01") return {100, 200, 400};
  if (id == "02" || id == "07") return {250, 500, 1000, 2000};
  if (id == "03") return {500, 1000, 2000, 4000};
  if (id == "04" || id == "05") return {1000, 2000, 4000, 8000};
  if (id == "06") return {2000, 8000, 32000, 128000};
  return {10000, 40000};  // 08
}
}  // namespace

void add_report(CLI::App& app) {
  struct Args {
    std::string stage, impl, out;
    std::vector<long long> n;
    std::vector<int> threads;
    long long steps = 100;
    int runs = 3;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "report", "Write your report's skeleton for a stage: runs the stage (yours by default in a "
                "student copy) on this machine over sizes and thread or rank counts, and writes "
                "OUT/report.md with this machine's description, the tables, figures of time "
                "against N, speedup and efficiency (matplotlib), and the handout's questions to "
                "answer.");
  c->add_option("--stage", a->stage, "the stage, e.g. 03")->required();
  c->add_option("--impl", a->impl, "student or solution (default as for run)");
  c->add_option("--n", a->n, "particle counts (default: the stage's, growing by 2)")
      ->delimiter(',');
  c->add_option("--threads,--ranks", a->threads,
                "thread counts (OpenMP stages) or rank counts (stage 08); default 1, 2, 4, ... "
                "up to this machine's cores")->delimiter(',')->check(CLI::PositiveNumber);
  c->add_option("--steps", a->steps, "steps of each scene")->capture_default_str()
      ->check(CLI::PositiveNumber);
  c->add_option("--runs", a->runs, "timed runs of each configuration (the median is reported)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--out", a->out, "the report's folder (default: report-NN)");
  c->callback([a] {
    const std::string id = two_digits(a->stage);
    const std::string impl = a->impl.empty() ? default_impl() : a->impl;
    check_impl(impl);
    require_stage(id, impl);  // a clear error when it is not built from its current code
    const bool openmp = stage_declares(id, impl, "needs_openmp") == true;
    const bool mpi = stage_declares(id, impl, "needs_mpi") == true;
    const std::string out = a->out.empty() ? "report-" + id : a->out;
    fs::create_directories(out);
    const std::vector<long long> n = a->n.empty() ? default_sizes(id) : a->n;
    const std::vector<int> counts =
        a->threads.empty() ? ((openmp || mpi) ? up_to_cores() : std::vector<int>{1}) : a->threads;
    const std::string csv = out + "/bench.csv";
    std::vector<std::string> bench{bin_dir() + "/plab", "bench", "--stage", id, "--impl", impl,
                                   "--n", joined(n), "--steps", std::to_string(a->steps),
                                   "--runs", std::to_string(a->runs), "--csv", csv,
                                   mpi ? "--ranks" : "--threads", joined(counts)};
    std::printf("plab report: timing stage %s (%s) at N = %s, %s %s, %lld steps, %d runs each "
                "(plab bench)\n", id.c_str(), impl.c_str(), joined(n).c_str(),
                mpi ? "ranks" : "threads", joined(counts).c_str(), a->steps, a->runs);
    std::fflush(stdout);
    if (const int rc = run_program(bench); rc != 0)
      throw std::runtime_error("the timings failed (plab bench exit " + std::to_string(rc) + ")");
    const std::vector<std::string> draw{"python3", "-m", "plab.report",
                                        "--csv", csv, "--stage", id, "--impl", impl,
                                        "--kit", source_dir(), "--out", out,
                                        "--counts", mpi ? "ranks" : "threads"};
    if (const int rc = run_program(draw); rc != 0)
      throw std::runtime_error("writing the report failed (exit " + std::to_string(rc) + ")");
  });
}

}  // namespace plab::cli
