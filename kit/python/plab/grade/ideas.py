"""The stage's idea, measured outside its code (rubric.json's per-stage "idea"): the work
shared by the threads or ranks, the bytes sent, the time against a scene only the idea makes
fast."""
import json
import os
import pathlib
import random
import shutil
import subprocess
import tempfile
import time

from plab.grade import heap_probe, queue_probe, rounds_count
from plab.grade.rounds_count import SCHEDULE, RoundsCount
from plab.grade.build import unbuilt
from plab.grade.run import stderr_tail


class Ideas:
    """The idea tests: a mixin of Grader (plab.grade.grader)."""

    # -- the stage's idea, measured outside its code -----------------------------------------------
    def idea_test(self, st, program, folder):
        """The stage's idea, measured by the grader outside the student's code (rubric: the
        stage's "idea"); a failure takes every correctness point of the stage folder.
          scale:   a hidden scene too large for the idea the stage replaces (stage 02: O(N^3)
                   selection; 06: O(N^2) pair tests; 07: a linear scan for each event), under a
                   time limit that the kit's solution meets many times over, with the
                   reference's output; and (07's `queue_probe`) the event queue driven alone
                   by the kit's probe (queue_probe.py);
          threads: the stage on `threads` OpenMP threads (waiting passively): at least two
                   threads each used `share` of the program's CPU time (read from /proc), and
                   (`min_syncs_per_round`) it ran that many OpenMP synchronisations for each
                   mutual-earliest round of the scene's steps (rounds_count.RoundsCount: counted
                   by the kit's preloaded libplab-ompcount.so, the rounds from plab-rounds), and
                   (`min_balanced_comparisons`) its comparisons with plab::EventOrder are the
                   rounds' (plab-rounds'), that share of them split evenly among the threads
                   loop by loop (and, on every correctness scene, the comparisons are the
                   rounds' there too: rounds_compared());
          ranks:   the stage under mpirun on `ranks` processes: it sent at most
                   `max_bytes_per_particle_step` and more than none (counted by the kit's MPI
                   layer), every rank did `share` of the steps' work outside MPI calls (measured
                   by the kit's MPI layer: `min_work_seconds`), the ranks' work in all was at most
                   `max_work_multiple` times the kit's solution's on the same scene and ranks
                   (ranks that each step every particle, or burn CPU while one steps them all),
                   and they used `share` of the ranks' CPU time (read from /proc), so rank 0
                   does not step everything.
        Both watched kinds also take `max_share`: the most that one thread or rank may use."""
        idea = st.idea
        test = f"{st.sid}: idea ({idea['what']})"
        if isinstance(program, str):
            self.results.add(test, 0, 0, False, f"not run: {unbuilt(st.sid, program)}")
            self.idea_failed[st.sid] = unbuilt(st.sid, program, 1)
            return
        scene, what = self.idea_scene(st, folder)
        kind = idea["kind"]
        traced = "heap_probe" in idea  # stage 02: the step's heap comparisons, traced (EventOrder)
        own_report = folder / "idea-own-report.json" if kind == "ranks" or traced else None
        expected, own_seconds = self.own_run(st, scene, idea.get("threads", 1), folder / "idea.out",
                                             idea.get("ranks", 1), own_report)
        limit = max(idea.get("seconds", 0), idea.get("multiple", 0) * own_seconds)
        threads = str(idea.get("threads", st.threads))
        env = dict(st.env, OMP_WAIT_POLICY="passive") if kind == "threads" else st.env
        # Threads: the kit's counter (not the student's code) counts the OpenMP synchronisations
        counter = (RoundsCount(self.kit_bin, self.sandbox, scene)
                   if "min_syncs_per_round" in idea else None)
        if counter:
            env = dict(env, **counter.env(program))
        # Ranks: the kit's MPI layer (not the student's code) counts the bytes the ranks send.
        # Stage 03: the kit's runner reports the rounds' comparisons (plab::EventOrder)
        compared = counter is not None and "min_balanced_comparisons" in idea
        report = ["--report", "/plab/out/report.json"] if own_report or compared else []
        # Stage 03: schedule(runtime) loops shared the same way however busy the machine is
        schedule = ["--schedule", SCHEDULE] if compared else []
        run = self.run_program(program, scene, ["--quiet", "--threads", threads, *schedule,
                                                "--out", "/plab/out/out.txt", *report], limit,
                               max(self.rubric["limits"]["output_min_mb"] * 2**20,
                                   4 * len(expected)), st, env=env, watch=kind != "scale",
                               ranks=idea.get("ranks", st.ranks),
                               extra_ro=counter.mounts() if counter else None)
        problem = self.idea_run_problem(run, what, limit, own_seconds, expected, idea["hint"])
        probe = (heap_probe if "heap_probe" in idea else
                 queue_probe if "queue_probe" in idea else None)
        if problem is not None and probe is not None:
            # A wrong or failed run of a stage whose idea is a data structure of its own: the
            # structure driven alone names what is wrong in it, where the scene's first wrong
            # line does not (an instructor's trial: a heap that sank towards the left child lost
            # stage 02 with only "its output differs" to say why)
            found, _ = probe.grade_probe(self, st, idea)
            if found:
                problem = f"{found}\n(and so {problem})"
        text = f"the {what}: {run.seconds:.2f} s (the kit's solution: {own_seconds:.2f} s)"
        if problem is None and kind == "ranks" and "max_bytes_per_particle_step" in idea:
            problem, text = self.bytes_sent(idea, run, text, own_report)  # counted: first
        if problem is None and kind == "ranks" and "min_work_seconds" in idea:
            problem, text = self.work_outside_mpi(idea, run, text, own_work(own_report))
        if problem is None and counter:
            problem, text = counter.check(idea, run, text)  # counted, so decided first
        if problem is None and compared:
            problem, text = counter.comparisons(idea, run, text, int(threads))
        if problem is None and counter and "calm_speed" in idea:
            problem, text = self.rounds_follow(st, program, folder, counter, limit, text)
        if problem is None and kind != "scale":
            problem, text = self.work_shared(idea, run, text)
        if problem is None and "heap_probe" in idea:  # stage 02's own heap, driven alone
            problem, measured = heap_probe.grade_probe(self, st, idea)
            text += f"; {measured}" if measured else ""
        if problem is None and "queue_probe" in idea:  # stage 07's event queue, driven alone
            problem, measured = queue_probe.grade_probe(self, st, idea)
            text += f"; {measured}" if measured else ""
        if problem is None and traced:  # then the step's own comparisons against the kit's heap's
            problem, measured = heap_probe.judge_step(run.read_output("report.json"), own_report,
                                                      idea.get("hint", ""))
            text += f"; {measured}" if measured else ""
        if problem:
            self.idea_failed[st.sid] = f"the idea test of stage {st.sid} failed: {problem}"
        if run.reason and "time limit" in run.reason:
            self.idea_slow[st.sid] = (len(self.results.tests), what, limit, own_seconds)
        self.results.add(test, 0, 0, problem is None, problem or text, False, run.seconds)

    def idea_not_to_blame(self, st, name, budget, ref_seconds):
        """A correctness test of the stage ran out of time after its idea test had, on a scene the
        kit's solution finishes in under 1% of the test's budget: the stage's hint (the idea it
        lacks) would mislead a stage that never ends even a small scene, so the idea test's
        result says so instead, with the two scenes' times."""
        if st.sid not in self.idea_slow:
            return
        if ref_seconds * 100 > budget:
            # A scene the kit's solution needs more than 1% of the budget for: a stage without
            # the idea may well run out of time on it too (an O(N^3) stage 02 on random-1000), so
            # the idea test's hint stands
            return
        index, what, limit, own_seconds = self.idea_slow.pop(st.sid)
        problem = (f"it did not finish the {what} in {limit:.0f} s (the kit's solution takes "
                   f"{own_seconds:.2f} s), and it did not finish the test {name} either in "
                   f"{budget:.0f} s (the kit's solution: {ref_seconds:.2f} s): a step that never "
                   "ends (an endless loop, a wait that nothing ends) comes before the stage's idea; "
                   "find it first, on the public scenes")
        self.idea_failed[st.sid] = f"the idea test of stage {st.sid} failed: {problem}"
        self.results.tests[index]["output"] = self.results.banner + problem
        self.results.write()

    def own_run(self, st, scene, threads, out, ranks=1, report=None):
        """(output, seconds) of the stage's own solution on `scene` (the same bits as the
        reference, and the speed a limit is set from), written to `out`; on `ranks` processes
        under mpirun when ranks > 1; the kit's report of the run written to `report` if given."""
        argv = [self.solution(st.sid), scene, "--quiet", "--threads", str(threads), "--out", out]
        env = dict(os.environ, **st.env)
        if ranks <= 1 and report:
            argv += ["--report", str(report)]
        if ranks > 1:
            argv = [shutil.which("mpirun") or "mpirun", "--quiet", "--oversubscribe", "-np",
                    str(ranks), *argv, "--report", report]
            if os.geteuid() == 0:  # OpenMPI refuses root unless told twice (containers, CI)
                env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
            env["TMPDIR"] = tempfile.mkdtemp(prefix="mpi-", dir=self.private)  # its session files
        start = time.time()
        r = subprocess.run(argv, capture_output=True, text=True, env=env)
        seconds = time.time() - start
        if r.returncode != 0:
            raise RuntimeError(f"the kit's solution of stage {st.sid} failed on {scene}: {r.stderr}")
        return pathlib.Path(out).read_text(), seconds

    def rounds_follow(self, st, program, folder, counter, limit, text):
        """Stage 03's second measure of the rounds: the stage again on a calmer hidden scene (the
        idea scene's N, box and steps at the slow speeds `calm_speed`: fewer rounds), its output
        checked, its synchronisations counted: they must fall with the rounds
        (RoundsCount.follows)."""
        idea, sc = st.idea, st.idea["scene"]
        scene = folder / "idea-calm.in"
        self.kit_programs.gen(scene, "--n", sc["n"], "--l", sc["L"], "--r", sc["r"], "--steps",
                              sc["steps"], "--mode", "perf", "--speed", idea["calm_speed"],
                              "--seed", (self.seed * 17 + int(st.sid)) % 2**32)
        what = f"calmer hidden scene N = {sc['n']}, L = {sc['L']}, S = {sc['steps']}"
        threads = str(idea.get("threads", st.threads))
        expected, own_seconds = self.own_run(st, scene, threads, folder / "idea-calm.out")
        calm = RoundsCount(self.kit_bin, self.sandbox, scene)
        run = self.run_program(program, scene, ["--quiet", "--threads", threads, "--schedule",
                                                SCHEDULE, "--out", "/plab/out/out.txt"], limit,
                               max(self.rubric["limits"]["output_min_mb"] * 2**20,
                                   4 * len(expected)), st,
                               env=dict(st.env, OMP_WAIT_POLICY="passive", **calm.env(program)),
                               watch=True, ranks=st.ranks, extra_ro=calm.mounts())
        problem = self.idea_run_problem(run, what, limit, own_seconds, expected, idea["hint"])
        if problem:
            return problem, text
        return counter.follows(idea, calm, run, text)

    def idea_scene(self, st, folder):
        """(path, words) of the entry's hidden idea scene, generated from the grading's seed
        (the same scene for every kind of idea test, CPU and GPU)."""
        sc = st.idea["scene"]
        scene = folder / "idea.in"
        speed = ("--speed", sc["speed"]) if "speed" in sc else ()
        self.kit_programs.gen(scene, "--n", sc["n"], "--l", sc["L"], "--r", sc["r"], "--steps",
                              sc["steps"], "--mode", "perf", "--seed",
                              (self.seed * 13 + int(st.sid)) % 2**32, *speed)
        if st.idea["kind"] == "ranks":
            unguessable(scene)
        return scene, f"hidden scene N = {sc['n']}, L = {sc['L']}, S = {sc['steps']}"

    @staticmethod
    def idea_run_problem(run, what, limit, own_seconds, expected, hint):
        """What went wrong with the student's run on the idea scene (too slow, failed, another
        output), or None: the first check of every idea test."""
        if run.reason and "time limit" in run.reason:
            return (f"it did not finish the {what} in {limit:.0f} s (the kit's solution takes "
                    f"{own_seconds:.2f} s): {hint}")
        if run.reason or run.rc != 0:
            return (f"the run on the {what} {run.reason or 'exited ' + str(run.rc)}: "
                    f"{stderr_tail(run.stderr)}")
        if run.read_output() != expected:
            return f"its output on the {what} differs from the reference's"
        return None

    def bytes_sent(self, idea, run, text, own_report=None):
        """(problem or None, text): the bytes the ranks sent a particle and step, counted by the
        kit's MPI layer, against the rubric's most. The halo and the rounds' messages of a
        slow scene are a fraction of a byte; every particle sent to one rank and back, about 75
        a step; none at all, ranks that never worked together (rank 0 stepping alone while the
        others spin). The most is also what keeps out a stepper of the student's own fast
        enough to pass the work checks below: rank 0 stepping everything must receive every
        other rank's particles at least once and send them back at the end, and ranks that
        each step every particle must each receive them all once; at 32 bytes a particle's
        state (its position and velocity, the least that holds it exactly) over the scene's
        few steps, both are above the most (`gather_once()`). The scene's particles are moved by
        a secret amount (`unguessable()`), so no rank can make them again from the generator.
        And (`max_bytes_multiple`) at most that many times the bytes of the kit's solution on the
        same scene and ranks (`own_report`): the halo and the ghosts' values are the particles
        within the reach of another rank's slab, so a reach larger than the fastest speed of any
        rank (a sum of the ranks' speeds, say) sends more and prints the same."""
        sc, most = idea["scene"], idea["max_bytes_per_particle_step"]
        try:
            report = json.loads(run.read_output("report.json") or "")
            sent = float(report["bytes_sent"])
        except (ValueError, KeyError, TypeError):
            return "its run left no report of the bytes its ranks sent", text
        per = sent / (sc["n"] * sc["steps"])
        # one decimal, but a few hundred bytes in all must not read as none
        shown = f"{per:.1f}" if per >= 0.1 else f"{per:.2g}"
        text += f"; its ranks sent {shown} bytes a particle and step"
        if sent <= 0:  # ranks that share no halo and no round: each ran alone (or idled)
            return (f"its ranks sent each other nothing in {sc['steps']} steps of {sc['n']} "
                    f"particles: no halo, no round's message, so no rank stepped a slab of "
                    f"its own with the others. {idea['hint']}"), text
        if per > most:
            one, every = gather_once(idea["ranks"], sc["steps"])
            return (f"its ranks sent {per:.1f} bytes a particle and step (at most {most:g} may: "
                    f"the halo and the rounds' messages; every particle's state sent once in the "
                    f"{sc['steps']} steps to rank 0 and back is {one:.1f}, to every rank "
                    f"{every:.1f}, and every particle sent to one rank and back every step about "
                    f"75). {idea['hint']}"), text
        multiple = idea.get("max_bytes_multiple")
        if multiple and own_report:
            own = json.loads(pathlib.Path(own_report).read_text())
            own_sent = float(own["bytes_sent"])
            if own_sent > 0 and sent > multiple * own_sent:
                calls = sorted(set(own.get("bytes_by_call", {})) |
                               set(report.get("bytes_by_call", {})))
                by_call = ", ".join(
                    f"{c} {float(report.get('bytes_by_call', {}).get(c, 0)):.0f} / "
                    f"{float(own['bytes_by_call'].get(c, 0)):.0f}" for c in calls)
                return (f"its ranks sent {sent:.0f} bytes in {sc['steps']} steps, "
                        f"{sent / own_sent:.1f} times the kit's solution's {own_sent:.0f} on the "
                        f"same scene and ranks (at most {multiple:g} times). By call, its bytes / "
                        f"the solution's: {by_call}. The halo and the ghosts' values hold the "
                        f"particles within the reach of another rank's slab, the reach from the "
                        f"fastest speed of any rank: more bytes in those calls mean a larger "
                        f"halo than the step needs. {idea['hint']}"), text
        return None, text

    def work_outside_mpi(self, idea, run, text, own=None):
        """(problem or None, text): the CPU time each rank spent in its steps outside MPI calls,
        measured by the kit's MPI layer (the process's CPU clock read as each step and each MPI call
        of the stage, waits and tests included, starts and ends), against the rubric's `share` and
        `max_share`. MPI's waits spin, so a rank that waits in MPI_Barrier while rank 0 steps every
        particle uses as much CPU time as rank 0 (work_shared() cannot tell them apart): here it did
        no work. `own`: the same sum of the kit's solution on the same scene and ranks; the ranks'
        work in all may be at most `max_work_multiple` times it. The stepping is the kit's
        (local.hpp), so an honest stage does about the solution's work; ranks that each step every
        particle do R times it, and ranks that burn CPU outside MPI (so that their shares look even)
        while one steps everything, at least 1 / max_share times it."""
        try:
            report = json.loads(run.read_output("report.json") or "")
            work = [float(x) for x in report["rank_work_seconds"]]
            waiting = [float(x) for x in report["rank_mpi_seconds"]]
        except (ValueError, KeyError, TypeError):
            return "its run left no report of the work of its ranks", text
        total = sum(work)
        shown = ", ".join(f"{x:.3f}" for x in work)
        text += f"; CPU seconds of its ranks' steps outside MPI calls: {shown}"
        if own:
            text += f" (in all {total:.3f}; the kit's solution's {own:.3f})"
        if len(work) != idea["ranks"]:
            return (f"its run reported the work of {len(work)} ranks, not {idea['ranks']}. "
                    f"{idea['hint']}"), text
        # The kit reads the CPU clock at every change of state: a program that arms a process
        # timer (Linux then reads the clock from the timer's sums, which stand still between
        # ticks) or changes the kit's SIGPROF handler may report little work, while /proc shows
        # its ranks' CPU time (the solution: about 60% of it in its steps, the rest reading,
        # scattering, printing)
        used = sum(getattr(run, "cpu", {}).values())
        if total + sum(waiting) < 0.2 * used and used >= idea["min_cpu_seconds"]:
            return (f"the kit's measurement of its ranks' steps saw {total + sum(waiting):.3f} s "
                    f"of the {used:.2f} s of CPU time its ranks used: a timer or a signal "
                    f"(SIGPROF) was changed. {idea['hint']}"), text
        if total < idea["min_work_seconds"]:
            return None, text + " (too little to judge: not held against it)"
        least = idea.get("min_work_multiple")
        if least and own and total < least * own:
            return (f"its ranks did {total:.3f} s of work outside MPI calls in all, "
                    f"{total / own:.2f} times the kit's solution's {own:.3f} s on the same scene "
                    f"and ranks (at least {least:g} times: the stepping is the kit's, so ranks "
                    f"that step their slabs do about the solution's work; less means work done "
                    f"where the kit counts time in MPI). CPU seconds of its ranks' steps outside "
                    f"MPI calls: {shown}. {idea['hint']}"), text
        most = idea.get("max_work_multiple")
        if most and own and total > most * own:
            return (f"its ranks did {total:.3f} s of work outside MPI calls in all, "
                    f"{total / own:.1f} times the kit's solution's {own:.3f} s on the same scene "
                    f"and ranks (at most {most:g} times: the stepping is the kit's, so a rank that "
                    f"steps its own slab does its share of the solution's work; ranks that each "
                    f"step every particle, or burn CPU while one steps them all, do more). CPU "
                    f"seconds of its ranks' steps outside MPI calls: {shown}. {idea['hint']}"), text
        low, high = min(work), max(work)
        most_share = idea.get("max_work_share", idea.get("max_share", 1.0))
        if low < idea["share"] * total or high > most_share * total:
            which = work.index(low if low < idea["share"] * total else high)
            return (f"rank {which} did {100 * work[which] / total:.0f}% of the work of the "
                    f"steps (each rank at least {100 * idea['share']:.0f}%, at most "
                    f"{100 * most_share:.0f}%: CPU time outside MPI calls, "
                    f"measured by the kit; a rank waiting in an MPI call does no work, even "
                    f"when the wait spins). CPU seconds of its ranks' steps outside MPI calls: "
                    f"{shown}. {idea['hint']}"), text
        return None, text

    def ranks_work(self, st, run, scene, stem):
        """None, or why a run on several ranks that printed the reference's text still fails
        (rubric.json's correctness.ranks_work): once its ranks' work outside MPI calls
        reaches `min_work_seconds` (the scenes of a thousand particles and more), every rank
        must have done `share` of it and all of them at most `max_work_multiple` times the kit's
        solution's on the same scene and ranks (run now, `stem`.out and `stem`.json). So a stage
        that steps its own slab only on the idea test's scene, and gathers every particle on
        rank 0 elsewhere, loses those scenes."""
        conf = self.rubric["correctness"].get("ranks_work")
        if not conf:
            return None
        try:
            work = [float(x) for x in
                    json.loads(run.read_output("report.json") or "")["rank_work_seconds"]]
        except (ValueError, KeyError, TypeError):
            return "the output is right, but its run left no report of the work of its ranks"
        total = sum(work)
        if total < conf["min_work_seconds"]:
            return None  # too little to judge
        shown = ", ".join(f"{x:.3f}" for x in work)
        low = min(work)
        if low < conf["share"] * total:
            return (f"the output is right, but rank {work.index(low)} of {st.ranks} did "
                    f"{100 * low / total:.0f}% of the work of the steps (each rank at least "
                    f"{100 * conf['share']:.0f}%: CPU time outside MPI calls, measured by the "
                    f"kit). CPU seconds of its ranks' steps outside MPI calls: {shown}. Every "
                    f"rank steps the particles of its own slab, on every scene")
        stem.parent.mkdir(parents=True, exist_ok=True)
        report = stem.with_suffix(".json")
        self.own_run(st, scene, st.threads, stem.with_suffix(".out"), st.ranks, report)
        own = own_work(report)
        if own > 0 and total > conf["max_work_multiple"] * own:
            return (f"the output is right, but its ranks did {total:.3f} s of work outside MPI "
                    f"calls in all, {total / own:.1f} times the kit's solution's {own:.3f} s on "
                    f"this scene and {st.ranks} ranks (at most {conf['max_work_multiple']:g} "
                    f"times). CPU seconds of its ranks' steps outside MPI calls: {shown}. Every "
                    f"rank steps the particles of its own slab, on every scene")
        return None

    @staticmethod
    def compares_rounds(st):
        """Whether stage folder st's runs are checked for the rounds' comparisons (stage 03: its
        idea's min_balanced_comparisons): every graded run then writes the runner's report."""
        return bool(st.idea) and "min_balanced_comparisons" in st.idea

    def rounds_compared(self, st, run, scene):
        """None, or why a stage 03 run that printed the reference's text still fails: its
        comparisons with earlier() (the runner's report) must be those of the kit's rounds on
        this scene (plab-rounds), on every scene, not only where the idea test counts them. So a
        stage that selects in rounds only on large scenes, or only when the idea test's counter
        is loaded, and otherwise (a heap, a scan) another way, loses those scenes."""
        counted = rounds_count.made_and_later(run.read_output("report.json"))
        if counted is None:
            return "the output is right, but its run left no report of its comparisons"
        made, later = counted
        hint = f"{st.idea['hint'][:1].upper()}{st.idea['hint'][1:]}"
        problem = rounds_count.not_the_rounds(sum(made), later,
                                              rounds_count.plan(self.kit_bin, scene), hint)
        return f"the output is right, but {problem}" if problem else None

    def work_shared(self, idea, run, text):
        """(problem or None, text) of a watched run: who did the work, threads or ranks."""
        share = idea["share"]
        if idea["kind"] == "threads":
            pids = {pid for pid, _ in run.cpu}
            if len(pids) != 1:
                return f"expected one process, saw {len(pids)}", text
            parts = sorted(run.cpu.values(), reverse=True)
            who = "threads"
        else:
            per_rank = {}
            for (pid, _), seconds in run.cpu.items():
                per_rank[pid] = per_rank.get(pid, 0) + seconds
            parts = sorted(per_rank.values(), reverse=True)
            who = "ranks"
        total = sum(parts)
        shown = ", ".join(f"{x:.2f}" for x in parts[:8])
        text += f"; CPU seconds of its {who}: {shown} (total {total:.2f})"
        if total < idea["min_cpu_seconds"]:
            return None, text + " (too little to judge: not held against it)"
        need = 2 if idea["kind"] == "threads" else idea["ranks"]
        real = [x for x in parts if x >= share * total]
        if len(real) < need:
            return (f"{len(real)} of its {who} did a real share of the work (at least "
                    f"{100 * share:.0f}% of its CPU time each); {need} must. CPU seconds of its "
                    f"{who}: {shown} (total {total:.2f}). {idea['hint']}"), text
        most = idea.get("max_share", 1.0)
        if parts[0] > most * total:
            return (f"one of its {who} did {100 * parts[0] / total:.0f}% of the work (at most "
                    f"{100 * most:.0f}% may). CPU seconds of its {who}: {shown} (total "
                    f"{total:.2f}). {idea['hint']}"), text
        return None, text


def unguessable(scene, shift=1e-3):
    """Moves every particle of `scene` (a scene file with its particle lines) by a secret random
    amount, at most `shift` in each coordinate of its position (kept within [r, L - r]) and of its
    velocity, drawn from the system's random source. Stage 08's idea scene is so: the kit's
    generator (SplitMix64) can be run backwards, and a red-team stage 08 recovered the seed from
    particle 0's position, rebuilt all 2 x 10^5 particles on every rank from one 8-byte message and
    stepped them all (164 of 164, the bytes' most beaten). The moved values are no generator's
    output, so a rank holds another's particles only by receiving them. Not replayed by --seed."""
    draw = random.SystemRandom()
    lines = pathlib.Path(scene).read_text().split("\n")
    L, r = float(lines[1]), float(lines[2])
    out = lines[:5]
    for line in lines[5:]:
        fields = line.split()
        if len(fields) != 5:
            out.append(line)
            continue
        x, y, vx, vy = (float(f) + draw.uniform(-shift, shift) for f in fields[1:])
        x, y = min(max(x, r), L - r), min(max(y, r), L - r)
        out.append(f"{fields[0]} {x!r} {y!r} {vx!r} {vy!r}")
    pathlib.Path(scene).write_text("\n".join(out))


def gather_once(ranks, steps, state=32):
    """(to rank 0 and back, to every rank): the fewest bytes a particle and step that a stage
    sends to hold every particle on one rank (or every rank) for `steps` steps, gathering each
    particle's exact state (`state` bytes: position and velocity in double) once. Rank 0 receives
    the (ranks - 1) / ranks of the particles that are not its own and sends them back at the
    end; every rank receiving every other rank's particles is ranks - 1 copies of the scene."""
    return 2 * state * (ranks - 1) / ranks / steps, state * (ranks - 1) / steps


def own_work(report):
    """The work outside MPI calls in all of the kit's solution's run that wrote `report` (the
    sum of its rank_work_seconds)."""
    try:
        return sum(float(x) for x in json.loads(pathlib.Path(report).read_text())["rank_work_seconds"])
    except (OSError, TypeError, ValueError, KeyError) as e:
        raise RuntimeError(f"the kit's solution left no report of its ranks' work ({report}): "
                           f"{e}") from None
