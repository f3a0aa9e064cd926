"""Animates particle-lab outputs with matplotlib: the box, the disks at their true radius, one
frame per step, the step's collisions marked: `plab render` (its options are this module's own).
It runs a stage (found with `plab built --json`) on the scene, or draws any print-mode output (a
golden file, a student's output), or two side by side with their first difference ringed.

Frame k shows the state at the start of step k and marks the particles that collide during that
step: orange for a wall, red for another particle. A run of the scene records its events (the
runner's --events, also `plab run --events`); for an output drawn as it is (--from, --diff),
collisions are read from the velocities of the next printed step (a flip of signs with equal
magnitudes counts as a wall).
The files are read by the kit's own reader (`plab read --json`, through plab.plabio).
"""
import argparse
import pathlib
import sys
import tempfile

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
    """Collisions of each step read from the velocities of the next; None for a step with no next
    (the last): its collisions are not known."""
    kinds = {}
    for s in range(first, last + 1):
        now = frames[s]
        kinds[s] = np.zeros(len(now), dtype=int) if s + 1 in frames else None
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
        known = self.kinds[step] is not None
        every = self.kinds[step] if known else np.zeros(len(self.frames[step]), dtype=int)
        kinds = every[self.shown]
        colours = np.array([COLOURS["none"], COLOURS["wall"], COLOURS["pair"]])[kinds]
        self.disks.set_offsets(state[:, 0:2])
        if self.follow is not None:
            colours[np.searchsorted(self.shown, self.follow)] = COLOURS["follow"]
            path = np.array([self.frames[s][self.follow, 0:2] for s in sorted(self.frames)
                             if s <= step])
            self.trail.set_data(path[:, 0], path[:, 1])
        self.disks.set_facecolors(colours)
        walls = int(np.sum(every == 1))
        pairs = int(np.sum(every == 2)) // 2
        what = (f"{pairs} pair and {walls} wall collisions" if known else
                "its collisions not known (read from the next step's velocities: none follows)")
        self.label.set_text(f"{self.title}step {step}: {what}{self.note}")
        self.label.set_fontsize(9)
        if self.ring is not None:
            self.ring.remove()
            self.ring = None
        if mark is not None and step == mark[0]:
            x, y = self.frames[step][mark[1], 0:2]
            size = max(self.ax.get_xlim()[1] / 25, 1e-9)
            self.ring = self.ax.add_patch(Circle((x, y), size, fill=False, color="magenta",
                                                 linewidth=2))


def particles_of(path):
    """How many particles an output file's first step holds (its lines up to the next step)."""
    first, n = None, 0
    with open(path, errors="replace") as f:
        for line in f:
            token = line.split(maxsplit=1)
            if not token:
                continue
            if first is None:
                first = token[0]
            elif token[0] != first:
                break
            n += 1
    return n


def same_particles(scene, path, option):
    """Fails unless output `path` holds the scene's particles (a student drew a 1000-particle
    output over a 25-particle scene, told only that the two outputs were equal)."""
    n = particles_of(path)
    if n != scene["n"]:
        fail(f"{option}: {path} holds {n} particles a step, the scene {scene['n']}: an output of "
             "another scene? (give the scene the outputs were made from)")


def what_to_draw(plab, a, scratch):
    """The outputs to draw (paths), their titles, the events file (or None), the steps FIRST:LAST
    and the difference to ring (STEP, PARTICLE, TEXT or None), from the command's options: two
    outputs (--diff), one (--from), or a run of the stage (--stage, --impl) on the scene."""
    try:
        scene = plab.read_scene(a.scene)
    except plabio.FormatError as e:
        fail(str(e))
    a.box, a.radius = scene["L"], scene["r"]
    steps = a.steps
    default_steps = f"0:{min(scene['steps'], 20)}"
    if a.diff:
        for path in a.diff:
            if not pathlib.Path(path).is_file():
                fail(f"--diff: {path} is not a file")
            same_particles(scene, path, "--diff")
        d = plab.diff(*a.diff)
        mark = None
        if not d.get("comparable", True):
            fail(f"--diff: {d['text']}")
        if d["equal"]:
            print("the two outputs are equal")
        else:
            print(d["text"])
            f = d["first"]
            step = f["step"] if f["step"] is not None else 0  # a garbled line: from the start
            if steps is None:  # a few steps before, and the next one (to show its collisions)
                steps = f"{max(0, step - 8)}:{step + 1 if step < scene['steps'] else step}"
            if f["particle"] is not None:
                mark = (step, f["particle"],
                        f"first difference: step {step}, particle {f['particle']}, {f['field']}: "
                        f"expected {f['expected']}, got {f['actual']}")
        return (list(a.diff), [f"expected: {a.diff[0]}", f"actual: {a.diff[1]}"], None,
                steps or default_steps, mark)
    if a.from_output:
        if not pathlib.Path(a.from_output).is_file():
            fail(f"--from: {a.from_output} is not a file")
        same_particles(scene, a.from_output, "--from")
        return [a.from_output], [a.from_output], None, steps or default_steps, None
    steps = steps or default_steps
    last = steps.split(":")[-1]
    try:
        found = plab.built(a.impl, [a.stage])
    except plabio.ProgramError as e:
        fail(str(e))
    stage = found["stages"][0]
    if stage["problem"]:
        fail(stage["problem"])
    output, events = scratch / "render.out", scratch / "render.events"
    done = plabio.run_stage(stage["program"], a.scene, "--quiet", "--mode", "print", "--steps", last,
                            "--out", output, "--events", events)
    if done.returncode != 0:
        fail(f"stage {stage['id']} failed on {a.scene} (exit {done.returncode}): "
             f"{done.stderr.strip()[-500:]}")
    label = f"stage {stage['id']} ({found['impl']}), {pathlib.Path(a.scene).name}"
    return [str(output)], [label], str(events), steps, None


def main():
    ap = argparse.ArgumentParser(
        prog="plab render", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Animate a run: the box, the disks at their true radius, one frame per step, "
                    "collisions marked (orange: wall, red: pair). With --diff, two outputs side by "
                    "side and their first difference ringed.",
        epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("scene", help="scene file (with --diff or --from: only its L and r are used)")
    ap.add_argument("--stage", default="02", help="stage that runs the scene (%(default)s)")
    ap.add_argument("--impl", help="solution, student or engine (default as for plab run)")
    ap.add_argument("--steps", help="FIRST:LAST steps to draw (default 0:20; with --diff, around "
                                    "the first difference)")
    ap.add_argument("--follow", type=int, help="highlight this particle and draw its path")
    ap.add_argument("--from", dest="from_output", metavar="OUTPUT",
                    help="draw this print-mode output (a golden file, yours) instead of running a stage")
    ap.add_argument("--diff", nargs=2, metavar=("EXPECTED", "ACTUAL"),
                    help="two print-mode outputs to compare")
    ap.add_argument("--fps", type=float, default=4, help="frames per second (%(default)s)")
    ap.add_argument("--sample", type=int, default=20000, help="draw at most this many particles")
    ap.add_argument("--out", help="FILE.gif or FILE.mp4 (animation), FILE.svg or FILE.png (one "
                                  "frame); default: the scene's name with .gif")
    ap.add_argument("--plab", help=argparse.SUPPRESS)  # the kit's plab program (plab passes it)
    a = ap.parse_args()
    plab = plabio.Plab(a.plab)
    if not pathlib.Path(a.scene).is_file():
        fail(f"{a.scene} is not a file")
    a.out = a.out or pathlib.Path(a.scene).stem + ".gif"
    with tempfile.TemporaryDirectory(prefix="plab-render-") as scratch:
        a.output, a.label, a.events, a.steps, mark = what_to_draw(plab, a, pathlib.Path(scratch))
        draw(plab, a, mark)
    print(f"wrote {a.out} (steps {a.steps})")


def draw(plab, a, mark):
    """Draws a.output (one or two outputs) over a.steps into a.out."""
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
