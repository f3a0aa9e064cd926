#!/usr/bin/env python3
"""Self-tests of `plab grade` (CTest label grader): the solutions get full marks, the untouched
starting points get no correctness points and each test names the exercise, five mutated solutions
are each caught at the right first divergence, every mutated stage (those five and six slips that
only exact edge cases show) loses points on the hidden scenes too, and submissions that crash, loop forever or print
without end are stopped, scored zero with the reason, and still get a results.json.

  grader_selftest.py PLAB_PROGRAM KIT_SOURCE_DIR SCRATCH_DIR [CASE ...]
"""
import json
import re
import pathlib
import shutil
import subprocess
import sys

plab, kit, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
only = set(sys.argv[4:])
STAGES = {"01": "01-naive", "02": "02-heap", "03": "03-openmp"}
failures = []
# The mutants (each a slip a student makes, with what it is) are data, shared with the course
# guide's common mistakes (tools/mistakes.py): kit/instructor/mutants.json (instructor-only: they
# quote the solutions).
MUTANTS = json.loads((kit / "kit" / "instructor" / "mutants.json").read_text())["mutants"]


def mutants_of(group):
    """The mutants of one group of tests/mutants.json, as (stage, old text, new text, file)."""
    return [(m["stage"], m["old"], m["new"], m.get("file", "step.cpp")) for m in MUTANTS
            if m["group"] == group]


def submission(name, tree="solutions", mutations=()):
    """A copy of the kit's stages 01-03 (solutions or starting points), with `mutations`
    applied: (stage, old text, new text), each of which must match exactly once."""
    root = scratch / name
    shutil.rmtree(root, ignore_errors=True)
    for folder in STAGES.values():
        shutil.copytree(kit / tree / folder, root / "stages" / folder)
    for stage, old, new, *file in mutations:
        f = root / "stages" / STAGES[stage] / (file[0] if file else "step.cpp")
        text = f.read_text()
        assert text.count(old) == 1, f"mutation of stage {stage} does not match once: {old!r}"
        f.write_text(text.replace(old, new))
    return root


def grade(name, root, *extra, stages="01,02,03"):
    """Grades `stages` of `root`; the race check (on by default) only where a case asks for
    it ("--races") or grades the solutions as they are ("--default")."""
    out = scratch / f"{name}.json"
    out.unlink(missing_ok=True)
    extra = [e for e in extra if e != "--default"] if "--default" in extra else \
        (list(extra) if "--races" in extra else [*extra, "--no-races"])
    done = subprocess.run([plab, "grade", "--submission", root, "--stages", stages, "--out",
                           out, "--hidden-seed", "7", *extra], capture_output=True, text=True)
    (scratch / f"{name}.log").write_text(done.stdout + done.stderr)
    assert out.exists(), f"{name}: no results.json written:\n{done.stdout[-3000:]}{done.stderr}"
    tests = {t["name"]: t for t in json.loads(out.read_text())["tests"]}
    assert "grader error" not in tests, tests.get("grader error", {}).get("output")
    return tests, done.stdout


def check(name, condition, message):
    print(("ok   " if condition else "FAIL ") + f"{name}: {message}", flush=True)
    if not condition:
        failures.append(f"{name}: {message}")


def failed(tests, prefix):
    return {n: t for n, t in tests.items() if n.startswith(prefix) and t["status"] == "failed"}


def points_lost(tests, stage, hidden):
    """Points lost by one stage on the hidden (after_published) or the public tests."""
    want = "after_published" if hidden else "visible"
    return sum(t["max_score"] - t["score"] for n, t in tests.items()
               if n.startswith(f"{stage}:") and t["visibility"] == want)


def check_hidden(name, tests, stages):
    """Each mutated stage loses points on the hidden scenes too, not only on the public ones."""
    for stage in stages:
        pub, hid = points_lost(tests, stage, False), points_lost(tests, stage, True)
        print(f"  mutant {name} (stage {stage}): public points lost {pub:g}, hidden {hid:g}")
        check(name, hid > 0, f"stage {stage} loses {hid:g} hidden points (public: {pub:g})")


def case_solutions():
    tests, _ = grade("solutions", submission("solutions"), "--default")
    lost = {n: t for n, t in tests.items() if t["score"] < t["max_score"]}
    noisy = all("TOO NOISY" in t["output"] for n, t in lost.items() if "performance" in n)
    for stage in STAGES:
        check("solutions", points_lost(tests, stage, True) == 0,
              f"stage {stage}: full marks on the hidden scenes")
    check("solutions", not lost or (noisy and all("performance" in n for n in lost)),
          f"full marks on {len(tests)} tests" if not lost else f"lost points: {list(lost)}")


def case_starting_points():
    tests, _ = grade("starting-points", submission("starting-points", "stages"))
    correctness = {n: t for n, t in tests.items() if "performance" not in n}
    check("starting points", all(t["score"] == 0 for t in correctness.values()),
          "no correctness points")
    named = [t for t in correctness.values() if "EXERCISE" in t["output"]]
    check("starting points", len(named) == len(correctness),
          f"{len(named)} of {len(correctness)} tests name the unfinished exercise, e.g. "
          f"{next(iter(named), {}).get('output', '')!r}")


def case_mutants_a():
    root = submission("mutants-a", mutations=mutants_of("mutants-a"))
    tests, out = grade("mutants-a", root)
    t = tests["02: public wall-and-pair-tie"]
    check("tie rule", t["status"] == "failed" and "hits a wall" in t["output"],
          "02: wall-and-pair-tie fails; the reference says the particle hits a wall")
    t = tests["01: public pair-then-wall-stop"]
    check("stop at a wall", t["status"] == "failed" and "step 1, particle" in t["output"],
          "01: pair-then-wall-stop fails at step 1, after the pair collision of step 0")
    t = tests["03: public course-1"]
    check("off-by-one", t["status"] == "failed" and "step 1, particle 1" in t["output"],
          "03: course-1 fails at step 1 on particle 1, the last one")
    check_hidden("tie rule / stop at a wall / off-by-one", tests, ["02", "01", "03"])
    print(out[out.find("first failure of stage 02"):][:1500])


def case_mutants_b():
    root = submission("mutants-b", mutations=mutants_of("mutants-b"))
    tests, _ = grade("mutants-b", root, "--races")
    t = tests["02: public event-at-step-end"]
    check("t <= 1", t["status"] == "failed" and "first difference" in t["output"],
          "02: event-at-step-end fails with a first difference")
    check_hidden("t <= 1", tests, ["02"])
    # A race may or may not change a printed bit in one run; ThreadSanitizer finds it every time,
    # and a race found costs the rubric's races_points: points lost beyond the public scenes.
    race_lost = sum(t["max_score"] - t["score"] for n, t in tests.items()
                    if n.startswith("03:") and "ThreadSanitizer" in n)
    beyond = points_lost(tests, "03", True) + race_lost
    check("data race", beyond > 0, f"stage 03 loses {beyond:g} points beyond the public scenes "
          f"(hidden scenes: {points_lost(tests, '03', True):g}, race check: {race_lost:g})")
    bad = failed(tests, "03:")
    check("data race", bool(bad), f"stage 03 with 2 threads fails {len(bad)} tests, e.g. "
          f"{next(iter(bad), '')}: {next(iter(bad.values()), {}).get('output', '')[:80]!r}")
    race = tests.get("03: data races (ThreadSanitizer, 3 threads)", {})
    unavailable = "not available" in race.get("output", "")
    # TSan names the race, or (the shared vector corrupted first, as CI saw once) the program
    # fails under TSan: either way the race points are lost, never left out of the total.
    named = re.search(r"data race at step\.cpp:\d+", race.get("output", ""))
    crashed = "failed under ThreadSanitizer" in race.get("output", "")
    check("data race", unavailable or ((named or crashed) and race.get("max_score", 0) > 0
                                       and race.get("score") == 0),
          f"--races names the race with file and line, or the failure under TSan, and its "
          f"points are lost: {race.get('output', 'no race test')!r}")


def case_mutants_hidden():
    """Slips that the random hidden scenes alone never catch (they never put an event exactly at
    t = 1 or 0, never tie two events): the family scenes of plab.grade.hidden must."""
    for name in ("mutants-c", "mutants-d", "mutants-e"):
        tests, _ = grade(name, submission(name, mutations=mutants_of(name)))
        check_hidden(name, tests, [m[0] for m in mutants_of(name)])


def case_hostile():
    root = submission("hostile", mutations=mutants_of("hostile"))
    tests, _ = grade("hostile", root)
    total = sum(t["score"] for t in tests.values())
    check("hostile", total == 0, f"scored {total} in all")
    crash = tests["01: public course-1"]["output"]
    check("crash", "crashed with signal 11 (SIGSEGV)" in crash, crash.splitlines()[0])
    loop = tests["02: public course-1"]["output"]
    check("endless loop", "time limit" in loop, loop.splitlines()[0])
    later = tests["02: public course-2"]["output"]
    check("endless loop", later.startswith("not run: an earlier test"), later.splitlines()[0])
    # Its idea test ran out of time first: it names the loop, not the idea (the heap) it lacks.
    idea = next((t["output"] for n, t in tests.items() if n.startswith("02: idea")), "no idea test")
    check("endless loop", "never ends" in idea and "course-1" in idea and "full scan" not in idea,
          idea.splitlines()[0])
    flood = tests["03: public course-1"]["output"]
    check("flood", "output cap" in flood, flood.splitlines()[0])


def case_hang_large():
    """A stage that hangs only on scenes of more than 100 particles: its first time-out holds back
    the later scenes as large or larger, never the smaller ones, which keep their points; a
    second time-out (none here) would hold back everything after it."""
    root = submission("hang-large", mutations=mutants_of("hang-large"))
    tests, _ = grade("hang-large", root, stages="01")
    names = [n for n in tests if n.startswith("01: public") or n.startswith("01: hidden")]
    first = next((n for n in names if "time limit" in tests[n]["output"]), None)
    check("hang-large", first is not None, f"a time-out among {len(names)} tests")
    if first is None:
        return
    later = names[names.index(first) + 1:]
    held = [n for n in later if tests[n]["output"].startswith("not run: an earlier test")]
    ran = [n for n in later if n not in held]
    check("hang-large", held and all(f"({first.split(' ', 2)[2]}, N = " in tests[n]["output"]
                                     for n in held),
          f"{len(held)} later tests held back, naming the scene and its N: "
          f"{tests[held[0]]['output'].splitlines()[0] if held else 'none'}")
    check("hang-large", ran and all(tests[n]["status"] == "passed" for n in ran),
          f"the {len(ran)} later scenes of at most 100 particles ran and passed: "
          f"{', '.join(n.split(' ', 2)[2] for n in ran)}")
    score = sum(t["score"] for t in tests.values())
    check("hang-large", 0 < score < sum(t["max_score"] for t in tests.values()),
          f"{score:g} points: those of the scenes it finishes")


CASES = {"solutions": case_solutions, "starting-points": case_starting_points,
         "mutants-a": case_mutants_a, "mutants-b": case_mutants_b, "mutants-hidden": case_mutants_hidden,
         "hostile": case_hostile, "hang-large": case_hang_large}
scratch.mkdir(parents=True, exist_ok=True)
for name, case in CASES.items():
    if not only or name in only:
        case()
if failures:
    sys.exit("grader self-test failures:\n  " + "\n  ".join(failures))
print("every grader self-test passed")
