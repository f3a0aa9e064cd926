#!/usr/bin/env python3
"""Checks that a `plab` command stopped by a signal leaves nothing behind: `plab bench` writes its
scene into BUILD/tmp/ (named with its process id) and runs the stage on it; SIGTERM to the bench
alone (as `kill PID` or a timeout sends it; Ctrl-C's SIGINT alike) while it runs must remove the
scene and end the stage's run too, and the command must still end by that signal. Run by CTest
(label kit).

  scratch_cleanup_check.py PLAB_PROGRAM BUILD_DIR
"""
import os
import pathlib
import signal
import subprocess
import sys
import time

plab, build = sys.argv[1], pathlib.Path(sys.argv[2])
tmp = build / "tmp"
# A scene big enough that the bench is still running its first repetition when the signal comes
# (some seconds of stage 01 on this 2-core machine), and small enough that a run left behind by a
# failure of this check ends by itself soon.
bench = subprocess.Popen([plab, "bench", "--stage", "01", "--impl", "solution", "--n", "1000",
                          "--steps", "20"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
mine = []
deadline = time.time() + 60
while not mine and time.time() < deadline and bench.poll() is None:
    time.sleep(0.1)
    mine = [p for p in tmp.glob(f"bench-*.{bench.pid}")]
assert mine, f"plab bench wrote no scratch scene into {tmp} (exit {bench.poll()})"
time.sleep(0.5)
assert bench.poll() is None, "plab bench ended before the signal: make its scene bigger"
bench.send_signal(signal.SIGTERM)
bench.wait(timeout=30)
assert bench.returncode == -signal.SIGTERM, f"plab bench exited {bench.returncode}, not by SIGTERM"
time.sleep(0.5)
left = [p.name for p in tmp.glob(f"*.{bench.pid}")]
running = []  # the stage's run on the bench's scene, if it outlived the bench
for proc in pathlib.Path("/proc").iterdir():
    try:
        line = (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        continue
    if any(str(p) in line for p in mine):
        running.append(int(proc.name))
for pid in running:  # (ended here so that a failure leaves nothing running either)
    try:
        os.kill(pid, signal.SIGKILL)
    except OSError:
        pass
assert not running, f"the stage's run went on after plab bench was stopped: pids {running}"
assert not left, f"a stopped plab bench left its scratch files in {tmp}: {left}"
print(f"plab bench stopped by SIGTERM removed its scratch files ({', '.join(p.name for p in mine)})")
