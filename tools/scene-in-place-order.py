#!/usr/bin/env python3
"""Writes a scene with its particles numbered in the order of place: rows of height L / ROWS,
each cut into 4 columns a row height (the order of the engine's grid at the step's start),
row-major. The same particles and the same physics, other scene ids; handouts/engine-gpu.md uses
it to measure what particles kept in cell order would be worth (the scene as generated against
the same scene numbered by place).

  tools/scene-in-place-order.py IN OUT [--rows ROWS]
"""
import argparse
import math
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="a scene with its particle lines (plab gen --out)")
    ap.add_argument("out", help="where the renumbered scene goes")
    ap.add_argument("--rows", type=int, default=0,
                    help="rows of the order (default: sqrt(N), about the engine's own)")
    a = ap.parse_args()
    with open(a.scene) as f:
        head = [f.readline() for _ in range(5)]
        try:
            n, box = int(head[0]), float(head[1])
        except ValueError:
            sys.exit(f"{a.scene}: lines 1-2: expected N and L (model.md's input)")
        parts = [line.split() for line in f if line.strip()]
    if len(parts) != n or any(len(p) != 5 for p in parts):
        sys.exit(f"{a.scene}: expected {n} particle lines 'i x y vx vy' after the header "
                 f"(a scene without them: write it with plab gen first)")
    rows = a.rows if a.rows > 0 else max(1, int(math.sqrt(n)))
    cell = box / rows
    parts.sort(key=lambda p: (int(float(p[2]) / cell), int(float(p[1]) * 4 / cell)))
    with open(a.out, "w") as f:
        f.writelines(head)
        for k, p in enumerate(parts):  # the numbers as written: the same bits
            f.write(f"{k} {p[1]} {p[2]} {p[3]} {p[4]}\n")
    print(f"{a.out}: {n} particles numbered in the order of {rows} rows x {4 * rows} columns")


if __name__ == "__main__":
    main()
