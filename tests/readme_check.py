#!/usr/bin/env python3
"""Runs the README's quick starts as written (CTest test readme, labels release and long).

The `sh` code blocks under "Instructor quick start" and "Student quick start" of README.md, and
under "Student quick start" of the student README (kit/release/README.student.md, the release's
README.md), are taken from the kit's HEAD and run line by line, literally (`bash -c LINE`), in
scratch copies:

1. the instructor's block in a clone of the kit's HEAD, in order. Left out, and said so:
   `./plab test --long` (the N = 10000, 500-step scene on every stage: many minutes per stage,
   and the plain `./plab test` line already runs every other test it adds). `~` is a scratch
   home whose `alice` is a submission (the kit's stages/ with the solutions' files of stages 01-03
   copied in) for the grader's line. Checked: every line exits 0 and writes what it names
   (scene.in, out.txt, dense-box.gif, alice/results.json, the release, acc.csv and acc.png);
2. README.md's student block, in the same clone after the instructor's block.

The student README's own block is run in a release by tests/release_check.py (test release), in
the release that it has built already, with student_block() below.

In a student block the `./plab test` line before `$EDITOR` must fail with "stage 01: EXERCISE 1
(...) is not done yet"; `$EDITOR` is a command that copies solutions/01-naive/step.cpp over the
file it is given (what a student who finished the exercise has); every other line must exit 0.
The scratch copies are configured with CUDA off, as on the kit's CI (no GPU), before ./plab's
first run, which then builds there as it would anywhere. The scratch folder is removed whatever
the outcome. Instructor lines named in the environment variable PLAB_README_RAN_BY_CI (one a line)
are not run again: CI sets it for the lines its own steps run literally in its fresh clone.

  readme_check.py [--kit DIR] [--part all|instructor|student] [--keep]
"""
import argparse
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import time

# Instructor lines that are not run, and why.
SKIPPED = {"./plab test --long": "the N = 10000, 500-step scene on every stage takes many minutes "
                                 "per stage; the plain ./plab test line runs every other test",
           "./plab test --fuzz": "the same tests again with fresh seeds for the stage-against-stage "
                                 "scenes: CI runs the fuzz tests (label fuzz) in a step of their own",
           "./plab golden": "regenerates every golden file (minutes); CI runs ./plab golden --check, "
                            "which makes the same files and compares them",
           "./plab accuracy --csv acc.csv --plot acc.png": "the full lab takes many minutes; its "
                            "short run is the test accuracy.short",
           "./plab stress": "the full suite takes many minutes; its short run is the test "
                            "stress.short"}
# Instructor lines (by their start) and the files they must leave (relative to the clone).
WRITES = {"./plab docs": ["build/docs/html/index.html"],
          "./plab gen": ["scene.in"],
          "./plab run --stage 02 scene.in": ["out.txt"],
          "./plab render datasets/scenes/dense-box.in": ["dense-box.gif"],
          "./plab grade": ["alice/results.json"],
          "./plab release": ["../particle-lab-student/README.md",
                             "../particle-lab-student/kit/reference/bin/plab-reference"]}
# Lines that CI (.ci/run) runs literally, in its own steps, in the same fresh clone: it names them in
# PLAB_README_RAN_BY_CI (one per line), and this check does not run them a second time.
RAN_BY_CI = [ln.strip() for ln in os.environ.get("PLAB_README_RAN_BY_CI", "").splitlines() if ln.strip()]
NOT_DONE = re.compile(r"stage 01: EXERCISE 1 \([^)]+\) is not done yet")


def check(condition, message):
    if not condition:
        sys.exit(f"README check FAILED: {message}")


def block(text, heading, where):
    """The lines of the first ```sh block after `## heading`."""
    found = re.search(r"^## " + re.escape(heading) + r"\s*\n.*?^```sh\n(.*?)^```", text,
                      re.MULTILINE | re.DOTALL)
    check(found, f"{where} has no ```sh block under '## {heading}'")
    return [ln for ln in found.group(1).splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def command(line):
    """The command of a line, without its comment."""
    return re.sub(r"\s+#.*$", "", line).strip()


def scratch_home_env(home, **extra):
    """The environment of a line run with HOME set to a scratch home: ccache keeps the caller's
    cache (cmake/ccache-launcher.sh would otherwise start an empty one under the scratch home and
    compile the whole kit cold: 7 of this check's 18 minutes on CI's 2-core machine)."""
    cache = os.environ.get("CCACHE_DIR") or str(pathlib.Path(
        os.environ.get("XDG_CACHE_HOME") or pathlib.Path(os.environ.get("HOME", "/nonexistent"))
        / ".cache") / "ccache")
    return dict(os.environ, HOME=str(home), CCACHE_DIR=cache, **extra)


def run_line(line, cwd, env):
    t0 = time.monotonic()
    done = subprocess.run(["bash", "-c", line], cwd=cwd, env=env, capture_output=True, text=True)
    return done, time.monotonic() - t0


def configure(copy):
    """CUDA off in the scratch copies (./plab configures only when build/ is not configured)."""
    done = subprocess.run(["cmake", "--preset", "release", "-DPLAB_ENABLE_CUDA=OFF"], cwd=copy,
                          capture_output=True, text=True)
    check(done.returncode == 0, f"configuring {copy} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")


def student_block(lines, copy, solution, env, where):
    """Runs a student quick start: the test before the edit fails, everything else passes."""
    edited = False
    for line in lines:
        cmd = command(line)
        if cmd.startswith("$EDITOR"):
            done, took = run_line(line, copy, env)
            check(done.returncode == 0, f"{where}: '{cmd}' failed:\n{done.stderr[-2000:]}")
            check((copy / "stages/01-naive/step.cpp").read_bytes() == solution.read_bytes(),
                  f"{where}: $EDITOR did not put the solution in place")
            edited = True
            print(f"  ok  {took:6.1f} s  {cmd}   ($EDITOR: copies the solution's step.cpp in)", flush=True)
            continue
        done, took = run_line(line, copy, env)
        said = done.stdout + done.stderr
        if not edited and cmd.startswith("./plab test"):
            check(done.returncode != 0 and NOT_DONE.search(said),
                  f"{where}: '{cmd}' on the starting point should fail with 'stage 01: EXERCISE 1 "
                  f"(...) is not done yet'; it exited {done.returncode}:\n{said[-2000:]}")
            print(f"  ok  {took:6.1f} s  {cmd}   (fails: {NOT_DONE.search(said).group(0)})", flush=True)
            continue
        check(done.returncode == 0, f"{where}: '{cmd}' exited {done.returncode}:\n{said[-3000:]}")
        print(f"  ok  {took:6.1f} s  {cmd}", flush=True)
    check(edited, f"{where}: the student quick start has no $EDITOR line")


def instructor_block(lines, clone, env):
    for line in lines:
        cmd = command(line)
        if cmd in SKIPPED:
            print(f"  --  skipped     {cmd}   ({SKIPPED[cmd]})", flush=True)
            continue
        if cmd in RAN_BY_CI:
            print(f"  --  ran by CI   {cmd}   (CI's own step ran this line in a fresh clone)", flush=True)
            continue
        done, took = run_line(line, clone, env)
        said = done.stdout + done.stderr
        check(done.returncode == 0, f"instructor quick start: '{cmd}' exited {done.returncode}:\n"
                                    f"{said[-3000:]}")
        for start, files in WRITES.items():
            if cmd.startswith(start):
                for f in files:
                    check((clone / f).exists(), f"instructor quick start: '{cmd}' did not write {f}")
        print(f"  ok  {took:6.1f} s  {cmd}", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kit", default=str(pathlib.Path(__file__).resolve().parents[1]),
                    help="the instructor's kit, a git checkout (default: the one of this script)")
    ap.add_argument("--part", choices=("all", "instructor", "student"), default="all",
                    help="student: only README.md's student block, in a clone")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    a = ap.parse_args()
    kit = pathlib.Path(a.kit).resolve()
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-readme-check-"))
    t0 = time.monotonic()
    try:
        clone = scratch / "particle-lab"
        done = subprocess.run(["git", "clone", "-q", str(kit), str(clone)], capture_output=True, text=True)
        check(done.returncode == 0, f"git clone failed: {done.stderr}")
        readme = (clone / "README.md").read_text()
        instructor = block(readme, "Instructor quick start", "README.md")
        student = block(readme, "Student quick start", "README.md")
        solution = clone / "solutions/01-naive/step.cpp"
        home = scratch / "home"
        submission = home / "alice"
        shutil.copytree(clone / "stages", submission / "stages")
        for stage in ("01-naive", "02-heap", "03-openmp"):
            for f in (clone / "solutions" / stage).iterdir():
                shutil.copy2(f, submission / "stages" / stage / f.name)
        env = scratch_home_env(home, EDITOR=f"cp {solution}")
        configure(clone)
        if a.part in ("all", "instructor"):
            print(f"README.md, instructor quick start, in a clone of HEAD ({clone}):", flush=True)
            instructor_block(instructor, clone, env)
        if a.part in ("all", "student"):
            print("README.md, student quick start, in the same clone:", flush=True)
            student_block(student, clone, solution, env, "README.md's student quick start")
    finally:
        if a.keep:
            print(f"kept {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    print(f"README check passed in {time.monotonic() - t0:.0f} s")


if __name__ == "__main__":
    main()
