#!/usr/bin/env python3
"""Checks `plab release` (CTest label release): the student copy has no solutions, carries docs
built from itself, builds on its own, passes the kit's tests and fails each stage's tests on the
untouched starting points with the "not done yet" message.

  release_check.py PLAB_PROGRAM      (works in a temporary folder outside the kit)
"""
import pathlib
import shutil
import subprocess
import sys
import tempfile

plab = sys.argv[1]
scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-release-check-"))
out = scratch / "student-kit"


def run(*cmd, ok=True, **kw):
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    if ok and done.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))} exited {done.returncode}:\n"
                 f"{done.stdout[-3000:]}{done.stderr[-3000:]}")
    return done


run(plab, "release", "--out", out)
assert not (out / "solutions").exists(), "the release contains solutions/"
assert not (out / ".ci").exists(), "the release contains the instructor's CI"
index = out / "docs" / "html" / "index.html"
assert index.exists(), "no docs in the release"
html = " ".join(p.read_text(errors="replace") for p in (out / "docs" / "html").glob("*.html"))
# Lines that only the solutions contain (the instructor's docs show each of them):
for line in ("mine.push_back", "heap.push"):  # solution-only lines of stages 02, 03 and 06
    assert line not in html, f"the release's docs show a solution's '{line}'"
print(f"release written: no solutions/, docs at {index.relative_to(scratch)}")

build = out / "build"
run("cmake", "-S", out, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release")
run("cmake", "--build", build, "-j", "2")
print("the release configures and builds on its own")
kit = run("ctest", "--test-dir", build, "-L", "^kit$", "-E", "render")
print("its kit tests pass: " + kit.stdout.strip().splitlines()[-1 if "Total" not in kit.stdout else -2]
      if kit.stdout else "its kit tests pass")
for stage in ("01", "02", "03"):
    r = run("ctest", "--test-dir", build, "-L", f"^stage{stage}$", "-LE", "long",
            "--output-on-failure", ok=False)
    assert r.returncode != 0, f"stage {stage}'s tests pass on an untouched starting point"
    said = f"stage {stage}: EXERCISE 1 ("
    assert said in r.stdout, f"stage {stage}'s failing tests do not say '{said}...':\n{r.stdout[-2000:]}"
    print(f"stage {stage}: tests fail on the starting point, saying '{said}...) is not done yet'")
shutil.rmtree(scratch)
print("release check passed")
