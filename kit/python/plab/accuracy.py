"""plab accuracy: run time against error, the stepped model against exact hard-disk dynamics.

Started by `./plab accuracy` (its options are this module's own; the programs come from
`plab built --json`). For each scene it runs the exact event-driven stage (07) and, against
it, the fastest stepped stage (06) in variants: K substeps per printed step (K = 1, 2, 4, ..., 64;
velocities divided by K, K times the steps), in double (model.md's contract) and in float, on the
CPU and, where there is a GPU, on the GPU (double). Errors, at equal physical time:
  collisions  the stepped run's pair collisions over the exact run's (1: none missed)
  overlap     the mean fraction of disks overlapping another at the printed times, and the deepest
  position    the mean distance from the exact positions after 1, 2 and 4 printed steps, in r
  energy      the largest relative change of the kinetic energy over the run
Scenes and outputs are read by the kit's own reader (`plab read --json`, plab.plabio).
"""
import argparse
import csv
import json
import math
import os
import pathlib
import sys

from plab import load_module, plabio  # the kit's formats and programs

SCENES = {
    "report": ("the 2019 report's scene: N = 10^4, L = 20000, r = 1, model.md's speeds",
               ["--n", "10000", "--l", "20000", "--r", "1", "--steps", "8", "--seed", "6"]),
    "dense-gas": ("a dense slow gas: N = 10^4, area fraction 0.3, speeds 1 to 2 (r = 1)",
                  ["--n", "10000", "--l", "323.6", "--r", "1", "--steps", "8", "--speed", "1:2",
                   "--seed", "3"]),
    "cradle": ("the course's Newton's cradle (course-2)", None),
}


def read_output(plab, path):
    """Print-mode output: {step: (xs, ys)} and the pair collisions (the final counters)."""
    blocks = plab.read_output(path)["blocks"]
    pc = sum(sum(b["pc"]) for b in blocks if b["counters"])
    return {b["step"]: (b["x"], b["y"]) for b in blocks}, pc // 2


def read_audit_log(path):
    with open(path) as f:
        return [json.loads(line) for line in f]


def run(plab, program, scene, work, tag, extra, env=None):
    out, rep, log = (os.path.join(work, f"{tag}.{x}") for x in ("out", "report.json", "audit.jsonl"))
    p = plabio.run_stage(program, scene, "--quiet", "--mode", "print", "--out", out, "--report", rep,
                         "--audit", os.path.join(work, f"{tag}.audit.json"), "--audit-log", log,
                         *extra, env=env)
    if p.returncode != 0:
        said = p.stderr.strip().splitlines()
        sys.exit(f"plab accuracy: {os.path.basename(program)} stopped on {tag} (exit "
                 f"{p.returncode}): {said[-1] if said else 'no message'}" +
                 ("; plab accuracy needs stages 06 and 07 done" if p.returncode == 3 else ""))
    with open(rep) as f:
        report = json.load(f)
    blocks, pairs = read_output(plab, out)
    os.remove(out)
    return {"seconds": report["step_seconds"], "device": report["device"], "blocks": blocks,
            "pairs": pairs, "log": read_audit_log(log)}


def errors(exact, got, r):
    """The error measures of one variant against the exact run."""
    row = {"collision_ratio": got["pairs"] / exact["pairs"] if exact["pairs"] else float("nan")}
    for t in (1, 2, 4):
        if t in exact["blocks"] and t in got["blocks"]:
            (ex, ey), (gx, gy) = exact["blocks"][t], got["blocks"][t]
            row[f"position_error_{t}"] = sum(math.hypot(a - c, b - d) for a, b, c, d in zip(ex, ey, gx, gy)) / len(ex) / r
        else:
            row[f"position_error_{t}"] = float("nan")
    n = len(exact["blocks"][0][0])
    states = got["log"][1:]  # after each printed step
    row["overlap_fraction"] = sum(s["overlapping"] for s in states) / max(1, len(states)) / n
    row["deepest_overlap"] = max((s["deepest_overlap"] for s in states), default=0)
    e0 = got["log"][0]["energy"]
    row["energy_drift"] = max(abs(s["energy"] - e0) / e0 for s in got["log"]) if e0 else 0
    return row


def substeps(text):
    """--max-k's value: an integer from 1 to 1024."""
    try:
        k = int(text)
    except ValueError:
        k = 0
    if not 1 <= k <= 1024:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of substeps from 1 to 1024")
    return k


def programs(plab, stepped, impl=None):
    """(kit, stepped program, exact program, whether the stepped one has a float path): in the
    instructor's copy the stepped stage from the kit's engine where it has that stage (its float
    path), else from `impl`; the manifest's exact stage from `impl` (default as for plab run: the
    solutions, or a student's own stages in a student copy). SystemExit with the reason when one
    cannot run."""
    try:
        kit = plab.built(impl)
        impl = kit["impl"]
        use_engine = False
        if impl == "solution":
            try:
                use_engine = any(s["id"] == stepped for s in plab.built("engine")["stages"])
            except plabio.ProgramError:
                use_engine = False
        if not kit["exact_stage"]:
            sys.exit("plab accuracy: the manifest names no exact stage")
        return (kit, plab.stage_program(stepped, "engine" if use_engine else impl),
                plab.stage_program(kit["exact_stage"], impl), use_engine)
    except plabio.ProgramError as e:
        sys.exit(f"plab accuracy: {e}")


def main():
    ap = argparse.ArgumentParser(
        prog="plab accuracy", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Run time against error: the exact event-driven stage (07) against the fastest "
                    "stepped stage (06) with K substeps per step (K = 1, 2, 4, ... up to --max-k), "
                    "in double and float, on the CPU and (with a GPU) the GPU: collisions missed, "
                    "overlaps, position error after 1, 2 and 4 steps, energy drift; a table, a CSV, "
                    "a plot.", epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--scene", action="append", default=[],
                    help=f"a scene ({', '.join(SCENES)}; default all; repeat or comma-separate)")
    ap.add_argument("--max-k", type=substeps, default=64, metavar="K",
                    help="largest number of substeps (powers of two up to it; 1-1024, default 64)")
    ap.add_argument("--steps", type=int, help="printed steps of the generated scenes (default 8)")
    ap.add_argument("--csv", help="write the table as CSV here")
    ap.add_argument("--plot", help="draw time against error here (PNG or SVG)")
    ap.add_argument("--impl", choices=("solution", "student"),
                    help="whose stages 06 and 07: solution (the kit's; stage 06 from its engine, "
                         "in double and float) or student (yours, in double); default as for "
                         "plab run")
    ap.add_argument("--plab", help=argparse.SUPPRESS)  # the kit's plab program (plab passes it)
    args = ap.parse_args()
    plab = plabio.Plab(args.plab)
    kit, args.stepped, args.exact, has_float = programs(plab, "06", args.impl)
    args.datasets = os.path.join(kit["source"], "datasets")
    args.work = os.path.join(kit["build"], "accuracy")
    args.figures = os.path.join(kit["source"], "handouts", "figures")
    args.scene = [n for s in args.scene for n in s.split(",") if n]
    os.makedirs(args.work, exist_ok=True)
    names = args.scene or list(SCENES)
    for n in names:
        if n not in SCENES:
            ap.error(f"unknown scene {n} (known: {', '.join(SCENES)})")

    cpu_env = dict(os.environ, PLAB_DEVICE="cpu")
    rows = []
    print(f"{'scene':10} {'variant':22} {'time (s)':>9} {'collisions':>10} {'overlap':>8} {'deepest':>8} "
          f"{'pos err 1':>9} {'pos err 2':>9} {'pos err 4':>9} {'E drift':>8}")
    for name in names:
        about, gen = SCENES[name]
        scene = os.path.join(args.work, name + ".in")
        if gen is None:
            scene = os.path.join(args.datasets, "scenes", "course-2.in")
        else:
            g = list(gen)
            if args.steps:
                g[g.index("--steps") + 1] = str(args.steps)
            plab.gen(scene, *g)
        r = plab.read_scene(scene)["r"]
        exact = run(plab, args.exact, scene, args.work, f"{name}.exact", [])
        variants = [("exact (stage 07)", exact, {"k": 0, "real": "double", "device": "cpu"})]
        gpu = None
        k = 1
        while k <= args.max_k:
            for real in ("double", "float") if has_float else ("double",):
                v = run(plab, args.stepped, scene, args.work, f"{name}.{real}.{k}",
                        ["--substeps", str(k), "--real", real], env=cpu_env)
                variants.append((f"06 cpu {real} K={k}", v, {"k": k, "real": real, "device": "cpu"}))
            if gpu is None or gpu:
                v = run(plab, args.stepped, scene, args.work, f"{name}.gpu.{k}", ["--substeps", str(k)])
                gpu = v["device"] != "cpu"
                if gpu:
                    variants.append((f"06 gpu double K={k}", v, {"k": k, "real": "double", "device": "gpu"}))
            k *= 2
        for label, v, meta in variants:
            row = {"scene": name, "variant": label, **meta, "seconds": v["seconds"], **errors(exact, v, r)}
            rows.append(row)
            print(f"{name:10} {label:22} {row['seconds']:9.4f} {row['collision_ratio']:10.4f} "
                  f"{row['overlap_fraction']:8.2g} {row['deepest_overlap']:8.2g} {row['position_error_1']:9.2g} "
                  f"{row['position_error_2']:9.2g} {row['position_error_4']:9.2g} {row['energy_drift']:8.2g}",
                  flush=True)
        print(f"{'':10} ({about}; exact: {exact['pairs']} pair collisions)")
    table = args.csv or os.path.join(args.work, "accuracy.csv")
    with open(table, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    if args.csv:
        print(f"wrote {args.csv}")
    if args.plot:
        plot_bench = load_module(pathlib.Path(args.figures) / "plot_bench.py")
        plot_bench.accuracy_frontier(table, args.plot)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
