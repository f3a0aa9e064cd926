"""The performance test: alternate timed runs of the reference and the submission in the same
sandbox, scored by plab.grade.leaderboard (against the reference, or the class), the measured
median time on the leaderboard."""
import os
import shutil
import statistics

from plab.grade import leaderboard, rounds_count
from plab.grade.ideas import unguessable


class Performance:
    """The performance test: a mixin of Grader (plab.grade.grader)."""

    def performance(self, st, program, correct, why="every correctness test must pass first"):
        perf = self.rubric["performance"]
        test = f"{st.key}: performance"
        if isinstance(program, str) or not correct:
            self.results.add(test, 0, perf["points"], False, f"not timed: {why}")
            return
        s = perf["scene"]
        scene = self.private / f"perf-{st.key}.in"
        # The grading's secret seed: a program cannot recognise the timed scene and skip the work
        self.kit_programs.gen(scene, "--n", s["n"], "--l", s["L"], "--r", s["r"], "--steps",
                              s["steps"], "--mode", "perf", "--seed",
                              (self.seed * 31 + int(st.sid) + 1) % 2**32)
        limits = self.rubric["limits"]
        own = self.solution(st.sid)
        kit_prog = own if own.exists() else self.solution(self.manifest["reference_stage"])
        ref_prog = self.sandbox.shared_dir("bin") / f"reference-{st.key}"  # the sandbox's uid
        shutil.copyfile(kit_prog, ref_prog)  # may not read the kit's build folder
        os.chmod(ref_prog, 0o755)
        args = ["--quiet", "--threads", st.threads, "--out", "/plab/out/out.txt"]
        if self.compares_rounds(st):  # stage 03: the rounds' comparisons, the reference's alike
            args += ["--report", "/plab/out/report.json"]
        cap = limits["output_min_mb"] * 2**20
        # Runs alternate (reference, submission, ...) so that a change in the machine's load
        # falls on both alike; the reference runs in the same sandbox, paying its costs alike.
        ref, mine = [], []
        try:
            self.timed_runs(st, program, ref_prog, scene, args, cap, ref, mine)
        finally:
            ref_prog.unlink()  # no later stage may find a correct program beside its own
        if len(mine) < perf["runs"]:
            return
        self.score_performance(st, test, ref, mine)

    def timed_runs(self, st, program, ref_prog, scene, args, cap, ref, mine):
        """Alternate runs of the reference and the submission, each pair on the timed scene
        moved by a secret amount of its own (ideas.unguessable(): every value by at most 10^-3),
        so that no run can be answered from an earlier one (a red-team stage kept its first
        run's final state in the names of symbolic links under /tmp, where the sandbox without
        namespaces lets them last, and wrote it back in 10 ms on the next four runs); each of the
        submission's outputs is compared with the reference's on the same scene, like any other
        run's (a fast wrong program earns nothing)."""
        limits, perf = self.rubric["limits"], self.rubric["performance"]
        test = f"{st.key}: performance"
        # A CPU stage on one process is watched (its threads' CPU time, read from /proc), and so
        # is the reference, which pays the reading's cost alike
        watch = not st.gpu and st.ranks == 1
        for k in range(perf["runs"]):
            moved = self.private / f"perf-{st.key}-{k}.in"
            shutil.copyfile(scene, moved)
            unguessable(moved)
            r = self.run_program(ref_prog, moved, args, 3600, cap, st, watch=watch)
            if r.rc != 0 or r.reason:
                raise RuntimeError(f"the reference failed on {moved}: {r.reason or ''} {r.stderr}")
            ref.append(r.seconds)
            expected = r.read_output()
            if not expected:
                raise RuntimeError(f"the reference wrote no output on {moved}")
            own_counts = None
            if self.compares_rounds(st):  # the kit's rounds' comparisons on this moved scene
                own_counts = rounds_count.made_and_later(r.read_output("report.json"))
                if own_counts is None:
                    raise RuntimeError(f"the reference wrote no report on {moved}")
            r = self.run_program(program, moved, args,
                                 max(limits["min_seconds"], limits["time_multiple"] * max(ref)),
                                 cap, st, watch=watch)
            if r.rc != 0 or r.reason:
                self.results.add(test, 0, perf["points"], False,
                                 f"the timed run {r.reason or 'exited ' + str(r.rc)}")
                return
            if watch and (busy := more_threads(r, int(st.threads))):
                self.results.add(test, 0, perf["points"], False, busy)
                return
            if r.read_output() != expected:
                self.results.add(test, 0, perf["points"], False,
                                 "the timed run's output differs from the reference's (the "
                                 "timed scene is a hidden one: every run must be right)")
                return
            if own_counts is not None and (problem := self.timed_rounds(st, r, own_counts)):
                self.results.add(test, 0, perf["points"], False, problem)
                return
            mine.append(r.seconds)

    @staticmethod
    def timed_rounds(st, run, own_counts):
        """None, or why stage 03's timed run fails though its output is right: its comparisons
        with earlier() are not the kit's solution's on the same scene (rounds_count: the rounds
        make the same ones however scheduled), so a stage cannot select another way where it is
        timed."""
        counted = rounds_count.made_and_later(run.read_output("report.json"))
        if counted is None:
            return "the timed run left no report of its comparisons (the kit's runner writes it)"
        made, later = counted
        own = {"comparisons": sum(own_counts[0]), "later_sum": own_counts[1]}
        hint = f"{st.idea['hint'][:1].upper()}{st.idea['hint'][1:]}"
        problem = rounds_count.not_the_rounds(sum(made), later, own, hint)
        return f"the timed run's output is right, but {problem}" if problem else None

    def score_performance(self, st, test, ref, mine):
        perf, s = self.rubric["performance"], self.rubric["performance"]["scene"]
        rm, mm = statistics.median(ref), statistics.median(mine)
        spread = max((max(ref) - min(ref)) / rm, (max(mine) - min(mine)) / mm)
        ratio = mm / max(rm, 1e-3)
        # Full points up to full_up_to, none from zero_at_ratio, linear in log(ratio) between:
        # bounded, continuous, and no division by a small time (the reference's is >= 1 ms).
        full, zero = perf["full_up_to_ratio"], perf["zero_at_ratio"]
        fraction = leaderboard.fraction(ratio, full, zero)
        text = (f"median {mm:.3f} s against the reference's {rm:.3f} s (ratio {ratio:.2f}; full "
                f"points up to {full}, none from {zero}), {perf['runs']} runs each on "
                f"N = {s['n']}, S = {s['steps']}, {st.threads} thread(s); spread {100 * spread:.0f}%")
        if spread > perf["noisy_spread"]:
            text += (f". TOO NOISY (spread above {100 * perf['noisy_spread']:.0f}%): the grading "
                     "machine was busy; these points are kept, and your instructor may time it "
                     "again")
        if leaderboard.check_mode(perf) != "reference":
            text += (f". The rubric scores these points against the class ({perf['relative']}): "
                     "plab grade --class gives them again from every student's time")
        # The leaderboard holds the time the grader measured, never one the program printed
        # and its ratio to the reference's, timed run after run in the same grading (what a
        # class is ranked by: steadier than the time when the machine's load changes)
        self.results.leaderboard.append(leaderboard.entry(st.key, mm))
        self.results.leaderboard.append(leaderboard.ratio_entry(st.key, ratio))
        self.results.add(test, perf["points"] * fraction, perf["points"], fraction >= 0.999, text,
                         False, sum(mine))


def more_threads(run, threads):
    """Why a watched timed run used more threads than the stage is given, or None: its threads'
    CPU time in all (read from /proc, outside the program) above `threads` times its wall time,
    with a margin for the readings' granularity. A stage timed on T threads that starts more
    (OpenMP's num_threads, omp_set_num_threads) would be timed against a reference on T
    threads while using every core of a larger grading machine (a red-team pass of 2026-12-07
    found it possible on stages 03 and 06; the machine it ran on had only two cores). Read from
    the whole process, so that threads that lived between two readings count too."""
    # the whole processes' time (their threads that ended too), or the threads' where none
    used = max(sum(run.cpu_total.values()), sum(run.cpu.values()))
    if used <= threads * run.seconds * 1.2 + 0.1:
        return None
    return (f"the timed run used {used:.2f} s of CPU in {run.seconds:.2f} s, {used / run.seconds:.1f} "
            f"cores' worth: the stage is timed on {threads} thread{'s' * (threads > 1)} (--threads "
            f"{threads}, as the reference is), so it may keep at most {threads} busy (a parallel "
            "region's num_threads or omp_set_num_threads above the threads given uses cores the "
            "reference does not)")
