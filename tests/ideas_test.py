#!/usr/bin/env python3
"""Unit test of plab.grade.ideas' checks of stage 08's idea (every rank steps its own slab): the
bytes the kit's MPI layer counted, against the rubric's most, and none at all (ranks that never
worked together: rank 0 stepping alone while the others idle or spin); and each rank's work
outside MPI calls, sampled by the kit, against the rubric's shares (rank 0 stepping everything
while the others spin in an MPI wait) and, in all, against the kit's solution's (every rank
stepping every particle; ranks burning CPU outside MPI while rank 0 steps everything); and the
same on the correctness scenes large enough to judge (ranks_work(): a stage that steps its slab
only on the idea test's scene).

  ideas_test.py   (PYTHONPATH=kit/python: CTest sets it)
"""
import json
import pathlib
import tempfile
import unittest

from plab.grade.ideas import Ideas, gather_once, unguessable
from plab.grade.performance import more_threads
from plab.grade.run import launcher_crashed

IDEA = {"scene": {"n": 1000, "steps": 10}, "max_bytes_per_particle_step": 20, "ranks": 3,
        "min_work_seconds": 0.05, "min_cpu_seconds": 0.4, "share": 0.1, "max_share": 0.55, "max_work_share": 0.45,
        "min_work_multiple": 0.5, "max_work_multiple": 1.75,
        "hint": "each rank must step its own slab"}


class Run:
    """What bytes_sent() and work_outside_mpi() read of a graded run: its report.json, and each
    process's CPU seconds read from /proc."""

    def __init__(self, report, cpu=None):
        self.report = report
        self.cpu = cpu or {}

    def read_output(self, name):
        assert name == "report.json"
        return self.report


def check(sent):
    return Ideas.bytes_sent(None, IDEA, Run(json.dumps({"bytes_sent": sent})), "ran")


class BytesSent(unittest.TestCase):
    def test_a_halo_passes(self):
        problem, text = check(2000.0)  # 0.2 bytes a particle and step
        self.assertIsNone(problem)
        self.assertIn("0.2 bytes a particle and step", text)

    def test_a_few_bytes_do_not_read_as_none(self):
        problem, text = check(300.0)  # 0.03 bytes a particle and step: not "0.0"
        self.assertIsNone(problem)
        self.assertIn("sent 0.03 bytes a particle and step", text)

    def test_nothing_sent_fails(self):
        problem, _ = check(0.0)
        self.assertIsNotNone(problem)
        self.assertIn("sent each other nothing", problem)

    def test_everything_sent_fails(self):
        problem, _ = check(75.0 * 1000 * 10)
        self.assertIn("75.0 bytes a particle and step (at most 20", problem)

    def test_one_gather_of_every_particle_fails(self):
        # The rubric's idea scene and most: 10 steps on 3 ranks, at most 1 byte. Rank 0 taking
        # every particle's 32-byte state once and sending it back at the end, or every rank
        # taking every particle once (a stepper of the student's own, fast enough for the work
        # checks), is over; the kit's solution (0.2 there) is under.
        idea = dict(IDEA, scene={"n": 1000, "steps": 10}, max_bytes_per_particle_step=1)
        one, every = gather_once(3, 10)
        self.assertAlmostEqual(one, 4.27, places=2)
        self.assertAlmostEqual(every, 6.4)
        for per in (one / 2, one, every):  # rank 0's gather alone too (its return is the output)
            problem, _ = Ideas.bytes_sent(None, idea, Run(json.dumps({"bytes_sent": per * 10000})),
                                          "ran")
            self.assertIn(f"{per:.1f} bytes a particle and step (at most 1 may", problem)
            self.assertIn("to rank 0 and back is 4.3, to every rank 6.4", problem)
        problem, _ = Ideas.bytes_sent(None, idea, Run(json.dumps({"bytes_sent": 0.19 * 10000})),
                                      "ran")
        self.assertIsNone(problem)

    def test_no_report_fails(self):
        problem, _ = Ideas.bytes_sent(None, IDEA, Run(""), "ran")
        self.assertIn("left no report", problem)


def work(seconds, waiting=None, cpu=None, own=0.78):
    report = json.dumps({"rank_work_seconds": seconds,
                         "rank_mpi_seconds": waiting or [0.05] * len(seconds)})
    return Ideas.work_outside_mpi(None, IDEA, Run(report, cpu), "ran", own)


class WorkOutsideMpi(unittest.TestCase):
    def test_even_work_passes(self):
        problem, text = work([0.310, 0.254, 0.267])  # the solution, graded on this machine
        self.assertIsNone(problem)
        self.assertIn("outside MPI calls: 0.310, 0.254, 0.267", text)

    def test_ranks_that_wait_fail(self):
        problem, _ = work([1.029, 0.007, 0.0])  # rank 0 steps all; the others spin in a wait
        self.assertIn("rank 2 did 0% of the work", problem)

    def test_one_rank_doing_most_fails(self):
        problem, _ = work([0.6, 0.2, 0.2])
        self.assertIn("rank 0 did 60% of the work", problem)

    def test_every_rank_stepping_everything_fails(self):
        # even shares, but each rank steps all the particles: 3 times the solution's work
        problem, _ = work([0.80, 0.79, 0.81])
        self.assertIn("3.1 times the kit's solution's 0.780 s", problem)

    def test_ranks_burning_cpu_beside_one_that_steps_all_fail(self):
        # rank 0 steps everything; the others spin outside MPI just enough for their shares
        problem, _ = work([0.78, 0.48, 0.48])  # rank 0's share 45%: the most allowed
        self.assertIn("2.2 times the kit's solution's", problem)

    def test_work_hidden_inside_mpi_calls_fails(self):
        # every rank steps everything inside a reduction's own operation (time in MPI): the
        # work outside MPI calls falls below the solution's (a red-team helper's, 0.344 s)
        problem, _ = work([0.080, 0.136, 0.128], [2.5, 2.4, 2.4], own=0.902)
        self.assertIn("0.38 times the kit's solution's 0.902 s", problem)

    def test_a_slower_honest_stage_passes(self):
        problem, text = work([0.45, 0.40, 0.42])  # 1.6 times the solution's work in all
        self.assertIsNone(problem)
        self.assertIn("in all 1.270; the kit's solution's 0.780", text)

    def test_without_the_solution_s_work_only_the_shares_count(self):
        problem, _ = work([0.80, 0.79, 0.81], own=None)
        self.assertIsNone(problem)

    def test_too_little_is_not_held_against(self):
        problem, text = work([0.03, 0.0, 0.0])
        self.assertIsNone(problem)
        self.assertIn("too little to judge", text)

    def test_sampling_stopped_fails(self):
        # a program that arms a process timer or changes SIGPROF: nothing measured, CPU time used
        problem, _ = work([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], {(1, 1): 0.9, (2, 2): 0.5, (3, 3): 0.5})
        self.assertIn("a timer or a signal (SIGPROF) was changed", problem)
        problem, _ = work([0.3, 0.3, 0.3], [0.1, 0.1, 0.1], {(1, 1): 0.9, (2, 2): 0.5, (3, 3): 0.5})
        self.assertIsNone(problem)

    def test_wrong_rank_count_fails(self):
        problem, _ = work([0.1, 0.1])
        self.assertIn("work of 2 ranks, not 3", problem)

    def test_no_report_fails(self):
        problem, _ = Ideas.work_outside_mpi(None, IDEA, Run(json.dumps({"bytes_sent": 1.0})), "ran")
        self.assertIn("left no report of the work", problem)


class Graded(Ideas):
    """The grader's part that ranks_work() uses: the rubric, and the kit's solution's run (here
    one that writes a report of `own` seconds of work in all)."""

    def __init__(self, own):
        self.rubric = {"correctness": {"ranks_work": {"min_work_seconds": 0.5, "share": 0.1,
                                                      "max_work_multiple": 1.75}}}
        self.own = own
        self.solution_runs = 0

    def own_run(self, st, scene, threads, out, ranks=1, report=None):
        self.solution_runs += 1
        pathlib.Path(report).write_text(json.dumps({"rank_work_seconds": [self.own / ranks] * ranks}))
        return "", 0.0


class LauncherCrash(unittest.TestCase):
    """mpirun's own crash in its forwarding of stdin (Open MPI 4.1) is told from a rank's."""

    class Crashed:
        def __init__(self, stderr):
            self.reason, self.stderr = "crashed with signal 11 (SIGSEGV)", stderr

    def test_mpirun_s_stdin_handler(self):
        self.assertTrue(launcher_crashed(self.Crashed(
            "[vm:05350] [ 1] /usr/lib/x86_64-linux-gnu/openmpi/lib/openmpi3/mca_iof_hnp.so"
            "(orte_iof_hnp_read_local_handler+0x2d6)[0x7f4d81c89366]")))

    def test_a_rank_s_crash_is_the_stage_s(self):
        self.assertFalse(launcher_crashed(self.Crashed("[vm:1] [ 1] /plab/stage(+0x13b9)")))


class Stage:
    ranks, threads = 3, "1"


def ranks_work(seconds, own=2.4):
    grader = Graded(own)
    with tempfile.TemporaryDirectory() as folder:
        said = grader.ranks_work(Stage(), Run(json.dumps({"rank_work_seconds": seconds})),
                                 "scene.in", pathlib.Path(folder) / "ranks-random-2000")
    return said, grader.solution_runs


class RanksWork(unittest.TestCase):
    """A correctness run on several ranks whose output is right (ranks_work())."""

    def test_the_solution_s_shares_pass(self):
        self.assertEqual(ranks_work([0.82, 0.84, 0.80]), (None, 1))  # random-2000, 3 ranks

    def test_a_small_scene_is_not_judged_nor_the_solution_run(self):
        self.assertEqual(ranks_work([0.01, 0.0, 0.0]), (None, 0))

    def test_rank_0_stepping_everything_fails(self):
        said, runs = ranks_work([2.4, 0.001, 0.0])  # a gather on rank 0 off the idea scene
        self.assertIn("rank 2 of 3 did 0% of the work of the steps", said)
        self.assertEqual(runs, 0)

    def test_ranks_burning_cpu_beside_rank_0_fail(self):
        said, _ = ranks_work([2.4, 1.0, 1.0])  # the same, the others spinning outside MPI
        self.assertIn("1.8 times the kit's solution's 2.400 s on this scene and 3 ranks", said)

    def test_no_report_fails(self):
        grader = Graded(2.4)
        said = grader.ranks_work(Stage(), Run(""), "scene.in", pathlib.Path("unused"))
        self.assertIn("left no report of the work of its ranks", said)


class Unguessable(unittest.TestCase):
    """Stage 08's idea scene, moved by a secret amount (no generator's output any more: a red team
    rebuilt the generated scene on every rank from its recovered seed)."""

    def test_every_value_moves_a_little_and_stays_in_the_box(self):
        head = ["3", "100", "1", "10", "perf"]
        particles = [(0, 1.0, 50.0, 2.5, -3.0), (1, 99.0, 99.0, 0.0, 0.0), (2, 50.5, 1.0, 1e-9, 7.0)]
        with tempfile.TemporaryDirectory() as d:
            scene = pathlib.Path(d) / "idea.in"
            scene.write_text("\n".join(head + [" ".join(repr(v) for v in p) for p in particles]) + "\n")
            unguessable(scene)
            lines = scene.read_text().split("\n")
        self.assertEqual(lines[:5], head)
        moved = [[float(f) for f in line.split()] for line in lines[5:] if line.strip()]
        self.assertEqual([int(m[0]) for m in moved], [0, 1, 2])
        for before, after in zip(particles, moved):
            for k in range(1, 5):
                self.assertLessEqual(abs(after[k] - before[k]), 1e-3)
                # a position at the box's edge (r or L - r) is clamped back half of the time;
                # every other value moves (a flaky count of all twelve failed 1 time in 16)
                if not (k <= 2 and before[k] in (1.0, 99.0)):
                    self.assertNotEqual(after[k], before[k], (before, after, k))
            self.assertTrue(1 <= after[1] <= 99 and 1 <= after[2] <= 99, after)


class TimedThreads(unittest.TestCase):
    """performance.more_threads(): a timed run may keep busy the threads it is given, no more."""

    class Timed:
        def __init__(self, seconds, cpu, total=None):
            self.seconds, self.cpu = seconds, dict(enumerate(cpu))
            self.cpu_total = {1: total} if total is not None else {}

    def test_threads_that_ended_count(self):
        # A thread started and joined inside each step is seldom seen by a reading of the
        # threads; the process's own time counts it (a red team's stage 02: 2.43 s of CPU in
        # 1.32 s, of which the threads' readings saw 1.20)
        self.assertIsNotNone(more_threads(self.Timed(1.32, [1.20], total=2.43), 1))
        self.assertIsNone(more_threads(self.Timed(1.32, [1.20], total=1.30), 1))

    def test_threads_given_pass(self):
        self.assertIsNone(more_threads(self.Timed(1.0, [0.98]), 1))
        self.assertIsNone(more_threads(self.Timed(1.0, [0.99, 0.97, 0.01]), 2))
        self.assertIsNone(more_threads(self.Timed(0.05, [0.06, 0.06]), 1))  # granularity

    def test_more_cores_fail(self):
        said = more_threads(self.Timed(0.5, [0.5] * 8), 2)  # num_threads(8) on a big machine
        self.assertIn("used 4.00 s of CPU in 0.50 s, 8.0 cores' worth", said)
        self.assertIn("timed on 2 threads", said)
        self.assertIsNotNone(more_threads(self.Timed(1.0, [1.0, 0.9]), 1))


if __name__ == "__main__":
    unittest.main()
