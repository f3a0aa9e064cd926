#!/usr/bin/env python3
"""Writes a scene with its particles numbered in the order of place: rows of height L / ROWS,
each cut into 4 columns a row height (the order of the engine's grid at the step's start),
row-major. The same particles and the same physics, other scene ids; handouts/engine-gpu.md uses
it to measure what particles kept in cell order would be worth (the scene as generated against
the same scene numbered by place). The scene is read by the kit's reader (`plab read`: a
malformed one is refused with its line) and written with every value's bits kept.

  tools/scene-in-place-order.py IN OUT [--rows ROWS]
"""
import argparse
import math
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "kit" / "python"))
from plab import plabio  # noqa: E402  (the kit's formats and programs)
from plab.stress import scene_text  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="a scene with its particle lines (plab gen --out)")
    ap.add_argument("out", help="where the renumbered scene goes")
    ap.add_argument("--rows", type=int, default=0,
                    help="rows of the order (default: sqrt(N), about the engine's own)")
    a = ap.parse_args()
    try:
        s = plabio.Plab().read_scene(a.scene)
    except (plabio.FormatError, plabio.ProgramError) as e:
        sys.exit(f"error: {e}")
    if s["generated"]:
        sys.exit(f"error: {a.scene} has no particle lines (the kit generates them): write the "
                 f"scene with plab gen --out first")
    n = s["n"]
    rows = a.rows if a.rows > 0 else max(1, int(math.sqrt(n)))
    cell = s["L"] / rows
    order = sorted(range(n), key=lambda i: (int(s["y"][i] / cell), int(s["x"][i] * 4 / cell)))
    particles = [(s["x"][i], s["y"][i], s["vx"][i], s["vy"][i]) for i in order]
    with open(a.out, "w") as f:
        f.write(scene_text(s["L"], s["r"], s["steps"], particles, s["mode"]))
    print(f"{a.out}: {n} particles numbered in the order of {rows} rows x {4 * rows} columns")


if __name__ == "__main__":
    main()
