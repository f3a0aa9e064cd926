#!/usr/bin/env python3
"""The grader meets uploads as students make them, and instructors replay gradings (CTest labels
grader, long):

- one stage's files uploaded flat are graded as the stage their banner names, with no --stages;
- a zip of the kit folder is unpacked and graded;
- an upload with no stage in it gets a three-line message naming what was found, never a build log;
  flat files whose banners were taken out are told how to re-upload them (a student cannot pass
  --stages; the message says an instructor can);
- a stage missing from an upload costs that stage's points only; without --stages, a stage that
  is the untouched starting point is not graded, and the summary says so;
- a stage the rubric does not know is a clear error, and results.json says so (never empty);
- the hidden seed is in the summary file and in results.json's extra_data, not in what students
  see at once,
  and `--seed S` replays the same hidden scenes;
- an output left as a link (symbolic or hard) to another file, a golden one say, is never read;
- without namespaces the grader refuses to run student code as an unprivileged user that could read
  the kit's private parts; `--no-sandbox` is printed on every result.

  grader_uploads.py PLAB_PROGRAM KIT_SOURCE_DIR SCRATCH_DIR
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys
import zipfile

plab, kit, scratch = sys.argv[1], pathlib.Path(sys.argv[2]).resolve(), pathlib.Path(sys.argv[3])
failures = []
# a wrong comparison: the later event wins (public and hidden scenes both fail)
MUTANT = ("if (model::key_less(w, best)) best = w;", "if (model::key_less(best, w)) best = w;")


def check(name, condition, message):
    print(("ok   " if condition else "FAIL ") + f"{name}: {message}", flush=True)
    if not condition:
        failures.append(f"{name}: {message}")


def grade(name, submission, *extra):
    out = scratch / name / "results.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    done = subprocess.run([plab, "grade", "--submission", submission, "--out", out,
                           "--scratch", scratch, *extra], capture_output=True, text=True)
    (scratch / name / "log").write_text(done.stdout + done.stderr)
    assert out.exists(), f"{name}: no results.json:\n{done.stdout[-2000:]}{done.stderr[-2000:]}"
    doc = json.loads(out.read_text())
    summary = out.with_suffix(".summary.txt")
    return doc, {t["name"]: t for t in doc["tests"]}, done, summary.read_text() if summary.exists() else ""


def mutant_step():
    text = (kit / "solutions" / "01-naive" / "step.cpp").read_text()
    assert text.count(MUTANT[0]) == 1
    return text.replace(*MUTANT)


def hidden(tests):
    return {n: t["output"] for n, t in tests.items() if t["visibility"] == "after_published"}


def case_flat_and_replay():
    flat = scratch / "flat-upload"
    flat.mkdir(parents=True)
    (flat / "step.cpp").write_text(mutant_step())
    doc, tests, done, summary = grade("flat", flat)
    check("flat", "took 1 file uploaded flat (step.cpp) as stage 01" in doc["output"],
          "a lone step.cpp is taken as the stage its banner names, with no --stages")
    check("flat", tests and all(n.startswith("01") for n in tests), f"{len(tests)} tests of stage 01")
    seed = doc.get("extra_data", {}).get("seed")
    check("seed", seed is not None and f"seed {seed}" in summary,
          f"the seed ({seed}) is in results.json's extra_data and the summary file")
    shown = json.dumps([t["output"] for t in doc["tests"] if t["visibility"] == "visible"])
    check("seed", str(seed) not in shown and str(seed) not in doc["output"],
          "no visible test output, nor results.json's output (shown to students at once), holds "
          "the seed")
    lost = [n for n, t in hidden(tests).items() if "same text" not in t]
    check("mutant", len(lost) > 0, f"the wrong comparison loses {len(lost)} hidden tests")
    repro = next((t for t in hidden(tests).values() if "Reproduce:" in t), "")
    check("reproduce", "EXPECTED" not in repro and "plab.grade.hidden --seed" in repro and "./plab diff" in repro,
          "a hidden failure's Reproduce line is real commands: "
          + repro[repro.find("Reproduce:"):][:200])

    kit_zip = scratch / "kit-upload" / "submission.zip"
    kit_zip.parent.mkdir(parents=True)
    with zipfile.ZipFile(kit_zip, "w") as z:
        z.writestr("particle-lab/README.md", "my kit\n")
        z.writestr("particle-lab/stages/01-naive/step.cpp", mutant_step())
        z.writestr("particle-lab/stages/01-naive/CMakeLists.txt", "this is never read\n")
    doc2, tests2, _, _ = grade("zip", kit_zip.parent, "--seed", str(seed))
    check("zip", "unpacked submission.zip" in doc2["output"] and "stages 01" in doc2["output"],
          "a zip of the kit folder is unpacked and its stages/ taken: "
          + doc2["output"].splitlines()[1 if len(doc2["output"].splitlines()) > 1 else 0][:120])
    check("replay", hidden(tests2) == hidden(tests) and len(hidden(tests)) > 0,
          f"--seed {seed} replays the same {len(hidden(tests))} hidden tests, outputs identical")


def case_refusals():
    junk = scratch / "junk-upload"
    junk.mkdir(parents=True)
    (junk / "notes.txt").write_text("I did it all\n")
    (junk / "screenshot.png").write_bytes(b"\x89PNG")
    doc, tests, done, _ = grade("junk", junk)
    message = tests.get("not graded", {}).get("output", "")
    check("junk", done.returncode != 0 and 0 < len(message.splitlines()) <= 3
          and "notes.txt" in message and "expected:" in message and "cmake" not in message.lower(),
          f"a three-line message naming what was found: {message!r}")
    nameless = scratch / "no-banner-upload"  # one stage's files flat, their banners taken out
    nameless.mkdir(parents=True)
    text = (kit / "solutions" / "01-naive" / "step.cpp").read_text()
    (nameless / "step.cpp").write_text("\n".join(l for l in text.splitlines() if "\\file" not in l))
    doc, tests, done, _ = grade("no-banner", nameless)
    message = tests.get("not graded", {}).get("output", "")
    check("no banner", done.returncode != 0 and "step.cpp" in message
          and "stages/NN-name/ folder" in message and "banner" in message
          and "instructor" in message,
          f"flat files that name no stage: what a student can do, then the instructor's "
          f"--stages: {message!r}")
    doc, tests, done, _ = grade("unknown", junk, "--stages", "09")
    message = tests.get("not graded", {}).get("output", "")
    check("unknown stage", done.returncode != 0 and "no stage 09" in message and doc["tests"],
          f"--stages 09 is a clear error and results.json says so: {message[:100]!r}")
    if os.geteuid() == 0:
        doc, tests, done, _ = grade("user-mode", junk, "--sandbox", "user")
        message = tests.get("not graded", {}).get("output", "")
        check("user mode", done.returncode != 0 and "can read" in message and "chmod" in message,
              f"an unprivileged user that could read the kit is refused: {message[:160]!r}")


def case_links():
    """A program that leaves a link to a golden file as its output gets nothing for it."""
    from plab.grade import sandbox  # PYTHONPATH=kit/python (CTest sets it)
    golden = kit / "datasets" / "golden" / "course-1.out"
    out = scratch / "links"
    out.mkdir(parents=True)
    run = sandbox.Run(0, 0.0, None, None, "", out)
    (out / "out.txt").symlink_to(golden)
    check("links", run.read_output() is None, "an output that is a symbolic link is not read")
    (out / "out.txt").unlink()
    shutil.copyfile(golden, out / "copy.out")
    os.link(out / "copy.out", out / "out.txt")
    check("links", run.read_output() is None, "an output with a second name (a hard link) is not read")
    (out / "out.txt").unlink()
    (out / "out.txt").write_text("0 0 1.00000000 1.00000000 0.00000000 0.00000000\n")
    check("links", run.read_output() is not None, "a plain output file is read")


def case_no_sandbox():
    flat = scratch / "flat-honest"
    flat.mkdir(parents=True)
    shutil.copy2(kit / "solutions" / "01-naive" / "step.cpp", flat / "step.cpp")
    doc, tests, done, _ = grade("no-sandbox", flat, "--no-sandbox")
    check("--no-sandbox", tests and all(t["output"].startswith("[UNSANDBOXED")
                                         for t in tests.values()),
          f"every one of {len(tests)} results says it was not sandboxed")
    check("--no-sandbox", doc.get("extra_data", {}).get("sandbox") == "none"
          and sum(t["score"] for t in tests.values()) == sum(t["max_score"] for t in tests.values()),
          "the honest stage keeps full marks")


def case_partial():
    # A stages/ folder without one of the stages asked for: the others are graded as usual (the
    # kit's CMake once found a folder with no sources for it, and the whole build failed)
    sub = scratch / "partial-upload" / "stages" / "01-naive"
    sub.mkdir(parents=True)
    shutil.copy2(kit / "solutions" / "01-naive" / "step.cpp", sub / "step.cpp")
    doc, tests, done, _ = grade("partial", sub.parent.parent, "--stages", "01,02", "--no-races")
    ones = [t for n, t in tests.items() if n.startswith("01")]
    twos = [t for n, t in tests.items() if n.startswith("02")]
    check("partial", ones and all(t["score"] == t["max_score"] for t in ones),
          f"stage 01 keeps full marks ({sum(t['score'] for t in ones):g} of "
          f"{sum(t['max_score'] for t in ones):g}) beside a stage the upload lacks")
    check("partial", twos and all("has no stages/02-heap/" in t["output"] or
                                  t["output"].startswith("not timed") for t in twos),
          "every stage 02 test says the upload has no stages/02-heap/ (or is not timed)")


def case_untouched():
    # A whole copy of the kit handed in early: stage 01 done, stage 02 as given. Without --stages
    # the untouched starting point is not graded (its zeros are not the student's week)
    sub = scratch / "untouched-upload" / "stages"
    shutil.copytree(kit / "stages" / "02-heap", sub / "02-heap")
    (sub / "01-naive").mkdir()
    shutil.copy2(kit / "solutions" / "01-naive" / "step.cpp", sub / "01-naive" / "step.cpp")
    doc, tests, done, _ = grade("untouched", sub.parent)
    check("untouched", tests and all(n.startswith("01") for n in tests) and
          doc["score"] == sum(t["max_score"] for t in tests.values()),
          f"only stage 01 graded, full marks ({doc['score']} over {len(tests)} tests)")
    check("untouched", "stage 02: the untouched starting point, not graded" in doc["output"],
          "the summary says stage 02 was the untouched starting point")


shutil.rmtree(scratch, ignore_errors=True)
scratch.mkdir(parents=True)
try:
    only = set(sys.argv[4:])
    for name, case in (("links", case_links), ("refusals", case_refusals),
                       ("flat", case_flat_and_replay), ("partial", case_partial),
                       ("untouched", case_untouched),
                       ("no-sandbox", case_no_sandbox)):
        if not only or name in only:
            case()
finally:
    shutil.rmtree(scratch, ignore_errors=True)
if failures:
    sys.exit("grader upload failures:\n  " + "\n  ".join(failures))
print("every upload and replay check passed")
