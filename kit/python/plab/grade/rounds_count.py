"""Instruments of `plab grade`'s idea tests that the kit builds and the grader only reads.

Stage 03 (rubric: the idea's "min_syncs_per_round"): the kit's libplab-ompcount.so, preloaded
into the student's program, counts the OpenMP synchronisations it runs (parallel regions
started, barriers and ends of work-sharing loops passed by thread 0 of a team: the program's code
is not asked), and the kit's plab-rounds says how many mutual-earliest rounds the scene's steps
need (JSON, from the same C++ as the kit's oracle). A stage that selects its events in rounds of
parallel loops passes at least two synchronisations a round; one that runs a parallel phase and
then selects sequentially, or keeps a thread busy beside a sequential program, a few a step;
and (the idea's "calm_speed") the count must grow with the rounds: a second run on a calmer scene
(slow speeds, fewer rounds) must pass fewer synchronisations, at least one fewer a round.

And (the idea's "min_balanced_comparisons") the rounds' own comparisons: stage 03 compares events
with the kit's plab::EventOrder (`earlier` in step.cpp), which tallies on each thread the
comparisons of two events in the step, sums the later event of each, and files them by the
preloaded library's loops' clock (plab_omp_epoch: one epoch a loop); the runner's `--report`
gives them. Mutual-earliest rounds make the same ones as plab-rounds' (which compares with
EventOrder too), however their loops are scheduled and their candidates ordered; and loops
shared by the team split each loop's comparisons evenly among the threads. A selection on one
thread, empty barriers beside it, a thread that burns CPU or compares for show, or rounds done
one at a time in `single`, fails here. The comparisons are also asked of every other graded run
(plan(), not_the_rounds(): each correctness scene against plab-rounds, each timed run against the
kit's solution on the same scene), so that no scene is selected another way.
"""
import json
import os
import pathlib
import secrets
import shutil
import subprocess

#: The schedule of a counted run's schedule(runtime) loops (the runner's --schedule): each thread
#: the same share of every loop's iterations, however busy the machine is.
SCHEDULE = "static,1"
LIBRARY = "libplab-ompcount.so"
INSIDE = "/plab/ompcount.so"  # where the sandbox (bubblewrap) shows the library


def plan(kit_bin, scene):
    """plab-rounds' account of `scene` (JSON: the rounds of each step, their comparisons of two
    events in the step and the sum of the later event of each): the kit's own rounds."""
    tool = pathlib.Path(kit_bin) / "plab-rounds"
    r = subprocess.run([tool, scene], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"plab-rounds failed on {scene}: {r.stderr}")
    return json.loads(r.stdout)


def made_and_later(report_text):
    """(comparisons of two events in the step by thread, the sum of their later events) of a run's
    report.json (the kit's runner), or None when the run left none."""
    try:
        report = json.loads(report_text or "")
        return [int(x) for x in report["order_step_comparisons"]], str(report["order_later_sum"])
    except (ValueError, KeyError, TypeError):
        return None


def not_the_rounds(total, later, rounds, hint):
    """None when `total` comparisons of two events in the step whose later events sum to `later`
    are those of `rounds` (plan(), or a report of the kit's solution on the same scene: the same
    keys), else why not, for the student."""
    need = int(rounds["comparisons"])
    if total == need and later == rounds["later_sum"]:
        return None
    where = (f"the {rounds['total']} rounds of its {rounds['steps']} steps"
             if "total" in rounds else "the kit's rounds on the same scene")
    if total == 0:
        return (f"its selection made no comparisons with earlier() (plab::EventOrder, given in "
                f"step.cpp), where {where} make {need}: a round compares each unresolved "
                f"particle's wall (when in the step) and each candidate whose partner is "
                f"unresolved with earlier(a, b), which the kit counts on each thread; "
                f"model::key_less() or comparing the times yourself is not counted. {hint}")
    what = (f"{total} comparisons of two events in the step" if total != need else
            f"{total} comparisons of two events in the step, as many, but not of the same events")
    why = ("more: are events of resolved partners compared, or resolved particles searched "
           "again?" if total > need else
           "fewer: is a candidate left out (every pair event of exercise 1 with t < 1 is one, "
           "pruned by nothing), or a wall not compared?" if total < need else
           "are the events compared the particles' own, keyed as the model keys them?")
    return (f"its comparisons with earlier() are not the mutual-earliest rounds': it made {what}; "
            f"{where} make {need} (each round, each unresolved particle compares its wall, when "
            f"in the step, and each candidate whose partner is still unresolved, once, keeping "
            f"the earlier; a particle resolved in an earlier round compares nothing); {why} {hint}")


class RoundsCount:
    """The synchronisations of one watched run of stage 03 against the rounds its scene needs.
    With a sandbox (the grader), the library is copied where the sandbox's uid reads it; without
    one (a student's own check, plab.rounds_check), the run preloads it where it is."""

    def __init__(self, kit_bin, sandbox, scene):
        lib, tool = kit_bin / LIBRARY, kit_bin / "plab-rounds"  # the grading's copies
        if not lib.is_file() or not tool.is_file():
            raise RuntimeError(f"the kit's {lib.name} or {tool.name} is not built: run ./plab once "
                               "in the kit")
        self.sandbox = sandbox
        if sandbox is None:
            self.lib = lib
        else:
            self.lib = sandbox.shared_dir("bin") / LIBRARY  # readable by the sandbox's uid
            shutil.copyfile(lib, self.lib)
            os.chmod(self.lib, 0o755)
        self.secret = secrets.token_hex(16)
        self.rounds = plan(kit_bin, scene)

    def mounts(self):
        return {INSIDE: self.lib}

    def env(self, program):
        """The run's environment: the library preloaded, the secret it signs its counts with,
        and the program it counts (its path as the program sees it)."""
        bwrap = self.sandbox is not None and self.sandbox.mode == "bwrap"
        return {"LD_PRELOAD": INSIDE if bwrap else str(self.lib), "PLAB_OMP_COUNT": self.secret,
                "PLAB_OMP_COUNT_PROGRAM": "/plab/stage" if bwrap else str(program)}

    NO_COUNT = ("its run left no count of its OpenMP synchronisations (the kit's counter reads "
                "libgomp's entry points: the stage must use OpenMP, built by the kit's CMake)")

    def counted(self, run):
        """The run's counts {regions, syncs} as the library signed them, or None."""
        try:
            counts = json.loads(run.read_output("omp-count.json") or "")
            assert counts["secret"] == self.secret
            return {"regions": int(counts["regions"]), "syncs": int(counts["syncs"])}
        except (ValueError, KeyError, TypeError, AssertionError):
            return None

    def check(self, idea, run, text):
        """(problem or None, text): at least min_syncs_per_round synchronisations a round.
        Remembers the count (self.seen) for follows()."""
        counts = self.counted(run)
        if counts is None:
            return self.NO_COUNT, text
        seen = self.seen = counts["regions"] + counts["syncs"]
        rounds, steps = self.rounds["total"], self.rounds["steps"]
        need = idea["min_syncs_per_round"] * rounds
        text += (f"; {seen} OpenMP synchronisations ({counts['regions']} parallel regions, "
                 f"{counts['syncs']} barriers and loop ends) for the {rounds} rounds of its "
                 f"{steps} steps")
        if seen < need:
            return (f"it ran {seen} OpenMP synchronisations (parallel regions, barriers, ends of "
                    f"work-sharing loops) in {steps} steps whose event selection takes {rounds} "
                    f"mutual-earliest rounds ({self.rounds['rounds']}); a round of parallel loops "
                    f"passes at least one, so at least {need:g} were expected. "
                    f"{idea['hint'][:1].upper()}{idea['hint'][1:]}"), text
        return None, text

    def comparisons(self, idea, run, text, threads):
        """(problem or None, text): the run's comparisons of events in the step (by thread) and
        the sum of their later events (report.json, written by the kit's runner) are the rounds'
        (plab-rounds), and at least min_balanced_comparisons of them were shared evenly by the
        `threads` threads loop by loop (EventOrder::balanced(): in each epoch of the preloaded
        counter's clock, `threads` times the least that a thread made)."""
        hint = f"{idea['hint'][:1].upper()}{idea['hint'][1:]}"
        report_text = run.read_output("report.json")
        counted = made_and_later(report_text)
        if counted is None:
            return "its run left no report of its comparisons (the kit's runner writes it)", text
        made, later = counted
        report = json.loads(report_text)
        total = sum(made)
        text += (f"; {total} comparisons of events in the step ({self.rounds['comparisons']} in "
                 f"the rounds)")
        problem = not_the_rounds(total, later, self.rounds, hint)
        if problem:
            return problem, text
        shares = sorted(made, reverse=True) + [0] * max(0, threads - len(made))
        shown = " / ".join(f"{100 * x / total:.0f}%" for x in shares)
        text += f", by thread {shown}"
        balanced = int(report.get("order_balanced_comparisons", -1))
        if balanced < 0:
            return ("its run kept no epochs of its comparisons (the kit's OpenMP counter gives "
                    "them to plab::EventOrder: the stage must use OpenMP, built by the kit's "
                    "CMake)"), text
        least = idea["min_balanced_comparisons"]
        text += f", {100 * balanced / total:.0f}% shared evenly loop by loop"
        if balanced < least * total:
            return (f"its rounds' comparisons were not shared by its {threads} threads loop by "
                    f"loop: {100 * balanced / total:.0f}% of the {total} were made in loops "
                    f"(between two synchronisations) in which each thread made an equal part (at "
                    f"least {100 * least:.0f}% must be; by thread over the whole run {shown}; "
                    f"counted by the kit's earlier() on the thread that compares, the "
                    f"schedule(runtime) loops on {SCHEDULE}). A round's loops are shared by the "
                    f"team: #pragma omp for inside a parallel region, or #pragma omp parallel "
                    f"for, not a round in `single` or on one thread; a dynamic or guided "
                    f"schedule written into the rounds' loops can leave one thread most of a loop "
                    f"on a busy machine: use schedule(runtime) or static. {hint}"), text
        return None, text

    def follows(self, idea, calm, calm_run, text, scene="the hidden scene"):
        """(problem or None, text): the synchronisations grow with the rounds. `calm` counted a
        run of the same stage on a calmer scene (the same N, box and steps, slow speeds: fewer
        rounds); a stage whose rounds are parallel loops passes at least min_syncs_per_round more
        for each extra round, whatever it does once a step. A stage that pads its step with a
        fixed number of loops (its selection sequential) passes as many on both."""
        counts = calm.counted(calm_run)
        if counts is None:
            return self.NO_COUNT + " (on the calmer scene)", text
        seen = counts["regions"] + counts["syncs"]
        extra_rounds = self.rounds["total"] - calm.rounds["total"]
        need = idea["min_syncs_per_round"] * extra_rounds
        text += (f"; on a calmer scene (slow speeds) of {calm.rounds['total']} rounds: {seen} "
                 f"synchronisations ({self.seen - seen} fewer for {extra_rounds} fewer rounds)")
        if extra_rounds > 0 and self.seen - seen < need:
            return (f"its OpenMP synchronisations do not follow the rounds: {self.seen} on "
                    f"{scene} of {self.rounds['total']} rounds, {seen} on a calmer one (the "
                    f"same N, box and steps, slow speeds) of {calm.rounds['total']} rounds; a "
                    f"stage whose rounds are parallel loops passes at least {idea['min_syncs_per_round']:g} "
                    f"more for each extra round, so at least {need:g} more were expected. "
                    f"{idea['hint'][:1].upper()}{idea['hint'][1:]}"), text
        return None, text
