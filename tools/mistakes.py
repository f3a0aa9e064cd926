#!/usr/bin/env python3
"""The course guide's common mistakes, from real runs of the grader: each mutant of
kit/instructor/mutants.json (a slip a student makes: one exact replacement in a solution's
step.cpp, or its "file") is graded alone, as a student's upload of that one stage, and what the student then
reads is recorded in kit/instructor/mistakes.json: the points, how many tests failed, and the
first failed test with its feedback as results.json gives it. plab.guide (kit/python/plab/guide.py) shows it.

Rerun it when the grader's messages or the mutants change (about a minute a mutant on 2 cores):

  tools/mistakes.py [--kit KIT] [--plab KIT/plab] [--only NAME ...] [--out FILE]
"""
import argparse
import datetime
import json
import pathlib
import shutil
import subprocess
import sys
import tempfile

FOLDERS = {"01": "01-naive", "02": "02-heap", "03": "03-openmp"}
SHOWN_LINES = 12  # of the first failed test's feedback


def grade_one(plab, kit, mutant, work, seed):
    """Grades the solution of the mutant's stage with the mutant applied; returns the record."""
    stage = mutant["stage"]
    root = work / mutant["name"]
    shutil.rmtree(root, ignore_errors=True)
    folder = root / "stages" / FOLDERS[stage]
    shutil.copytree(kit / "solutions" / FOLDERS[stage], folder)
    step = folder / mutant.get("file", "step.cpp")
    text = step.read_text()
    if text.count(mutant["old"]) != 1:
        sys.exit(f"mutant {mutant['name']}: its old text is not once in {step.name}")
    step.write_text(text.replace(mutant["old"], mutant["new"]))
    out = work / f"{mutant['name']}.json"
    races = ["--races"] if mutant["name"].endswith("data-race") else ["--no-races"]
    done = subprocess.run([str(plab), "grade", "--submission", str(root), "--stages", stage,
                           "--out", str(out), "--hidden-seed", str(seed), *races],
                          capture_output=True, text=True, cwd=kit)
    if not out.exists():
        sys.exit(f"mutant {mutant['name']}: the grader wrote no results:\n"
                 f"{done.stdout[-2000:]}{done.stderr[-2000:]}")
    tests = json.loads(out.read_text())["tests"]
    mine = [t for t in tests if t["name"].startswith(f"{stage}:")]
    lost = [t for t in mine if t["score"] < t["max_score"]]
    # A test right on its own whose points the failed idea test took says so first.
    gated = [t for t in lost if t["output"].startswith("counts 0 (it would earn")]
    idea = next((t for t in mine if t["name"].startswith(f"{stage}: idea")), None)
    wrong = [t for t in mine if t not in gated and t is not idea and
             (t["status"] == "failed" or t["score"] < t["max_score"])]
    # The feedback a student reads: the first test that failed on its own (a public scene's
    # first, with its difference), and the idea test's when it failed.
    first = next((t for t in wrong if "public" in t["name"]), wrong[0] if wrong else None)
    return {
        "name": mutant["name"], "stage": stage, "mistake": mutant["mistake"],
        "old": mutant["old"], "new": mutant["new"],
        "score": sum(t["score"] for t in mine), "max_score": sum(t["max_score"] for t in mine),
        "tests": len(mine), "tests_wrong": len(wrong), "tests_gated": len(gated),
        "idea_failed": bool(idea and idea["status"] == "failed"),
        "idea_feedback": (idea["output"].rstrip().splitlines()[:3]
                          if idea and idea["status"] == "failed" else []),
        "first_failed": first["name"] if first else None,
        "feedback": first["output"].rstrip().splitlines()[:SHOWN_LINES] if first else [],
    }


def main():
    kit_default = pathlib.Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kit", type=pathlib.Path, default=kit_default)
    ap.add_argument("--plab", type=pathlib.Path, help="the kit's front door (default: KIT/plab)")
    ap.add_argument("--out", type=pathlib.Path, help="default: KIT/kit/instructor/mistakes.json")
    ap.add_argument("--only", nargs="*", default=[], help="these mutants (the others kept as "
                                                          "the output file has them)")
    ap.add_argument("--seed", type=int, default=7, help="the hidden scenes' seed")
    a = ap.parse_args()
    kit = a.kit.resolve()
    plab = (a.plab or kit / "plab").resolve()
    out = (a.out or kit / "kit" / "instructor" / "mistakes.json").resolve()
    mutants = json.loads((kit / "kit" / "instructor" / "mutants.json").read_text())["mutants"]
    old = {m["name"]: m for m in json.loads(out.read_text())["mistakes"]} if out.exists() else {}
    commit = subprocess.run(["git", "-C", str(kit), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or "unknown"
    records = []
    with tempfile.TemporaryDirectory(prefix="plab-mistakes-") as tmp:
        for m in mutants:
            if a.only and m["name"] not in a.only:
                if m["name"] in old:
                    records.append(old[m["name"]])
                continue
            print(f"grading mutant {m['name']} (stage {m['stage']})", flush=True)
            r = grade_one(plab, kit, m, pathlib.Path(tmp), a.seed)
            print(f"  {r['score']:g} of {r['max_score']:g} points, {r['tests_wrong']} of "
                  f"{r['tests']} tests wrong, {r['tests_gated']} more gated by the idea test; "
                  f"first: {r['first_failed']}", flush=True)
            records.append(r)
    doc = {"about": "Written by tools/mistakes.py: each mutant of kit/instructor/mutants.json "
                    "graded alone by `plab grade` (hidden seed "
                    f"{a.seed}, no race check but for the data race); do not edit by hand.",
           "commit": commit, "date": datetime.date.today().isoformat(), "mistakes": records}
    out.write_text(json.dumps(doc, indent=2) + "\n")
    print(f"common mistakes: {out} ({len(records)} mutants)")


if __name__ == "__main__":
    main()
