#!/usr/bin/env python3
"""Stage 08's sampled work (kit/mpi/ranks.cpp) under ThreadSanitizer, with its profiling signal
taken by every thread of the process, not only the stage's.

The kit's profiling timer (ITIMER_PROF) rings the process, and the kernel may hand the ring to any
of its threads: MPI's own progress thread too. CI's TSan run once stopped on a race between the
handler on that thread and the handler on the main thread (a one-in-many event there). This test
makes the event certain: while stage 08's solution runs, it sends SIGPROF to each of the process's
threads in turn, many times a second. TSan stops a race (exit 66) and the test fails; the output
must also be stage 02's, bit for bit (the signals change no result).

Usage: tsan_sampling_check.py BIN_DIR   (the tsan build's bin/; the environment is CTest's)
"""
import ctypes
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time

libc = ctypes.CDLL(None, use_errno=True)


def catches(pid, sig):
    """Whether process pid has a handler for sig (the SigCgt mask of /proc/PID/status)."""
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("SigCgt:"):
                return bool(int(line.split()[1], 16) >> (sig - 1) & 1)
    except OSError:
        pass
    return False


def threads(pid):
    try:
        return [int(t) for t in os.listdir(f"/proc/{pid}/task")]
    except OSError:
        return []


def main():
    bin_dir = pathlib.Path(sys.argv[1])
    with tempfile.TemporaryDirectory(prefix="plab-tsan-sampling-") as tmp:
        tmp = pathlib.Path(tmp)
        scene = tmp / "scene.in"
        subprocess.run([bin_dir / "plab", "gen", "--n", "1000", "--l", "4000", "--r", "1",
                        "--steps", "40", "--seed", "8", "--out", scene], check=True)
        reference = tmp / "stage02.out"
        subprocess.run([bin_dir / "plab-run-02-solution", scene, "--quiet", "--out", reference],
                       check=True)
        out = tmp / "stage08.out"
        run = subprocess.Popen([bin_dir / "plab-run-08-solution", scene, "--quiet", "--out", out],
                               stderr=subprocess.PIPE, text=True)
        rings, by_thread = 0, set()
        while run.poll() is None:
            # The default action of SIGPROF ends the process: send only once the kit's handler is
            # in place (it stays until the process ends).
            if catches(run.pid, signal.SIGPROF):
                for tid in threads(run.pid):
                    if libc.tgkill(run.pid, tid, signal.SIGPROF) == 0:
                        rings += 1
                        by_thread.add(tid)
            time.sleep(0.002)
        stderr = run.stderr.read()
        if run.returncode != 0:
            sys.exit(f"stage 08 exited {run.returncode} (66: ThreadSanitizer found a race) with "
                     f"SIGPROF sent {rings} times to {len(by_thread)} threads:\n{stderr[-4000:]}")
        if len(by_thread) < 2:
            sys.exit(f"the check did not run: SIGPROF reached {len(by_thread)} thread(s) of stage "
                     f"08 ({rings} rings); MPI's progress thread was never rung")
        if out.read_bytes() != reference.read_bytes():
            sys.exit("stage 08 printed other text than stage 02 while its threads were rung")
        print(f"stage 08, SIGPROF sent {rings} times to {len(by_thread)} threads: no race, "
              "stage 02's text")


if __name__ == "__main__":
    main()
