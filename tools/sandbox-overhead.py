#!/usr/bin/env python3
"""What the grader's sandbox adds to one run of student code: the same stage program on the same
scene, started bare (no sandbox), as an unprivileged user, and in bubblewrap, interleaved, with
the median and spread of each and the medians' differences.

  PYTHONPATH=kit/python tools/sandbox-overhead.py [--program build/bin/plab-run-01-solution]
                                                  [--scene datasets/scenes/course-1.in] [--runs 21]
"""
import argparse
import os
import pathlib
import shutil
import statistics
import sys
import tempfile

root = pathlib.Path(__file__).resolve().parent.parent
from plab.grade import sandbox  # noqa: E402  (run with PYTHONPATH=kit/python)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--program", default=str(root / "build" / "bin" / "plab-run-01-solution"))
    ap.add_argument("--scene", default=str(root / "datasets" / "scenes" / "course-1.in"))
    ap.add_argument("--runs", type=int, default=21)
    a = ap.parse_args()
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-overhead-"))
    try:
        modes = ["none"] + [m for m in ("user", "bwrap") if sandbox.choose(m, scratch)[0] == m]
        box = scratch / "box"
        box.mkdir(exist_ok=True)
        os.chmod(box, 0o711)
        shutil.copyfile(a.program, box / "stage")
        shutil.copyfile(a.scene, box / "scene.in")
        os.chmod(box / "stage", 0o755)
        os.chmod(box / "scene.in", 0o644)
        limits = {"memory_mb": 2048, "processes": 512}
        times = {m: [] for m in modes}
        for k in range(a.runs):
            for mode in modes:
                sb = sandbox.Sandbox(scratch, limits, mode)
                out = sb.writable_dir(scratch, "out-")
                run = sb.run(["/plab/stage", "/plab/scene.in", "--quiet", "--out",
                              "/plab/out/out.txt"],
                             {"/plab/stage": box / "stage", "/plab/scene.in": box / "scene.in"},
                             {"/plab/out": out}, "/plab/out", 60, 2**26)
                if run.rc != 0 or run.reason:
                    sys.exit(f"{mode}: the run failed ({run.reason or run.rc}): {run.stderr}")
                times[mode].append(run.seconds)
            print(f"\rround {k + 1}/{a.runs}", end="", file=sys.stderr, flush=True)
        print(file=sys.stderr)
        bare = statistics.median(times["none"])
        print(f"{'sandbox':<8} {'median s':>9} {'min s':>8} {'max s':>8} {'added s':>8}  "
              f"({a.runs} runs each, interleaved; {pathlib.Path(a.program).name} on "
              f"{pathlib.Path(a.scene).name})")
        for mode, t in times.items():
            med = statistics.median(t)
            print(f"{mode:<8} {med:9.4f} {min(t):8.4f} {max(t):8.4f} {med - bare:8.4f}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
