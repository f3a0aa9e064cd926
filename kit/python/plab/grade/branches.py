"""Stage 05's branchless wall event (its exercise 2), measured outside the student's code.

The tests compare bits, and the branchy model::wall_event() gives the same bits as a branchless
one: so the grader reads the code the compiler made. It compiles a probe of its own (PROBE) with
nvcc to PTX: one kernel calls the student's kernels::BranchlessWall on one particle, another does
only what the kit gives for it (model::wall_times() and model::wall_time(), whose `v == 0` tests
are branches of their own). A conditional branch (`@%p bra`) is a place where a warp can split;
the student's wall event may leave no more of them than the given part alone, counting the
branches of every function it calls (a `__noinline__` helper is its own `.func` in PTX); a call
through a pointer, which the grader cannot follow, fails. Measured with nvcc
13.0 (sm_90, --fmad=false): the given part leaves 4, the solution 4; model::wall_event() (the
kit's BranchyWall) 6, and the same event written with if/else 6.

No GPU is needed to compile (tests/branchless_check.py runs this on CI's machine); the grader
runs it in the sandbox, on the student's own stage folder, as part of stage 05's idea test.
"""
import re

#: The probe (the grader's own source, beside the student's kernels.cuh).
PROBE = r"""// The grader's probe of stage 05's branchless wall event (kit/python/plab/grade/branches.py).
#include "kernels.cuh"

extern "C" __global__ void plab_probe_given(double* x, double* y, double* vx, double* vy,
                                            long long* wc, double L, double r) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const plab::model::WallTimesOf<double> w = plab::model::wall_times(x[i], y[i], vx[i], vy[i], L, r);
  x[i] = plab::model::wall_time(w);
  y[i] = w.tx;
  vx[i] = w.ty;
  wc[i] = wc[i] + 1;
}

extern "C" __global__ void plab_probe_student(double* x, double* y, double* vx, double* vy,
                                              long long* wc, double L, double r) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  plab::kernels::BranchlessWall{}(x[i], y[i], vx[i], vy[i], wc[i], L, r);
}
"""

#: Where the probe is written, and its PTX, in the stage's folder of the sandbox's sources.
SOURCE, OUTPUT = "plab_branch_probe.cu", "plab_branch_probe.ptx"

_HEAD = re.compile(r"^\s*(?:\.visible\s+|\.weak\s+|\.extern\s+)*\.(entry|func)\s+"
                   r"(?:\([^)]*\)\s*)?(\w+)")
_COND_BRANCH = re.compile(r"^\s*@!?%p\d+\s+bra(\.uni)?\b")
_CALL = re.compile(r"^\s*call(\.uni)?\b")
_INDIRECT = "(indirect)"


def nvcc_command(nvcc, include, stage_dir, arch="90"):
    """The compiler's command line: the probe, in `stage_dir`, to PTX (the kit's flags)."""
    # The stage build's own definitions and optimisation (cmake/PlabStage.cmake, Release), so
    # that a header cannot tell the probe from the stage by them. Every path a whole argument:
    # the sandbox without namespaces rewrites those to the outside paths.
    return [str(nvcc), "-std=c++17", f"-arch=sm_{arch}", "--fmad=false", "-O3", "-DNDEBUG",
            '-DPLAB_STAGE_ID="05"', "-DPLAB_STAGE_NUMBER=5", "-ptx", "-I", str(include),
            "-I", str(stage_dir), f"{stage_dir}/{SOURCE}", "-o", f"{stage_dir}/{OUTPUT}"]


def functions(ptx):
    """{name: (conditional branches in its body, names it calls)} of the PTX's kernels and
    device functions; a call through a pointer is named "(indirect)"."""
    found, name, calls_of, pending = {}, None, {}, None
    lines = ptx.splitlines()
    names = {m.group(2) for m in map(_HEAD.match, lines) if m}
    for line in lines:
        m = _HEAD.match(line)
        if m:
            name = m.group(2)
            found.setdefault(name, 0)
            calls_of.setdefault(name, set())
            continue
        if name is None:
            continue
        if _COND_BRANCH.match(line):
            found[name] += 1
        if _CALL.match(line):
            pending = ""
        if pending is not None:  # a call's text runs to its `;` over several lines
            pending += " " + line
            if ";" in line:
                callees = set(re.findall(r"\w+", pending)) & names
                calls_of[name] |= callees or {_INDIRECT}
                pending = None
    return {n: (found[n], calls_of[n]) for n in found}


def conditional_branches(ptx):
    """{kernel or function name: conditional branches in it and in every function it calls,
    directly or not}; a call through a pointer counts as unbounded (infinity)."""
    funcs = functions(ptx)
    total = {}
    for root in funcs:
        seen, todo, count = set(), [root], 0
        while todo:
            f = todo.pop()
            if f in seen:
                continue
            seen.add(f)
            if f == _INDIRECT:
                count = float("inf")
                continue
            branches, calls = funcs.get(f, (0, set()))
            count += branches
            todo += calls
        total[root] = count
    return total


def judge(ptx, hint=""):
    """(problem or None, what was measured) for the probe's PTX."""
    counts = conditional_branches(ptx)
    given, mine = counts.get("plab_probe_given"), counts.get("plab_probe_student")
    if given is None or mine is None:
        return "the probe's PTX has not both kernels (the compiler's output was not read)", ""
    if mine == float("inf"):
        return ("its BranchlessWall calls a function through a pointer: the grader cannot see "
                f"what it runs. {hint}").strip(), "an indirect call"
    text = (f"its BranchlessWall leaves {mine} conditional branches in the compiled code (with "
            f"the functions it calls), the model's wall times alone {given}")
    if mine > given:
        return (f"{text}: the wall event itself branches ({mine - given} more; "
                f"model::wall_event() leaves 2 more, as does the same event written with "
                f"if/else). {hint}").strip(), text
    return None, text
