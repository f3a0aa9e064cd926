"""Animates particle-lab outputs with matplotlib: the box, the disks at their true radius, one
frame per step, the step's collisions marked. `plab render` runs a stage and calls this; it can
also be run on any print-mode output (a golden file, a student's output).

  python3 -m plab.render --output FILE [--events FILE] --box L --radius R [--steps A:B] [--follow I]
            [--out anim.gif|anim.mp4|frame.svg|frame.png] [--plab PLAB]
  python3 -m plab.render --output EXPECTED --output ACTUAL --mark STEP:PARTICLE:TEXT ...   (side by side)

Frame k shows the state at the start of step k and marks the particles that collide during that
step: orange for a wall, red for another particle. Without --events, collisions are read from the
velocities of the next printed step (a flip of signs with equal magnitudes counts as a wall).
The files are read by the kit's own reader (`plab read --json`, through plab.plabio).
"""
import argparse
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import animation  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

from plab import plabio  # noqa: E402  (the kit's formats, read by its C++ reader)

COLOURS = {"none": "#4c72b0", "wall": "#ff9f1c", "pair": "#d62728", "follow": "#2ca02c"}


def fail(message):
    print(f"plab render: {message}", file=sys.stderr)
    sys.exit(2)


def read_frames(plab, path, first, last):
    """States of steps first..last (inclusive) from a print-mode output: {step: array[n, 4]}."""
    try:
        blocks = plab.read_output(path, steps=(first, last))["blocks"]
    except plabio.FormatError as e:
        fail(str(e))
    rows = {b["step"]: np.array([b["x"], b["y"], b["vx"], b["vy"]]).T for b in blocks}
    missing = [s for s in range(first, last + 1) if s not in rows]
    if len(missing) == last - first + 1:
        fail(f"{path} has no block for steps {first}..{last}")
    if missing:
        fail(f"{path} has no block for step {missing[0]} (a perf-mode output? render runs the "
             f"stage in print mode; for a file, use a print-mode output)")
    return rows


def read_events(plab, path, first, last, n):
    """{step: array of kinds per particle} from the runner's --events file."""
    kinds = {s: np.zeros(n, dtype=int) for s in range(first, last + 1)}
    try:
        events = plab.read_events(path, steps=(first, last))["events"]
    except plabio.FormatError as e:
        fail(str(e))
    for e in events:
        if e["particle"] >= n:
            fail(f"{path}: particle {e['particle']} collides in step {e['step']}, but the output "
                 f"has particles 0..{n - 1}")
        kinds[e["step"]][e["particle"]] = 1 if e["kind"] == "wall" else 2
    return kinds


def infer_events(frames, first, last):
    """Collisions of each step read from the velocities of the next (none for the last)."""
    kinds = {}
    for s in range(first, last + 1):
        now = frames[s]
        kinds[s] = np.zeros(len(now), dtype=int)
        if s + 1 in frames:
            v0, v1 = now[:, 2:4], frames[s + 1][:, 2:4]
            changed = np.any(v0 != v1, axis=1)
            flipped = np.all(np.abs(v0) == np.abs(v1), axis=1)
            kinds[s][changed & flipped] = 1
            kinds[s][changed & ~flipped] = 2
    return kinds


class Panel:
    """One box with its disks, updated frame by frame."""

    def __init__(self, ax, title, frames, kinds, box, radius, follow, sample):
        self.ax, self.title, self.frames, self.kinds = ax, title, frames, kinds
        self.follow = follow
        n = len(next(iter(frames.values())))
        self.shown = np.arange(n)
        if n > sample:
            rng = np.random.default_rng(0)
            self.shown = np.sort(rng.choice(n, sample, replace=False))
            if follow is not None and follow not in self.shown:
                self.shown = np.sort(np.append(self.shown, follow))
        ax.set_xlim(0, box)
        ax.set_ylim(0, box)
        ax.set_aspect("equal")
        ax.add_patch(Rectangle((0, 0), box, box, fill=False, linewidth=1.5))
        pixels = 2 * radius / box * ax.get_window_extent().width
        first = frames[min(frames)][self.shown, 0:2]
        if pixels >= 1.5:
            self.disks = EllipseCollection(2 * radius, 2 * radius, 0, units="xy", offsets=first,
                                           offset_transform=ax.transData, linewidths=0.3,
                                           edgecolors="black")
            ax.add_collection(self.disks)
            self.note = ""
        else:
            self.disks = ax.scatter(first[:, 0], first[:, 1], s=4, linewidths=0)
            self.note = " (disks drawn larger than true size)"
        if len(self.shown) < n:
            self.note += f" ({len(self.shown)} of {n} particles drawn)"
        self.trail = ax.plot([], [], "-", color=COLOURS["follow"], linewidth=1)[0]
        self.ring = None
        self.label = ax.set_title("")

    def draw(self, step, mark=None):
        state = self.frames[step][self.shown]
        kinds = self.kinds[step][self.shown]
        colours = np.array([COLOURS["none"], COLOURS["wall"], COLOURS["pair"]])[kinds]
        self.disks.set_offsets(state[:, 0:2])
        if self.follow is not None:
            colours[np.searchsorted(self.shown, self.follow)] = COLOURS["follow"]
            path = np.array([self.frames[s][self.follow, 0:2] for s in sorted(self.frames)
                             if s <= step])
            self.trail.set_data(path[:, 0], path[:, 1])
        self.disks.set_facecolors(colours)
        walls = int(np.sum(self.kinds[step] == 1))
        pairs = int(np.sum(self.kinds[step] == 2)) // 2
        self.label.set_text(f"{self.title}step {step}: {pairs} pair and {walls} wall collisions"
                            f"{self.note}")
        self.label.set_fontsize(9)
        if self.ring is not None:
            self.ring.remove()
            self.ring = None
        if mark is not None and step == mark[0]:
            x, y = self.frames[step][mark[1], 0:2]
            size = max(self.ax.get_xlim()[1] / 25, 1e-9)
            self.ring = self.ax.add_patch(Circle((x, y), size, fill=False, color="magenta",
                                                 linewidth=2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--output", action="append", required=True, help="print-mode output (1 or 2)")
    ap.add_argument("--label", action="append", default=[], help="title of each output")
    ap.add_argument("--events", help="the runner's --events file for the (first) output")
    ap.add_argument("--box", type=float, required=True, help="side L of the box")
    ap.add_argument("--radius", type=float, required=True, help="radius r of the disks")
    ap.add_argument("--steps", default="0:20", help="first:last step to draw (inclusive)")
    ap.add_argument("--follow", type=int, help="highlight this particle and draw its path")
    ap.add_argument("--mark", help="STEP:PARTICLE:TEXT, a difference to ring and describe")
    ap.add_argument("--sample", type=int, default=20000, help="draw at most this many particles")
    ap.add_argument("--fps", type=float, default=4)
    ap.add_argument("--out", required=True, help=".gif or .mp4 (animation), .svg or .png (frame)")
    ap.add_argument("--plab", help="the kit's plab program, whose `plab read` reads the files "
                                   "(default: build/bin/plab of this kit)")
    a = ap.parse_args()
    plab = plabio.Plab(a.plab)

    try:
        first, last = (int(v) for v in a.steps.split(":"))
    except ValueError:
        fail(f"--steps expects FIRST:LAST, e.g. 0:20, not {a.steps!r}")
    if not 0 <= first <= last:
        fail(f"--steps needs 0 <= FIRST <= LAST, not {a.steps}")
    kind = a.out.rsplit(".", 1)[-1].lower()
    if kind not in ("gif", "mp4", "svg", "png"):
        fail(f"--out must end in .gif, .mp4, .svg or .png, not {a.out!r}")
    if kind == "mp4" and not animation.writers.is_available("ffmpeg"):
        fail("writing .mp4 needs ffmpeg (apt-get install ffmpeg); .gif needs nothing more")
    mark = None
    if a.mark:
        step, particle, text = a.mark.split(":", 2)
        mark = (int(step), int(particle), text)

    outputs = [(path, read_frames(plab, path, first, last)) for path in a.output]
    n = len(outputs[0][1][first])
    if a.follow is not None and not 0 <= a.follow < n:
        fail(f"--follow {a.follow}: the scene has particles 0..{n - 1}")
    width = 5.5 * len(outputs)
    fig, axes = plt.subplots(1, len(outputs), figsize=(width, 5.8), squeeze=False)
    panels = []
    for k, (path, frames) in enumerate(outputs):
        kinds = (read_events(plab, a.events, first, last, n) if a.events and k == 0
                 else infer_events(frames, first, last))
        title = (a.label[k] + "\n") if k < len(a.label) else ""
        panels.append(Panel(axes[0][k], title, frames, kinds, a.box, a.radius, a.follow, a.sample))
    if mark:
        fig.suptitle(mark[2], fontsize=9, color="magenta")
    fig.text(0.5, 0.01, "colliding in this step: orange with a wall, red with a particle"
             + ("; green: followed" if a.follow is not None else ""), ha="center", fontsize=8)
    fig.tight_layout(rect=(0, 0.03, 1, 1))

    def update(step):
        for p in panels:
            p.draw(step, mark)
        return []

    steps = list(range(first, last + 1))
    if kind in ("svg", "png"):
        update(mark[0] if mark and first <= mark[0] <= last else first)
        fig.savefig(a.out, dpi=100)
        return
    show = sys.stderr.isatty()

    def progress(done, total):
        if show:
            print(f"\r  frame {done + 1}/{total}", end="", file=sys.stderr)

    anim = animation.FuncAnimation(fig, update, frames=steps, blit=False)
    writer = (animation.PillowWriter(fps=a.fps) if kind == "gif"
              else animation.FFMpegWriter(fps=a.fps))
    anim.save(a.out, writer=writer, dpi=100, progress_callback=progress)
    if show:
        print("\r" + " " * 30 + "\r", end="", file=sys.stderr)


if __name__ == "__main__":
    main()
