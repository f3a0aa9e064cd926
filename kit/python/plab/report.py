"""The student's report skeleton (`plab report`; its options are this module's own): times the
student's own stage with `plab bench --csv` (the stage found with `plab built --json`), then writes
a Markdown report with this machine's description, the tables, figures of time against N, speedup
and efficiency (matplotlib), and the stage handout's questions.
"""
import argparse
import csv
import os
import pathlib
import platform
import re
import shutil
import subprocess
import sys

from plab import plabio  # the kit's programs

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


MARK = "<!-- plab report: {} (rewritten by each plab report run; write outside these marks) -->"
END = "<!-- plab report: end of {} -->"


def marked(name, lines):
    """`lines` between the marks that a later run finds and rewrites (write_report())."""
    return [MARK.format(name), *lines, END.format(name)]


def write_report(path, fresh, parts):
    """Writes `fresh` to `path` unless the student's report is there already: then only what lies
    between each part's marks is rewritten, everything else kept as they wrote it; a report whose
    marks are gone is left untouched, the fresh skeleton written beside it. Returns what it did."""
    if not path.exists():
        path.write_text(fresh)
        return f"wrote {path}"
    text = path.read_text()
    for name, lines in parts.items():
        start, end = MARK.format(name), END.format(name)
        a, b = text.find(start), text.find(end)
        if a < 0 or b < a:
            new = path.with_name("report.new.md")
            new.write_text(fresh)
            return (f"{path} is yours and its marks around the {name} are gone: left as it was; "
                    f"the new skeleton, with the new measurements, is {new}")
        text = text[:a] + "\n".join(marked(name, lines)) + text[b + len(end):]
    path.write_text(text)
    return f"updated the machine and the measurements in {path}, the rest kept as you wrote it"


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
                  label=f"{c} {counts if c != 1 else counts[:-1]}")
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
    """The timings as a Markdown table; on ranks (stage 08) also the bytes sent a step, in all and
    by MPI function (bench's bytes_per_step and bytes_by_call)."""
    ranks = any(r.get("bytes_per_step") for r in rows)
    head = (f"| N | {counts} | median s (whole run) | spread | s in steps | ms a step | speedup "
            "| device |")
    if ranks:
        head += " bytes a step | by call, a step |"
    lines = [head, "|" + "---|" * (10 if ranks else 8)]
    for r in sorted(rows, key=lambda r: (int(r["n"]), int(r.get(counts) or r["threads"]))):
        steps = int(r["steps"]) or 1
        median = float(r["median_s"])
        spread = (float(r["max_s"]) - float(r["min_s"])) / median if median > 0 else 0
        line = (f"| {r['n']} | {r.get(counts) or r['threads']} | {median:.3f} "
                f"| {100 * spread:.0f}%{' (noisy)' if spread > 0.3 else ''} "
                f"| {float(r['step_median_s']):.4f} "
                f"| {1e3 * float(r['step_median_s']) / steps:.3f} | {r['speedup']} "
                f"| {r['device']} |")
        if ranks:
            line += f" {float(r.get('bytes_per_step') or 0):.3g} | {r.get('bytes_by_call') or '-'} |"
        lines.append(line)
    return "\n".join(lines)


def default_sizes(stage):
    """Sizes a stage's report runs by default: a few seconds a run on a laptop at 100 steps,
    growing by 2 so that the slope of time against N (the stage's complexity) shows."""
    return {"01": [100, 200, 400], "02": [250, 500, 1000, 2000], "07": [250, 500, 1000, 2000],
            "03": [500, 1000, 2000, 4000], "04": [1000, 2000, 4000, 8000],
            "05": [1000, 2000, 4000, 8000], "06": [2000, 8000, 32000, 128000]}.get(stage, [10000, 40000])


def up_to_cores():
    """Thread (or rank) counts 1, 2, 4, ... up to this machine's cores, and the cores themselves."""
    cores = max(1, os.cpu_count() or 1)
    counts, t = [], 1
    while t < cores:
        counts.append(t)
        t *= 2
    return counts + [cores]


def numbers(text):
    """A comma-separated list of positive integers (--n, --threads)."""
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of positive integers")
    return values


def positive(text):
    """A positive integer (--steps, --runs)."""
    values = numbers(text)
    if len(values) != 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not one positive integer")
    return values[0]


def bench(plab, stage, impl, sizes, counts, mpi, steps, runs, csv_path):
    """Times the stage with `plab bench` (its medians into csv_path); exits with its reason on a
    failure."""
    joined = lambda v: ",".join(map(str, v))  # noqa: E731
    print(f"plab report: timing stage {stage} ({impl}) at N = {joined(sizes)}, "
          f"{'ranks' if mpi else 'threads'} {joined(counts)}, {steps} steps, {runs} runs each "
          f"(plab bench)", flush=True)
    done = subprocess.run([plab.program, "bench", "--stage", stage, "--impl", impl, "--n", joined(sizes),
                           "--steps", str(steps), "--runs", str(runs), "--csv", csv_path,
                           "--ranks" if mpi else "--threads", joined(counts)])
    if done.returncode != 0:
        sys.exit(f"plab report: the timings failed (plab bench exit {done.returncode})")


def main():
    ap = argparse.ArgumentParser(
        prog="plab report",
        description="Write your report's skeleton for a stage: runs the stage (yours by default in "
                    "a student copy) on this machine over sizes and thread or rank counts, and "
                    "writes OUT/report.md with this machine's description, the tables, figures of "
                    "time against N, speedup and efficiency (matplotlib), and the handout's "
                    "questions to answer.")
    ap.add_argument("--stage", required=True, help="the stage, e.g. 03")
    ap.add_argument("--impl", help="student or solution (default as for plab run)")
    ap.add_argument("--n", type=numbers, help="particle counts, comma-separated (default: the "
                                              "stage's, growing by 2)")
    ap.add_argument("--threads", "--ranks", dest="threads", type=numbers,
                    help="thread counts (OpenMP stages) or rank counts (stage 08); default 1, 2, "
                         "4, ... up to this machine's cores")
    ap.add_argument("--steps", type=positive, default=100, help="steps of each scene (%(default)s)")
    ap.add_argument("--runs", type=positive, default=3,
                    help="timed runs of each configuration, the median reported (%(default)s)")
    ap.add_argument("--out", help="the report's folder (default: report-NN)")
    ap.add_argument("--plab", help=argparse.SUPPRESS)  # the kit's plab program (plab passes it)
    a = ap.parse_args()
    plab = plabio.Plab(a.plab)
    try:
        kit = plab.built(a.impl, [a.stage])
    except plabio.ProgramError as e:
        sys.exit(f"plab report: {e}")
    stage = kit["stages"][0]
    if stage["problem"]:  # a clear error when it is not built from its current code
        sys.exit(f"plab report: {stage['problem']}")
    a.stage, a.impl, a.kit = stage["id"], kit["impl"], kit["source"]
    mpi = stage["needs_mpi"]
    a.counts = "ranks" if mpi else "threads"
    a.out = a.out or f"report-{a.stage}"
    parallel = stage["needs_openmp"] or mpi
    if a.threads and not parallel and a.threads != [1]:
        print(f"plab report: stage {a.stage} runs on one thread (no OpenMP loop): --threads "
              f"{','.join(map(str, a.threads))} is left aside, it is timed on 1", flush=True)
        a.threads = [1]
    made = not os.path.isdir(a.out)
    os.makedirs(a.out, exist_ok=True)
    counts = a.threads or (up_to_cores() if parallel else [1])
    a.csv = os.path.join(a.out, "bench.csv")
    partial = a.csv + ".partial"  # the last run's timings stay until these are whole
    try:
        bench(plab, a.stage, a.impl, a.n or default_sizes(a.stage), counts, mpi, a.steps, a.runs,
              partial)
        rows = read_rows(partial)
        if not rows:
            sys.exit(f"plab report: {partial} holds no timing")
        os.replace(partial, a.csv)
    except (SystemExit, KeyboardInterrupt):
        if made:  # a folder this run made, holding nothing of the student's
            shutil.rmtree(a.out, ignore_errors=True)
        elif os.path.exists(partial):
            os.remove(partial)
        raise
    out = pathlib.Path(a.out)
    figs = figure(rows, a.counts, out)
    handout, qs = questions(a.kit, a.stage)
    steps = rows[0]["steps"]
    machine_part = ["| | |", "|---|---|"] + [f"| {k} | {v} |" for k, v in machine()]
    measured = [f"Stage {a.stage} ({a.impl}), {steps} steps a scene, scenes like the 2019 "
                "report's (L = 20000, r = 1, perf mode); each figure is the median of the runs "
                f"({rows[0]['runs']} each; spread: (slowest - fastest) / median, noisy past 30%: "
                "run again on a quieter machine, or with more --runs). `s in steps` is the "
                "stage's own time in its steps; `median s` the whole process.", "",
                table(rows, a.counts), ""]
    measured += [f"![{f[:-4]}]({f})\n" for f in figs]
    md = [f"# Stage {a.stage}: report", "",
          "*Written by `plab report`: the tables and figures are your stage's own runs on the "
          "machine below; fill in every part in italics. Running `plab report` again rewrites "
          "only the parts between its marks (the machine, the measurements) and keeps your "
          "text.*", "",
          "## Name, date", "", "*your name, the date*", "",
          "## The machine", "", *marked("machine", machine_part), "",
          "## What I built", "",
          "*In a paragraph: the stage's idea as you wrote it, and the choices you made.*", "",
          "## Measurements", "", *marked("measurements", measured), "",
          "## Analysis", "",
          ("*What the figures show: the slope of time against N (the complexity), where speedup "
           "stops growing and why, what you would change next.*" if len(counts) > 1 else
           "*What the figures show: the slope of time against N (the complexity) against what "
           "the stage's idea predicts, and what you would change next.*"), "",
          "## Questions from the handout" + (f" (handouts/{handout})" if handout else ""), "",
          qs, ""]
    written = write_report(out / "report.md", "\n".join(md), {"machine": machine_part,
                                                            "measurements": measured})
    print(f"plab report: {written}; figures {', '.join(figs)} in {out}/")


if __name__ == "__main__":
    main()
