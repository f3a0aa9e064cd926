#!/usr/bin/env python3
"""Instructors' ThreadSanitizer checks of whole runs (the tsan build; CTest's environment: TSan
stops a race with exit code 66). Each runs a program on a generated scene and also checks its
output, bit for bit, against another stage's.

engine    Stage 06's engine on many cores: its team path, where every thread works on every slab
          and slab k + 1 is sorted while slab k is searched, on a scene larger than the engine's
          small-scene limit (N = 36 000: the golden scenes are small enough for each thread to
          take whole slabs alone). Three and four threads, against the solution.
sampling  Stage 08's measured work (kit/mpi/ranks.cpp) with its SIGPROF handler run on every
          thread of the process, not only the stage's. Until 2026-12-07 a profiling timer
          (ITIMER_PROF) rang the process, and the kernel could hand the ring to any of its
          threads, MPI's own progress thread too; CI's TSan run once stopped on a race between the
          handler on that thread and the handler on the main thread (a one-in-many event there).
          No timer is armed now, but the handler stays and reads the clock as the main thread's
          changes of state do, from any thread a ring reaches. This check makes
          the event certain: while stage 08's solution runs, it sends SIGPROF to each of the
          process's threads in turn, many times a second. Against stage 02 (the signals change
          no result).

Usage: tsan_runs_check.py engine|sampling BIN_DIR   (BIN_DIR: the tsan build's bin/)
"""
import ctypes
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time


def scene_and_reference(bin_dir, tmp, gen, stage, env=None):
    """Writes `plab gen`'s scene for the arguments `gen` into tmp, and stage `stage`'s solution's
    output for it; returns both paths."""
    scene, reference = tmp / "scene.in", tmp / f"stage{stage}.out"
    subprocess.run([bin_dir / "plab", "gen", *gen, "--out", scene], check=True)
    subprocess.run([bin_dir / f"plab-run-{stage}-solution", scene, "--quiet", "--out", reference],
                   check=True, env=env)
    return scene, reference


def engine(bin_dir, tmp):
    scene, reference = scene_and_reference(
        bin_dir, tmp, ["--n", "36000", "--l", "100000", "--r", "1", "--steps", "3", "--seed", "5"],
        "06", env={**os.environ, "OMP_NUM_THREADS": "1"})
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


def catches(pid, sig):
    """Whether process pid has a handler for sig (the SigCgt mask of /proc/PID/status)."""
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("SigCgt:"):
                return bool(int(line.split()[1], 16) >> (sig - 1) & 1)
    except OSError:
        pass
    return False


def threads_of(pid):
    try:
        return [int(t) for t in os.listdir(f"/proc/{pid}/task")]
    except OSError:
        return []


def sampling(bin_dir, tmp):
    libc = ctypes.CDLL(None, use_errno=True)
    scene, reference = scene_and_reference(
        bin_dir, tmp, ["--n", "1000", "--l", "4000", "--r", "1", "--steps", "40", "--seed", "8"],
        "02")
    out = tmp / "stage08.out"
    run = subprocess.Popen([bin_dir / "plab-run-08-solution", scene, "--quiet", "--out", out],
                           stderr=subprocess.PIPE, text=True)
    rings, rung = 0, set()
    while run.poll() is None:
        # The default action of SIGPROF ends the process: send only once the kit's handler is in
        # place (it stays until the process ends).
        if catches(run.pid, signal.SIGPROF):
            for tid in threads_of(run.pid):
                if libc.tgkill(run.pid, tid, signal.SIGPROF) == 0:
                    rings += 1
                    rung.add(tid)
        time.sleep(0.002)
    stderr = run.stderr.read()
    if run.returncode != 0:
        sys.exit(f"stage 08 exited {run.returncode} (66: ThreadSanitizer found a race) with "
                 f"SIGPROF sent {rings} times to {len(rung)} threads:\n{stderr[-4000:]}")
    if len(rung) < 2:
        sys.exit(f"the check did not run: SIGPROF reached {len(rung)} thread(s) of stage 08 "
                 f"({rings} rings); MPI's progress thread was never rung")
    if out.read_bytes() != reference.read_bytes():
        sys.exit("stage 08 printed other text than stage 02 while its threads were rung")
    print(f"stage 08, SIGPROF sent {rings} times to {len(rung)} threads: no race, "
          "stage 02's text")


CHECKS = {"engine": engine, "sampling": sampling}


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in CHECKS:
        sys.exit(__doc__)
    with tempfile.TemporaryDirectory(prefix=f"plab-tsan-{sys.argv[1]}-") as tmp:
        CHECKS[sys.argv[1]](pathlib.Path(sys.argv[2]), pathlib.Path(tmp))


if __name__ == "__main__":
    main()
