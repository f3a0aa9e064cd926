#!/usr/bin/env python3
"""Checks `plab report`: on the reference stage 03 with two sizes and two thread counts it writes
report.md with this machine's description, one table row per configuration (the timings' own CSV),
the three figures as PNG images of a real size, and the handout's questions; run again, it rewrites
only its marked parts and keeps the student's text (or, marks gone, leaves the report alone and
writes report.new.md); on stage 08, the bytes its ranks sent a step, by MPI function too. Run by
CTest (label report).

  report_check.py PLAB_PROGRAM SCRATCH_DIR
"""
import csv
import pathlib
import shutil
import subprocess
import sys

from PIL import Image

plab, scratch = sys.argv[1], pathlib.Path(sys.argv[2])
shutil.rmtree(scratch, ignore_errors=True)


def report(stage, out, n, counts):
    """`plab report` of the kit's solution of `stage` at sizes `n` on `counts` threads (or
    ranks), 1 run of 5 steps (3 on ranks) into `out`; exits on a failure."""
    option = "--ranks" if stage == "08" else "--threads"
    done = subprocess.run([plab, "report", "--stage", stage, "--impl", "solution", "--n", n,
                           option, counts, "--steps", "3" if stage == "08" else "5", "--runs", "1",
                           "--out", str(out)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"plab report --stage {stage} exited {done.returncode}:\n{done.stdout}\n"
                 f"{done.stderr}")
    return done


out = scratch / "report-03"
report("03", out, "100,200", "1,2")
md = (out / "report.md").read_text()
rows = list(csv.DictReader(open(out / "bench.csv", newline="")))
assert len(rows) == 4, f"{len(rows)} timings, expected 2 sizes x 2 thread counts"
for r in rows:  # every timing is in the table, as measured
    line = f"| {r['n']} | {r['threads']} | {float(r['median_s']):.3f} |"
    assert line in md, f"the table has no row {line!r}"
for part in ("## The machine", "| cores the OS sees |", "## Measurements",
             "## Questions from the handout (handouts/03-"):
    assert part in md, f"report.md has no {part!r}"
questions = md.split("## Questions from the handout", 1)[1]
assert "has no section named Questions" not in questions and len(questions.strip()) > 80, \
    f"the handout's questions are missing:\n{questions}"
for fig in ("time-vs-n.png", "speedup.png", "efficiency.png"):
    assert f"]({fig})" in md, f"report.md does not show {fig}"
    with Image.open(out / fig) as im:
        assert im.format == "PNG" and im.size[0] > 300 and im.size[1] > 200, (fig, im.size)
# Run again: the student's text stays, only the marked parts (machine, measurements) are new
mine = md.replace("*your name, the date*", "Ada Student, 7 December").replace(
    "*In a paragraph: the stage's idea", "I wrote rounds. *In a paragraph: the stage's idea")
(out / "report.md").write_text(mine)
again = report("03", out, "150", "1")
assert again.returncode == 0 and "the rest kept as you wrote it" in again.stdout, again.stdout
md2 = (out / "report.md").read_text()
assert "Ada Student, 7 December" in md2 and "I wrote rounds." in md2, "the student's text is lost"
assert "| 150 | 1 |" in md2 and "| 100 | 1 |" not in md2, "the measurements were not rewritten"
assert md2.count("## Measurements") == 1 and md2.count("| cores the OS sees |") == 1, md2
# Marks removed by the student: their report is left as it was, the new skeleton beside it
(out / "report.md").write_text("my own report, no marks\n")
third = report("03", out, "150", "1")
assert third.returncode == 0 and "report.new.md" in third.stdout, third.stdout
assert (out / "report.md").read_text() == "my own report, no marks\n", "the report was overwritten"
assert "| 150 | 1 |" in (out / "report.new.md").read_text()
# On ranks (stage 08): the bytes a step, in all and by MPI function (handout 08's question 2).
out8 = scratch / "report-08"
report("08", out8, "400", "1,2")
md8 = (out8 / "report.md").read_text()
assert "| bytes a step | by call, a step |" in md8, f"no bytes columns:\n{md8}"
two = [line for line in md8.splitlines() if line.startswith("| 400 | 2 |")]
assert len(two) == 1 and "MPI_" in two[0], f"the 2-rank row names no MPI call: {two}"
bad = subprocess.run([plab, "report", "--stage", "42"], capture_output=True, text=True)
assert bad.returncode != 0 and "42" in bad.stderr, f"stage 42 accepted:\n{bad.stderr}"
shutil.rmtree(scratch)
print("plab report: table, figures and questions written")
