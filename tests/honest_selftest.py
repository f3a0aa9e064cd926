#!/usr/bin/env python3
"""Self-test of the honest answers a student gets (CTest label honest, long).

In a scratch copy of the kit that keeps only stage 01 (the starting point and the solution), it
breaks the student's stage in the ways students do and checks what `plab test` and `plab run` say:

  * a stage that does not compile fails its tests with "stage 01 did not compile" and the
    compiler's first error (file:line), and its last good binary is not tested; fixed, it passes;
  * an endless loop (`break` turned into `continue`) ends within its limit, naming the scene and
    the step; `plab run --timeout` ends it too, nothing left running;
  * the untouched starting point says once that its exercise is not done, in its own words;
  * a stage that starts another program (the compiled reference) is refused by its first test;
  * a test that checked no case (no reference stage to compare with) is counted as skipped;
  * a wrong comparison (model::key_less's arguments swapped) gives a report of at most 40 lines
    with the commands that reproduce and draw the first difference.

The real stages/ is never touched; the scratch copy is removed whatever the outcome.
Usage: honest_selftest.py KIT_SOURCE WORK_DIR
"""
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

KIT = Path(sys.argv[1]).resolve()
WORK = Path(sys.argv[2]).resolve()
COPY = WORK / "kit"
TOKEN = f"{os.getpid()}-{time.time_ns()}"  # marks the processes this self-test starts
STEP = COPY / "stages" / "01-naive" / "step.cpp"
SOLUTION = (KIT / "solutions" / "01-naive" / "step.cpp").read_text()
failures = []


def check(name, condition, detail):
    """Records one check; on failure keeps what was seen."""
    print(("ok   " if condition else "FAIL ") + name, flush=True)
    if not condition:
        failures.append(f"{name}:\n{detail}")


def make_copy():
    """The kit without build/, .git and every stage but 01, configured (CUDA off)."""
    shutil.rmtree(WORK, ignore_errors=True)
    ignore = shutil.ignore_patterns("build", ".git", "build-*", "*.log")
    shutil.copytree(KIT, COPY, ignore=ignore)
    for tree in ("stages", "solutions"):
        for d in (COPY / tree).iterdir():
            if d.is_dir() and not d.name.startswith("01-"):
                shutil.rmtree(d)
    subprocess.run(["cmake", "--preset", "release", "-DPLAB_ENABLE_CUDA=OFF"], cwd=COPY,
                   check=True, stdout=subprocess.DEVNULL)
    rc, out = plab("--help", timeout=1500)  # the first build: the kit and stage 01
    if rc != 0:
        raise RuntimeError("the scratch copy did not build:\n" + out)


def plab(*args, timeout=600, env=None):
    """Runs ./plab in the copy (it builds first, as for a student); returns (status, text).
    At the timeout its whole process group (the build, ctest, the tests) is ended."""
    e = dict(os.environ, **(env or {}), PLAB_HONEST_SELFTEST=TOKEN)
    p = subprocess.Popen(["./plab", *args], cwd=COPY, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, env=e, start_new_session=True)
    try:
        out, _ = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, _ = p.communicate()
        return 124, out + f"\n(ended by the self-test after {timeout} s)"
    return p.returncode, out


def leftovers():
    """Processes that this self-test's plab calls started and that still run: they carry its
    TOKEN in their environment. (Not "any process running the copy's programs": the red team's
    control case, beside it in CI, finds and runs every plab-run-* program on the machine.)"""
    left = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit() or int(proc.name) == os.getpid():
            continue
        try:
            if f"PLAB_HONEST_SELFTEST={TOKEN}".encode() not in (proc / "environ").read_bytes():
                continue
            args = (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:  # ended meanwhile, or not ours to read
            continue
        left.append(f"{proc.name} {args}")
    return left


def broken_compile():
    STEP.write_text(SOLUTION)
    rc, out = plab("test", "--impl", "student", "--stage", "01")
    check("the solution copied into stages/ passes", rc == 0, out)
    STEP.write_text(SOLUTION + "\nthis line is not C++\n")
    rc, out = plab("test", "--impl", "student", "--stage", "01")
    check("a broken stage fails", rc != 0, out)
    check("... saying that it did not compile, with file:line",
          re.search(r"stage 01 did not compile: stages/01-naive/step\.cpp:\d+:\d+: error", out), out)
    check("... and its old binary is not tested",
          "passed   stage01.student.Golden" not in out and "100% tests passed" not in out, out)
    rc, out = plab("run", "--stage", "01", "--impl", "student", "datasets/scenes/course-1.in")
    check("plab run refuses the old binary", rc != 0 and "did not compile" in out, out)
    STEP.write_text(SOLUTION)
    rc, out = plab("test", "--impl", "student", "--stage", "01")
    check("fixed again, it passes again", rc == 0, out)


def endless_loop():
    looping = SOLUTION.replace("if (!model::in_step(best.t)) break;",
                               "if (!model::in_step(best.t)) continue;")
    assert looping != SOLUTION, "the loop's exit is not where this test expects it"
    STEP.write_text(looping)
    t0 = time.monotonic()
    rc, out = plab("test", "--impl", "student", "--stage", "01", env={"PLAB_STALL_SECONDS": "5"})
    took = time.monotonic() - t0
    check("an endless loop fails within its limit", rc != 0 and took < 120, f"{took:.0f} s\n{out}")
    check("... naming the stage, the scene and the step",
          re.search(r"stage 01, scene [\w-]+: .*step.*then nothing for \d+ s: an endless loop\?", out),
          out)
    rc, out = plab("run", "--stage", "01", "--impl", "student", "--timeout", "3",
                   "datasets/scenes/course-1.in")
    check("plab run --timeout ends it with status 124 and where it was",
          rc == 124 and re.search(r"stopped at the --timeout of 3 s, after step \d+ of \d+", out), out)
    time.sleep(1)
    check("... and nothing is left running", not leftovers(), "\n".join(leftovers()))


def not_done():
    rc, out = plab("test", "--impl", "student", "--stage", "01")  # the untouched starting point
    said = re.findall(r"stage 01: EXERCISE 1 \([^)]+\) is not done yet", out)
    check("an untouched starting point fails, saying what is not done", rc != 0 and said, out)
    check("... once for all its golden scenes, not once a scene",
          re.search(r"all \d+ scenes failed: stage 01: EXERCISE 1", out) and len(said) <= 6, out)
    check("... in its own words (not GoogleTest's 'C++ exception with description')",
          "C++ exception" not in out, out)


def reference_refused():
    # the shortcut a student found: the step asks the compiled reference for each step's events
    STEP.write_text('#include <cstdlib>\nstatic const int asked = std::system('
                    '"kit/reference/bin/plab-reference s.in --explain 0:0 --json");\n' + SOLUTION)
    rc, out = plab("test", "--impl", "student", "--stage", "01")
    check("a stage that starts another program is refused before any test runs it",
          rc != 0 and "stage 01 is refused, as the grader refuses it" in out and
          "step.cpp calls system" in out and re.search(r"\b4 not run\b", out), out)


def skip_is_skip():
    STEP.write_text(SOLUTION)
    rc, out = plab("test", "--impl", "student", "--stage", "01")
    check("a test that checked no case is skipped, with its reason",
          rc == 0 and re.search(r"\b1 skipped\b", out) and
          "skipped stage01.student.AgainstOtherStage: no other stage's solution is built" in out, out)


def short_report():
    swapped = SOLUTION.replace("model::key_less(w, best)", "model::key_less(best, w)")
    assert swapped != SOLUTION, "no model::key_less(w, best) in stage 01's solution"
    STEP.write_text(swapped)
    rc, out = plab("test", "--impl", "student", "--stage", "01")
    lines = [l for l in out.splitlines() if not l.startswith("[")]
    check("a failing stage fails", rc != 0, out)
    check("... in at most 40 lines", len(lines) <= 40, f"{len(lines)} lines:\n{out}")
    for what in (r"\./plab run --stage 01 --impl student datasets/scenes/\S+\.in --out mine\.out",
                 r"\./plab diff datasets/golden/\S+\.out mine\.out",
                 r"--explain \d+:\d+", r"\./plab render datasets/scenes/\S+\.in --diff ",
                 r"the whole log: build/test-logs/plab-test\.log"):
        check("... holding " + what, re.search(what, out), out)
    check("... no threads for a serial stage", "threads" not in out, out)


def main():
    try:
        make_copy()
        for part in (not_done, reference_refused, broken_compile, endless_loop, skip_is_skip, short_report):
            part()
    finally:
        for line in leftovers():
            os.kill(int(line.split()[0]), signal.SIGKILL)
        shutil.rmtree(WORK, ignore_errors=True)
    for f in failures:
        print("\n" + f)
    print(f"honest self-test: {len(failures)} checks failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
