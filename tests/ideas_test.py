#!/usr/bin/env python3
"""Unit test of plab.grade.ideas' bytes check (stage 08's idea: every rank steps its own slab):
the bytes the kit's MPI layer counted, against the rubric's most, and none at all (ranks that
never worked together: rank 0 stepping alone while the others idle or spin).

  ideas_test.py   (PYTHONPATH=kit/python: CTest sets it)
"""
import json
import unittest

from plab.grade.ideas import Ideas

IDEA = {"scene": {"n": 1000, "steps": 10}, "max_bytes_per_particle_step": 20,
        "hint": "each rank must step its own slab"}


class Run:
    """What bytes_sent() reads of a graded run: its report.json."""

    def __init__(self, report):
        self.report = report

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

    def test_nothing_sent_fails(self):
        problem, _ = check(0.0)
        self.assertIsNotNone(problem)
        self.assertIn("sent each other nothing", problem)

    def test_everything_sent_fails(self):
        problem, _ = check(75.0 * 1000 * 10)
        self.assertIn("75.0 bytes a particle and step (at most 20", problem)

    def test_no_report_fails(self):
        problem, _ = Ideas.bytes_sent(None, IDEA, Run(""), "ran")
        self.assertIn("left no report", problem)


if __name__ == "__main__":
    unittest.main()
