#!/usr/bin/env python3
"""Speedup figure of stage 03 from the CSV that `plab bench --csv` writes (matplotlib).

Usage: python3 handouts/figures/plot_bench.py   (reads data/bench-stage03*.csv, writes *.png)
"""
import csv
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent


def rows(name):
    with open(HERE / "data" / name, newline="") as f:
        return list(csv.DictReader(f))


def main():
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    data = [r for r in rows("bench-stage03.csv") if r["stage"] == "03"]
    for n in sorted({int(r["n"]) for r in data}):
        pts = sorted((int(r["threads"]), float(r["speedup"])) for r in data if int(r["n"]) == n)
        left.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"N = {n}")
    left.plot([1, 2], [1, 2], "k:", label="linear")
    left.set(xlabel="threads", ylabel="speedup over 1 thread", xticks=[1, 2],
             title="Stage 03, S = 500 (2-core machine)")
    left.legend()
    sched = [r for r in rows("bench-stage03-schedules.csv") if r["threads"] == "2"]
    right.bar([r["schedule"] for r in sched], [float(r["speedup"]) for r in sched])
    right.axhline(2, color="k", linestyle=":")
    right.set(ylabel="speedup with 2 threads", title="Phase-1 schedule, N = 4000, S = 100")
    fig.tight_layout()
    fig.savefig(HERE / "stage03-speedup.png", dpi=100)


if __name__ == "__main__":
    main()
