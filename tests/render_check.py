#!/usr/bin/env python3
"""Checks `plab render`: a small scene becomes a GIF with one frame per step, one frame becomes an
SVG, and --diff renders two outputs and names their first difference. Run by CTest (label render).

  render_check.py PLAB_PROGRAM DATASETS_DIR SCRATCH_DIR
"""
import pathlib
import subprocess
import sys

from PIL import Image

plab, datasets, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
scratch.mkdir(parents=True, exist_ok=True)
scene = datasets / "scenes" / "dense-box.in"
golden = datasets / "golden" / "dense-box.out"  # print mode: every step
# The instructor's copy draws the kit's solution's run; a student's copy (no solutions/), whose
# stage 02 may not be done yet, draws the golden file: this test checks plab render, not a stage
source = (("--impl", "solution") if (datasets.parent / "solutions").is_dir()
          else ("--from", golden))


def run(*args):
    done = subprocess.run([plab, *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"plab {' '.join(map(str, args))} exited {done.returncode}:\n{done.stderr}")
    return done.stdout


gif = scratch / "dense-box.gif"
run("render", scene, *source, "--steps", "3:14", "--follow", "5", "--out", gif)
with Image.open(gif) as im:
    assert im.format == "GIF", im.format
    assert im.n_frames == 12, f"{im.n_frames} frames for steps 3..14, expected 12"
    assert im.size[0] > 300 and im.size[1] > 300, im.size
print(f"{gif.name}: 12 frames, {im.size[0]} x {im.size[1]}")

svg = scratch / "dense-box.svg"
run("render", scene, *source, "--steps", "0:4", "--out", svg)
text = svg.read_text()
assert text.lstrip().startswith("<?xml") and "<svg" in text, "not an SVG"
assert "step 0:" in text or "step 0" in text
print(f"{svg.name}: one frame, {len(text)} bytes")

expected, actual = golden, scratch / "actual.out"
lines = expected.read_text().splitlines()
changed = [ln if not ln.startswith("9 7 ") else "9 7 " + " ".join(
    f"{float(v) + 0.5:.8f}" if k == 0 else v for k, v in enumerate(ln.split()[2:]))
    for ln in lines]
actual.write_text("\n".join(changed) + "\n")
said = run("render", scene, "--diff", expected, actual, "--out", scratch / "diff.gif")
assert "step 9, particle 7, field x" in said, said
with Image.open(scratch / "diff.gif") as im:
    assert im.n_frames == 10, f"{im.n_frames} frames for steps 1..10, expected 10"
print("diff: first difference named (step 9, particle 7, x); 10 frames side by side")

other = datasets / "golden" / "random-150.out"  # another scene's output
wrong = subprocess.run([plab, "render", scene, "--diff", other, other, "--out", scratch / "w.gif"],
                       capture_output=True, text=True)
assert wrong.returncode != 0 and "holds 150 particles a step, the scene 40" in wrong.stderr, wrong.stderr
print("another scene's outputs: refused, with both counts")

bad = subprocess.run([plab, "render", scene, *source, "--steps", "5:2", "--out", scratch / "x.gif"],
                     capture_output=True, text=True)
assert bad.returncode != 0 and "--steps needs 0 <= FIRST <= LAST" in bad.stderr, bad.stderr
print("bad --steps: refused with a message")
