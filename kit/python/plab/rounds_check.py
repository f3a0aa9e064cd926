"""Stage 03's idea, checked on your own machine as the grade checks it: are the events selected in
mutual-earliest rounds of parallel loops, or by one thread after a parallel phase?

  python3 -m plab.rounds_check --program build/bin/plab-run-03-student --kit-bin DIR --plab PLAB

Your stage 03 runs twice on 2 threads (its schedule(runtime) loops on `static,1`), with the kit's
counter of OpenMP synchronisations preloaded (libplab-ompcount.so: parallel regions started,
barriers and ends of work-sharing loops passed; it reads libgomp's entry points, never your code):
on a scene of N = 8000 at stage 03's grading density, then on the same scene with slow speeds
(fewer rounds). The kit's plab-rounds says how many rounds each scene's steps need. A stage whose
rounds are parallel loops passes at least one synchronisation a round on the first scene, and at
least one fewer a round on the calmer one; a stage that selects its events on one thread passes a
few a step on both. Its comparisons with earlier() (plab::EventOrder, counted by the kit on each
thread) must be the rounds' own, as plab-rounds makes them, shared evenly by the threads loop by
loop. The thresholds are stage 03's idea in kit/grade/rubric.json, the grade's own; the grade
measures again on hidden scenes, and also each thread's share of the CPU time. CTest runs this as
stage03.IMPL.Rounds. Exit 0: the selection follows the rounds; 1: it does not (or the stage
failed); 2: bad use.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

from plab import KIT
from plab.grade.rounds_count import LIBRARY, RoundsCount

#: The scenes: stage 03's idea scene (kit/grade/rubric.json) made smaller at the same density, so
#: that the check takes about a second (N = 8000: 26 rounds in 4 steps; calm: 4).
N, L, STEPS, SEED = 8000, 1265, 4, 2019
#: The schedule of the stage's schedule(runtime) loops in these runs, as graded: the same share of
#: every loop's iterations to each thread however busy the machine is.
SCHEDULE = "static,1"


class LocalRun:
    """What RoundsCount reads of a run: the files the run wrote in its folder."""

    def __init__(self, folder):
        self.folder = folder

    def read_output(self, name):
        path = self.folder / name
        return path.read_text() if path.is_file() else None


def run_counted(program, scene, counter, folder, threads):
    """Runs the stage on `scene` in `folder` with the counter preloaded; (LocalRun, problem)."""
    folder.mkdir()
    env = dict(os.environ, OMP_WAIT_POLICY="passive", **counter.env(program))
    done = subprocess.run([str(program), str(scene), "--quiet", "--threads", str(threads),
                           "--schedule", SCHEDULE, "--out", "out.txt", "--report", "report.json"],
                          cwd=folder, env=env,
                          capture_output=True,
                          text=True, timeout=300)
    if done.returncode != 0:
        tail = "\n".join(done.stderr.strip().splitlines()[-3:])
        return None, f"the stage exited {done.returncode} on {scene.name}:\n{tail}"
    return LocalRun(folder), None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split(
        "\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--program", required=True, help="the stage 03 program to check")
    ap.add_argument("--kit-bin", required=True,
                    help=f"the folder of the kit's {LIBRARY} and plab-rounds (build/bin in the "
                         "instructor's kit, kit/reference/bin in a student's copy)")
    ap.add_argument("--plab", required=True, help="the kit's plab program (it writes the scenes)")
    ap.add_argument("--threads", type=int, default=2, help="OpenMP threads (default 2, as graded)")
    ap.add_argument("--rubric", default=str(KIT / "kit" / "grade" / "rubric.json"),
                    help="the rubric whose stage 03 idea gives the thresholds")
    a = ap.parse_args()
    program, kit_bin = pathlib.Path(a.program).resolve(), pathlib.Path(a.kit_bin).resolve()
    if not program.is_file():
        sys.exit(f"plab.rounds_check: {program} is not built")
    idea = json.loads(pathlib.Path(a.rubric).read_text())["stages"]["03"]["idea"]
    with tempfile.TemporaryDirectory(prefix="plab-rounds-") as tmp:
        tmp = pathlib.Path(tmp)
        scene, calm_scene = tmp / "scene.in", tmp / "calm.in"
        for path, speed in ((scene, ()), (calm_scene, ("--speed", idea["calm_speed"]))):
            subprocess.run([a.plab, "gen", "--n", str(N), "--l", str(L), "--r", "1", "--steps",
                            str(STEPS), "--mode", "perf", "--seed", str(SEED), *speed, "--out",
                            str(path)], check=True, capture_output=True)
        try:
            counter = RoundsCount(kit_bin, None, scene)
            calm = RoundsCount(kit_bin, None, calm_scene)
        except RuntimeError as e:
            sys.exit(f"plab.rounds_check: {e}")
        what = f"N = {N}, L = {L}, {STEPS} steps, {a.threads} threads"
        print(f"stage 03's rounds, counted from outside its code ({what}):", flush=True)
        run, problem = run_counted(program, scene, counter, tmp / "run", a.threads)
        text = f"the scene of {counter.rounds['total']} rounds ({counter.rounds['rounds']} a step)"
        if problem is None:
            problem, text = counter.check(idea, run, text)
        if problem is None:
            problem, text = counter.comparisons(idea, run, text, a.threads)
        if problem is None:
            calm_run, problem = run_counted(program, calm_scene, calm, tmp / "calm", a.threads)
            if problem is None:
                problem, text = counter.follows(idea, calm, calm_run, text, "the scene")
    print(f"  {text}")
    if problem:
        print(f"FAILED: {problem}")
        return 1
    print("  the synchronisations and the comparisons follow the rounds. The grade measures this "
          "again on hidden scenes, with each thread's share of the CPU time (handouts/working.md).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
