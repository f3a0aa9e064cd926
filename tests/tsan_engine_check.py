#!/usr/bin/env python3
"""Stage 06's engine (instructors) on many cores, under ThreadSanitizer: its team path, where
every thread works on every slab and slab k + 1 is sorted while slab k is searched, on a scene
larger than the engine's small-scene limit (N = 36 000: the golden scenes are small enough for
each thread to take whole slabs alone). Three and four threads; TSan stops a race (exit 66) and
the test fails; the output must also be the solution's, bit for bit.

Usage: tsan_engine_check.py BIN_DIR   (the tsan build's bin/; the environment is CTest's)
"""
import os
import pathlib
import subprocess
import sys
import tempfile


def main():
    bin_dir = pathlib.Path(sys.argv[1])
    with tempfile.TemporaryDirectory(prefix="plab-tsan-engine-") as tmp:
        tmp = pathlib.Path(tmp)
        scene = tmp / "team.in"
        subprocess.run([bin_dir / "plab", "gen", "--n", "36000", "--l", "100000", "--r", "1",
                        "--steps", "3", "--seed", "5", "--out", scene], check=True)
        reference = tmp / "solution.out"
        subprocess.run([bin_dir / "plab-run-06-solution", scene, "--quiet", "--out", reference],
                       check=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
        for threads in ("3", "4"):
            out = tmp / f"engine-{threads}.out"
            run = subprocess.run([bin_dir / "plab-run-06-engine", scene, "--quiet", "--out", out],
                                 capture_output=True, text=True,
                                 env={**os.environ, "OMP_NUM_THREADS": threads})
            if run.returncode != 0:
                sys.exit(f"the engine on {threads} threads exited {run.returncode} "
                         f"(66: ThreadSanitizer found a race):\n{run.stderr[-4000:]}")
            if out.read_bytes() != reference.read_bytes():
                sys.exit(f"the engine on {threads} threads printed other text than the solution")
            print(f"engine, {threads} threads, N = 36000: no race, the solution's text")


if __name__ == "__main__":
    main()
