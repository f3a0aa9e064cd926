#!/usr/bin/env python3
"""Shortcut tests (CTest label shortcut, with release so that CI runs it): no exercise's answer is
in what a student receives.

Writes the files of a student release of the kit's HEAD (plab.grade.release --files-only: the
very selection `plab release` ships, without its build), then compiles, against that release
alone, "shortcut" stages: a stage whose EXERCISEs are done by calling a function that does them,
named from the instructor's kit (greedy_plan() and apply() for stages 01-03, the team's selection
for 06, model::contact_response() for 07, the CUDA rounds for 04-05, the MPI collectives for 08),
or from a public header that a later stage may use but not this one (the device arrays' copies and
DeviceParticles in stage 04).
Each must fail to compile, and the compiler's error must name the missing function or header (not
some unrelated mistake): an honest control file, built the same way with the same compiler,
must compile. A CUDA shortcut needs nvcc (compile only, no GPU), an MPI one MPI's headers; without
them they are reported as skipped. Exit 0 when every shortcut that could be compiled failed as it
should; 1 otherwise, naming each that compiled.

  shortcut_check.py SOURCE_DIR [--nvcc PATH] [--only ID,ID] [--keep DIR]
"""
import argparse
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

# The stages' common lines: a CPU stage's entry point around a step() body.
CPU = """#include <vector>
{includes}
#include "plab/stage.hpp"

namespace plab {{
void step(const Box& box, Particles& p) {{
  const int n = static_cast<int>(p.size());
{body}
}}
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {{
  return cpu_stage(box, p, options, {{step}});
}}
}}  // namespace plab
"""
# Every candidate of the step, as the oracle lists them.
CANDIDATES = """  std::vector<model::Event> events;
  for (int i = 0; i < n; ++i) {
    const model::Event w = wall_candidate(box, p, i);
    if (model::in_step(w.t)) events.push_back(w);
    for (int j = i + 1; j < n; ++j) {
      const model::Event e = pair_candidate(box, p, i, j);
      if (model::in_step(e.t)) events.push_back(e);
    }
  }
"""
GREEDY = CANDIDATES + "  apply(box, p, greedy_plan(events, p.size()));\n"
# What an honest stage may use: the candidates, a plan, apply_one().
HONEST = CANDIDATES + """  Plan plan;
  plan.reset(n);
  for (const model::Event& e : events) (void)e;
  for (int i = 0; i < n; ++i) apply_one(box, p, plan, i);
"""

CUDA = """{includes}
#include "plab/model.hpp"
#include "plab/plan.hpp"

namespace plab {{
struct Arrays {{
  int* partner; double* time; double* wall; int* best;
}};
__global__ void shortcut(int n, Arrays a, double* x, double* y, double* vx, double* vy,
                         long long* wc, double L, double r) {{
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
{body}
}}
}}  // namespace plab
"""
CUDA_HONEST = """  model::free_move(x[i], y[i], vx[i], vy[i]);
  (void)a; (void)wc; (void)L; (void)r;"""

# Stage 04's to_device() (its exercise 1: cudaMalloc and cudaMemcpy of one field).
CUDA_HOST = """#include <vector>
{includes}
#include "plab/cuda/check.hpp"
#include "plab/cuda/particles.hpp"
#include "plab/scene.hpp"

namespace plab {{
template <class T>
T* to_device(const std::vector<T>& host) {{
{body}
}}
template double* to_device(const std::vector<double>&);
}}  // namespace plab
"""

MPI = """#include <vector>
#include "plab/mpi/ranks.hpp"

namespace plab::dist {{
void shortcut(const Ranks& r, std::vector<std::vector<int>>& out, bool open) {{
{body}
}}
}}  // namespace plab::dist
"""


# How g++ and nvcc say that a header or a name is not there.
MISSING = re.compile(r"No such file|cannot open source file|not declared|is not a member|"
                     r"is undefined|has no member|no matching function|no instance of|"
                     r"is not a template|wrong number of template arguments|too many template")


def shortcuts():
    """(id, compiler kind, source, what the error must name, stage) for each shortcut; the
    controls are the honest files of each compiler kind."""
    s = []
    for sid, inc in (("01", ""), ("02", "#include <queue>"), ("03", "#include <omp.h>")):
        s.append((f"{sid}-greedy", "cxx", CPU.format(includes=inc, body=GREEDY), r"greedy_plan", sid))
        s.append((f"{sid}-greedy-header", "cxx",
                  CPU.format(includes='#include "plab/greedy.hpp"', body=GREEDY),
                  r"plab/greedy\.hpp", sid))
    s.append(("06-sparse-greedy", "cxx", CPU.format(includes="", body="""  std::vector<model::Event> pairs;
  std::vector<double> wall(n);
  apply(box, p, sparse_greedy_plan(pairs, wall));"""), r"sparse_greedy_plan", "06"))
    s.append(("06-plan-team", "cxx", CPU.format(includes='#include "plab/plan_team.hpp"', body="""  std::vector<model::Event> mine;
  std::vector<double> wall(n);
  Plan plan;
  plan.reset(n);
  SparseSelection work;
  sparse_greedy_plan_in_team(mine, wall, plan, work);
  (void)box; (void)p;"""), r"plan_team\.hpp", "06"))
    s.append(("06-sweep", "cxx", CPU.format(includes='#include "plab/sweep.hpp"', body="""  int lo = 0, hi = 0;
  sweep::Grid g{};
  sweep::columns_within(p.x[0], 2 * box.r, g, lo, hi);
  (void)n;"""), r"sweep\.hpp", "06"))
    s.append(("07-contact-response", "cxx", CPU.format(includes="", body="""  if (n >= 2)
    model::contact_response(p.x[0], p.y[0], p.vx[0], p.vy[0], p.x[1], p.y[1], p.vx[1], p.vy[1]);
  (void)box;"""), r"contact_response", "07"))
    s.append(("04-rounds", "cuda", CUDA.format(includes='#include "plab/cuda/rounds.cuh"', body="""  const model::Event none = model::pair_event_key(model::never(), n, n);
  cuda::choose_one(i, a, none);
  (void)cuda::accept_one(i, a);
  (void)x; (void)y; (void)vx; (void)vy; (void)wc; (void)L; (void)r;"""),
              r"rounds\.cuh", "04"))
    # Stage 04's exercise 1 (the state in device memory) from the kit's device arrays: their
    # copies, or the particles on the device whole (DeviceParticles, stages 05 on).
    s.append(("04-device-array-copies", "cuda", CUDA_HOST.format(includes="", body="""  auto* device = new cuda::DeviceArray<T>(host.size());
  device->upload(host);
  return device->get();"""), r"upload", "04"))
    s.append(("04-device-particles", "cuda", CUDA_HOST.format(
        includes='#include "plab/cuda/stepper.hpp"', body="""  (void)host;
  return nullptr;
}
cuda::ParticlesView state(const Particles& p) {
  return (new cuda::DeviceParticles(p))->view();"""), r"stepper\.hpp", "04"))
    s.append(("05-resolve-block", "cuda", CUDA.format(includes='#include "plab/cuda/rounds.cuh"', body="""  cuda::resolve_block(n, a);
  (void)x; (void)y; (void)vx; (void)vy; (void)wc; (void)L; (void)r;"""),
              r"rounds\.cuh", "05"))
    s.append(("05-wall-branchless", "cuda", CUDA.format(includes="", body="""  model::wall_event_branchless(x[i], y[i], vx[i], vy[i], wc[i], L, r);
  (void)a;"""), r"wall_event_branchless", "05"))
    s.append(("05-apply-planned-branchless", "cuda", CUDA.format(includes="", body="""  struct {
    double *x, *y, *vx, *vy; long long *pc, *wc;
  } f{x, y, vx, vy, wc, wc};
  apply_planned<true>(f, a.partner, a.time, i, L, r);"""), r"apply_planned", "05"))
    s.append(("08-all-to-all", "mpi", MPI.format(body="""  std::vector<int> in = all_to_all(r, out);
  (void)in; (void)open;"""), r"all_to_all", "08"))
    s.append(("08-any-rank", "mpi", MPI.format(body="""  (void)any_rank(r, open);
  (void)out;"""), r"any_rank", "08"))
    return s


CONTROLS = {
    "cxx": CPU.format(includes="", body=HONEST),
    "cuda": CUDA.format(includes="", body=CUDA_HONEST),
    "mpi": MPI.format(body="  (void)r; (void)out; (void)open;"),
}


def compile_command(kind, release, source, stage, a, mpi_flags):
    inc = ["-I", str(release / "kit" / "include"), f'-DPLAB_STAGE_ID="{stage}"',
           f"-DPLAB_STAGE_NUMBER={int(stage)}"]  # as cmake/PlabStage.cmake defines them
    if kind == "cuda":
        return [a.nvcc, "-std=c++17", "--fmad=false", "-x", "cu", "-c", *inc, str(source),
                "-o", str(source.with_suffix(".o"))]
    extra = mpi_flags if kind == "mpi" else []
    return ["c++", "-std=c++20", "-fopenmp", "-ffp-contract=off", "-fsyntax-only", *inc, *extra,
            str(source)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", help="the instructor's kit (a git checkout; its HEAD is released)")
    ap.add_argument("--nvcc", default=shutil.which("nvcc") or "/usr/local/cuda/bin/nvcc")
    ap.add_argument("--only", default="", help="shortcut ids (or prefixes such as 01,07), comma-separated")
    ap.add_argument("--keep", help="write the release and the shortcut files here, and keep them")
    a = ap.parse_args()
    source = pathlib.Path(a.source).resolve()
    scratch = pathlib.Path(a.keep).resolve() if a.keep else pathlib.Path(tempfile.mkdtemp(prefix="plab-shortcut-"))
    release = scratch / "release"
    try:
        done = subprocess.run([sys.executable, "-m", "plab.grade.release",
                               "--kit-source", str(source), "--out", str(release), "--allow-dirty",
                               "--files-only"], capture_output=True, text=True,
                              env=dict(os.environ, PYTHONPATH=str(source / "kit" / "python")))
        if done.returncode != 0:
            print(f"shortcut_check: FAIL: the release could not be written:\n{done.stdout}{done.stderr}")
            return 1
        if (release / "solutions").exists() or (release / "kit" / "instructor").exists():
            print("shortcut_check: FAIL: the release holds solutions/ or kit/instructor/")
            return 1
        mpi_flags = []
        if shutil.which("mpicxx"):
            shown = subprocess.run(["mpicxx", "--showme:compile"], capture_output=True, text=True)
            mpi_flags = shown.stdout.split() if shown.returncode == 0 else []
        have = {"cxx": True, "cuda": bool(a.nvcc and os.access(a.nvcc, os.X_OK)),
                "mpi": bool(mpi_flags)}
        wanted = [w for w in a.only.split(",") if w]
        chosen = [s for s in shortcuts() if not wanted or any(s[0].startswith(w) for w in wanted)]
        work = scratch / "shortcuts"
        work.mkdir(parents=True, exist_ok=True)
        failures, skipped = [], []
        for kind in sorted({s[1] for s in chosen}):
            if not have[kind]:
                skipped.append(kind)
                continue
            ext = ".cu" if kind == "cuda" else ".cpp"
            control = work / f"control-{kind}{ext}"
            control.write_text(CONTROLS[kind])
            r = subprocess.run(compile_command(kind, release, control, "00", a, mpi_flags),
                               capture_output=True, text=True)
            if r.returncode != 0:
                print(f"shortcut_check: FAIL: the honest {kind} control does not compile in the "
                      f"release (so a failing shortcut proves nothing):\n{r.stderr[-3000:]}")
                return 1
            print(f"control ({kind}): an honest file compiles in the release")
        for sid, kind, text, must_name, stage in chosen:
            if kind in skipped:
                print(f"shortcut {sid}: skipped (no {'nvcc' if kind == 'cuda' else 'MPI'} here)")
                continue
            path = work / (sid + (".cu" if kind == "cuda" else ".cpp"))
            path.write_text(text)
            r = subprocess.run(compile_command(kind, release, path, stage, a, mpi_flags),
                               capture_output=True, text=True)
            # The error must be the shortcut's own line, saying that the name is missing (not an
            # error inside a header that is still there, which would be another failure).
            errors = [l for l in (r.stdout + r.stderr).splitlines()
                      if "error" in l and path.name in l.split("error")[0]]
            missing = [l for l in errors if re.search(must_name, l) and MISSING.search(l)]
            # A header that refuses the stage (#error naming itself and the exercise) says so on
            # its own line, the shortcut's #include the line after.
            missing += [l for l in (r.stdout + r.stderr).splitlines()
                        if "#error" in l and re.search(must_name, l)]
            if r.returncode == 0:
                failures.append(sid)
                print(f"shortcut {sid}: FAIL: it compiles in the student release "
                      f"(what it calls, {must_name.replace(chr(92), '')}, is still there)")
            elif not missing:
                failures.append(sid)
                shown = errors or (r.stdout + r.stderr).splitlines()
                print(f"shortcut {sid}: FAIL: it does not compile, but not because "
                      f"{must_name.replace(chr(92), '')} is missing:\n  " + "\n  ".join(shown[:4]))
            else:
                first = missing[0]
                print(f"shortcut {sid}: does not compile, as it should: "
                      f"{first.split(str(work) + '/')[-1].strip()}")
        if failures:
            print(f"shortcut_check: FAIL: {len(failures)} shortcut(s) compile or fail for another "
                  f"reason: {', '.join(failures)}")
            return 1
        print(f"shortcut_check: OK: {len(chosen)} shortcuts, none compiles in the student release"
              + (f" ({', '.join(skipped)} skipped)" if skipped else ""))
        return 0
    finally:
        if not a.keep:
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
