#!/usr/bin/env python3
"""The race check can fail: a mutant of stage 03 with a real data race must be reported by TSan.

Usage: tsan_mutant_check.py SOURCE_DIR BINARY_DIR NINJA [--keep-report FILE]

In a scratch folder: copies solutions/03-openmp/step.cpp, makes every thread of the first
parallel region push into found[0] (instead of its own found[omp_get_thread_num()]), compiles it
with the tsan build's own compile command, links it in place of the stage 03 solution's library
with the build's own link command (ninja -t commands), runs it on dense-box.in (40 particles in a small box) with three threads
(schedule static: each thread has rows of its own) and the environment of plab.grade.races, and checks that TSan stopped it (exit code 66) with a
data race whose first_race() message names step.cpp and a line. The scratch folder is removed.
"""
import json
import os
import pathlib
import shlex
import shutil
import subprocess
import sys
import tempfile

ORIGINAL = "std::vector<FoundPair>& mine = found[omp_get_thread_num()];"
MUTANT = "std::vector<FoundPair>& mine = found[0];  // MUTANT: every thread shares one list"


def fail(message):
    print("tsan_mutant_check: FAIL: " + message)
    sys.exit(1)


def main():
    source_dir, binary_dir, ninja = (pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]),
                                     sys.argv[3])
    keep = sys.argv[5] if len(sys.argv) > 5 and sys.argv[4] == "--keep-report" else None
    from plab.grade import races  # what the autograder imports (PYTHONPATH=kit/python)

    problem = races.toolchain_problem()
    if problem:
        fail(problem)
    step = source_dir / "solutions" / "03-openmp" / "step.cpp"
    text = step.read_text()
    if text.count(ORIGINAL) != 1:
        fail(f"{step} no longer has the line this mutant replaces: {ORIGINAL}")
    mutant_line = text[: text.index(ORIGINAL)].count("\n") + 1

    commands = json.loads((binary_dir / "compile_commands.json").read_text())
    compile_entry = next((e for e in commands if pathlib.Path(e["file"]) == step), None)
    if compile_entry is None:
        fail(f"no compile command for {step} in {binary_dir}/compile_commands.json")
    link = subprocess.run([ninja, "-C", str(binary_dir), "-t", "commands", "plab-run-03-solution"],
                          capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1]
    stage_lib = "solutions/03-openmp/libplab_stage_03_solution.a"
    if stage_lib not in link or "-o bin/plab-run-03-solution" not in link:
        fail("unexpected link command for plab-run-03-solution: " + link)

    scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-tsan-mutant-"))
    try:
        mutant_cpp = scratch / "step.cpp"
        mutant_cpp.write_text(text.replace(ORIGINAL, MUTANT))
        obj = scratch / "step.o"
        args = shlex.split(compile_entry["command"])
        args[args.index("-o") + 1] = str(obj)
        args[args.index(str(step))] = str(mutant_cpp)
        subprocess.run(args, cwd=compile_entry["directory"], check=True)
        program = scratch / "plab-run-03-mutant"
        # The mutant's object before the stage's library: the library still gives what the mutant
        # does not define (stage_info(), which CMake writes from stage.json).
        link = link.replace(stage_lib, str(obj) + " " + stage_lib).replace(
            "-o bin/plab-run-03-solution", "-o " + shlex.quote(str(program)))
        subprocess.run(["sh", "-c", link], cwd=binary_dir, check=True)

        env = dict(os.environ)
        env.update(races.tsan_env(threads=3))
        run = subprocess.run([str(program), "--quiet", "--schedule", "static", "--out", str(scratch / "out.txt"),
                              str(source_dir / "datasets" / "scenes" / "dense-box.in")],
                             capture_output=True, text=True, env=env, timeout=600)
        if keep:
            pathlib.Path(keep).write_text(run.stderr)
        message = races.first_race(run.stderr, ["step.cpp"])
        print(f"mutant (step.cpp line {mutant_line}: found[0]): exit code {run.returncode}")
        print(f"first_race: {message}")
        if run.returncode != races.TSAN_EXIT_CODE:
            fail(f"TSan did not stop the mutant with exit code {races.TSAN_EXIT_CODE} "
                 f"(got {run.returncode}); stderr:\n{run.stderr[-3000:]}")
        if message is None or "step.cpp:" not in message:
            fail("no data race in step.cpp found in the report:\n" + run.stderr[-3000:])
        print("tsan_mutant_check: OK, the race check catches the mutant")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
