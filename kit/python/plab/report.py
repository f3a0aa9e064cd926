"""The student's report skeleton (`plab report`): from the CSV that `plab bench --csv` wrote for
the student's own stage, a Markdown report with this machine's description, the tables, figures
of time against N, speedup and efficiency (matplotlib), and the stage handout's questions.

  python3 -m plab.report --csv BENCH.csv --stage NN --impl IMPL --kit KIT --out DIR [--counts threads|ranks]

`plab report --help` is the command to run; this script is its second half.
"""
import argparse
import csv
import os
import pathlib
import platform
import re
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def machine():
    """This machine in a few lines: processor, cores, memory, operating system, compiler."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(re.search(r"MemTotal:\s+(\d+)", pathlib.Path("/proc/meminfo").read_text())[1])
        mem = f"{kb / 2**20:.1f} GiB"
    except (OSError, TypeError):
        pass
    try:
        gxx = subprocess.run(["g++", "--version"], capture_output=True, text=True).stdout
        gxx = gxx.splitlines()[0]
    except (OSError, IndexError):
        gxx = "unknown"
    return [("processor", cpu), ("cores the OS sees", str(os.cpu_count())),
            ("memory", mem or "unknown"), ("system", f"{platform.system()} {platform.release()}"),
            ("compiler", gxx)]


def questions(kit, stage):
    """The handout's questions: the section whose heading names them, as Markdown."""
    found = sorted((pathlib.Path(kit) / "handouts").glob(f"{stage}-*.md"))
    if not found:
        return None, "(no handout found for this stage)"
    lines = found[0].read_text().splitlines()
    for k, line in enumerate(lines):
        m = re.match(r"(#+)\s+(.*)", line)
        if m and re.search(r"question", m[2], re.I):
            level = len(m[1])
            body = []
            for nxt in lines[k + 1:]:
                h = re.match(r"(#+)\s", nxt)
                if h and len(h[1]) <= level:
                    break
                body.append(nxt)
            return found[0].name, "\n".join(body).strip()
    return found[0].name, f"(handouts/{found[0].name} has no section named Questions)"


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def figure(rows, counts, out):
    """time-vs-n.png, and with several counts speedup.png and efficiency.png."""
    made = []
    by_count = {}
    for r in rows:
        by_count.setdefault(int(r[counts] if counts in r and r[counts] else r["threads"]), []).append(r)
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for c, rs in sorted(by_count.items()):
        rs = sorted(rs, key=lambda r: int(r["n"]))
        ax.loglog([int(r["n"]) for r in rs], [float(r["step_median_s"]) for r in rs], "o-",
                  label=f"{c} {counts}")
    ax.set_xlabel("N (particles)")
    ax.set_ylabel("time in steps (s, median)")
    ax.set_title("time against N")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "time-vs-n.png", dpi=120)
    plt.close(fig)
    made.append("time-vs-n.png")
    if len(by_count) < 2:
        return made
    base = min(by_count)
    ns = sorted({int(r["n"]) for r in rows})
    for name, what in (("speedup", "speedup over 1"), ("efficiency", "efficiency")):
        fig, ax = plt.subplots(figsize=(5.5, 4))
        for n in ns:
            t1 = [float(r["step_median_s"]) for r in by_count[base] if int(r["n"]) == n]
            pts = []
            for c in sorted(by_count):
                t = [float(r["step_median_s"]) for r in by_count[c] if int(r["n"]) == n]
                if t1 and t and t[0] > 0:
                    s = t1[0] / t[0] * base
                    pts.append((c, s if name == "speedup" else s / c))
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"N = {n}")
        cs = sorted(by_count)
        ax.plot(cs, cs if name == "speedup" else [1] * len(cs), "k--", lw=0.8, label="ideal")
        ax.set_xlabel(counts)
        ax.set_ylabel(what)
        ax.set_title(f"{name} against {counts}")
        ax.grid(True, alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / f"{name}.png", dpi=120)
        plt.close(fig)
        made.append(f"{name}.png")
    return made


def table(rows, counts):
    head = f"| N | {counts} | median s (whole run) | s in steps | ms a step | speedup | device |"
    lines = [head, "|" + "---|" * 7]
    for r in sorted(rows, key=lambda r: (int(r["n"]), int(r.get(counts) or r["threads"]))):
        steps = int(r["steps"]) or 1
        lines.append(f"| {r['n']} | {r.get(counts) or r['threads']} | {float(r['median_s']):.3f} "
                     f"| {float(r['step_median_s']):.4f} "
                     f"| {1e3 * float(r['step_median_s']) / steps:.3f} | {r['speedup']} "
                     f"| {r['device']} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--csv", required=True)
    ap.add_argument("--stage", required=True)
    ap.add_argument("--impl", required=True)
    ap.add_argument("--kit", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--counts", choices=["threads", "ranks"], default="threads")
    a = ap.parse_args()
    out = pathlib.Path(a.out)
    rows = read_rows(a.csv)
    if not rows:
        sys.exit(f"plab report: {a.csv} holds no timing")
    figs = figure(rows, a.counts, out)
    handout, qs = questions(a.kit, a.stage)
    steps = rows[0]["steps"]
    md = [f"# Stage {a.stage}: report", "",
          "*Written by `plab report`: the tables and figures are your stage's own runs on the "
          "machine below; fill in every part in italics.*", "",
          "## Name, date", "", "*your name, the date*", "",
          "## The machine", "", "| | |", "|---|---|"]
    md += [f"| {k} | {v} |" for k, v in machine()]
    md += ["", "## What I built", "",
           "*In a paragraph: the stage's idea as you wrote it, and the choices you made.*", "",
           "## Measurements", "",
           f"Stage {a.stage} ({a.impl}), {steps} steps a scene, scenes like the 2019 report's "
           "(L = 20000, r = 1, perf mode); each figure is the median of the runs "
           f"({rows[0]['runs']} each). `s in steps` is the stage's own time in its steps; "
           "`median s` the whole process.", "", table(rows, a.counts), ""]
    md += [f"![{f[:-4]}]({f})\n" for f in figs]
    md += ["## Analysis", "",
           "*What the figures show: the slope of time against N (the complexity), where speedup "
           "stops growing and why, what you would change next.*", "",
           "## Questions from the handout" + (f" (handouts/{handout})" if handout else ""), "",
           qs, ""]
    (out / "report.md").write_text("\n".join(md))
    print(f"plab report: wrote {out / 'report.md'} and {', '.join(figs)} in {out}/")


if __name__ == "__main__":
    main()
