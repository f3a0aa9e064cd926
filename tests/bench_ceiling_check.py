#!/usr/bin/env python3
"""Checks `plab bench --ceiling`: the machine's own ceiling for a speedup, from copies of the
first count's run started at once. Run by CTest (label kit).

- Threads: twice as many copies as this process may use cores must share the cores, so the
  ceiling comes out near the cores, not near the copies (copies run one after another would
  give the copies).
- Ranks: two copies of a one-rank run must get a core each (mpirun binds a one-rank run to the
  first core; copies left bound would share it and give a ceiling of 1).
- The CSV has the ceiling on the rows above the first count only, and the text says it.

  bench_ceiling_check.py PLAB_PROGRAM SCRATCH_DIR
"""
import csv
import os
import pathlib
import shutil
import subprocess
import sys

plab, scratch = sys.argv[1], pathlib.Path(sys.argv[2])
shutil.rmtree(scratch, ignore_errors=True)
scratch.mkdir(parents=True)
cores = len(os.sched_getaffinity(0))


def bench(*args):
    table = scratch / "bench.csv"
    done = subprocess.run([plab, "bench", "--ceiling", "--csv", str(table), *args],
                          capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"plab bench {' '.join(args)} exited {done.returncode}:\n{done.stdout}\n"
                 f"{done.stderr}")
    return done.stdout, list(csv.DictReader(open(table, newline="")))


# Threads: 2 x cores copies of the one-thread run on `cores` cores.
copies = 2 * cores
text, rows = bench("--stage", "03", "--impl", "solution", "--n", "2000", "--steps", "100",
                   "--threads", f"1,{copies}", "--runs", "1")
assert len(rows) == 2, rows
assert rows[0]["ceiling"] == "" and rows[0]["ceiling_slowest"] == "", \
    f"the first count has no ceiling of its own: {rows[0]}"
ceiling, slowest = float(rows[1]["ceiling"]), float(rows[1]["ceiling_slowest"])
assert 0 < slowest <= ceiling, (ceiling, slowest)
assert ceiling < 1.5 * cores, \
    f"{copies} copies on {cores} core(s) gave a ceiling of {ceiling:.2f}: they did not run at once"
assert f"this machine's ceiling: {copies} copies of the 1-thread run at once" in text, text

# Ranks: two copies of a one-rank run, each on a core of its own.
if cores >= 2 and shutil.which("mpirun"):
    text, rows = bench("--stage", "08", "--impl", "solution", "--n", "4000", "--steps", "20",
                       "--ranks", "1,2", "--runs", "1")
    ceiling = float(rows[1]["ceiling"])
    assert ceiling > 1.25, \
        f"two one-rank copies gave a ceiling of {ceiling:.2f}: they shared a core (bound by mpirun)"
    assert "copies of the 1-rank run at once" in text, text
else:
    print(f"ranks part skipped: {cores} core(s), mpirun {shutil.which('mpirun')}")
shutil.rmtree(scratch, ignore_errors=True)
print(f"ok: {cores} core(s)")
