#!/usr/bin/env python3
"""Stage 05's branchless wall, as the grader measures it (kit/python/plab/grade/branches.py), on
the student's starting point with exercise 2 written seven ways: the kit's solution and a
select-only version must pass; calling model::wall_event() or the kit's BranchyWall (also from
a function kept out of line, or through a function pointer), or writing the event with if/else,
must fail (the same bits, but the warp splits). Compiles with nvcc to PTX
only: no GPU needed. Exit 0 when every case is judged as it should be, 1 otherwise, 77 (skipped)
without nvcc.

  branchless_check.py SOURCE_DIR --nvcc PATH
"""
import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

from plab.grade import branches

FLAGS = """    const model::WallTimesOf<Real> w = model::wall_times(x, y, vx, vy, L, r);
    const Real e = model::wall_time(w);
"""
CASES = {  # name: (body of BranchlessWall's call operator, passes)
    "selects": (FLAGS + """    const bool fx = w.tx == e, fy = w.ty == e;
    const Real later = (fx && fy) ? Real(1) : (fx ? w.ty : w.tx);
    const Real m = ((later < 1) ? later : Real(1)) - e;
    x = x + e * vx;
    y = y + e * vy;
    vx = fx ? -vx : vx;
    vy = fy ? -vy : vy;
    x = x + m * vx;
    y = y + m * vy;
    wc = wc + 1;
""", True),
    "wall_event": ("    model::wall_event(x, y, vx, vy, wc, L, r);\n", False),
    "BranchyWall": ("    BranchyWall{}(x, y, vx, vy, wc, L, r);\n", False),
    # model::wall_event() behind a function the compiler may not inline (its own .func)
    "noinline": ("""    struct Hidden {
      static __noinline__ __device__ void wall(Real& x, Real& y, Real& vx, Real& vy,
                                               long long& wc, Real L, Real r) {
        model::wall_event(x, y, vx, vy, wc, L, r);
      }
    };
    Hidden::wall(x, y, vx, vy, wc, L, r);
""", False),
    # ... or through a function pointer the grader cannot follow
    "pointer": ("""    struct Hidden {
      static __device__ void wall(Real& x, Real& y, Real& vx, Real& vy, long long& wc, Real L,
                                  Real r) {
        model::wall_event(x, y, vx, vy, wc, L, r);
      }
    };
    void (*volatile f)(Real&, Real&, Real&, Real&, long long&, Real, Real) = &Hidden::wall;
    f(x, y, vx, vy, wc, L, r);
""", False),
    "if-else": (FLAGS + """    const bool fx = w.tx == e, fy = w.ty == e;
    Real later;
    if (fx && fy) later = 1; else if (fx) later = w.ty; else later = w.tx;
    Real m;
    if (later < 1) m = later - e; else m = 1 - e;
    x = x + e * vx;
    y = y + e * vy;
    if (fx) vx = -vx;
    if (fy) vy = -vy;
    x = x + m * vx;
    y = y + m * vy;
    wc = wc + 1;
""", False),
}


def with_body(start, body):
    """The starting point's kernels.cuh with exercise 2's comment replaced by `body`."""
    lines = start.splitlines(keepends=True)
    first = next(k for k, ln in enumerate(lines) if ln.startswith("    // EXERCISE 2:"))
    last = first
    while lines[last + 1].startswith("    //"):
        last += 1
    return "".join(lines[:first]) + body + "".join(lines[last + 1:])


def judge(nvcc, source, kernels, folder):
    folder.mkdir(parents=True)
    (folder / "kernels.cuh").write_text(kernels)
    (folder / branches.SOURCE).write_text(branches.PROBE)
    r = subprocess.run(branches.nvcc_command(nvcc, source / "kit/include", folder),
                       capture_output=True, text=True)
    if r.returncode != 0:
        return "did not compile", r.stderr[-800:]
    return branches.judge((folder / branches.OUTPUT).read_text())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", type=pathlib.Path)
    ap.add_argument("--nvcc")
    a = ap.parse_args()
    if not a.nvcc or not shutil.which(a.nvcc):
        print("SKIP: no nvcc (the kit was configured without CUDA)")
        return 77
    start = (a.source / "stages/05-cuda-streams/kernels.cuh").read_text()
    cases = {"solution": ((a.source / "solutions/05-cuda-streams/kernels.cuh").read_text(), True)}
    cases.update({name: (with_body(start, body), ok) for name, (body, ok) in CASES.items()})
    bad = 0
    with tempfile.TemporaryDirectory(prefix="plab-branchless-") as tmp:
        for name, (kernels, should_pass) in cases.items():
            problem, measured = judge(a.nvcc, a.source, kernels, pathlib.Path(tmp) / name)
            if problem == "did not compile":
                print(f"FAIL {name}: the probe did not compile:\n{measured}")
                bad += 1
                continue
            right = (problem is None) == should_pass
            bad += not right
            print(f"{'ok  ' if right else 'FAIL'} {name}: {'passes' if problem is None else 'fails'}"
                  f" (should {'pass' if should_pass else 'fail'}): {measured}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
