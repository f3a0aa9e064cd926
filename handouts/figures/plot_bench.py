#!/usr/bin/env python3
"""The handouts' benchmark figures, from the CSV files that `plab bench --csv` writes (matplotlib).

Usage: python3 handouts/figures/plot_bench.py [--out DIR]   (reads data/*.csv; writes PNGs into
DIR, by default beside itself; `plab docs` writes them into build/docs/figures)
  stage03-speedup.png   speedup against threads (data/bench-stage03*.csv)
  stage04-05-time.png   time against N, CPU and GPU, with the 2019 report's figures
                        (data/bench-gpu-h100.csv, data/report-2019.csv)
  stage05-changes.png   what each of stage 05's changes buys (data/ablation-stage05-h100.csv)
  stage06-pairs.png     pairs tested per step by stage 06 against all pairs, and time per step
                        against N at the report's density (data/pairs-stage06.csv,
                        data/bench-stage0[36]-cpu-scale.csv, data/bench-stage06-gpu-scale.csv)
  stage06-cores.png     stage 06's CPU path on 1-16 threads of the H100 and H200 machines' hosts
                        (data/bench-stage06-cpu16.csv, data/bench-engine-selection-h200.csv)
  ceiling.png           speedup on 1-16 threads (stage 06's engine) and ranks (stage 08's) against
                        the machine's own ceiling that `plab bench --ceiling` measured in the same
                        call (data/bench-issue30-ceiling-{cpu,cpu-packed,mpi}-h200*.csv, and
                        data/bench-issue30-ceiling-cpu-h100*.csv)
  stage08-scaling.png   stage 08 on 1-16 ranks: strong scaling at N = 10^6 and weak scaling at
                        10^5 a rank, with the share of time in exchanges (data/bench-stage08-cpu16.csv)
  accuracy.png          run time against error of the stepped model's variants, against stage
                        07's exact dynamics, best-for-its-cost variants ringed (data/accuracy.csv,
                        from `plab accuracy --csv`)
  pairtime-ulps.png     the pair time's error in ulps, model.md's form and the robust one
                        (data/pairtime-ulps.csv, from `plab stress --ulps-csv`)
"""
import argparse
import csv
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
OUT = HERE


def rows(name):
    with open(HERE / "data" / name, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def stage03_speedup():
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
    fig.savefig(OUT / "stage03-speedup.png", dpi=100)
    plt.close(fig)


def report_lines(ax, implementations):
    for r_impl, style in implementations:
        pts = [r for r in rows("report-2019.csv") if r["implementation"] == r_impl]
        ax.plot([int(r["n"]) for r in pts], [float(r["seconds"]) for r in pts], style, color="grey",
                label=f"2019 report, {r_impl} ({pts[0]['device']})")


def gpu_time():
    fig, (cpu, gpu) = plt.subplots(1, 2, figsize=(13, 5))
    report_lines(cpu, (("OpenMP (20 threads)", "^--"),))
    small = rows("bench-stage03.csv")
    for stage, threads, style in (("02", "1", "s-"), ("03", "1", "o-"), ("03", "2", "o--")):
        pts = [r for r in small if r["stage"] == stage and r["threads"] == threads]
        cpu.plot([int(r["n"]) for r in pts], [float(r["median_s"]) for r in pts], style,
                 label=f"stage {stage}, {threads} thread{'s' if threads != '1' else ''}")
    cpu.set(title="CPU stages on this kit's 2-core machine (whole process)")
    report_lines(gpu, (("CUDA", "s--"), ("OpenMP (20 threads)", "^--")))
    bench = rows("bench-gpu-h100.csv")
    labels = {"03": "stage 03, OpenMP, 16 threads", "04": "stage 04, CUDA",
              "05": "stage 05, CUDA + graph"}
    for stage, style in (("03", "o-"), ("04", "D-"), ("05", "v-")):
        pts = [r for r in bench if r["stage"] == stage]
        device = pts[0]["device"] if pts[0]["device"] != "cpu" else "H100 host CPU"
        gpu.plot([int(r["n"]) for r in pts], [float(r["step_median_s"]) for r in pts], style,
                 label=f"{labels[stage]} ({device})")
    gpu.set(title="GPU machine (time in steps; CUDA events on the GPU)")
    for ax in (cpu, gpu):
        ax.set(xscale="log", yscale="log", xlabel="particles N",
               ylabel="seconds for S = 500 steps, L = 20000, r = 1")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "stage04-05-time.png", dpi=100)
    plt.close(fig)


def stage05_changes():
    data = rows("ablation-stage05-h100.csv")
    names = {"none": "all on", "graph": "no graph", "streams": "no second stream",
             "branchless": "branchy walls", "graph-streams-branchless": "all three off"}
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for ax, n in zip(axes, ("1000", "10000")):
        pts = [r for r in data if r["n"] == n]
        ax.bar([names[r["off"]] for r in pts], [1e3 * float(r["step_median_s"]) / 500 for r in pts])
        ax.set(ylabel="ms per step", title=f"Stage 05, N = {n} (H100)")
        ax.tick_params(axis="x", labelrotation=20, labelsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "stage05-changes.png", dpi=100)
    plt.close(fig)


def stage06_pairs():
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5))
    data = rows("pairs-stage06.csv")
    n = [int(r["n"]) for r in data]
    for key, style, label in (("all_pairs", "k--", "all pairs, N(N-1)/2 (stages 01-05)"),
                              ("slab_tests", "o-", "stage 06: slab tests (broad phase)"),
                              ("pair_times", "s-", "stage 06: pair times (narrow phase)")):
        left.plot(n, [float(r[key]) for r in data], style, label=label)
    left.set(xscale="log", yscale="log", xlabel="particles N", ylabel="per step",
             title="Pairs tested per step, at the report's density")
    for name, stage, style, label in (
            ("bench-stage03-cpu-scale.csv", "03", "o--", "stage 03, CPU, 2 threads"),
            ("bench-stage06-cpu-scale.csv", "06", "s-", "stage 06, CPU, 2 threads"),
            ("bench-stage06-gpu-scale.csv", "06", "v-", "stage 06, H100")):
        pts = [r for r in rows(name) if r["stage"] == stage]
        right.plot([int(r["n"]) for r in pts],
                   [1e3 * float(r["step_median_s"]) / int(r["steps"]) for r in pts], style,
                   label=label)
    right.set(xscale="log", yscale="log", xlabel="particles N", ylabel="ms per step",
              title="Time per step at the report's density (L grows with sqrt N)")
    for ax in (left, right):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "stage06-pairs.png", dpi=100)
    plt.close(fig)


def stage06_cores():
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for name, style, when in (("bench-stage06-cpu16.csv", "o-", "H100 host, 2026-11-24"),
                              ("bench-engine-selection-h200.csv", "s--",
                               "H200 host, 2026-11-29, selection in rounds")):
        data = rows(name)
        for n, steps in sorted({(int(r["n"]), int(r["steps"])) for r in data}):
            pts = sorted((int(r["threads"]), float(r["step_median_s"])) for r in data
                         if int(r["n"]) == n and int(r["steps"]) == steps)
            ax.plot([p[0] for p in pts], [pts[0][1] / p[1] for p in pts], style,
                    label=f"N = {n}, S = {steps} ({when})")
    ax.plot([1, 16], [1, 16], "k:", label="linear")
    ax.set(xscale="log", yscale="log", xlabel="threads", ylabel="speedup over 1 thread (time in steps)",
           xticks=[1, 2, 4, 8, 16], xticklabels=["1", "2", "4", "8", "16"],
           title="Stage 06, CPU path, 16-core hosts")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "stage06-cores.png", dpi=100)
    plt.close(fig)


def ceiling():
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))
    panels = ((left, "threads", (("bench-issue30-ceiling-cpu-h200.csv", "o", "11-29, call 1"),
                                 ("bench-issue30-ceiling-cpu-packed-h200.csv", "s", "11-29, call 3"),
                                 ("bench-issue30-ceiling-cpu-h200-3.csv", "^", "11-30"),
                                 ("bench-issue30-ceiling-cpu-h200-4.csv", "v", "11-30 (2)"),
                                 ("bench-issue30-ceiling-cpu-h100.csv", "D", "12-06 (H100 host)"),
                                 ("bench-issue30-ceiling-cpu-h100-2.csv", "P", "12-06 (2)"),
                                 ("bench-issue30-ceiling-cpu-h100-3.csv", "X", "12-06 (3)"),
                                 ("bench-issue30-ceiling-cpu-h100-4.csv", "h", "12-06 (4)"),
                                 ("bench-issue30-ceiling-cpu-h100-5.csv", "*", "12-06 (5)"),
                                 ("bench-issue30-ceiling-cpu-h100-6.csv", "p", "12-06 (6)")),
               "Stage 06's engine, CPU, N = 10^6", 12, "12x (issue 30)"),
              (right, "ranks", (("bench-issue30-ceiling-mpi-h200.csv", "o", "11-29, call 1"),
                                ("bench-issue30-ceiling-mpi-h200-2.csv", "^", "11-30"),
                                ("bench-issue30-ceiling-mpi-h200-3.csv", "v", "11-30 (2)"),
                                ("bench-issue30-ceiling-mpi-h100.csv", "p", "12-06 (6)")),
               "Stage 08's engine, N = 10^6", 0.7 * 16, "70% at 16 ranks (issue 30)"))
    # one colour a device call, the same in both panels
    call_color = {"11-29, call 1": "C0", "11-29, call 3": "C1", "11-30": "C2", "11-30 (2)": "C3",
                  "12-06 (H100 host)": "C4", "12-06 (2)": "C5",
                  "12-06 (3)": "C6", "12-06 (4)": "C7", "12-06 (5)": "C8",
                  "12-06 (6)": "C9"}
    from matplotlib.lines import Line2D
    for ax, count, files, title, goal, goal_label in panels:
        keys = []  # one legend entry a call (its colour and marker), then the three line styles
        for name, marker, call in files:
            data = sorted(rows(name), key=lambda r: int(r["threads"]))
            one = float(data[0]["step_median_s"])
            xs = [int(r["threads"]) for r in data]
            color = call_color[call]
            ax.plot(xs, [one / float(r["step_median_s"]) for r in data], marker + "-", color=color)
            up = [(int(r["threads"]), float(r["ceiling"]), float(r["ceiling_slowest"]))
                  for r in data if r["ceiling"]]
            ax.plot([1] + [u[0] for u in up], [1] + [u[1] for u in up], "--", color=color)
            ax.plot([1] + [u[0] for u in up], [1] + [u[2] for u in up], ":", color=color)
            keys.append(Line2D([], [], color=color, marker=marker, label=call))
        keys += [Line2D([], [], color="gray", ls="-", label="speedup in steps"),
                 Line2D([], [], color="gray", ls="--", label="ceiling, the mean copy"),
                 Line2D([], [], color="gray", ls=":", label="ceiling, the slowest copy")]
        ax.plot([1, 16], [1, 16], "k-", lw=0.5)
        ax.plot([16], [goal], "k*", ms=10)
        keys += [Line2D([], [], color="k", lw=0.5, label="linear"),
                 Line2D([], [], color="k", marker="*", ms=10, ls="", label=goal_label)]
        ax.set(xscale="log", yscale="log", xlabel=count, ylabel=f"speedup over 1 {count[:-1]}",
               xticks=[1, 2, 4, 8, 16], xticklabels=["1", "2", "4", "8", "16"], title=title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(handles=keys, fontsize=7, loc="lower right")
    fig.suptitle("H200 machines' 16-core hosts, 2026-11-29 and 11-30, and six H100 machines', 12-06: "
                 "plab bench --ceiling "
                 "(copies of the one-thread or one-rank run at once)", fontsize=9)
    fig.tight_layout()
    fig.savefig(OUT / "ceiling.png", dpi=100)
    plt.close(fig)


def stage08_scaling():
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))
    data = rows("bench-stage08-cpu16.csv")
    strong = sorted((int(r["ranks"]), r) for r in data if int(r["n"]) == 1000000)
    weak = sorted((int(r["ranks"]), r) for r in data if int(r["n"]) == 100000 * int(r["ranks"]))
    one = float(strong[0][1]["step_median_s"])
    ranks = [k for k, _ in strong]
    left.plot(ranks, [one / float(r["step_median_s"]) for _, r in strong], "o-",
              label="strong: N = 10^6, speedup")
    left.plot(ranks, ranks, "k:", label="linear")
    left.plot(ranks, [0.7 * k for k in ranks], "k--", lw=0.8, label="70% efficiency (goal)")
    w1 = float(weak[0][1]["step_median_s"])
    left.plot([k for k, _ in weak], [w1 / float(r["step_median_s"]) for _, r in weak], "s-",
              label="weak: 10^5 a rank, efficiency (T1 / TR)")
    left.set(xscale="log", yscale="log", xlabel="ranks", xticks=ranks,
             xticklabels=[str(k) for k in ranks], title="Stage 08 on the 16-core host")
    width = 0.38
    xs = range(len(ranks))
    right.bar([x - width / 2 for x in xs], [100 * float(r["comm_share"]) for _, r in strong], width,
              label="strong, N = 10^6")
    right.bar([x + width / 2 for x in xs], [100 * float(r["comm_share"]) for _, r in weak], width,
              label="weak, 10^5 a rank")
    right.set(xticks=list(xs), xticklabels=[str(k) for k in ranks], xlabel="ranks",
              ylabel="% of the busiest rank's time in exchanges", title="Time in exchanges")
    for ax in (left, right):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "stage08-scaling.png", dpi=100)
    plt.close(fig)


def frontier(points):
    """The points no other point beats in both coordinates (lower is better in both)."""
    return [p for p in points if not any(q[0] <= p[0] and q[1] <= p[1] and q != p for q in points)]


def accuracy_frontier(path, out):
    """Time against error, one column per scene: the mean position error after one printed step
    (top) and the fraction of collisions missed (bottom) of each variant against stage 07's exact
    run; the best-for-its-cost variants (no other is both faster and closer) are ringed. Errors of
    exactly 0 cannot sit on a log axis and are left out."""
    with open(path, newline="") as f:
        data = list(csv.DictReader(line for line in f if not line.startswith("#")))
    scenes = list(dict.fromkeys(r["scene"] for r in data))
    measures = (("position_error_1", lambda v: v, "mean position error after 1 step (r)"),
                ("collision_ratio", lambda v: abs(1 - v), "collisions missed (fraction)"))
    fig, axes = plt.subplots(2, len(scenes), figsize=(4.6 * len(scenes), 7.5), squeeze=False)
    styles = {("cpu", "double"): ("o-", "tab:blue", "stage 06 CPU, double"),
              ("cpu", "float"): ("s--", "tab:orange", "stage 06 CPU, float"),
              ("gpu", "double"): ("^-", "tab:green", "stage 06 GPU, double")}
    for col, scene in enumerate(scenes):
        rows_ = [r for r in data if r["scene"] == scene]
        exact = next(r for r in rows_ if r["k"] == "0")
        for row, (field, err, label_y) in enumerate(measures):
            ax = axes[row][col]
            pts = []
            for (device, real), (style, color, label) in styles.items():
                line = sorted((int(r["k"]), float(r["seconds"]), err(float(r[field])))
                              for r in rows_ if r["device"] == device and r["real"] == real and r["k"] != "0")
                line = [p for p in line if p[2] > 0 and p[1] > 0]
                if not line:
                    continue
                ax.plot([p[1] for p in line], [p[2] for p in line], style, color=color, label=label)
                for k, t, e in line:
                    if k in (1, 8, 64):
                        ax.annotate(f"K={k}", (t, e), fontsize=7, textcoords="offset points", xytext=(4, 4))
                pts += [(t, e) for _, t, e in line]
            best = frontier(pts)
            ax.plot([p[0] for p in best], [p[1] for p in best], "o", mfc="none", mec="k", ms=12,
                    label="best for its cost")
            ax.axvline(float(exact["seconds"]), color="k", ls=":", label="stage 07: exact (error 0)")
            ax.set(xscale="log", yscale="log", xlabel="time in steps (s)", ylabel=label_y)
            if row == 0:
                ax.set_title(scene)
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def pairtime_ulps(path, out):
    """Bars of the pair time's error in ulps: one panel per kind of pair, model.md's form and the
    robust one."""
    data = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            if row["bucket"] != "missed":
                data.setdefault(row["kind"], {}).setdefault(row["form"], []).append(
                    (float(row["bucket"]), int(row["count"])))
    kinds = list(data)
    fig, axes = plt.subplots(1, len(kinds), figsize=(3.3 * len(kinds), 3.4), sharey=True)
    for ax, kind in zip(axes, kinds):
        for k, (form, color) in enumerate((("MODEL.md", "tab:red"), ("robust", "tab:blue"))):
            buckets = data[kind][form]
            total = sum(c for _, c in buckets) or 1
            labels = ["0" if e == 0 else ("more" if e > 1e100 else f"<={e:g}") for e, _ in buckets]
            ax.bar([i + (k - 0.5) * 0.4 for i in range(len(buckets))], [c / total for _, c in buckets],
                   width=0.4, color=color, label=form)
        ax.set_xticks(range(len(labels)), labels, rotation=60, fontsize=7)
        ax.set_title(kind, fontsize=9)
        ax.set_xlabel("error (ulps)", fontsize=8)
    axes[0].set_ylabel("fraction of pairs")
    axes[0].legend(fontsize=8)
    fig.suptitle("Pair time in double against the robust form in long double", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def main():
    global OUT
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=pathlib.Path, default=HERE, help="folder for the PNG files")
    OUT = ap.parse_args().out
    OUT.mkdir(parents=True, exist_ok=True)
    stage03_speedup()
    gpu_time()
    stage05_changes()
    stage06_pairs()
    stage06_cores()
    ceiling()
    stage08_scaling()
    accuracy_frontier(HERE / "data" / "accuracy.csv", OUT / "accuracy.png")
    pairtime_ulps(HERE / "data" / "pairtime-ulps.csv", OUT / "pairtime-ulps.png")


if __name__ == "__main__":
    main()
