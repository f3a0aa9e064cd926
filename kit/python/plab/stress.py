"""plab stress: hostile scenes on every stage, invariants at every step, all stages bit-identical.

Started by `./plab stress` (its options are this module's own; the stage programs come from
`plab built --json`). For each scene it runs each stage with
`--audit` (full-precision checks of every state and step, see kit/include/plab/audit.hpp) and
`--digest` (a hash of every state), then checks:
  - no NaN or infinity;
  - every centre within [r, L - r] up to OUTSIDE_ULPS ulps of L;
  - the kinetic energy of each collision (pair: the two disks together; wall: the disk) kept to
    within COLLISION_ULPS ulps;
  - counters: never falling, at most one event per particle per step, pair counters summing even;
  - every stage's digests identical to the first stage's.
It prints a table and exits 1 on any violation. It also measures the pair-time formula itself
(plab-pairtime-ulps) and can draw that distribution (--plot). Scenes are read and digests compared
by the kit's own programs (`plab read --json`, `plab diff`, through plab.plabio).
"""
import argparse
import csv
import json
import math
import os
import pathlib
import random
import subprocess
import sys
import time

from plab import load_module, plabio  # the kit's formats and programs

OUTSIDE_ULPS = 4      # a centre may be this many ulps of L outside [r, L - r] (rounding of x + t v)
COLLISION_ULPS = 16   # a collision may change the energy of its disks by this many ulps (model.md
                      # turns the velocities into normal and tangent parts and back: a few roundings
                      # for each component)


def fmt(v):
    """A double as text that reads back to the same value."""
    return repr(float(v))


def scene_text(L, r, steps, particles, mode="perf"):
    lines = [str(len(particles)), fmt(L), fmt(r), str(steps), mode]
    lines += [f"{i} {fmt(x)} {fmt(y)} {fmt(vx)} {fmt(vy)}" for i, (x, y, vx, vy) in enumerate(particles)]
    return "\n".join(lines) + "\n"


def lattice(n, L, r, spacing, rng, speed):
    """n disks on a square lattice of the given spacing, random directions at `speed`."""
    per_row = int((L - 2 * r) // spacing) + 1
    out = []
    for k in range(n):
        x, y = r + spacing * (k % per_row), r + spacing * (k // per_row)
        a = rng.uniform(0, 2 * math.pi)
        out.append((x, y, speed * math.cos(a), speed * math.sin(a)))
    return out


def scenes(rng, long_steps):
    """The hostile scenes: (name, what it tests, scene text or generator arguments)."""
    s = []
    # Exact corner hits, at integer and other times, on both diagonals.
    s.append(("corner-hits", "exact corner hits (both axes at once), at integer and other times",
              scene_text(100, 1, 200, [(50, 50, 7, 7), (25, 25, -0.75, -0.75), (30, 70, -2.5, 2.5),
                                       (70, 30, 0.5, -0.5), (90, 10, 1.125, -1.125)], "print")))
    # Tangent paths (discriminant exactly 0) and paths an ulp either side.
    tiny = 2.0 ** -46
    s.append(("grazing", "tangent paths (discriminant exactly 0) and an ulp inside and outside",
              scene_text(200, 1, 60, [(20, 50, 1, 0), (40, 52, 0, 0), (20, 100, 1, 0),
                                      (40, 102 - tiny, 0, 0), (20, 150, 1, 0), (40, 152 + tiny, 0, 0)],
                         "print")))
    s.append(("head-on-fast", "head-on at speed 1e9 (L = 1e10, r = 1), then the walls",
              scene_text(1e10, 1, 100, [(3e9, 5e9, 1e9, 0), (7e9, 5e9, -1e9, 0)], "print")))
    s.append(("head-on-slow", "head-on at speed 1e-9, 1e-9 apart",
              scene_text(100, 1, 100, [(48.9999999995, 50, 1e-9, 0), (51.0000000005, 50, -1e-9, 0)],
                         "print")))
    s.append(("tiny-r", "r = 1e-3 in L = 1e9, speeds L/8 to L/4 a step",
              ["--n", "200", "--l", "1e9", "--r", "1e-3", "--steps", "50", "--speed", "1.25e8:2.5e8",
               "--seed", "3"]))
    # model.md's generation takes speeds between L/4 and L/(8r) when r < 1/2: here up to 125 box
    # lengths a step. The once-per-step model reflects once and then moves on for the rest of the
    # step, so a disk crossing the box more than once a step leaves it: a limit of the model, not of
    # its arithmetic. The row shows it; it is expected and not counted as a violation.
    s.append(("faster-than-box", "model.md's speeds for r = 1e-3, L = 1e9: up to 125 box lengths a step "
              "(expected to leave the box: the model's limit)",
              ["--n", "200", "--l", "1e9", "--r", "1e-3", "--steps", "50", "--seed", "3"]))
    s.append(("huge-r", "r = 4.99 in L = 10: a disk that can barely move",
              scene_text(10, 4.99, 2000, [(5, 5, 0.003, 0.007)], "print")))
    s.append(("resting-on-walls", "disks on the walls with zero velocity components, at rest in corners",
              scene_text(20, 1, 100, [(1, 5, 0, 3), (19, 15, 0, -2.5), (7, 1, 1.5, 0), (13, 19, -1.25, 0),
                                      (1, 1, 0, 0), (19, 19, 0, 0), (1, 19, 0, 0)], "print")))
    s.append(("equal-velocities", "every disk with the same velocity (a = 0 for every pair)",
              scene_text(100, 1, 300, [(x, y, 3.25, -1.5) for (x, y, _, _) in lattice(100, 100, 1, 5, rng, 0)])))
    s.append(("coincident-centres", "pairs with the same centre (no normal: the event is dropped)",
              scene_text(100, 1, 100, [(20 + 15 * (k // 2), 50, (k % 2) * 2 - 1 + 0.25 * k, 0.5 * k)
                                       for k in range(10)], "print")))
    cluster = [(47 + 6 * rng.random(), 47 + 6 * rng.random(), rng.uniform(-2, 2), rng.uniform(-2, 2))
               for _ in range(60)]
    s.append(("overlapping-starts", "60 disks overlapping each other at the start", scene_text(100, 1, 300, cluster)))
    line = [(10 + 2 * k, 250, 0, 0) for k in range(100)] + [(5, 250, 1.5, 0)]
    s.append(("touching-line", "a line of 100 touching disks (distance exactly 2r) hit at one end",
              scene_text(500, 1, 300, line)))
    hexes = []
    d = 2 * 1.001
    row = 0
    while 1 + row * d * math.sqrt(3) / 2 <= 69:
        x = 1 + (d / 2 if row % 2 else 0)
        while x <= 69:
            hexes.append((x, 1 + row * d * math.sqrt(3) / 2, rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01)))
            x += d
        row += 1
    s.append(("near-jamming", f"{len(hexes)} disks on a hexagonal lattice 0.1% from touching (area "
              f"fraction {len(hexes) * math.pi / 70 ** 2:.2f})", scene_text(70, 1, 100, hexes)))
    s.append(("long-run", f"10 disks for {long_steps} steps",
              ["--n", "10", "--l", "30", "--r", "1", "--steps", str(long_steps), "--speed", "0.5:3",
               "--seed", "9"]))
    return s


def stage_programs(plab, impl, named):
    """[(id, program)]: the stages named, or every stepped stage of `impl` that is built; a clear
    error (SystemExit) for the exact stage or one that cannot run."""
    kit = plab.built(impl, named)
    if named:
        for s in kit["stages"]:
            if s["id"] == kit["exact_stage"]:
                sys.exit(f"plab stress: stage {s['id']} is the exact event-driven stage: its tests "
                         f"check it (./plab test --stage {s['id']}), not the stepped model's invariants")
            if s["problem"]:
                sys.exit(f"plab stress: {s['problem']}")
        return kit, [(s["id"], s["program"]) for s in kit["stages"]]
    chosen = [s for s in kit["stages"] if s["id"] != kit["exact_stage"] and s["exists"]]
    for s in chosen:
        if s["problem"]:
            sys.exit(f"plab stress: {s['problem']}")
    return kit, [(s["id"], s["program"]) for s in chosen]


def main():
    ap = argparse.ArgumentParser(
        prog="plab stress", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Numerical stress suite: hostile scenes (corner hits, grazing, speeds 1e9 and "
                    "1e-9, tiny and huge radii, disks resting on walls, equal velocities, coincident "
                    "centres, overlapping starts, a line of touching disks, near jamming, a long run) "
                    "on every stage, invariants checked at every step, all stages bit-identical; then "
                    "the pair-time formula's error in ulps. Exits 1 on any violation.",
        epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--stages", default="", metavar="NN,NN",
                    help="stages (default: every stepped stage built; a CUDA stage is skipped "
                         "without a GPU)")
    ap.add_argument("--impl", help="solution, student or engine (default as for plab run)")
    ap.add_argument("--only", default="", help="only these scenes (comma-separated names)")
    ap.add_argument("--long-steps", type=int, default=100000, help="steps of the long run (%(default)s)")
    ap.add_argument("--pairs", type=int, default=200000,
                    help="pairs of each kind for the pair-time check (%(default)s)")
    ap.add_argument("--csv", help="write the scene table as CSV here")
    ap.add_argument("--ulps-csv", help="write the pair-time error histograms as CSV here")
    ap.add_argument("--plot", help="draw the pair-time error distribution here (PNG or SVG)")
    ap.add_argument("--plab", help=argparse.SUPPRESS)  # the kit's plab program (plab passes it)
    args = ap.parse_args()
    plab = plabio.Plab(args.plab)
    try:
        kit, stages = stage_programs(plab, args.impl, [s for s in args.stages.split(",") if s])
    except plabio.ProgramError as e:
        sys.exit(f"plab stress: {e}")
    args.ulps_program = os.path.join(kit["bin"], "plab-pairtime-ulps")
    args.work = os.path.join(kit["build"], "stress")
    args.figures = os.path.join(kit["source"], "handouts", "figures")

    os.makedirs(args.work, exist_ok=True)
    rng = random.Random(2019)
    only = set(filter(None, args.only.split(",")))
    rows, violations = [], 0
    header = f"{'scene':20} {'N':>5} {'S':>7} {'stages':14} {'out ulps':>8} {'coll ulps':>9} " \
             f"{'E drift':>9} {'overlap':>7} {'checked':>8}  verdict"
    print(header)
    print("-" * len(header))
    for name, what, spec in scenes(rng, args.long_steps):
        if only and name not in only:
            continue
        path = os.path.join(args.work, name + ".in")
        if isinstance(spec, list):
            plab.gen(path, *spec)
        else:
            with open(path, "w") as f:
                f.write(spec)
        head = plab.read_scene(path)
        n, steps = head["n"], head["steps"]
        digests, audits, ran, problems = {}, {}, [], []
        t0 = time.time()
        for sid, program in stages:
            if sid == "01" and n > 100:
                continue  # O(N^3) a step by design
            dig = os.path.join(args.work, f"{name}.{sid}.digest")
            aud = os.path.join(args.work, f"{name}.{sid}.audit.json")
            p = plabio.run_stage(program, path, "--quiet", "--out", os.devnull, "--digest", dig,
                                 "--audit", aud)
            if p.returncode == 4:  # a CUDA stage without a GPU
                continue
            if p.returncode != 0:
                problems.append(f"stage {sid} failed (exit {p.returncode}): {p.stderr.strip()[:200]}")
                continue
            ran.append(sid)
            with open(dig) as f:
                digests[sid] = (dig, f.read())
            with open(aud) as f:
                audits[sid] = json.load(f)
        for sid in ran[1:]:
            if digests[sid][1] != digests[ran[0]][1]:
                first = (plab.diff(digests[ran[0]][0], digests[sid][0])["first"] or {}).get("step")
                problems.append(f"stage {sid} differs from stage {ran[0]} from step {first or '?'}")
        worst = {k: max((a[k] for a in audits.values()), default=0)
                 for k in ("nonfinite", "outside_ulps", "collision_ulps", "energy_drift", "deepest_overlap",
                           "counter_errors", "collisions_checked")}
        if worst["nonfinite"]:
            problems.append(f"{worst['nonfinite']} NaN or infinite values")
        if worst["outside_ulps"] > OUTSIDE_ULPS:
            problems.append(f"a centre {worst['outside_ulps']:.3g} ulps of L outside [r, L - r]")
        if worst["collision_ulps"] > COLLISION_ULPS:
            problems.append(f"a collision changed the energy by {worst['collision_ulps']:.3g} ulps")
        if worst["counter_errors"]:
            problems.append(f"{worst['counter_errors']} counter errors")
        if not ran:
            problems.append("no stage ran")
        # The one scene built to leave the box: expected when leaving the box is all that happened.
        expected = name == "faster-than-box" and all("outside [r, L - r]" in p for p in problems)
        verdict = "ok" if not problems else ("expected: the model's limit" if expected else "VIOLATION")
        violations += bool(problems) and not expected
        print(f"{name:20} {n:5d} {steps:7d} {','.join(ran):14} {worst['outside_ulps']:8.3g} "
              f"{worst['collision_ulps']:9.3g} {worst['energy_drift']:9.2g} {worst['deepest_overlap']:7.3g} "
              f"{worst['collisions_checked']:8d}  {verdict} ({time.time() - t0:.1f} s)", flush=True)
        for p in problems:
            print(f"    {p}")
        rows.append({"scene": name, "tests": what, "n": n, "steps": steps, "stages": " ".join(ran),
                     **{k: worst[k] for k in worst}, "verdict": verdict, "problems": "; ".join(problems)})
    print(f"\nlimits: centres within {OUTSIDE_ULPS} ulps of L of [r, L - r]; each collision's energy within "
          f"{COLLISION_ULPS} ulps; 'overlap' is the deepest overlap in units of r (scenes that start "
          f"overlapping keep some: the model lets a disk collide once a step); 'checked' counts the "
          f"collisions whose energy was measured (the kit's oracle, N <= 3000)")

    print("\nThe pair-time formula itself, error in ulps against the robust form in long double:")
    ulps_cmd = [args.ulps_program, "--pairs", str(args.pairs)]
    ulps_csv = args.ulps_csv or os.path.join(args.work, "pairtime-ulps.csv")
    subprocess.run(ulps_cmd + ["--csv", ulps_csv], check=True)
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)
        print(f"wrote {args.csv}")
    if args.plot:
        plot_bench = load_module(pathlib.Path(args.figures) / "plot_bench.py")
        plot_bench.pairtime_ulps(ulps_csv, args.plot)
        print(f"wrote {args.plot}")
    print(f"\n{len(rows)} scenes, {violations} with violations")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
