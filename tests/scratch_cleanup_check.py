#!/usr/bin/env python3
"""Checks that a `plab` command stopped by a signal leaves no scratch file behind: `plab bench`
writes its scene into BUILD/tmp/ (named with its process id); SIGTERM (as `kill`, a timeout or a
closed terminal send it, and Ctrl-C's SIGINT alike) while it runs must remove it, and the command
must still end by that signal. Run by CTest (label kit).

  scratch_cleanup_check.py PLAB_PROGRAM BUILD_DIR
"""
import pathlib
import signal
import subprocess
import sys
import time

plab, build = sys.argv[1], pathlib.Path(sys.argv[2])
tmp = build / "tmp"
# A scene big enough that the bench is still running its first repetition when the signal comes.
bench = subprocess.Popen([plab, "bench", "--stage", "01", "--impl", "solution", "--n", "4000",
                          "--steps", "200"], stdout=subprocess.DEVNULL,
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
time.sleep(0.2)
left = [p.name for p in tmp.glob(f"*.{bench.pid}")]
assert not left, f"a stopped plab bench left its scratch files in {tmp}: {left}"
print(f"plab bench stopped by SIGTERM removed its scratch files ({', '.join(p.name for p in mine)})")
