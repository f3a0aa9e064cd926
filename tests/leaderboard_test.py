#!/usr/bin/env python3
"""Unit test of plab.grade.leaderboard: the performance points given again against the class
(class_best, curve) rank a faster submission higher (by its time over the reference's in the
same grading, or by its time in a results.json without that ratio), reference scoring changes
nothing, and the
class's page is one offline file with every measured time under its anonymous name. The times
themselves are the grader's (tests/grader_redteam.py's leaderboard case checks that a program's
printed time plays no part). Run by CTest (label kit); needs PYTHONPATH=kit/python.
"""
import copy
import pathlib
import sys
import tempfile
import unittest

from plab.grade import leaderboard

PERF = {"points": 5, "runs": 5, "full_up_to_ratio": 1.3, "zero_at_ratio": 4,
        "scene": {"n": 1500, "steps": 300}}


def graded(seconds, score=5.0, reference=1.0):
    """A results.json's data with a stage 03 performance test, its measured time and its ratio
    to the reference's time in the same grading (None: a results.json from before the ratio)."""
    board = [leaderboard.entry("03", seconds)]
    if reference is not None:
        board.append(leaderboard.ratio_entry("03", seconds / reference))
    return {"score": 10 + score, "tests": [
        {"name": "03: correctness", "score": 10, "max_score": 10, "status": "passed", "output": ""},
        {"name": "03: performance", "score": score, "max_score": 5, "status": "passed",
         "output": f"median {seconds:.3f} s against the reference's {reference or 1:.3f} s"}],
        "leaderboard": board}


def perf_score(data):
    return next(t["score"] for t in data["tests"] if t["name"] == "03: performance")


class Leaderboard(unittest.TestCase):
    def setUp(self):
        self.cls = {"fast": graded(0.5), "mid": graded(1.0), "slow": graded(3.0),
                    "broken": {"score": 0, "tests": [
                        {"name": "03: performance", "score": 0, "max_score": 5,
                         "status": "failed", "output": "not timed"}]}}

    def test_entry(self):
        self.assertEqual(leaderboard.entry("03", 0.123456),
                         {"name": "03: time (s)", "value": 0.1235, "order": "asc"})
        self.assertEqual(leaderboard.times(graded(0.25)), {"03": 0.25})

    def test_reference_changes_nothing(self):
        before = copy.deepcopy(self.cls)
        self.assertEqual(leaderboard.rescore(self.cls, dict(PERF, relative="reference")),
                         {"changed": set()})
        self.assertEqual(self.cls, before)

    def test_class_best(self):
        done = leaderboard.rescore(self.cls, dict(PERF, relative="class_best"))
        self.assertEqual(done["changed"], {"fast", "mid", "slow"})
        fast, mid, slow = (perf_score(self.cls[s]) for s in ("fast", "mid", "slow"))
        self.assertEqual(fast, 5)
        self.assertGreater(fast, mid)
        self.assertGreater(mid, slow)
        self.assertEqual(slow, 0)  # 6 times the best: past zero_at_ratio
        self.assertEqual(self.cls["mid"]["score"], 10 + mid)  # the total follows
        self.assertEqual(perf_score(self.cls["broken"]), 0)
        again = copy.deepcopy(self.cls)  # rescoring twice (a resumed class) says the same
        leaderboard.rescore(again, dict(PERF, relative="class_best"))
        self.assertEqual(again, self.cls)
        self.assertEqual(self.cls["mid"]["tests"][1]["output"].count("scored against"), 1)

    def test_curve(self):
        self.cls["tie"] = graded(1.0)
        leaderboard.rescore(self.cls, dict(PERF, relative="curve"))
        got = {s: perf_score(self.cls[s]) for s in ("fast", "mid", "tie", "slow")}
        self.assertEqual(got["fast"], 5)
        self.assertEqual(got["mid"], got["tie"])  # equal times share a rank
        self.assertGreater(got["fast"], got["mid"])
        self.assertGreater(got["mid"], got["slow"])

    def test_ranked_by_ratio(self):
        # "busy" was graded on a loaded machine: its time is the slower, its ratio the better
        cls = {"busy": graded(1.4, reference=1.4), "quiet": graded(1.1, reference=1.0)}
        leaderboard.rescore(cls, dict(PERF, relative="curve"))
        self.assertEqual(perf_score(cls["busy"]), 5)
        self.assertLess(perf_score(cls["quiet"]), 5)
        self.assertIn("by the time over the reference's): 1.000 x, rank 1 of 2",
                      cls["busy"]["tests"][1]["output"])

    def test_times_without_ratios(self):
        # a results.json from before the ratio: the class falls back to the times
        cls = {"busy": graded(1.4, reference=1.4), "old": graded(1.1, reference=None)}
        leaderboard.rescore(cls, dict(PERF, relative="curve"))
        self.assertEqual(perf_score(cls["old"]), 5)
        self.assertIn("by the time): 1.100 s, rank 1 of 2", cls["old"]["tests"][1]["output"])

    def test_unknown_mode(self):
        with self.assertRaises(ValueError):
            leaderboard.rescore(self.cls, dict(PERF, relative="fastest"))

    def test_page(self):
        with tempfile.TemporaryDirectory() as d:
            page = pathlib.Path(d) / "leaderboard.html"
            leaderboard.write_page(page, {"anon-1a2b": graded(0.5), "anon-3c4d": graded(3.0),
                                          "anon-5e6f": self.cls["broken"]}, PERF)
            text = page.read_text()
        self.assertIn("anon-1a2b", text)
        self.assertLess(text.index("anon-1a2b"), text.index("anon-3c4d"))  # fastest first
        with tempfile.TemporaryDirectory() as d:  # ranked by the ratio, not the time
            page = pathlib.Path(d) / "leaderboard.html"
            leaderboard.write_page(page, {"anon-busy": graded(1.4, reference=1.4),
                                          "anon-quiet": graded(1.1, reference=1.0)}, PERF)
            text = page.read_text()
        self.assertLess(text.index("anon-busy"), text.index("anon-quiet"))
        self.assertIn("<td>1.000</td><td>1.400</td>", text)
        self.assertNotIn("anon-5e6f", text)  # never timed: not on the board
        for remote in ("http:", "https:", "<script", "<link", "src=", "@import"):
            self.assertNotIn(remote, text)


if __name__ == "__main__":
    sys.exit(unittest.main())
