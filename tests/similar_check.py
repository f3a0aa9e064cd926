#!/usr/bin/env python3
"""Checks `plab similar`: a class of stage 03 submissions written independently (the kit's
solution and two others in tests/similar/, each checked against the golden files when written)
with one planted copy (tests/similar/dee: bo's code with every identifier renamed, its functions
in another order and its comments rewritten), one submission as a zip (with a Mac's __MACOSX
resource forks), one with no stage 03 and one with stage 02's file flat (neither compared).
The copy must rank first and be flagged; no independent pair may be flagged; the HTML page must
show the pair side by side and load nothing from the network. Run by CTest (label kit).

  similar_check.py PLAB_PROGRAM KIT_SOURCE SCRATCH_DIR
"""
import json
import pathlib
import shutil
import subprocess
import sys
import zipfile

try:
    import copydetect  # noqa: F401  (what plab similar runs; ./plab installs it)
except ImportError:
    print("skipped: copydetect is not installed (python3 -m pip install copydetect)")
    sys.exit(77)

plab, kit, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
shutil.rmtree(scratch, ignore_errors=True)
cls = scratch / "class"
for who in ("bo", "dee"):
    (cls / who / "stages" / "03-openmp").mkdir(parents=True)
    shutil.copy2(kit / "tests" / "similar" / who / "step.cpp", cls / who / "stages" / "03-openmp")
(cls / "ann").mkdir()  # flat upload: the kit's own solution
shutil.copy2(kit / "solutions" / "03-openmp" / "step.cpp", cls / "ann")
with zipfile.ZipFile(cls / "cy.zip", "w") as z:  # a zip upload, with a Mac's resource forks
    z.write(kit / "tests" / "similar" / "cy" / "step.cpp", "03-openmp/step.cpp")
    z.writestr("__MACOSX/03-openmp/._step.cpp", "\x00\x05\x16\x07 resource fork")
    z.writestr(".DS_Store", "\x00\x00\x00\x01Bud1")
(cls / "fay").mkdir()  # stage 02's file uploaded flat (its banner says so): not stage 03's
shutil.copy2(kit / "solutions" / "02-heap" / "step.cpp", cls / "fay")
(cls / "eve" / "stages" / "02-heap").mkdir(parents=True)  # no stage 03: not compared
shutil.copy2(kit / "stages" / "02-heap" / "step.cpp", cls / "eve" / "stages" / "02-heap")

page, ranking = scratch / "similar.html", scratch / "similar.json"
done = subprocess.run([plab, "similar", str(cls), "--stage", "3", "--out", str(page),
                       "--json", str(ranking)], capture_output=True, text=True)
if done.returncode != 0:
    sys.exit(f"plab similar exited {done.returncode}:\n{done.stdout}\n{done.stderr}")
r = json.loads(ranking.read_text())
pairs = r["pairs"]
assert r["submissions"] == ["ann", "bo", "cy", "dee"], r["submissions"]
assert any("eve" in s for s in r["not_compared"]), r["not_compared"]
assert any("fay" in s for s in r["not_compared"]), r["not_compared"]
assert {pairs[0]["a"], pairs[0]["b"]} == {"bo", "dee"}, f"the copy is not first: {pairs[:2]}"
assert pairs[0]["flagged"], f"the copy is not flagged: {pairs[0]}"
honest = [p for p in pairs if {p["a"], p["b"]} != {"bo", "dee"}]
assert not any(p["flagged"] for p in honest), f"an independent pair is flagged: {honest}"
# ann handed in the kit's own solution: the instructor's copy compares everyone with it.
near = {k["student"]: k for k in r["kit_solution"]}
assert near["ann"]["flagged"], f"ann's copy of the kit's solution is not flagged: {near}"
assert not any(k["flagged"] for s, k in near.items() if s != "ann"), f"others flagged: {near}"
assert "ann" in done.stdout and "kit's own solution" in done.stdout, done.stdout
text = page.read_text()
assert "bo and dee" in text and "highlight-red" in text, "the page does not show the pair"
assert "http://" not in text and "https://" not in text, "the page loads from the network"
assert "1         " in done.stdout or "FLAGGED" in done.stdout, done.stdout
assert r["groups"] == [["bo", "dee"]], r["groups"]
# A class copied from one source: its flagged pairs join into one group, listed once; equal
# similarities rank by the code they share, then by name (the same order every run).
sys.path.insert(0, str(kit / "kit" / "python"))
from plab.similar import groups  # noqa: E402
same = [{"a": a, "b": b, "score": 1.0} for a, b in (("k", "m"), ("m", "n"), ("k", "n"), ("p", "q"))]
same += [{"a": "k", "b": "p", "score": 0.3}, {"a": "x", "b": "y", "score": 0.8}]
assert groups(same, 0.75) == [["k", "m", "n"], ["p", "q"], ["x", "y"]], groups(same, 0.75)
assert groups(same, 0.9) == [["k", "m", "n"], ["p", "q"]], groups(same, 0.9)
assert groups(same, 0.2) == [["k", "m", "n", "p", "q"], ["x", "y"]], groups(same, 0.2)
shutil.rmtree(scratch)
print(f"plab similar: the copy first at {pairs[0]['similarity']:.0%}, the closest independent "
      f"pair {honest[0]['similarity']:.0%} (threshold {r['threshold']:.0%})")
