#!/usr/bin/env python3
"""Checks `plab bench --ceiling`: the machine's own ceiling for a speedup, from copies of the
first count's run started at once. Run by CTest (label kit).

- Threads: four times as many copies as this process may use cores must share the cores, so the
  ceiling comes out near the cores, not near the copies (copies run one after another would
  give the copies). The bound sits between the two (2.5 x the cores), so that a one-thread run
  slowed by other work (the ceiling is the copies' count times its time over theirs) does not
  fail the check: with twice the cores as copies and 1.5 x the cores as the bound, one such run
  did under ThreadSanitizer on CI's 2-core machine.
- Ranks: the copies of a one-rank run are started with --bind-to none (mpirun binds a run of one
  rank to the first core; copies left bound would share it and give a ceiling of 1).
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


# Threads: 4 x cores copies of the one-thread run on `cores` cores.
copies = 4 * cores
text, rows = bench("--stage", "03", "--impl", "solution", "--n", "2000", "--steps", "100",
                   "--threads", f"1,{copies}", "--runs", "1")
assert len(rows) == 2, rows
assert rows[0]["ceiling"] == "" and rows[0]["ceiling_slowest"] == "", \
    f"the first count has no ceiling of its own: {rows[0]}"
ceiling, slowest = float(rows[1]["ceiling"]), float(rows[1]["ceiling_slowest"])
assert 0 < slowest <= ceiling, (ceiling, slowest)
assert ceiling < 2.5 * cores, \
    f"{copies} copies on {cores} core(s) gave a ceiling of {ceiling:.2f}: they did not run at once"
assert f"this machine's ceiling: {copies} copies of the 1-thread run at once" in text, text

# Ranks: the copies of a one-rank run are started unbound (mpirun binds a run of one rank to the
# first core: bound copies would all share it). An mpirun first on PATH notes each command line and
# hands it to the real one; timings would not do here, another job on the machine blurs them.
real_mpirun = shutil.which("mpirun")
if real_mpirun:
    shim = scratch / "shim"
    shim.mkdir()
    calls = scratch / "mpirun-calls.txt"
    (shim / "mpirun").write_text(f'#!/bin/sh\necho "$*" >> "{calls}"\nexec "{real_mpirun}" "$@"\n')
    (shim / "mpirun").chmod(0o755)
    os.environ["PATH"] = f"{shim}{os.pathsep}{os.environ['PATH']}"
    text, rows = bench("--stage", "08", "--impl", "solution", "--n", "2000", "--steps", "5",
                       "--ranks", "1,2", "--runs", "1")
    lines = calls.read_text().splitlines()
    one_rank = [c for c in lines if " -np 1 " in c]
    two_ranks = [c for c in lines if " -np 2 " in c]
    assert len(one_rank) == 3 and len(two_ranks) == 1, \
        f"expected the one-rank run, its two copies and the two-rank run: {lines}"
    unbound = [c for c in one_rank if "--bind-to none" in c]
    assert len(unbound) == 2, f"the two copies must run unbound, the run alone as usual: {one_rank}"
    assert "--bind-to" not in two_ranks[0], two_ranks
    assert float(rows[1]["ceiling"]) > 0 and "copies of the 1-rank run at once" in text, text
else:
    print("ranks part skipped: no mpirun")
shutil.rmtree(scratch, ignore_errors=True)
print(f"ok: {cores} core(s)")
