#!/usr/bin/env python3
"""Times `plab grade --class` on a generated class: N submissions of stages 01-03 drawn from a
realistic mix (complete solutions, solutions with one slip that the grader must catch, untouched
starting points, one that does not compile, one that never ends), graded J at a time; prints the
wall time, the students graded a minute, the time a student, and the time 200 students would take
at that rate. `--limit S` stops the batch after S seconds (the class grading is resumable: what was
graded stays graded), for a measurement that must fit a time box; run again with the same `--out`
(and seed), it grades the rest, and OUT/class-bench.json adds up the batches' times, so a class
measured in several time boxes is reported as a whole.

  tools/class-bench.py [--students 200] [--jobs J] [--stages 01,02,03] [--limit S]
                       [--out DIR] [--keep] [-- GRADER ARGS...]
"""
import argparse
import csv
import json
import os
import pathlib
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

root = pathlib.Path(__file__).resolve().parent.parent
STAGES = {"01": "01-naive", "02": "02-heap", "03": "03-openmp"}

# Slips a class makes (stage, old text, new text): each must match the solution once; the
# grader's self-tests (tests/grader_selftest.py) show that each loses points.
SLIPS = [
    ("01", "if (!model::in_step(best.t)) break;", "if (best.t > 1) break;"),
    ("01", "if (model::key_less(e, best)) best = e;", "if (e.t <= best.t) best = e;"),
    ("02", "return model::key_less(b, a);", "return a.t > b.t;"),
    ("02", "if (model::in_step(e.t)) heap.push(e);",
     "if (e.t > 0 && model::in_step(e.t)) heap.push(e);"),
    ("03", "if (earlier(e, b)) b = e;", "if (earlier(e, b) || e.t == b.t) b = e;"),
    ("03", "std::vector<FoundPair>& mine = found[omp_get_thread_num()];",
     "std::vector<FoundPair>& mine = found[0];"),
]
# The mix of a class (kind, weight): most finish, some slip, a few hand in too little.
MIX = [("solution", 60), ("slip", 25), ("starting-point", 8), ("no-compile", 5), ("endless", 2)]


def student(folder, kind, rng, stages):
    """Writes one submission of `kind` (stages/NN-name/ folders) into `folder`."""
    for sid in stages:
        tree = "stages" if kind == "starting-point" else "solutions"
        shutil.copytree(root / tree / STAGES[sid], folder / "stages" / STAGES[sid])
    step = lambda sid: folder / "stages" / STAGES[sid] / "step.cpp"  # noqa: E731
    if kind == "slip":
        sid, old, new = rng.choice([s for s in SLIPS if s[0] in stages])
        text = step(sid).read_text()
        assert text.count(old) == 1, f"slip of stage {sid} does not match once: {old!r}"
        step(sid).write_text(text.replace(old, new))
    elif kind == "no-compile":
        sid = rng.choice(stages)  # a statement left without its semicolon, inside step()
        text = step(sid).read_text()
        head = "void step(const Box& box, Particles& p) {\n"
        assert text.count(head) == 1, f"stage {sid}: no step() to break"
        step(sid).write_text(text.replace(head, head + "  const int unfinished = 1\n"))
    elif kind == "endless":
        sid = rng.choice(stages)
        text = step(sid).read_text()
        head = "void step(const Box& box, Particles& p) {\n"
        assert text.count(head) == 1, f"stage {sid}: no step() to make endless"
        step(sid).write_text(text.replace(head, head + "  for (volatile long k = 0;; k = k + 1) {\n  }\n"))


def main():
    argv = sys.argv[1:]
    grader_args = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--students", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 2) // 2))
    ap.add_argument("--stages", default="01,02,03")
    ap.add_argument("--limit", type=float, default=0, help="stop the batch after this many seconds")
    ap.add_argument("--out", help="the class's results (default: a temporary folder)")
    ap.add_argument("--seed", type=int, default=1, help="the class's mix")
    ap.add_argument("--keep", action="store_true", help="keep the generated class and its grades")
    a = ap.parse_args(argv)
    stages = a.stages.split(",")
    rng = random.Random(a.seed)
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-class-"))
    out = pathlib.Path(a.out) if a.out else scratch / "grades"
    kinds = {}
    try:
        for k in range(a.students):
            name = f"student{k:03d}"
            kind = rng.choices([m[0] for m in MIX], [m[1] for m in MIX])[0]
            kinds[name] = kind
            student(scratch / "class" / name, kind, rng, stages)
        print(f"class-bench: {a.students} students ({', '.join(f'{sum(v == m for v in kinds.values())} {m}' for m, _ in MIX)}), "
              f"stages {a.stages}, {a.jobs} at a time on {os.cpu_count()} cores", flush=True)
        before = {d.parent.name for d in out.glob("students/*/upload.sha256")}
        cmd = [str(root / "plab"), "grade", "--class", str(scratch / "class"), "--stages", a.stages,
               "--out", str(out), "--jobs", str(a.jobs), *grader_args]
        t0 = time.monotonic()
        run = subprocess.Popen(cmd, start_new_session=True)
        try:
            run.wait(timeout=a.limit or None)
        except subprocess.TimeoutExpired:
            os.killpg(run.pid, 15)
            run.wait()
            print(f"class-bench: stopped after {a.limit:.0f} s (--limit)", flush=True)
        wall = time.monotonic() - t0
        graded = {}
        for done in out.glob("students/*/upload.sha256"):  # written once a student is graded
            graded[done.parent.name] = json.loads((done.parent / "results.json").read_text())
        refused = [n for n, r in graded.items() if any(t["name"] == "not graded" for t in r["tests"])]
        if refused:  # the grader refused (e.g. no sandbox possible): nothing was measured
            sys.exit(f"class-bench: the grader refused {len(refused)} students, e.g. "
                     f"{out / 'students' / refused[0] / 'grader.log'}")
        n = len(set(graded) - before)  # graded by this batch
        if not n:
            sys.exit("class-bench: no student graded")
        per = wall / n
        ledger = out / "class-bench.json"  # the batches so far of this class (a resumed class)
        batches = json.loads(ledger.read_text()) if ledger.is_file() else []
        batches.append({"graded": n, "seconds": round(wall, 1), "jobs": a.jobs,
                        "cores": os.cpu_count()})
        ledger.write_text(json.dumps(batches, indent=1) + "\n")
        by_kind = {}
        for name, r in graded.items():
            by_kind.setdefault(kinds[name], []).append(r.get("score", 0))
        print(f"class-bench: {n} students graded in {wall:.0f} s: {60 * n / wall:.1f} a minute, "
              f"{per:.1f} s a student at {a.jobs} at a time; 200 students at this rate: "
              f"{200 * per / 60:.0f} min", flush=True)
        if len(batches) > 1:
            total = sum(b["seconds"] for b in batches)
            print(f"class-bench: the class so far, {len(batches)} batches: {len(graded)} of "
                  f"{a.students} graded in {total:.0f} s of grading ({total / 60:.1f} min), "
                  f"{total / len(graded):.1f} s a student", flush=True)
        for kind, scores in sorted(by_kind.items()):
            print(f"  {kind:15s} {len(scores):4d} graded, median score {statistics.median(scores):g}")
        if (out / "gradebook.csv").exists():
            rows = list(csv.DictReader(open(out / "gradebook.csv", newline="")))
            print(f"  gradebook: {len(rows)} rows")
    finally:
        if a.keep:
            print(f"class-bench: kept {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
