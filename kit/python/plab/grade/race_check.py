"""`plab test --races`: a stage's data races, found by ThreadSanitizer, for the student.

  python3 -m plab.grade.race_check --source DIR --build DIR --stage NN --impl student|solution [--scene FILE ...]

Builds the stage's program with ThreadSanitizer in its own folder (DIR/races-NN: clang++, LLVM's
OpenMP and its Archer tool, the cmake arguments of races.py, no tests: only the stage's program),
runs it with three threads on crowded scenes under the OpenMP schedules of races.py (static,1
deals every loop's iterations round-robin, so every thread works in every loop of
schedule(runtime); the largest scene gives a loop with a schedule of its own several chunks), and stops at the
first race: it prints the file and line of both accesses (the stage's own files first) and keeps
TSan's whole report in DIR/races-NN/report.txt. Exit code 0: no race seen; 1: a race; 2: the check
could not run (no clang++, libomp or Archer; the build failed). The same build and run as the
grader's race check (plab.grade.grader), without the sandbox and the hidden scene.
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import time

from plab.grade import races  # the grader's race machinery: TSan's build, environment and report

#: The scenes a race check runs by default: crowded ones, where every loop has work for every
#: thread and particles meet (dense-box: 40 disks in a small box; course-1), then a generated one
#: as large as the grader's (the rubric's races_scene, a seed of its own): a loop with a chunked
#: schedule of its own, e.g. schedule(dynamic, 64), ignores the schedules run here, and only a
#: scene of several chunks shares its iterations between the threads.
SCENES = ("dense-box.in", "course-1.in")
CROWDED_SEED = 1


def say(text):
    print(f"plab test --races: {text}", flush=True)


def build(source, folder, target):
    """Configures (once) and builds `target` with ThreadSanitizer; returns the program's path or
    None (having said why)."""
    gen = ["-G", "Ninja"] if shutil.which("ninja") else []
    if not (folder / "CMakeCache.txt").exists():
        done = subprocess.run(["cmake", "-S", str(source), "-B", str(folder), *gen,
                               *races.TSAN_CMAKE_ARGS], capture_output=True, text=True)
        if done.returncode != 0:
            say(f"configuring the ThreadSanitizer build failed:\n{done.stdout[-2000:]}"
                f"{done.stderr[-2000:]}")
            return None
    done = subprocess.run(["cmake", "--build", str(folder), "--target", target, "-j", "2"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        say(f"building {target} with ThreadSanitizer failed:\n{done.stdout[-3000:]}"
            f"{done.stderr[-2000:]}")
        return None
    return folder / "bin" / target


def crowded_scene(source, build_dir, folder):
    """The rubric's races_scene, generated (once) into `folder` by the kit's `plab gen`."""
    spec = json.loads((source / "kit" / "grade" / "rubric.json").read_text())["correctness"][
        "races_scene"]
    scene = folder / f"crowded-{spec['n']}.in"
    if not scene.exists():
        subprocess.run([str(build_dir / "bin" / "plab"), "gen", "--n", str(spec["n"]), "--l",
                        str(spec["L"]), "--r", str(spec["r"]), "--steps", str(spec["steps"]),
                        "--seed", str(CROWDED_SEED), "--out", str(scene)], check=True)
    return str(scene)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--source", required=True, help="the kit's folder")
    ap.add_argument("--build", required=True, help="the kit's build folder")
    ap.add_argument("--stage", required=True, help="two digits, e.g. 03")
    ap.add_argument("--impl", default="student", choices=("student", "solution"))
    ap.add_argument("--scene", action="append", default=[], help="a scene file (repeatable)")
    a = ap.parse_args()
    source, started = pathlib.Path(a.source).resolve(), time.monotonic()
    problem = races.toolchain_problem()
    if problem:
        say(problem)
        return 2
    tree = "stages" if a.impl == "student" else "solutions"
    folders = sorted((source / tree).glob(f"{a.stage}-*"))
    if not folders:
        say(f"no {tree}/{a.stage}-* folder")
        return 2
    sources = [f.name for f in folders[0].iterdir() if f.suffix in (".cpp", ".hpp", ".cu", ".cuh")]
    folder = pathlib.Path(a.build).resolve() / f"races-{a.stage}"
    target = f"plab-run-{a.stage}-{a.impl}"
    say(f"building {target} with ThreadSanitizer (clang++, LLVM's OpenMP, Archer) in {folder}",)
    program = build(source, folder, target)
    if program is None:
        return 2
    say(f"built in {time.monotonic() - started:.0f} s; running it with 3 threads")
    scenes = a.scene or [str(source / "datasets" / "scenes" / s) for s in SCENES] + [
        crowded_scene(source, pathlib.Path(a.build).resolve(), folder)]
    env = dict(os.environ, **races.tsan_env(threads=3))
    report_file = folder / "report.txt"
    for scene in scenes:
        for schedule in races.SCHEDULES:
            run = subprocess.run([str(program), "--quiet", "--threads", "3", "--schedule",
                                  schedule, "--out", os.devnull, scene],
                                 capture_output=True, text=True, env=env)
            race = races.first_race(run.stderr, sources)
            name = pathlib.Path(scene).name
            if race:
                report_file.write_text(run.stderr)
                say(f"{race}")
                variable = races.race_location(run.stderr)
                if variable:
                    say(f"the variable: {variable}")
                say(f"(scene {name}, schedule {schedule}; TSan's whole report: {report_file}; "
                    f"{time.monotonic() - started:.0f} s)")
                return 1
            if run.returncode == 3:  # an EXERCISE not done yet: nothing further runs
                say(f"stage {a.stage} stopped: {run.stderr.strip().splitlines()[-1]}")
                return 2
            if run.returncode != 0:
                report_file.write_text(run.stderr)
                say(f"the run on {name} exited {run.returncode} without a race report:\n"
                    f"{run.stderr[-2000:]}")
                if run.returncode < 0 or run.returncode >= 128 or "Assertion failure" in run.stderr:
                    # a crash, or LLVM OpenMP's own assertion on a damaged heap: not a race seen
                    say("it crashed without a race report: most often a write past an array's end "
                        "(a count, an offset, a prefix sum off by one), which damages the memory "
                        "that the OpenMP runtime or the C library then trips on. The "
                        "AddressSanitizer build of handouts/working.md names its line.")
                return 2
            say(f"no race on {name} (schedule {schedule})")
    say(f"no data race seen ({len(scenes)} scenes x schedules {', '.join(races.SCHEDULES)}, "
        f"3 threads; {time.monotonic() - started:.0f} s). TSan sees only the races these runs "
        "make: it is evidence, not a proof.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
