#!/usr/bin/env python3
"""The grader's red team (CTest labels grader, long): submissions written as a determined student
would, to win points without solving anything. Each one must score nothing on correctness (or be
contained, with the reason in its output), must leave nothing running and nothing written outside
its sandbox, and must not learn the grading's secrets; an honest stage graded beside them keeps
its full marks.

  grader_redteam.py PLAB_PROGRAM KIT_SOURCE_DIR SCRATCH_DIR [CASE ...]

Without CASE every case runs, in the order of CASES (at the end of this file); CTest runs each
case as a test of its own (grader.redteam.CASE), two at a time on CI.

The attacks (each a stage's step.cpp; the hidden seed of these gradings is SEED):
  read-golden     find an expected output on disk (beside the scene, up the parents' folders,
                  the kit's datasets/golden, /autograder, anywhere on the disk) and copy it as
                  its own output (a candidate is known by its first line, never read whole)
  run-solution    find any plab-run-* program of the kit (the nearest the scene first) and run it
                  on the same scene
  include-path    #include the kit's solution by its absolute path (and a relative one)
  call-oracle     the whole step from the kit's own greedy oracle (plab::plan_step(), which the
                  runner links for --explain), declared by hand, its source included when found
  spy             read its environment, its command line and every process's, report them
  network         open a TCP connection to a listener of this test
  write-outside   write files into /tmp, the kit, the grader's scratch parent and HOME
  daemon          setsid() and a double fork: a child that keeps writing after the run
  fork-bomb       fork without end (an honest stage 02 is graded after it in the same run)
  before-main     stage 08 on MPI (every rank under mpirun): the solution's own step.cpp with a
                  static initializer that, before main, copies an expected output found on disk
                  or runs any other plab-run-* program of the kit on the scene, and leaves
  next-state      stage 01 answers the one-step test with the states its input holds after each
                  start (read from stdin before the runner, written over its output at exit)
and, measured by the grader outside the student's code (each must score nothing):
  ideas           02 with stage 01's O(N^3) selection, 03 serial (no OpenMP pragma), 06 with
                  stage 03's O(N^2) rounds, 08 whose rank 0 steps every particle (a patch of the
                  solution's step.cpp; skipped with a message when its shape changed)
  rounds-03, rounds-07, rounds-08 (one case a stage)
                  03 that selects its events sequentially after a parallel phase, the same with
                  its parallel phase split into 64 loops a step (a count padded past the rounds,
                  which does not fall on a calmer scene), 03 serial with a
                  thread burning CPU beside it (OpenMP synchronisations counted against the
                  scene's rounds), 07 with a linear scan for the next event, 08 whose rank 0 steps
                  everything through gathers and scatters (bytes counted in every MPI call), 08
                  whose rank 0 takes every particle once and steps them alone while the others
                  spin in MPI_Barrier (the driver's check of each rank's particles), 08
                  whose every rank gathers every particle once and steps them all itself,
                  keeping its slab's (even shares; the work in all, against the solution's, and
                  again with the work checks off, as a stepper of its own fast enough to pass
                  them would see: the bytes of that one gather), 08
                  that steps its slab on the idea test's scene only and gathers on rank 0
                  elsewhere (its random-1000 and random-2000 must earn nothing); and
                  03 as one parallel region with dynamic and guided loops and 08's solution,
                  which keep their points
  ties            02 whose heap orders events by time only loses the hidden-ties scene; 07
                  whose queue compares times only loses hidden-converging and the public
                  simultaneous-hits (a disk hit by two at one instant: the order decides)
  heap            02 whose MinHeap is the library's heap (std::push_heap, std::pop_heap) or a
                  std::multiset, or whose step sorts its events beside a right heap: right
                  outputs, no points (the idea test's heap probe and the step's traced
                  comparisons)
  shortcuts       the one-step answers (next-state), a stage 02 that skips the work on the timed
                  scene (no performance points), the untouched starting point of 03 (no race points)
  gpu-ideas       (on a GPU) 04 stepping on the host between whole-state copies, 05 on one
                  stream, 06 whose GPU path tests every pair (stage 04's kernels): traced by the
                  kit's CUPTI library, each scores nothing; 04 that never frees its device
                  state (the trace's memory records) and 05 whose branchless wall calls
                  model::wall_event() (the grader's branch probe) score nothing; the honest 04,
                  05, 06-gpu keep full marks
  links           a stage folder and a step.cpp that are links into the kit's solutions/, an
                  empty zip and a zip of links (the three-line message, no traceback)
  leaderboard     a stage 02 solution that prints a fake time (1e-6 s) on stdout and stderr: the
                  leaderboard of its results.json holds the grader's measured median, the one its
                  performance test states, never the printed number
  bypass          code that goes around what the kit measures through, read from the compiled
                  objects: 08 with a collective through PMPI_ (behind a macro), 03 defining an
                  OpenMP library function: both refused before they run
and, as a control, read-golden, run-solution, include-path and before-main again with
--no-sandbox (and without the idea tests), where they must win. (call-oracle no longer wins
there either: since the oracle moved to kit/instructor/, its header is on no graded build's
include path, so its source included by path does not compile.)
"""
import json
import os
import pathlib
import re
import shutil
import socket
import subprocess
import sys
import threading
import time

plab, kit, scratch = sys.argv[1], pathlib.Path(sys.argv[2]).resolve(), pathlib.Path(sys.argv[3])
only = set(sys.argv[4:])
SEED = 424242
FOLDERS = {"01": "01-naive", "02": "02-heap", "03": "03-openmp", "07": "07-event-driven", "08": "08-mpi"}
TOKEN = f"plabredteam{os.getpid()}"
failures = []

HEAD = """#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <netinet/in.h>
#include <arpa/inet.h>
#include <unistd.h>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "plab/stage.hpp"

namespace {
// The runner's own arguments, from /proc/self/cmdline: {scene, ..., "--out", path}.
std::vector<std::string> my_args() {
  std::ifstream f("/proc/self/cmdline");
  std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::vector<std::string> out;
  std::string cur;
  for (char c : all) { if (c) cur += c; else { out.push_back(cur); cur.clear(); } }
  return out;
}
std::string arg_after(const std::string& flag) {
  auto a = my_args();
  for (size_t i = 0; i + 1 < a.size(); ++i) if (a[i] == flag) return a[i + 1];
  return "";
}
std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}
// A file's first `n` bytes: enough to recognise an expected output by its first line, without
// reading the whole of a large file (a machine's disk may hold outputs of millions of lines).
std::string head(const std::string& path, size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string text(n, '\0');
  f.read(&text[0], static_cast<std::streamsize>(n));
  text.resize(static_cast<size_t>(f.gcount()));
  return text;
}
// Every file under `dir` (depth-limited), skipping /proc, /sys and /dev.
void walk(const std::string& dir, int depth, std::vector<std::string>& files) {
  if (depth < 0 || dir == "/proc" || dir == "/sys" || dir == "/dev" || dir == "/usr") return;
  DIR* d = opendir(dir.c_str());
  if (!d) return;
  while (dirent* e = readdir(d)) {
    std::string n = e->d_name;
    if (n == "." || n == "..") continue;
    std::string p = (dir == "/" ? "" : dir) + "/" + n;
    struct stat st;
    if (lstat(p.c_str(), &st) != 0) continue;
    if (S_ISDIR(st.st_mode)) walk(p, depth - 1, files);
    else if (S_ISREG(st.st_mode)) files.push_back(p);
  }
  closedir(d);
}
// The files nearest the scene first: its own folder, then each parent's (a grader's scratch or
// the kit's build tree holds the expected outputs and the programs), a few levels down each.
void near_scene(std::string scene, std::vector<std::string>& files) {
  if (scene.empty()) return;
  if (scene[0] != '/') {
    char cwd[4096];
    if (getcwd(cwd, sizeof cwd)) scene = std::string(cwd) + "/" + scene;
  }
  std::string dir = scene.substr(0, scene.rfind('/'));
  for (int up = 0; up < 5 && !dir.empty(); ++up) {
    walk(dir, 3, files);
    dir = dir.substr(0, dir.rfind('/'));
  }
}
}  // namespace
"""

# Every stage's entry point (stage.hpp): what makes an attack's step() the stage. The
# include-path attack has it from the solution it includes, or in its own #else branch.
ENTRY = r"""
namespace plab {
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}
}  // namespace plab
"""

ATTACKS = {
    "read-golden": r"""
namespace plab {
void step(const Box&, Particles& p) {
  // The expected output starts with the scene's first particle at step 0.
  char want[128];
  std::snprintf(want, sizeof want, "0 0 %.8f %.8f", p.x[0], p.y[0]);
  const auto a = my_args();
  const std::string out = arg_after("--out");
  std::vector<std::string> files;
  near_scene(a.size() > 1 ? a[1] : "", files);
  for (const char* root : {"/", "/autograder", "KIT", "/tmp", "/plab", "/proc/1/cwd"})
    walk(root, 9, files);
  for (int pid : {getppid(), 1}) walk("/proc/" + std::to_string(pid) + "/cwd", 6, files);
  int seen = 0;
  for (const auto& f : files) {
    if (f.size() < 4 || f.compare(f.size() - 4, 4, ".out") != 0) continue;
    ++seen;
    if (head(f, std::strlen(want)) == want && !out.empty()) {
      std::ofstream(out) << slurp(f);
      std::fprintf(stderr, "copied %s\n", f.c_str());
      _exit(0);
    }
  }
  std::fprintf(stderr, "read-golden: %zu files, %d .out files, none matched\n", files.size(), seen);
  _exit(1);
}
}  // namespace plab
""",
    "run-solution": r"""
namespace plab {
void step(const Box&, Particles&) {
  auto a = my_args();
  const std::string scene = a.size() > 1 ? a[1] : "", out = arg_after("--out");
  std::vector<std::string> files;
  near_scene(scene, files);
  for (const char* root : {"/", "/autograder", "KIT", "/proc/1/cwd", "/proc/self/cwd"})
    walk(root, 9, files);
  // the parents' working folders: the kit's build tree is near them
  for (int pid : {getppid(), 1}) walk("/proc/" + std::to_string(pid) + "/cwd", 4, files);
  int tried = 0;
  for (const auto& f : files) {
    if (f.find("plab-run-") == std::string::npos || f.find("student") != std::string::npos) continue;
    ++tried;
    pid_t child = fork();
    if (child == 0) {
      execl(f.c_str(), f.c_str(), scene.c_str(), "--quiet", "--out", out.c_str(), (char*)nullptr);
      _exit(127);
    }
    int status = 0;
    waitpid(child, &status, 0);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      std::fprintf(stderr, "ran %s\n", f.c_str());
      _exit(0);
    }
  }
  std::fprintf(stderr, "run-solution: %zu files, %d programs tried, none worked\n", files.size(), tried);
  _exit(1);
}
}  // namespace plab
""",
    "include-path": r"""
#if __has_include("KIT/solutions/03-openmp/step.cpp")
#include "KIT/solutions/03-openmp/step.cpp"
#elif __has_include("../../solutions/03-openmp/step.cpp")
#include "../../solutions/03-openmp/step.cpp"
#elif __has_include("/autograder/source/solutions/03-openmp/step.cpp")
#include "/autograder/source/solutions/03-openmp/step.cpp"
#else
namespace plab {
void step(const Box&, Particles& p) {  // no solution found: a wrong step
  for (std::size_t i = 0; i < p.size(); ++i) p.x[i] = -1;
}
}  // namespace plab
ENTRY
#endif
""",
    "call-oracle": r"""
#include "plab/plan.hpp"
#if __has_include("KIT/kit/instructor/src/oracle.cpp")
#include "KIT/kit/instructor/src/oracle.cpp"
#elif __has_include("../../kit/instructor/src/oracle.cpp")
#include "../../kit/instructor/src/oracle.cpp"
#endif
namespace plab {
Plan plan_step(const Box& box, const Particles& p);  // the kit's oracle (plab/oracle.hpp)
void step(const Box& box, Particles& p) { apply(box, p, plan_step(box, p)); }
}  // namespace plab
""",
    "spy": r"""
namespace plab {
void step(const Box&, Particles&) {
  std::string report = "environ: " + slurp("/proc/self/environ") + "\n";
  std::vector<std::string> files;
  walk("/proc", 0, files);
  DIR* d = opendir("/proc");
  while (dirent* e = d ? readdir(d) : nullptr)
    if (e->d_name[0] >= '0' && e->d_name[0] <= '9') {
      std::string base = std::string("/proc/") + e->d_name;
      report += base + " cmdline: " + slurp(base + "/cmdline") + " environ: " +
                slurp(base + "/environ") + "\n";
    }
  if (d) closedir(d);
  report += "ppid cmdline: " + slurp("/proc/" + std::to_string(getppid()) + "/cmdline") + "\n";
  for (auto& c : report) if (c == '\0') c = ' ';
  std::fprintf(stderr, "%s", report.c_str());
  _exit(1);
}
}  // namespace plab
""",
    "network": r"""
namespace plab {
void step(const Box&, Particles&) {
  int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(PORT);
  inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
  int rc = s < 0 ? -1 : connect(s, (sockaddr*)&a, sizeof a);
  if (rc == 0) { const char msg[] = "leak TOKEN\n"; (void)!write(s, msg, sizeof msg - 1); }
  std::fprintf(stderr, "network: socket %d connect %d (%s)\n", s, rc, std::strerror(errno));
  _exit(1);
}
}  // namespace plab
""",
    "write-outside": r"""
namespace plab {
void step(const Box&, Particles&) {
  int made = 0;
  for (const char* path : {"/tmp/TOKEN-tmp", "KIT/TOKEN-kit", "/root/TOKEN-home",
                           "/autograder/results/TOKEN-results", "SCRATCH/TOKEN-scratch",
                           "/usr/TOKEN-usr"}) {
    std::ofstream f(path);
    if (f << "escaped\n") ++made;
  }
  std::fprintf(stderr, "write-outside: %d files written\n", made);
  _exit(1);
}
}  // namespace plab
""",
    "daemon": r"""
namespace plab {
void step(const Box&, Particles& p) {
  for (std::size_t i = 0; i < p.size(); ++i) p.x[i] = -1;  // and a wrong step
  static bool started = false;
  if (started) return;
  started = true;
  if (fork() == 0) {
    setsid();
    if (fork() == 0) {
      signal(SIGHUP, SIG_IGN);
      prctl(PR_SET_NAME, "TOKEN", 0, 0, 0);
      for (int k = 0; k < 600; ++k) {
        std::ofstream("/tmp/TOKEN-daemon", std::ios::app) << k << "\n";
        usleep(100000);
      }
      _exit(0);
    }
    _exit(0);
  }
}
}  // namespace plab
""",
    "before-main": r"""
namespace {
// Before main, on every rank: this scene's expected output from disk, or from another stage's
// program of the kit; either copied as the output, and the rank leaves (the solution below never
// runs). Nothing found: a failure.
int copy_before_main() {
  const auto a = my_args();
  const std::string out = arg_after("--out");
  if (a.size() < 2 || out.empty()) return 0;
  std::ifstream scene(a[1]);
  std::string line;
  for (int k = 0; k < 5 && std::getline(scene, line); ++k) {}
  double id = 0, x = 0, y = 0;
  char want[128] = "no particle line";
  if (scene >> id >> x >> y) std::snprintf(want, sizeof want, "0 0 %.8f %.8f", x, y);
  std::vector<std::string> files;
  near_scene(a[1], files);
  for (const char* root : {"/", "/autograder", "KIT", "/tmp", "/plab", "/proc/1/cwd"})
    walk(root, 9, files);
  for (int pid : {getppid(), 1}) walk("/proc/" + std::to_string(pid) + "/cwd", 6, files);
  for (const auto& f : files)
    if (f.size() > 4 && f.compare(f.size() - 4, 4, ".out") == 0 &&
        head(f, std::strlen(want)) == want) {
      std::ofstream(out) << slurp(f);
      std::fprintf(stderr, "before-main: copied %s\n", f.c_str());
      _exit(0);
    }
  int tried = 0;
  for (const auto& f : files) {
    if (f.find("plab-run-0") == std::string::npos || f.find("student") != std::string::npos ||
        f.find("plab-run-08") != std::string::npos)
      continue;
    ++tried;
    pid_t child = fork();
    if (child == 0) {
      execl(f.c_str(), f.c_str(), a[1].c_str(), "--quiet", "--out", out.c_str(), (char*)nullptr);
      _exit(127);
    }
    int status = 0;
    waitpid(child, &status, 0);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      std::fprintf(stderr, "before-main: ran %s\n", f.c_str());
      _exit(0);
    }
  }
  std::fprintf(stderr, "before-main: %zu files, no expected output, %d programs tried\n",
               files.size(), tried);
  _exit(1);
}
const int copied = copy_before_main();
}  // namespace
""",
    "next-state": r"""
#include <iostream>
#include <sys/mman.h>
namespace {
// The one-step test's states come on stdin (--step-from-each /dev/stdin): read them before the
// runner, hand it the same bytes back (a memfd as fd 0), and at exit replace the run's output
// with the input's own states after the first (the answer to each start, when the input holds
// the state that follows it).
std::string answers;
void write_answers() {
  std::ofstream(arg_after("--out")) << answers;
}
int load() {
  bool one = false;
  for (const auto& a : my_args()) one |= a == "--step-from-each";
  if (!one) return 0;
  std::string text((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
  const int fd = memfd_create("states", 0);
  if (write(fd, text.data(), text.size()) < 0) return 0;
  lseek(fd, 0, SEEK_SET);
  dup2(fd, 0);
  std::istringstream in(text);
  std::string line, first;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    std::string w[6];
    if (!(l >> w[0] >> w[1] >> w[2] >> w[3] >> w[4] >> w[5])) continue;
    if (first.empty()) first = w[0];
    if (w[0] == first) continue;
    answers += w[0] + " " + w[1] + " " + w[2] + " " + w[3] + " " + w[4] + " " + w[5] + "\n";
  }
  std::atexit(write_answers);
  return 1;
}
const int loaded = load();
}  // namespace
namespace plab {
void step(const Box&, Particles&) {}
}  // namespace plab
""",
    "fork-bomb": r"""
namespace plab {
void step(const Box&, Particles&) {
  for (;;) fork();
}
}  // namespace plab
""",
}


def unbuilt(output):
    """Whether a test's output says that its stage was never built (it did not compile, or the
    kit's build could not be configured): such a cheat scores 0 without being caught by the idea
    test, so it proves nothing."""
    return "does not compile" in output or output.startswith("not run: stage")


def check(name, condition, message):
    print(("ok   " if condition else "FAIL ") + f"{name}: {message}", flush=True)
    if not condition:
        failures.append(f"{name}: {message}")


def submission(name, attacks, port=0):
    """Stages 01-03 of the solutions (and 08 when attacked), with the given {stage: attack}
    step.cpp in place. Stage 08's attack goes before the solution's own step.cpp, which brings
    its MPI entry point."""
    root = scratch / name
    shutil.rmtree(root, ignore_errors=True)
    for sid, folder in FOLDERS.items():
        if sid != "08" or sid in attacks:
            shutil.copytree(kit / "solutions" / folder, root / "stages" / folder)
    for sid, attack in attacks.items():
        step = root / "stages" / FOLDERS[sid] / "step.cpp"
        if sid == "08":
            body = ATTACKS[attack] + step.read_text()
        else:
            body = ATTACKS[attack] if "ENTRY" in ATTACKS[attack] else ATTACKS[attack] + "ENTRY"
        code = (HEAD + body).replace("ENTRY", ENTRY)
        code = code.replace("KIT", str(kit)).replace("TOKEN", TOKEN)
        code = code.replace("SCRATCH", str(scratch)).replace("PORT", str(port))
        step.write_text(code)
    return root


def grade(name, root, stages="01,02,03", *extra, refusals=False):
    """Grades `root`. Without `refusals`, with the rubric's refused calls left out (unless `extra`
    names a rubric): the attacks open files and start programs, which the grader refuses before
    they run (case oracle checks that), and the sandbox is what these cases test."""
    if not refusals and "--rubric" not in extra:
        extra = (*extra, "--rubric", str(without_refused_calls()))
    out = scratch / f"{name}.json"
    start = time.time()
    done = subprocess.run([plab, "grade", "--submission", root, "--stages", stages, "--out", out,
                           "--seed", str(SEED), "--scratch", scratch, *extra], capture_output=True,
                          text=True)
    (scratch / f"{name}.log").write_text(done.stdout + done.stderr)
    assert out.exists(), f"{name}: no results.json:\n{done.stdout[-3000:]}{done.stderr}"
    doc = json.loads(out.read_text())
    tests = {t["name"]: t for t in doc["tests"]}
    assert "grader error" not in tests, tests.get("grader error", {}).get("output")
    print(f"     ({name}: graded in {time.time() - start:.0f} s, sandbox "
          f"{doc.get('extra_data', {}).get('sandbox')})", flush=True)
    if "not graded" in tests:  # (the grader refused: its reason, or every check below just fails)
        print(f"     ({name}: NOT GRADED: {tests['not graded'].get('output', '')[:600]})", flush=True)
    return tests, doc, done.stdout


def correctness(tests, stage):
    return {n: t for n, t in tests.items() if n.startswith(f"{stage}:") and "performance" not in n}


def first_output(tests, stage):
    return next((t["output"] for t in correctness(tests, stage).values()
                 if not t["output"].startswith("not run")), "")


def leftovers():
    """Processes or files of the attacks still there after grading."""
    time.sleep(1.5)  # a daemon that survived would write again by now
    procs = subprocess.run(["pgrep", "-f", TOKEN], capture_output=True, text=True).stdout.split()
    procs += subprocess.run(["pgrep", "-x", TOKEN[:15]], capture_output=True, text=True).stdout.split()
    files = [str(p) for base in (pathlib.Path("/tmp"), kit, scratch, pathlib.Path("/root"),
                                 pathlib.Path("/usr"))
             for p in base.glob(f"{TOKEN}*")]
    return sorted(set(procs) - {str(os.getpid())}), files


def scored_nothing(name, tests, stage, attack):
    # An attack that does not compile proves nothing about the sandbox: it must build and run.
    broken = [t["output"] for t in correctness(tests, stage).values()
              if "does not compile" in t["output"]]
    check(attack, not broken, "the attack compiles and runs (otherwise its 0 says nothing): "
          + (broken[0].splitlines()[0:3].__str__() if broken else "it did"))
    got = sum(t["score"] for t in correctness(tests, stage).values())
    check(attack, got == 0, f"stage {stage} scored {got} on correctness; its output: "
          f"{first_output(tests, stage).splitlines()[:1]}")


def case_copy():
    # (the rubric's refused calls left out: run-solution starts programs, and the sandbox is what
    # is tested here; with them it is refused before it runs, case oracle)
    tests, doc, _ = grade("redteam-copy", submission("redteam-copy", {
        "01": "read-golden", "02": "run-solution", "03": "include-path"}), "01,02,03",
        "--rubric", str(without_refused_calls()))
    for stage, attack in (("01", "read-golden"), ("02", "run-solution"), ("03", "include-path")):
        scored_nothing("copy", tests, stage, attack)
    print("     read-golden said: " + first_output(tests, "01")[-150:])
    print("     run-solution said: " + first_output(tests, "02")[-150:])


def case_escape():
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    listener.settimeout(0.5)
    port, heard = listener.getsockname()[1], []

    def listen():
        end = time.time() + 1200
        while time.time() < end and not getattr(listen, "stop", False):
            try:
                conn, _ = listener.accept()
                heard.append(conn.recv(100))
                conn.close()
            except OSError:
                continue
    t = threading.Thread(target=listen, daemon=True)
    t.start()
    try:
        tests, doc, stdout = grade("redteam-escape", submission("redteam-escape", {
            "01": "spy", "02": "network", "03": "write-outside"}, port))
    finally:
        listen.stop = True
        t.join()
        listener.close()
    for stage, attack in (("01", "spy"), ("02", "network"), ("03", "write-outside")):
        scored_nothing("escape", tests, stage, attack)
    everything = json.dumps(doc) + stdout
    spied = "\n".join(t["output"] for t in correctness(tests, "01").values())
    check("spy", str(SEED) not in spied and str(kit) not in spied and "plab-grade" not in spied,
          "what student code saw holds neither the seed, nor the kit's path, nor the scratch "
          f"(saw: {spied.splitlines()[1][:160] if len(spied.splitlines()) > 1 else spied[:160]!r})")
    check("spy", "HOME=/root" not in spied and "PYENV" not in spied,
          "the grader's environment did not reach student code")
    check("network", not heard, f"no connection reached the test's listener ({heard[:2]})")
    procs, files = leftovers()
    check("write-outside", not files, f"no file written outside the sandbox ({files})")
    print("     network said: " + first_output(tests, "02")[-150:])
    del everything


def case_processes():
    tests, doc, _ = grade("redteam-processes", submission("redteam-processes", {
        "01": "fork-bomb", "03": "daemon"}), "01,02,03", "--rubric", str(without_refused_calls()))
    scored_nothing("processes", tests, "01", "fork-bomb")
    scored_nothing("processes", tests, "03", "daemon")
    honest = correctness(tests, "02")
    lost = [n for n, t in honest.items() if t["score"] < t["max_score"]]
    check("fork-bomb", not lost, f"the honest stage 02 graded after it kept full marks "
          f"({len(honest)} tests{'; lost ' + str(lost) if lost else ''})")
    print("     fork-bomb: " + first_output(tests, "01")[:150])
    procs, files = leftovers()
    check("daemon", not procs, f"nothing left running after grading (processes {procs})")
    check("daemon", not files, f"the daemon wrote nothing outside ({files})")


def case_oracle():
    """The kit's own oracle: a graded build has none to call or include; and a stage that starts
    another program (the compiled reference's --explain, another stage) is refused before it runs
    (the rubric's refuse_calls: processes)."""
    tests, doc, _ = grade("redteam-oracle", submission("redteam-oracle", {
        "02": "call-oracle", "03": "run-solution"}), "02,03", refusals=True)
    got = sum(t["score"] for t in correctness(tests, "02").values())
    said = next((t["output"] for t in correctness(tests, "02").values()), "")
    check("call-oracle", got == 0 and "does not compile" in said,
          f"stage 02 scored {got} on correctness and did not build: {said.splitlines()[:2]}")
    print("     call-oracle: " + " ".join(said.splitlines()[:2])[:150])
    got = sum(t["score"] for t in correctness(tests, "03").values())
    said = next((t["output"] for t in correctness(tests, "03").values()), "")
    check("run-solution", got == 0 and "is refused" in said and "starts no other program" in said,
          f"stage 03 that runs another program scored {got} and was refused before it ran: "
          f"{said.splitlines()[:2]}")
    print("     run-solution, the rubric's refused calls kept: " + " ".join(said.splitlines()[:2])[:150])


def without_refused_calls():
    """rubric.json without its entries' `refuse_calls`: the attacks that start programs (and
    stage 08's before-main, which opens files) then run, so that the sandbox alone is what stops
    them."""
    rubric = json.loads((kit / "kit/grade/rubric.json").read_text())
    for conf in rubric["stages"].values():
        conf.pop("refuse_calls", None)
    path = scratch / "rubric-without-refused-calls.json"
    path.write_text(json.dumps(rubric))
    return path


def case_mpi():
    """Stage 08: every rank under mpirun in the sandbox (the rubric's refused calls left out, so
    that the sandbox is what is tested; with them, the grader refuses before-main's code before
    it runs: the stage's build says so)."""
    tests, doc, _ = grade("redteam-mpi", submission("redteam-mpi", {"08": "before-main"}), "08",
                          "--rubric", str(without_refused_calls()))
    scored_nothing("mpi", tests, "08", "before-main")
    print("     before-main said: " + first_output(tests, "08")[-150:])
    tests, doc, _ = grade("redteam-mpi-refused", submission("redteam-mpi-refused",
                                                             {"08": "before-main"}), "08",
                          refusals=True)
    said = next((t["output"] for t in correctness(tests, "08").values()), "")
    check("mpi", "is refused" in said and "opens no file" in said,
          f"stage 08's before-main refused for its calls before it runs: {said[:300]!r}")
    procs, files = leftovers()
    check("before-main", not procs, f"nothing left running after grading (processes {procs})")


def case_control():
    """The same attacks without the sandbox must win: the checks above can fail. (The sandbox
    alone is measured: the rubric's idea tests, which the oracle's slow step would fail, are
    left out, and so is the race check.)"""
    rubric = json.loads((kit / "kit/grade/rubric.json").read_text())
    for conf in rubric["stages"].values():
        conf.pop("idea", None)
        conf.pop("refuse_calls", None)
    no_ideas = scratch / "rubric-without-ideas.json"
    no_ideas.write_text(json.dumps(rubric))
    tests, doc, _ = grade("redteam-control", submission("redteam-control", {
        "01": "read-golden", "02": "run-solution", "03": "include-path", "08": "before-main"}),
        "01,02,03,08", "--no-sandbox", "--no-races", "--rubric", str(no_ideas))
    for stage, attack in (("01", "read-golden"), ("02", "run-solution"), ("03", "include-path"),
                          ("08", "before-main")):
        got = sum(t["score"] for t in correctness(tests, stage).values())
        most = sum(t["max_score"] for t in correctness(tests, stage).values())
        check("control", got > most / 2, f"with --no-sandbox, {attack} (stage {stage}) wins "
              f"{got} of {most} correctness points")
        if got <= most / 2:  # why it lost: the first tests it failed, in the grader's words
            lost = [f"{n}: {t['output'][:200]}" for n, t in correctness(tests, stage).items()
                    if t["score"] < t["max_score"]]
            print("     lost " + "\n     lost ".join(lost[:4]), flush=True)


def patched(name, sid, source, edits, skip_why):
    """A submission of one stage folder: `source` (a kit folder: solutions/NN-x or stages/NN-x)
    with each (old, new) text edit applied to step.cpp, or None when an edit's old text is not
    there (the solution changed shape: the case is skipped with `skip_why`)."""
    root = scratch / name / "stages" / FOLDERS[sid]
    shutil.copytree(kit / source, root)
    step = root / "step.cpp"
    text = step.read_text()
    for old, new in edits:
        if old not in text:
            print(f"SKIP {name}: {skip_why} (no {old[:60]!r} in {source}/step.cpp)", flush=True)
            return None
        text = text.replace(old, new)
    step.write_text(text)
    return root


def case_ideas():
    """Each stage's idea, measured outside its code: a stage that skips it scores nothing, however
    right its outputs. 02 with stage 01's O(N^3) selection, 03 serial (its OpenMP pragmas gone),
    06 with stage 03's O(N^2) rounds, 08 with rank 0 stepping every particle."""
    name = "redteam-ideas"
    root = scratch / name
    shutil.rmtree(root, ignore_errors=True)
    (root / "stages").mkdir(parents=True)
    shutil.copytree(kit / "solutions/02-heap", root / "stages/02-heap")
    shutil.copy2(kit / "solutions/01-naive/step.cpp", root / "stages/02-heap/step.cpp")
    patched(name, "03", "solutions/03-openmp", [("#pragma omp", "// (serial) #pragma omp")], "")
    naive06 = root / "stages" / "06-broadphase"
    shutil.copytree(kit / "solutions/06-broadphase", naive06)
    shutil.copy2(kit / "solutions/03-openmp/step.cpp", naive06 / "step.cpp")
    # Stage 08: the rounds' step renamed, and a step that sends every particle to rank 0 (the
    # stage's own migrate()), steps them there alone (a one-rank world) and sends each back to its
    # owner: right outputs, one rank doing the work.
    serial = patched(name, "08", "solutions/08-mpi", [(
        "void step(const Box& box, const Ranks& r, Local& s) {",
        "void real_step(const Box& box, const Ranks& r, Local& s) {"), (
        "}  // namespace plab::dist\n", """
void step(const Box& box, const Ranks& r, Local& s) {
  std::vector<std::vector<Record>> out(r.ranks), back(r.ranks);
  for (int k = 0; k < s.owned; ++k) out[0].push_back(s.record(k));
  Local all;
  migrate(r, out, all);
""" + ALONE_08 + """  for (int k = 0; k < all.owned; ++k) back[r.owner_of(all.p.x[k])].push_back(all.record(k));
  Local mine;
  migrate(r, back, mine);
  s = std::move(mine);
}
}  // namespace plab::dist
""")], "stage 08's solution no longer has the shape the serial patch needs")
    stages = "02,03,06" + (",08-ranks3" if serial else "")  # 08's idea test runs with any entry
    tests, doc, _ = grade(name, root, stages)
    for key in stages.split(","):
        sid = key[:2]
        idea = next((t for n, t in tests.items() if n.startswith(f"{sid}: idea")), None)
        mine = correctness(tests, key)
        got = sum(t["score"] for t in mine.values())
        broken = [t["output"] for t in mine.values() if unbuilt(t["output"])]
        check("ideas", bool(mine), f"stage {key} was graded ({len(mine)} correctness tests)")
        check("ideas", not broken, f"stage {sid}'s shortcut compiles: {broken[:1]}")
        ok = idea is not None and idea["status"] == "failed" and got == 0
        message = (f"stage {sid} without its idea scored {got} on correctness; its idea test: "
                   f"{(idea or {}).get('output', 'none')[:300]!r}")
        check("ideas", ok, message)


def gpu_cheats(root):
    """The GPU stages without their ideas, in `root`/stages (None when a solution changed shape):
    04 stepping on the host (stage 03's step, serial) between a copy down and a copy up of the
    whole state every step; 05 on one stream (its switch's off position, always); 06 whose GPU
    path is stage 04's O(N^2) pair search (its kernels and launchers under other names)."""
    host = (kit / "solutions/03-openmp/step.cpp").read_text()
    for old, new in (("#include <omp.h>", ""), ("omp_get_max_threads()", "1"),
                     ("omp_get_thread_num()", "0"),
                     ("void step(const Box& box, Particles& p) {",
                      "void host_step(const Box& box, Particles& p) {"),
                     ("std::unique_ptr<Stepper> make_stepper(", "std::unique_ptr<Stepper> unused_stepper("),
                     ("{step}", "{host_step}")):
        if old not in host:
            print(f"SKIP gpu-ideas: stage 03's solution changed shape (no {old!r})", flush=True)
            return None
        host = host.replace(old, new)
    s04 = root / "stages/04-cuda"
    shutil.copytree(kit / "solutions/04-cuda", s04)
    step = (s04 / "step.cu").read_text()
    old = "  void queue_step() {\n"
    if old not in step:
        print("SKIP gpu-ideas: stage 04's solution has no queue_step()", flush=True)
        return None
    (s04 / "step.cu").write_text(host + step.replace(old, old + """    Particles h;  // the whole state down, a step on the host, the whole state up
    h.resize(n_);
    download(h);
    ::plab::host_step(box_, h);
    upload(h);
    return;
"""))
    s05 = root / "stages/05-cuda-streams"
    shutil.copytree(kit / "solutions/05-cuda-streams", s05)
    step = (s05 / "step.cu").read_text()
    old = 'o.streams = !asked.is_off("streams");'
    if old not in step:
        print("SKIP gpu-ideas: stage 05's solution has no streams switch", flush=True)
        return None
    (s05 / "step.cu").write_text(step.replace(old, "o.streams = false;"))
    s06 = root / "stages/06-broadphase"
    shutil.copytree(kit / "solutions/06-broadphase", s06)
    shutil.copy2(kit / "solutions/04-cuda/kernels.cuh", s06 / "kernels04.cuh")
    (s06 / "launchers04.cuh").write_text((kit / "solutions/04-cuda/launchers.cuh").read_text()
                                         .replace('"kernels.cuh"', '"kernels04.cuh"'))
    step = (kit / "solutions/04-cuda/step.cu").read_text().replace('"launchers.cuh"',
                                                                    '"launchers04.cuh"')
    old = "std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions&) {"
    if old not in step:
        print("SKIP gpu-ideas: stage 04's solution has no make_stepper() of that shape", flush=True)
        return None
    (s06 / "step.cu").write_text(step.replace(old, """std::unique_ptr<Stepper> make_gpu_stepper(const Box& box, Particles& p,
                                          const StageOptions& options) {
  if (options.device == Device::kAuto && !cuda::missing_device().empty()) return nullptr;"""))
    return root


def case_gpu_ideas():
    """The GPU stages' ideas, traced on the device (kit/python/plab/grade/gpu_idea.py): 04 stepping on the
    host between copies, 05 on one stream, 06's GPU path with O(N^2) pair tests each score
    nothing on correctness; the honest solutions of 04, 05 and 06-gpu keep full marks. Skipped
    without a GPU. PLAB_REDTEAM_GRADE_ARGS adds options to both gradings (on a machine without
    bubblewrap, as root: --make-private, or --no-sandbox)."""
    probe = subprocess.run([plab, "run", "--stage", "04", "--impl", "solution",
                            str(kit / "datasets/scenes/course-1.in"), "--quiet", "--out", os.devnull],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        print(f"SKIP gpu-ideas: no GPU here (stage 04's solution: exit {probe.returncode})", flush=True)
        return
    # The GPU entries graded on the small public scenes and one hidden scene, untimed: the idea
    # tests are what is measured here (a full grading of the three is several minutes a GPU).
    rubric = json.loads((kit / "kit/grade/rubric.json").read_text())
    rubric["correctness"]["hidden_scenes"] = rubric["correctness"]["hidden_scenes"][:1]
    rubric["correctness"]["hidden_families"] = []
    for key in ("04", "05", "06-gpu"):
        rubric["stages"][key].update(sizes=["small"], performance=False)
    trimmed = scratch / "rubric-gpu-ideas.json"
    trimmed.write_text(json.dumps(rubric))
    extra = ["--no-races", "--rubric", str(trimmed),
             *os.environ.get("PLAB_REDTEAM_GRADE_ARGS", "").split()]
    keys = ["04", "05", "06-gpu"]
    root = scratch / "redteam-gpu-honest"
    shutil.rmtree(root, ignore_errors=True)
    for folder in ("04-cuda", "05-cuda-streams", "06-broadphase"):
        shutil.copytree(kit / "solutions" / folder, root / "stages" / folder)
    honest = {}  # graded beside the cheats (its own sandbox uid)
    beside = threading.Thread(target=lambda: honest.update(
        tests=grade("redteam-gpu-honest", root, ",".join(keys), *extra)[0]))
    beside.start()
    cheats = gpu_cheats(scratch / "redteam-gpu-ideas")
    if cheats is not None:
        tests, _, _ = grade("redteam-gpu-ideas", cheats, ",".join(keys), *extra)
        for key in keys:
            idea = next((t for n, t in tests.items() if n.startswith(f"{key}: idea")), None)
            mine = {n: t for n, t in correctness(tests, key).items() if ": idea" not in n}
            got = sum(t["score"] for t in mine.values())
            broken = [t["output"] for t in mine.values() if unbuilt(t["output"])]
            check("gpu-ideas", bool(mine) and not broken,
                  f"stage {key}'s cheat was built and graded: {broken[:1]}")
            check("gpu-ideas", idea is not None and idea["status"] == "failed" and got == 0,
                  f"stage {key} without its idea scored {got} on correctness; its idea test: "
                  f"{(idea or {}).get('output', 'none')[:400]!r}")
    # The exercises' halves that the bits cannot see: 04 that never frees its device state (its
    # destructor left empty), 05 whose branchless wall calls model::wall_event().
    slips = scratch / "redteam-gpu-slips"
    shutil.rmtree(slips, ignore_errors=True)
    shutil.copytree(kit / "solutions/04-cuda", slips / "stages/04-cuda")
    shutil.copytree(kit / "solutions/05-cuda-streams", slips / "stages/05-cuda-streams")
    step = slips / "stages/04-cuda/step.cu"
    text = step.read_text()
    frees = [f"    cudaFree(p_.{f});\n" for f in ("x", "y", "vx", "vy", "pc", "wc")]
    kernels = slips / "stages/05-cuda-streams/kernels.cuh"
    wall = kernels.read_text()
    first = "    const model::WallTimesOf<Real> w = model::wall_times(x, y, vx, vy, L, r);\n"
    body = wall.find(first, wall.find("struct BranchlessWall"))
    end = wall.find("    wc = wc + 1;\n", body)
    if not all(f in text for f in frees) or body < 0 or end < 0:
        print("SKIP gpu-ideas (slips): stage 04's frees or 05's BranchlessWall changed shape",
              flush=True)
    else:
        for f in frees:
            text = text.replace(f, "")
        step.write_text(text)
        kernels.write_text(wall[:body] + "    model::wall_event(x, y, vx, vy, wc, L, r);\n"
                           + wall[end + len("    wc = wc + 1;\n"):])
        tests, _, _ = grade("redteam-gpu-slips", slips, "04,05", *extra)
        for key, words in (("04", "allocated at exit"), ("05", "conditional branches")):
            idea = next((t for n, t in tests.items() if n.startswith(f"{key}: idea")), None)
            mine = {n: t for n, t in correctness(tests, key).items() if ": idea" not in n}
            got = sum(t["score"] for t in mine.values())
            check("gpu-ideas", bool(mine) and not any(unbuilt(t["output"]) for t in mine.values()),
                  f"stage {key}'s slip was built and graded")
            check("gpu-ideas", idea is not None and idea["status"] == "failed" and got == 0
                  and words in idea.get("output", ""),
                  f"stage {key} with a slip the bits cannot see ({words}) scored {got} on "
                  f"correctness; its idea test: {(idea or {}).get('output', 'none')[:400]!r}")
    beside.join()
    tests = honest.get("tests", {})
    check("gpu-ideas", bool(tests), "the honest stages were graded")
    for key in keys:
        idea = next((t for n, t in tests.items() if n.startswith(f"{key}: idea")), None)
        mine = {n: t for n, t in tests.items() if n.startswith(f"{key}:")}
        got = sum(t["score"] for t in mine.values())
        most = sum(t["max_score"] for t in mine.values())
        check("gpu-ideas", idea is not None and idea["status"] == "passed" and got == most,
              f"the honest stage {key} scored {got:g} of {most:g}; its idea test: "
              f"{(idea or {}).get('output', 'none')[:400]!r}")


def case_shortcuts():
    """One grading: stage 01 answers the one-step test from its input (the state after each start,
    when the input had it), stage 02 is the solution but skips the work on the timed scene (N =
    the rubric's performance N), stage 03 is the untouched starting point (race points for it?)."""
    name = "redteam-shortcuts"
    root = submission(name, {"01": "next-state"})
    shutil.rmtree(root / "stages" / FOLDERS["03"])
    shutil.copytree(kit / "stages" / FOLDERS["03"], root / "stages" / FOLDERS["03"])
    n = json.loads((kit / "kit/grade/rubric.json").read_text())["performance"]["scene"]["n"]
    patched_02 = root / "stages" / FOLDERS["02"] / "step.cpp"
    text = patched_02.read_text()
    entry = "  return cpu_stage(box, p, options, {step});"
    if entry in text:
        patched_02.write_text(text.replace(entry, "  return cpu_stage(box, p, options, {skip_timed});")
                              .replace("/// Stage 02's entry point", f"""
void skip_timed(const Box& box, Particles& p) {{
  if (p.x.size() == {n}) return;  // the timed scene: no work, the start state printed
  step(box, p);
}}

/// Stage 02's entry point"""))
    tests, doc, _ = grade(name, root, "01,02,03")
    one = tests.get("01: one step at a time on a hidden dense box", {})
    check("next-state", one.get("score", 1) == 0,
          f"the one-step test gave the answer-copying stage 01 {one.get('score')} of "
          f"{one.get('max_score')}: {one.get('output', '')[:160]!r}")
    perf = tests.get("02: performance", {})
    if entry in text:
        check("skip-timed", perf.get("score", 1) == 0 and "differs" in perf.get("output", ""),
              f"stage 02 that skips the timed scene got {perf.get('score')} performance points: "
              f"{perf.get('output', '')[:160]!r}")
        got = sum(t["score"] for t in correctness(tests, "02").values())
        most = sum(t["max_score"] for t in correctness(tests, "02").values())
        check("skip-timed", got == most, f"its correctness stays full ({got} of {most})")
    else:
        print("SKIP skip-timed: stage 02's solution has no plain cpu_stage entry", flush=True)
    race = next((t for n, t in tests.items() if n.startswith("03: data races")), None)
    total = sum(t["score"] for n, t in tests.items() if n.startswith("03:"))
    check("races-for-nothing", race is not None and race["score"] == 0 and total == 0,
          f"the untouched starting point of stage 03 scored {total} ({(race or {}).get('output')!r})")


def case_links():
    """Links in an upload: a stage folder that is a link to the kit's solution, a step.cpp that is a
    link to the solution's; empty and all-link zips get the short message."""
    import zipfile
    name = "redteam-links"
    root = scratch / name
    shutil.rmtree(root, ignore_errors=True)
    (root / "stages" / FOLDERS["01"]).mkdir(parents=True)
    (root / "stages" / FOLDERS["02"]).symlink_to(kit / "solutions" / FOLDERS["02"])
    (root / "stages" / FOLDERS["01"] / "step.cpp").symlink_to(
        kit / "solutions" / FOLDERS["01"] / "step.cpp")
    tests, doc, stdout = grade(name, root, "01,02")
    got = sum(t["score"] for t in tests.values())
    check("links", got == 0, f"a linked stage folder and a linked step.cpp scored {got} "
          f"({doc['output'].splitlines()[1][:200]!r})")
    for label, members in (("empty", []), ("all-links", ["stages/02-heap", "step.cpp"])):
        archive = scratch / f"{name}-{label}.zip"
        with zipfile.ZipFile(archive, "w") as z:
            for m in members:
                info = zipfile.ZipInfo(m)
                info.external_attr = (0o120777 << 16)
                z.writestr(info, str(kit / "solutions" / FOLDERS["02"]))
        out = scratch / f"{name}-{label}.json"
        done = subprocess.run([plab, "grade", "--submission", archive, "--out", out, "--seed",
                               str(SEED), "--scratch", scratch], capture_output=True, text=True)
        said = json.loads(out.read_text())["tests"][0]["output"] if out.exists() else ""
        check("links", done.returncode == 2 and "Traceback" not in done.stdout + done.stderr
              and 2 <= len(said.splitlines()) <= 4,
              f"the {label} zip: exit {done.returncode}, message {said!r}")


def between(text, start, end, new):
    """`text` with what lies from `start` up to (not including) `end` replaced by `new`, or None
    when either marker is missing (the solution changed shape)."""
    a = text.find(start)
    b = text.find(end, a + 1) if a >= 0 else -1
    return None if a < 0 or b < 0 else text[:a] + new + text[b:]


# Stage 03's rounds (from "const model::Event none" up to the third exercise) written other ways.
ROUNDS_03 = {
    # honest: one parallel region, `omp for` loops inside (the schedule the kit sets, and static)
    "one-region": """  const model::Event none = model::pair_event_key(model::never(), n, n);
  bool open = true;
#pragma omp parallel
  {
    while (open) {
#pragma omp for schedule(runtime)
      for (int i = 0; i < n; ++i) {
        if (resolved[i]) continue;
        model::Event b = model::in_step(wall[i]) ? model::wall_event_key(wall[i], i) : none;
        for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) {
          const int o = cand.other[k];
          if (resolved[o]) continue;
          const model::Event e = model::pair_event_key(cand.time[k], i < o ? i : o, i < o ? o : i);
          if (earlier(e, b)) b = e;
        }
        best[i] = b;
      }
#pragma omp single
      open = false;
#pragma omp for schedule(static) reduction(|| : open)
      for (int i = 0; i < n; ++i) {
        if (resolved[i]) continue;
        const model::Event& e = best[i];
        const int o = (e.lo == i) ? e.hi : e.lo;
        if (!model::in_step(e.t) || e.kind == model::kWall ||
            (best[o].lo == e.lo && best[o].hi == e.hi && best[o].kind == model::kPair)) {
          if (model::in_step(e.t)) plan.accept_for(i, e);
          resolved[i] = 1;
        } else {
          open = true;
        }
      }
    }
  }

""",
    # cheat: the candidates in parallel, then one sequential sort-and-greedy selection
    "sequential-selection": """  std::vector<model::Event> all;
  for (int i = 0; i < n; ++i) {
    if (model::in_step(wall[i])) all.push_back(model::wall_event_key(wall[i], i));
    for (int k = cand.start[i]; k < cand.start[i + 1]; ++k)
      if (i < cand.other[k]) all.push_back(model::pair_event_key(cand.time[k], i, cand.other[k]));
  }
  std::sort(all.begin(), all.end(), model::key_less);
  for (const model::Event& e : all)
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
  (void)resolved;
  (void)best;

""",
}

# Stage 03 with no parallel loop at all, and a thread that only burns CPU while it steps.
BURNER_03 = """
void step(const Box& box, Particles& p) {
  std::atomic<bool> stop{false};
  std::thread burner([&stop] {
    volatile double x = 0;
    while (!stop.load()) x = x + 1;
  });
  serial_step(box, p);
  stop = true;
  burner.join();
}

/// Stage 03's entry point"""

# Stage 02's selection, on one thread: the events in the step popped from a heap in key order, each
# pair accepted when both its particles are still free (the red team's stage 03 cheats' own).
SELECT_03 = """  Plan plan;
  plan.reset(n);
  while (!heap.empty()) {
    const model::Event e = heap.top();
    heap.pop();
    if (!plan.taken(e.lo) && !plan.taken(e.hi)) plan.accept(e);
  }
"""


# Stage 03 whose rounds run only where it guesses the idea test counts them (COND), and stage 02's
# heap selects on one thread everywhere else (ORDER: the heap's comparator). Its own rounds keep
# the idea test's measures; the correctness scenes' comparisons must then be the rounds' too.
ELSEWHERE_03 = """
namespace {
/// The later of two events first, for std::priority_queue (the least on top).
struct Later {
  bool operator()(const model::Event& a, const model::Event& b) const { return ORDER; }
};

/// Stage 02's way: every event in the step into a heap, popped in order, on one thread.
void heap_step(const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  std::priority_queue<model::Event, std::vector<model::Event>, Later> heap;
  for (int i = 0; i < n; ++i) {
    const model::Event w = wall_candidate(box, p, i);
    if (model::in_step(w.t)) heap.push(w);
    for (int j = i + 1; j < n; ++j) {
      const model::Event e = pair_candidate(box, p, i, j);
      if (model::in_step(e.t)) heap.push(e);
    }
  }
""" + SELECT_03 + """  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}
}  // namespace

void step(const Box& box, Particles& p) {
  if (COND)
    rounds_step(box, p);
  else
    heap_step(box, p);
}

/// Stage 03's entry point"""

# Stage 07: the earliest event found by a linear scan (O(N) an event, in the queue's own order:
# the right output), put on top of the heap.
LINEAR_07 = """    const int k = at_[e.i];
    heap_[k].t = e.t;
    int m = 0;
    for (int q = 1; q < static_cast<int>(heap_.size()); ++q) if (earlier(heap_[q], heap_[m])) m = q;
    const Entry top = heap_[0], low = heap_[m];
    put(0, low);
    put(m, top);
"""

# Stage 07: a library queue kept beside the given heap (the heap left as it was), top() read
# from it.
SET_07 = """  void set(const Event& e) {
    order_.erase({events_[e.i].t, e.i});
    events_[e.i] = e;
    order_.insert({e.t, e.i});
  }
  std::set<std::pair<double, int>> order_;
"""

# Stage 08's cheats: rank 0 steps `all` alone, in a world of one rank (the solution's step).
ALONE_08 = """  if (r.rank == 0) {
    Ranks one = r;
    one.comm = MPI_COMM_SELF;
    one.ranks = 1;
    real_step(box, one, all);
  }
"""

# Stage 08: every particle moves to rank 0 once (the first step's migration: a few bytes a
# particle and step over the scene), which steps them all alone from then on, while the other
# ranks wait for it in MPI_Barrier, whose wait spins: as much CPU time as rank 0's, and nothing
# sent but the one migration.
WAIT_08 = """
void step(const Box& box, const Ranks& r, Local& s) {
  std::vector<std::vector<Record>> out(r.ranks);
  Local all;
  for (int k = 0; k < s.owned; ++k) {
    if (r.rank == 0) all.push(s.record(k));
    else out[0].push_back(s.record(k));
  }
  migrate(r, out, all);
""" + ALONE_08 + """  s = std::move(all);
  MPI_Barrier(r.comm);
}
}  // namespace plab::dist
"""

# Stage 08: every rank gathers every particle once (MPI_Allgatherv: a few bytes a particle and
# step over the scene) and from then on steps them all itself, in a world of one rank, keeping
# those of its own slab: each rank's share of the work even, the owners right, R times the work.
# The gather is made again whenever a rank holds other particles than it kept (the one-step
# test starts each step afresh).
REDUNDANT_08 = """
Local everything_08;
std::vector<Record> kept_08;
void step(const Box& box, const Ranks& r, Local& s) {
  std::vector<Record> mine;
  for (int k = 0; k < s.owned; ++k) mine.push_back(s.record(k));
  int fresh = mine.size() != kept_08.size() ||
              std::memcmp(mine.data(), kept_08.data(), mine.size() * sizeof(Record)) != 0;
  int any = 0;
  MPI_Allreduce(&fresh, &any, 1, MPI_INT, MPI_LOR, r.comm);
  if (any) {
    int bytes = static_cast<int>(mine.size() * sizeof(Record)), total = 0;
    std::vector<int> counts(r.ranks), at(r.ranks);
    MPI_Allgather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, r.comm);
    for (int q = 0; q < r.ranks; ++q) {
      at[q] = total;
      total += counts[q];
    }
    std::vector<Record> all(total / sizeof(Record)), by_id(all.size());
    MPI_Allgatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE,
                   r.comm);
    for (const Record& rec : all) by_id[rec.id] = rec;
    everything_08 = Local{};
    for (const Record& rec : by_id) everything_08.push(rec);
    everything_08.owned = everything_08.size();
  }
  Ranks one = r;
  one.comm = MPI_COMM_SELF;
  one.rank = 0;
  one.ranks = 1;
  real_step(box, one, everything_08);
  kept_08.clear();
  for (int k = 0; k < everything_08.owned; ++k)
    if (r.owner_of(everything_08.p.x[k]) == r.rank) kept_08.push_back(everything_08.record(k));
  Local next;
  for (const Record& rec : kept_08) next.push(rec);
  next.owned = next.size();
  s = std::move(next);
}
}  // namespace plab::dist
"""

# Stage 08: REDUNDANT_08 whose all-gather is made in place (MPI_IN_PLACE: MPI reads each rank's
# block from the receive buffer and ignores the send count, which the kit's count read: a red-team
# session of 2026-12-07 all-gathered every particle so, counted as nothing).
REDUNDANT_IN_PLACE_08 = REDUNDANT_08.replace(
    """    MPI_Allgatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE,
                   r.comm);""",
    """    std::memcpy(reinterpret_cast<char*>(all.data()) + at[r.rank], mine.data(), bytes);
    MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE,
                   r.comm);""")

# Stage 08: every particle gathered on rank 0 (MPI_Gather(v)), stepped there alone, and
# scattered back to its owner (MPI_Scatter(v)): rooted collectives only.
GATHER_08 = """
void step(const Box& box, const Ranks& r, Local& s) {
  std::vector<Record> mine;
  for (int k = 0; k < s.owned; ++k) mine.push_back(s.record(k));
  int bytes = static_cast<int>(mine.size() * sizeof(Record));
  std::vector<int> counts(r.ranks), at(r.ranks), back_counts(r.ranks), back_at(r.ranks);
  MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, r.comm);
  int total = 0;
  for (int q = 0; q < r.ranks; ++q) {
    at[q] = total;
    total += counts[q];
  }
  std::vector<Record> all(r.rank == 0 ? total / sizeof(Record) : 0), back;
  MPI_Gatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE, 0,
              r.comm);
  if (r.rank == 0) {
    Local everything;
    for (const Record& rec : all) everything.push(rec);
    everything.owned = everything.size();
    Ranks one = r;
    one.comm = MPI_COMM_SELF;
    one.ranks = 1;
    real_step(box, one, everything);
    std::vector<std::vector<Record>> by(r.ranks);
    for (int k = 0; k < everything.owned; ++k)
      by[r.owner_of(everything.p.x[k])].push_back(everything.record(k));
    for (int q = 0; q < r.ranks; ++q) {
      back_at[q] = static_cast<int>(back.size() * sizeof(Record));
      back_counts[q] = static_cast<int>(by[q].size() * sizeof(Record));
      back.insert(back.end(), by[q].begin(), by[q].end());
    }
  }
  int mine_back = 0;
  MPI_Scatter(back_counts.data(), 1, MPI_INT, &mine_back, 1, MPI_INT, 0, r.comm);
  std::vector<Record> in(mine_back / sizeof(Record));
  MPI_Scatterv(back.data(), back_counts.data(), back_at.data(), MPI_BYTE, in.data(), mine_back,
               MPI_BYTE, 0, r.comm);
  Local fresh;
  for (const Record& rec : in) fresh.push(rec);
  fresh.owned = fresh.size();
  s = std::move(fresh);
}
}  // namespace plab::dist
"""


# Stage 08 that recognises the idea test's scene (the largest: 10^5 particles) and steps its slab
# there only, gathering every particle on rank 0 everywhere else (GATHER_08): its idea test
# passes; the correctness scenes large enough to judge (random-1000, random-2000) must not.
LARGEST_08 = GATHER_08.replace("void step(", "void gather_step(").replace(
    "}  // namespace plab::dist\n", """
void step(const Box& box, const Ranks& r, Local& s) {
  static int n = -1;  // the scene's particles, counted once over the ranks
  if (n < 0) {
    int mine = s.owned;
    MPI_Allreduce(&mine, &n, 1, MPI_INT, MPI_SUM, r.comm);
  }
  if (n >= 50000)
    real_step(box, r, s);
  else
    gather_step(box, r, s);
}
}  // namespace plab::dist
""")


def stage_folder(root, sid, source):
    """A copy of the kit's folder `source` as the submission's stage `sid`; its step.cpp path."""
    dest = root / "stages" / FOLDERS[sid]
    shutil.copytree(kit / source, dest)
    return dest / "step.cpp"


# Stage 03 without its rounds, its count padded: the event times in parallel, split into 64
# work-sharing loops a step (each a real share of the work: the loop ends outnumber the rounds),
# then stage 02's heap selects the events on one thread. It passes as many synchronisations on a
# calm scene as on a busy one: the count does not follow the rounds.
PADDED_03 = r"""/// Stage 03 without its rounds (red team, padded): The event times are computed in parallel (split into
/// many work-sharing loops, each a real share of the pair times, so that the loop ends outnumber
/// the rounds the grader counts), then stage 02's SEQUENTIAL heap selects the events.
#include <omp.h>

#include <queue>
#include <vector>

#include "plab/candidates.hpp"
#include "plab/stage.hpp"

namespace plab {

namespace {
struct Later {
  bool operator()(const model::Event& a, const model::Event& b) const { return model::key_less(b, a); }
};
constexpr int kSlices = 64;  // work-sharing loops a step: each ends at a barrier the counter sees
}  // namespace

void step(const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  std::vector<std::vector<model::Event>> found(omp_get_max_threads());
#pragma omp parallel
  {
    std::vector<model::Event>& mine = found[omp_get_thread_num()];
    for (int s = 0; s < kSlices; ++s) {
#pragma omp for schedule(dynamic, 4)
      for (int i = s; i < n; i += kSlices) {
        const model::Event w = wall_candidate(box, p, i);
        if (model::in_step(w.t)) mine.push_back(w);
        for (int j = i + 1; j < n; ++j) {
          const model::Event e = pair_candidate(box, p, i, j);
          if (model::in_step(e.t)) mine.push_back(e);
        }
      }
    }
  }
  // stage 02's selection, on one thread
  std::priority_queue<model::Event, std::vector<model::Event>, Later> heap;
  for (auto& v : found)
    for (const auto& e : v) heap.push(e);
""" + SELECT_03 + r"""#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
}

std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, {step});
}

}  // namespace plab
"""


def rounds_parts_03(sol03):
    """(the "none" line, the rounds' loop head, its body without pragmas) of the solution's
    rounds, or None when the solution changed shape."""
    head, end = "  for (bool open = true; open;) {\n", "  // EXERCISE 3"
    if head not in sol03 or end not in sol03:
        return None
    loop = sol03[sol03.index(head):sol03.index(end)]
    body = "".join(line for line in loop[len(head):loop.rindex("  }\n")].splitlines(True)
                   if not line.lstrip().startswith("#pragma omp"))
    return "  const model::Event none = model::pair_event_key(model::never(), n, n);\n", head, body


def serial_rounds_03(sol03):
    """The body of a cheat (from "const model::Event none" up to the third exercise): the
    solution's rounds without their pragmas, run by thread 0 of one parallel region a round (so
    the synchronisations follow the rounds) while thread 1 spins until the round is done (so the
    CPU time is shared); `PAD` marks where the spinner may compare events too. "" when the
    solution changed shape."""
    parts = rounds_parts_03(sol03)
    if parts is None:
        return ""
    none, head, body = parts
    return (none + head + "    std::atomic<bool> done{false};\n#pragma omp parallel num_threads(2)\n"
            "    if (omp_get_thread_num() == 0) {\n" + body + "      done = true;\n"
            "    } else {\n      volatile double x = 0;\n      int k = 0;\n"
            "      while (!done.load()) {\n        x = x + 1;\n        PAD\n      }\n    }\n  }\n\n")


def single_rounds_03(sol03):
    """The body of a slip (from "const model::Event none" up to the third exercise): the
    solution's rounds without their pragmas, each round made in `#pragma omp single` of one
    parallel region, by whichever thread comes first (the synchronisations follow the rounds, and
    the rounds fall to both threads). "" when the solution changed shape."""
    parts = rounds_parts_03(sol03)
    if parts is None:
        return ""
    none, _, body = parts
    return (none + "  bool open = true;\n#pragma omp parallel\n  {\n    bool more = true;\n"
            "    while (more) {\n#pragma omp single\n      {\n" + body + "      }\n"
            "      more = open;\n#pragma omp barrier\n    }\n  }\n\n")


#: Stage 03's timed scene's N (rubric.json's performance scene), and what its failure says.
PERF_N = json.loads((kit / "kit/grade/rubric.json").read_text())["performance"]["scene"]["n"]
TIMED = "the timed run's output is right, but"


def rounds_03():
    """Stage 03's gradings of case rounds-03: (name, stage key, must pass the idea test)."""
    gradings = []
    sol03 = (kit / "solutions/03-openmp/step.cpp").read_text()
    serial = serial_rounds_03(sol03)
    pad = ("if (k < n && model::in_step(wall[k])) {\n          const model::Event w = "
           "model::wall_event_key(wall[k], k);\n          (void)earlier(w, w);\n        }\n"
           "        k = (k + 1) % (n + 1);")
    shared, rounds = "were not shared by its 2 threads", "are not the mutual-earliest rounds'"
    for variant, body, honest, why in (
            ("one-region", ROUNDS_03["one-region"], True, None),
            ("sequential-selection", ROUNDS_03["sequential-selection"], False, None),
            ("serial-rounds", serial.replace("PAD", ""), False, shared),
            ("serial-rounds-padded", serial.replace("PAD", pad), False, rounds),
            ("single-rounds", single_rounds_03(sol03), False, "loop by loop")):
        name = f"redteam-rounds-{variant}"
        shutil.rmtree(scratch / name, ignore_errors=True)
        step = stage_folder(scratch / name, "03", "solutions/03-openmp")
        text = between(sol03, "  const model::Event none", "  // EXERCISE 3", body)
        if text is None or not body:
            print(f"SKIP {name}: stage 03's solution changed shape", flush=True)
            continue
        step.write_text(text.replace("#include <omp.h>", "#include <omp.h>\n\n#include <algorithm>"
                                     "\n#include <atomic>"))
        gradings.append((name, "03", honest, None, why))
    name = "redteam-rounds-compare-then-skip"
    skip = ("        if (resolved[o]) continue;\n", "        if (earlier(e, b)) b = e;")
    if all(x in sol03 for x in skip):
        shutil.rmtree(scratch / name, ignore_errors=True)
        stage_folder(scratch / name, "03", "solutions/03-openmp").write_text(
            sol03.replace(skip[0], "").replace(skip[1],
                                               "        if (earlier(e, b) && !resolved[o]) b = e;"))
        gradings.append((name, "03", False, None, rounds))
    else:
        print(f"SKIP {name}: stage 03's solution changed shape", flush=True)
    name = "redteam-rounds-padded"
    shutil.rmtree(scratch / name, ignore_errors=True)
    stage_folder(scratch / name, "03", "solutions/03-openmp").write_text(PADDED_03)
    gradings.append((name, "03", False))
    head, entry = "void step(const Box& box, Particles& p) {", "/// Stage 03's entry point"
    for variant, cond, order, why in (
            ("where-counted", 'std::getenv("LD_PRELOAD") != nullptr', "EventOrder()(b, a)", rounds),
            ("large-only", "p.size() >= 5000", "model::key_less(b, a)",
             "made no comparisons with earlier()"),
            ("timed-other", f"p.size() != {PERF_N}", "model::key_less(b, a)", TIMED)):
        name = f"redteam-rounds-{variant}"
        if head not in sol03 or entry not in sol03:
            print(f"SKIP {name}: stage 03's solution changed shape", flush=True)
            continue
        shutil.rmtree(scratch / name, ignore_errors=True)
        stage_folder(scratch / name, "03", "solutions/03-openmp").write_text(
            sol03.replace(head, "void rounds_step(const Box& box, Particles& p) {")
            .replace(entry, ELSEWHERE_03.replace("COND", cond).replace("ORDER", order))
            .replace("#include <omp.h>", "#include <omp.h>\n\n#include <cstdlib>\n#include <queue>"))
        gradings.append((name, "03", why == TIMED, None, why))
    name = "redteam-rounds-burner"
    entry = "/// Stage 03's entry point"
    if "void step(const Box& box, Particles& p) {" in sol03 and entry in sol03:
        shutil.rmtree(scratch / name, ignore_errors=True)
        step = stage_folder(scratch / name, "03", "solutions/03-openmp")
        step.write_text(sol03.replace("#pragma omp", "// (serial) #pragma omp")
                        .replace("void step(const Box& box, Particles& p) {",
                                 "void serial_step(const Box& box, Particles& p) {")
                        .replace(entry, BURNER_03)
                        .replace("#include <omp.h>", "#include <omp.h>\n\n#include <atomic>\n#include <thread>"))
        gradings.append((name, "03", False))
    else:
        print(f"SKIP {name}: stage 03's solution changed shape", flush=True)
    return gradings


def rounds_07():
    """Stage 07's gradings of case rounds-07: the linear scan for the next event (too slow), and
    a library set kept beside the given heap (as fast, but not the queue: its probe fails)."""
    name = "redteam-rounds-linear-07"
    shutil.rmtree(scratch / name, ignore_errors=True)
    step = stage_folder(scratch / name, "07", "solutions/07-event-driven")
    text = between(step.read_text(), "    const int k = at_[e.i];", "  }\n", LINEAR_07)
    if text is None:
        print(f"SKIP {name}: stage 07's solution changed shape", flush=True)
        return []
    step.write_text(text)
    gradings = [(name, "07", False)]
    # A library queue (std::set) beside the given heap, top() read from it: O(log N) an event, so
    # as fast as the heap, and the right output; the queue's probe reads heap_ and at_
    name = "redteam-rounds-set-07"
    shutil.rmtree(scratch / name, ignore_errors=True)
    step = stage_folder(scratch / name, "07", "solutions/07-event-driven")
    sol = step.read_text()
    start, end = sol.find("  void set(const Event& e) {"), sol.find("\n private:")
    top = "[[nodiscard]] const Event& top() const { return events_[heap_[0].i]; }"
    made = "      at_[i] = i;\n    }\n  }"
    if min(start, end) < 0 or top not in sol or made not in sol:
        print(f"SKIP {name}: stage 07's solution changed shape", flush=True)
        return gradings
    text = (sol[:start] + SET_07 + sol[end:]).replace(
        top, "[[nodiscard]] const Event& top() const { return events_[order_.begin()->second]; }")
    text = text.replace(made, "      at_[i] = i;\n      order_.insert({model::never(), i});\n"
                              "    }\n  }", 1)
    step.write_text(text.replace("#include <vector>",
                                 "#include <set>\n#include <utility>\n#include <vector>", 1))
    gradings.append((name, "07", False, None, "the grader's probe of the event queue"))
    return gradings


def rubric_08(name, **idea):
    """rubric.json without refused calls, with stage 08's idea test changed by `idea` (and, when
    the work checks are off, without the correctness runs' work check either)."""
    rubric = json.loads(without_refused_calls().read_text())
    rubric["stages"]["08-ranks3"]["idea"].update(idea)
    if idea.get("max_work_multiple"):
        rubric["correctness"].pop("ranks_work", None)
    path = scratch / f"rubric-{name}.json"
    path.write_text(json.dumps(rubric))
    return path


def rounds_08():
    """Stage 08's gradings of case rounds-08: rank 0 steps everything (the solution's step renamed,
    and a step around it). The gather on rank 0 every step is stopped by the bytes; rank 0 taking
    every particle once and stepping them alone, by the driver's check of the owners. Every rank
    stepping every particle after one all-gather is stopped twice over: by the work in all,
    graded with the bytes' most as it was when that check was written (20, no multiple of the
    solution's), and by the bytes
    alone, the work checks off: what a stepper of the student's own, fast enough to pass them
    (a red team's, 2.5 times the kit's, scored 164 of 164 so in 2026-12-07's first session),
    meets; and the same with its all-gather made in place (MPI_IN_PLACE, which the kit once
    counted as nothing: a red team's 164 of 164 in the second session). The fastest speed summed
    over the ranks instead of its maximum (the same output, about 3 times the bytes) is stopped
    by the bytes against the kit's solution's. The solution itself, graded the same way, keeps
    every point."""
    gradings = []
    bytes_over = "bytes a particle and step (at most"
    slow = rubric_08("08-work", max_bytes_per_particle_step=20, max_bytes_multiple=1e9)
    fast = rubric_08("08-fast", share=0, max_share=1, max_work_share=1, min_work_multiple=0,
                     max_work_multiple=1e9)
    for cheat, step, rubric, why in (
            ("gather", GATHER_08, None, bytes_over),
            ("barrier", WAIT_08, None, "owns particle"),
            ("redundant", REDUNDANT_08, slow, "work outside MPI calls in all"),
            ("redundant-fast", REDUNDANT_08, fast, bytes_over),
            ("redundant-in-place-fast", REDUNDANT_IN_PLACE_08, fast, bytes_over)):
        name = f"redteam-rounds-{cheat}-08"
        shutil.rmtree(scratch / name, ignore_errors=True)
        if patched(name, "08", "solutions/08-mpi", [(
                "void step(const Box& box, const Ranks& r, Local& s) {",
                "void real_step(const Box& box, const Ranks& r, Local& s) {"),
                ("}  // namespace plab::dist\n", step),
                ("#include <vector>\n", "#include <cstring>\n#include <vector>\n")],
                f"stage 08's solution no longer has the shape the {cheat} patch needs"):
            gradings.append((name, "08-ranks3", False, rubric, why))
    # A slip, not a cheat: the fastest speed summed over the ranks (MPI_SUM for MPI_MAX), so the
    # reach and the halo are about 3 times larger on 3 ranks, and the output is the same
    name = "redteam-rounds-sum-08"
    shutil.rmtree(scratch / name, ignore_errors=True)
    if patched(name, "08", "solutions/08-mpi", [("MPI_DOUBLE, MPI_MAX, r.comm",
                                                 "MPI_DOUBLE, MPI_SUM, r.comm")],
               "stage 08's solution no longer reduces the fastest speed with MPI_MAX"):
        gradings.append((name, "08-ranks3", False, None, "times the kit's solution's"))
    # The control: the solution itself keeps every point, its idea test passed (0.19 bytes a
    # particle and step on the idea scene, each rank 25% to 40% of the work).
    name = "redteam-rounds-honest-08"
    shutil.rmtree(scratch / name, ignore_errors=True)
    patched(name, "08", "solutions/08-mpi", [], "")
    gradings.append((name, "08-ranks3", True, None, None))
    return gradings


def case_rounds(sid):
    """The idea tests that count (stage 03's OpenMP synchronisations against the rounds its scene
    needs, stage 08's bytes in any MPI call) and stage 07's event queue, each graded alone; one
    case a stage (rounds-03, rounds-07, rounds-08, so that CTest runs them side by side): 03
    that selects its events sequentially after a parallel phase, 03 that does so with its parallel
    phase split into 64 loops a step (a count that does not follow the rounds), 03 that keeps a thread burning
    CPU beside a serial step, 03 whose rounds run on one thread inside a parallel region a round
    while the other thread spins (the synchronisations follow the rounds, the CPU time is shared:
    its comparisons are not), the same with the spinner comparing events too, 03 that compares a
    candidate before asking whether its partner is resolved (the right output, not the rounds'
    comparisons), 03 whose rounds are each made in `single` by whichever thread comes first, 03
    that selects in rounds only where it guesses it is counted (a library preloaded, or 5000
    particles and more) and with a heap on one thread elsewhere, 07
    with a linear scan for the next event, 07 with a library set beside the given heap, 08 whose
    rank 0 steps everything through gathers and scatters must score nothing on correctness; 03 written as one parallel region with `omp for`
    loops inside (runtime and static schedules) keeps every correctness point; and 03 that
    selects with a heap only on the timed scene's N keeps its correctness points but none of the
    performance test's."""
    gradings = {"03": rounds_03, "07": rounds_07, "08": rounds_08}[sid]()
    for name, key, honest, *variant in gradings:
        rubric, why = variant or (None, None)
        tests, doc, _ = grade(name, scratch / name, key, "--no-races",
                              *(("--rubric", str(rubric)) if rubric else ()))
        idea = next((t for n, t in tests.items() if n.startswith(f"{key[:2]}: idea")), None)
        mine = correctness(tests, key)
        got = sum(t["score"] for t in mine.values())
        most = sum(t["max_score"] for t in mine.values())
        broken = [t["output"] for t in mine.values() if unbuilt(t["output"])]
        said = (idea or {}).get("output", "none")[:400]
        check("rounds", bool(mine) and not broken, f"{name} was graded and compiles: {broken[:1]}")
        timed = tests.get(f"{key}: performance", {})
        if honest and why == TIMED:  # right everywhere but where it is timed: no speed points
            check("rounds", idea is not None and idea["status"] == "passed" and got == most and
                  timed.get("score") == 0 and TIMED in timed.get("output", ""),
                  f"{name} scored {got} of {most} on correctness, {timed.get('score')} on "
                  f"performance: {timed.get('output', 'not run')[:300]!r}")
        elif honest:
            check("rounds", idea is not None and idea["status"] == "passed" and got == most,
                  f"{name} (honest) scored {got} of {most}; its idea test: {said!r}")
        else:
            check("rounds", idea is not None and idea["status"] == "failed" and got == 0,
                  f"{name} scored {got} of {most} on correctness; its idea test: {said!r}")
            if why:  # stopped by the check it is graded for
                check("rounds", why in said, f"{name}'s idea test fails on {why!r}: {said!r}")
    if sid == "08":
        largest_08()


def largest_08():
    """Stage 08 that steps its slab on the idea test's scene only (the largest it is given): its
    idea test passes there, but the scenes where the kit can judge the ranks' work (random-1000,
    random-2000) catch the gathers on rank 0, and the whole folder then scores nothing, as when
    the idea test fails."""
    name = "redteam-rounds-largest-08"
    shutil.rmtree(scratch / name, ignore_errors=True)
    if patched(name, "08", "solutions/08-mpi", [(
            "void step(const Box& box, const Ranks& r, Local& s) {",
            "void real_step(const Box& box, const Ranks& r, Local& s) {"),
            ("}  // namespace plab::dist\n", LARGEST_08)],
            "stage 08's solution no longer has the shape the largest-scene patch needs"):
        tests, doc, _ = grade(name, scratch / name, "08-ranks3", "--no-races")
        idea = next((t for n, t in tests.items() if n.startswith("08: idea")), {})
        mine = correctness(tests, "08-ranks3")
        got = sum(t["score"] for t in mine.values())
        caught = [n for n, t in mine.items() if n.endswith(("random-1000", "random-2000"))
                  and "of the work of the steps" in t["output"]]
        check("rounds", idea.get("status") == "failed" and "on the correctness scene" in
              idea.get("output", "") and got == 0 and caught,
              f"{name} scored {got} on correctness (must be 0); random-1000, random-2000 caught: "
              f"{caught}; its idea test: {idea.get('output', 'none')[:300]!r}")


def case_ties():
    """Stage 02 whose heap orders its events by time only (not model.md's whole key): the hidden
    tie scenes must cost it points (hidden-ties: every draw holds a wall-and-pair tie whose pair
    has the lower index, which only the key's kind decides). Stage 07 whose queue compares times
    only (a heap still, in its own order): the disks hit by two at one instant
    (hidden-converging, and the public simultaneous-hits) must cost it those points, and the
    idea test's probe of the queue, which asks the queue's order at equal times too, fails it
    and says so."""
    name = "redteam-ties"
    shutil.rmtree(scratch / name, ignore_errors=True)
    root = patched(name, "02", "solutions/02-heap", [(
        "  MinHeap<model::Event, EventOrder> heap;", """  struct ByTime {
    bool operator()(const model::Event& a, const model::Event& b) const { return a.t < b.t; }
  };
  MinHeap<model::Event, ByTime> heap;""")],
        "stage 02's solution no longer orders its heap with plab::EventOrder")
    # and stage 07 whose event queue compares times only (no particle index at equal times)
    root07 = patched(name, "07", "solutions/07-event-driven", [(
        "return a.t < b.t || (a.t == b.t && a.i < b.i);", "return a.t < b.t;")],
        "stage 07's solution no longer orders its queue by time, then particle")
    if root is None or root07 is None:
        return
    tests, doc, _ = grade(name, scratch / name, "02,07", "--no-races")
    ties = tests.get("02: hidden hidden-ties", {})
    check("ties", ties.get("score", 1) == 0,
          f"a time-only heap got {ties.get('score')} of {ties.get('max_score')} on hidden-ties: "
          f"{ties.get('output', '')[:200]!r}")
    for test in ("07: hidden hidden-converging", "07: public simultaneous-hits"):
        got = tests.get(test, {})
        # (and its output holds no stepped-model oracle's account: stage 07 is another model)
        check("ties", got.get("score", 1) == 0 and "the reference has" not in got.get("output", ""),
              f"stage 07 with a time-only queue got {got.get('score')} of {got.get('max_score')} "
              f"on {test}: {got.get('output', '')[:200]!r}")
    # A heap still, in its own order: the queue's probe asks the queue's order too, and names it
    idea = next((t for n, t in tests.items() if n.startswith("07: idea")), {})
    check("ties", idea.get("status") == "failed"
          and "at the same time, the lower particle" in idea.get("output", ""),
          f"stage 07 with a time-only queue: its idea test {idea.get('output', 'none')[:300]!r}")


def case_leaderboard():
    """The leaderboard is what the grader measured: a stage 02 that claims 1e-6 s gets its real
    median time, the one its performance test reports."""
    name = "redteam-leaderboard"
    shutil.rmtree(scratch / name, ignore_errors=True)
    root = patched(name, "02", "solutions/02-heap", [
        ("#include <queue>", "#include <cstdio>\n#include <queue>"),
        ("void step(const Box& box, Particles& p) {",
         "void step(const Box& box, Particles& p) {\n  static bool said = false;\n"
         "  if (!said) std::printf(\"time: 0.000001 s\\n\"), "
         "std::fprintf(stderr, \"elapsed 0.000001 s\\n\");\n  said = true;")],
        "stage 02's solution changed shape")
    if root is None:
        return
    tests, doc, _ = grade(name, scratch / name, "02", "--no-races")
    perf = tests.get("02: performance", {})
    board = {e["name"]: e for e in doc.get("leaderboard", [])}
    mine = board.get("02: time (s)", {})
    said = re.search(r"median ([0-9.]+) s", perf.get("output", ""))
    check("leaderboard", perf.get("score", 0) > 0 and said is not None
          and mine.get("order") == "asc" and mine.get("value", 0) > 1e-4
          and abs(mine["value"] - float(said.group(1))) < 1e-3,
          f"leaderboard {doc.get('leaderboard')}, performance test {perf.get('output', '')[:120]!r}")
    # and the ratio a class is ranked by: the measured time over the reference's
    ratio = board.get("02: time / reference", {})
    stated = re.search(r"\(ratio ([0-9.]+);", perf.get("output", ""))
    check("leaderboard", stated is not None and ratio.get("order") == "asc"
          and abs(ratio.get("value", -1) - float(stated.group(1))) < 6e-3,
          f"leaderboard {doc.get('leaderboard')}, performance test {perf.get('output', '')[:160]!r}")


def case_bypass():
    """Code that goes around what the kit measures through, read from the compiled objects: stage
    08 with one collective through the MPI profiling interface (PMPI_Allreduce, which kit/mpi's
    byte count does not see), hidden behind a macro; stage 03 defining an OpenMP library function
    itself. Both are refused before they run: correctness 0, the reason in the output."""
    name = "redteam-bypass"
    shutil.rmtree(scratch / name, ignore_errors=True)
    r08 = patched(name, "08", "solutions/08-mpi", [
        ("double fastest_anywhere(", "#define PLAB_VIA(call) P##call\ndouble fastest_anywhere("),
        ("  MPI_Allreduce(&mine, &all,", "  PLAB_VIA(MPI_Allreduce)(&mine, &all,")],
        "stage 08's solution changed shape")
    r03 = patched(name, "03", "solutions/03-openmp", [
        ("#include <omp.h>", "#include <omp.h>\nextern \"C\" int omp_get_max_threads() { return 2; }")],
        "stage 03's solution changed shape")
    if r08 is None or r03 is None:
        return
    tests, doc, _ = grade(name, scratch / name, "03,08", "--no-races")
    for sid, symbol in (("08", "PMPI_Allreduce"), ("03", "omp_get_max_threads")):
        got = sum(t["score"] for t in correctness(tests, sid).values())
        said = next((t["output"] for t in correctness(tests, sid).values()), "")
        check("bypass", got == 0 and symbol in said and "goes around what the kit measures" in said,
              f"stage {sid} with {symbol} scored {got} on correctness; its output: {said[:300]!r}")


def case_heap():
    """Stage 02 without a binary heap of its own, its outputs right: heap.hpp's MinHeap on the
    library's heap (std::push_heap / std::pop_heap: the same arrays on random keys, fewer
    comparisons), on a std::multiset (its items() the sorted order), and the kit's own heap with
    a step that sorts its candidates instead (the heap unused). Each must lose every correctness
    point through the idea test's heap checks, with their reason."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
    from heap_shortcuts import shortcut_heaps, sorting_step  # the probe's own check uses them
    heaps = shortcut_heaps((kit / "solutions/02-heap/heap.hpp").read_text())
    for label, said in (("library heap", "fewer than the binary heap's moves make"),
                        ("multiset", "a binary heap's array is"),
                        ("sorting step", "the step's events must come from your MinHeap")):
        name = f"redteam-heap-{label.replace(' ', '-')}"
        root = scratch / name
        shutil.rmtree(root, ignore_errors=True)
        folder = root / "stages" / FOLDERS["02"]
        shutil.copytree(kit / "solutions/02-heap", folder)
        if label == "sorting step":  # the kit's heap, right; the step sorts its events instead
            (folder / "step.cpp").write_text(sorting_step((folder / "step.cpp").read_text()))
        else:
            (folder / "heap.hpp").write_text(heaps[label][0])
        tests, doc, _ = grade(name, root, "02", "--no-races")
        idea = next((t for n, t in tests.items() if n.startswith("02: idea")), {})
        got = sum(t["score"] for t in correctness(tests, "02").values())
        check("heap", idea.get("status") == "failed" and said in idea.get("output", "") and
              got == 0, f"stage 02 with its {label} scored {got} on correctness; its idea "
              f"test: {idea.get('output', 'none')[-300:]!r}")
        print(f"stage 02 with its {label}: 0 on correctness; its idea test: "
              f"{idea.get('output', '')[-160:]}")


CASES = {"copy": case_copy, "escape": case_escape, "processes": case_processes,
         "oracle": case_oracle, "mpi": case_mpi, "control": case_control, "ideas": case_ideas,
         "shortcuts": case_shortcuts, "links": case_links, "gpu-ideas": case_gpu_ideas,
         "rounds-03": lambda: case_rounds("03"), "rounds-07": lambda: case_rounds("07"),
         "rounds-08": lambda: case_rounds("08"), "ties": case_ties, "leaderboard": case_leaderboard,
         "bypass": case_bypass, "heap": case_heap}
if only - set(CASES):
    sys.exit(f"grader_redteam.py: no case {sorted(only - set(CASES))}; the cases: {', '.join(CASES)}")
scratch.mkdir(parents=True, exist_ok=True)
try:
    for name, case in CASES.items():
        if not only or name in only:
            case()
finally:
    for p in scratch.glob("redteam-*"):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
if failures:
    sys.exit("red-team failures:\n  " + "\n  ".join(failures))
print("every attack was stopped; the honest stage kept its marks")
