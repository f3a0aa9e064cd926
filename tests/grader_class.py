#!/usr/bin/env python3
"""Checks `plab grade --class` on a class of 5 stage 01 submissions (the solution as a folder and as
a zip, the untouched starting point, one that does not compile, one flat upload) and a tarball
(left out, and named): the batch is killed once the first student is graded (no grader of it may
go on running; the gradebook so far is written, the others not-graded), started again, and
must grade only those left (a second batch into the same folder meanwhile is refused); then the
gradebook has one row per student with the right totals, each student has results.json, and the
summary page shows the histogram; the leaderboard page is written and each student has an
anonymous name there. Then, in-process with the graders faked: a failed correctness scene is
flagged `wrong`, and a kit that changes while the class is graded stops the batch (no student kept
as graded), and the next batch grades everyone again. Run by CTest (label grader).

  grader_class.py PLAB_PROGRAM KIT_SOURCE SCRATCH_DIR
"""
import csv
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import zipfile

plab, kit, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
shutil.rmtree(scratch, ignore_errors=True)
cls, out = scratch / "class", scratch / "grades"
solution = (kit / "solutions" / "01-naive" / "step.cpp").read_text()


def upload(name, text, flat=False):
    folder = cls / name if flat else cls / name / "stages" / "01-naive"
    folder.mkdir(parents=True)
    (folder / "step.cpp").write_text(text)


upload("ann", solution)
upload("ben", (kit / "stages" / "01-naive" / "step.cpp").read_text())
upload("cat", solution.replace("apply_one(box, p, plan, i);", "apply_one(box, p, plan, i)"))
upload("dan", solution, flat=True)
with zipfile.ZipFile(cls / "eve.zip", "w") as z:
    z.writestr("stages/01-naive/step.cpp", solution)
expected = {"ann": "full", "ben": "zero", "cat": "zero", "dan": "full", "eve": "full"}
(cls / "fay.tar.gz").write_bytes(b"not a zip")  # left out, and named
cmd = [plab, "grade", "--class", str(cls), "--stages", "01", "--out", str(out), "--jobs", "2"]

# First batch: killed (its whole process group) as soon as one student is graded.
first = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         start_new_session=True)
seen = []
for line in first.stdout:
    seen.append(line.rstrip())
    if "to grade" in line:  # a second batch into the same OUT meanwhile is refused
        other = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
        assert other.returncode != 0 and "another grading is writing" in other.stderr, \
            f"a second batch ran beside the first: exit {other.returncode}\n{other.stderr}"
    if "1/5" in line:
        os.killpg(first.pid, signal.SIGTERM)
        break
first.wait(timeout=120)
assert any("1/5" in ln for ln in seen), "the first batch never finished a student:\n" + "\n".join(seen)


def graders_left():
    """Processes still grading into OUT (a stopped batch must leave none: a queued student
    started after the stop would race the resumed batch)."""
    left = []
    for proc in pathlib.Path("/proc").iterdir():
        try:
            line = (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if str(out) in line and "plab.grade" in line:
            left.append(line)
    return left


assert not graders_left(), f"graders still running after the batch stopped: {graders_left()}"
graded = [p.parent.name for p in out.glob("students/*/upload.sha256")]
assert 1 <= len(graded) < 5, f"after the kill, {len(graded)} students graded: {graded}"
assert any("left out" in ln and "fay.tar.gz" in ln for ln in seen), "\n".join(seen)
# The stopped batch wrote the gradebook so far: the graded students' rows, the others not-graded
rows = {r["student"]: r for r in csv.DictReader(open(out / "gradebook.csv", newline=""))}
assert sorted(rows) == sorted(expected), f"gradebook rows after the stop: {sorted(rows)}"
assert all(("not-graded" in r["flags"]) == (name not in graded) for name, r in rows.items()), rows

# Second batch: resumes, grades only the others.
done = subprocess.run(cmd, capture_output=True, text=True, timeout=1200)
assert done.returncode == 0, f"second batch exited {done.returncode}:\n{done.stdout}\n{done.stderr}"
assert f"{len(graded)} graded already, {5 - len(graded)} to grade" in done.stdout, done.stdout
for name in graded:
    assert f" {name}: " not in done.stdout, f"{name} was graded twice:\n{done.stdout}"

# Third batch: the same stages written "1" (read as 01): nothing to grade. (Other --stages, options
# or another rubric would grade everyone again: the stored key covers them.)
again = subprocess.run([*cmd[:cmd.index("--stages") + 1], "1", *cmd[cmd.index("--stages") + 2:]],
                       capture_output=True, text=True, timeout=600)
assert "5 graded already, 0 to grade" in again.stdout, again.stdout + again.stderr

rows = {r["student"]: r for r in csv.DictReader(open(out / "gradebook.csv", newline=""))}
assert sorted(rows) == sorted(expected), f"gradebook rows: {sorted(rows)}"
for name, what in expected.items():
    r = rows[name]
    total, most = float(r["total"]), float(r["max"])
    assert most > 0, f"{name}: no points possible: {r}"
    assert (total == most) if what == "full" else (total == 0), f"{name}: {r} (expected {what})"
    assert (out / "students" / name / "results.json").is_file(), name
assert "build" in rows["cat"]["flags"], rows["cat"]
page = (out / "summary.html").read_text()
assert "data:image/png;base64," in page and "stage 01" in page, "the summary has no histogram"
# The copies: every pair of the stage compared, the page linked from the summary; the three
# uploads of the kit's solution (ann, dan, eve) flagged as a pair and as close to the solution
assert (out / "similar-01.html").is_file() and 'href="similar-01.html"' in page, page[-2000:]
same = json.loads((out / "similar-01.json").read_text())
flagged = {tuple(sorted((q["a"], q["b"]))) for q in same["pairs"] if q["flagged"]}
assert ("ann", "dan") in flagged and "kit's own solution" in page, (flagged, page[-1500:])
# (cat's upload is the same solution with a compile error: one group of four, said once)
assert ["ann", "cat", "dan", "eve"] in same["groups"] and "4 students (ann, cat, dan, eve)" in page, \
    (same["groups"], page[-1500:])
board = (out / "leaderboard.html").read_text()
assert board.startswith("<!DOCTYPE html>") and "http" not in board, "no offline leaderboard page"
anonymous = {r["leaderboard name"] for r in rows.values()}
assert len(anonymous) == 5 and all(a.startswith("anon-") for a in anonymous), anonymous
assert not any(f">{name}<" in board for name in expected), "a student's name on the leaderboard"
shutil.rmtree(scratch)
print(f"plab grade --class: killed after {len(graded)} of 5, resumed with the other "
      f"{5 - len(graded)}; gradebook of 5 rows")

# In-process, with the graders faked: the flags of a wrong output, and a kit that changes while
# the class is graded (a `git pull` mid-batch): the batch stops, keeps no student as graded, and
# the same command grades everyone again.
sys.path.insert(0, str(kit / "kit" / "python"))
from plab.grade import classroom  # noqa: E402

wrong = {"tests": [{"name": "02: public course-2", "status": "failed", "score": 0, "max_score": 1,
                    "output": "first difference at line 3: step 1, particle 0, field x"},
                   {"name": "02: hidden hidden-ties", "status": "failed", "score": 0,
                    "max_score": 2, "output": "not run: an earlier test ran out of its time"},
                   {"name": "01: public course-1", "status": "failed", "score": 0, "max_score": 1,
                    "output": "stage 01 does not compile: step.cpp:3: error: expected ';'"}]}
assert classroom.flags(wrong) == ["build", "wrong"], classroom.flags(wrong)
fake_kit = scratch / "fake-kit"
(fake_kit / "kit").mkdir(parents=True)
(fake_kit / "kit" / "file.txt").write_text("before")
fake_cls, fake_out = scratch / "fake-class", scratch / "fake-grades"
for name in ("ann", "ben", "cat"):
    (fake_cls / name / "stages" / "01-naive").mkdir(parents=True)
    (fake_cls / name / "stages" / "01-naive" / "step.cpp").write_text(solution)
started = []


def fake_grade_one(name, entry, out, grader_args, stages, jobs_cpu, key, graders):
    started.append(name)
    mine = out / "students" / name
    mine.mkdir(parents=True, exist_ok=True)
    data = {"tests": [{"name": "01: public course-1", "status": "passed", "score": 1,
                       "max_score": 1, "output": ""}]}
    (mine / "results.json").write_text(classroom.json.dumps(data))
    (mine / "upload.sha256").write_text(key + "\n")
    if len(started) == 1:
        (fake_kit / "kit" / "file.txt").write_text("after")  # the kit moves under the batch
    return name, data, 0.1


classroom.KIT, classroom.grade_one = fake_kit, fake_grade_one
rubric = kit / "kit" / "grade" / "rubric.json"
status = classroom.run(fake_cls, fake_out, 1, "01", False, [], rubric)
assert status == 1 and started == ["ann"], (status, started)
rows = {r["student"]: r for r in csv.DictReader(open(fake_out / "gradebook.csv", newline=""))}
assert all("not-graded" in r["flags"] for r in rows.values()), rows
started.clear()
status = classroom.run(fake_cls, fake_out, 1, "01", False, [], rubric)
assert status == 0 and sorted(started) == ["ann", "ben", "cat"], (status, started)
# --regrade WHO: the students named, or those whose timing was too noisy, and no one else
started.clear()
assert classroom.run(fake_cls, fake_out, 1, "01", "ben", [], rubric) == 0 and started == ["ben"], started
noisy = fake_out / "students" / "cat" / "results.json"
noisy.write_text(json.dumps({"tests": [{"name": "01: performance", "status": "passed", "score": 1,
                                        "max_score": 1, "output": "TOO NOISY: rerun"}]}))
started.clear()
assert classroom.run(fake_cls, fake_out, 1, "01", "noisy", [], rubric) == 0 and started == ["cat"], started
shutil.rmtree(scratch)
print("a wrong output is flagged `wrong`; a kit changed mid-batch stops it, and the next batch "
      "grades every student again")
