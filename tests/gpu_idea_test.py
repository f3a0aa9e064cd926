#!/usr/bin/env python3
"""Unit test of plab.grade.gpu_idea's verdicts on a GPU trace, without a GPU: the overlap of two
streams (stage 05), and stage 04's device memory (nothing left allocated at exit, nothing
managed; a trace without memory records is not held against the stage). The traces are written
here in the trace library's format (kit/gputrace/trace.cpp); tests/grader_redteam.py's gpu-ideas
case checks the same verdicts on real runs, on a GPU. Run by CTest (label kit); needs
PYTHONPATH=kit/python.
"""
import unittest

from plab.grade import gpu_idea

IDEA = {"max_live_device_bytes": 0, "hint": "the hint",
        "scene": {"n": 100, "steps": 10}}


def trace(allocations=14, live=0, live_bytes=0, managed=0):
    return {"kernels": 50, "kernel_ns": 1000, "copies": {"htod": 4800, "dtoh": 4800},
            "streams": {"7": {}}, "intervals": [],
            "memory": {"allocations": allocations, "allocated_bytes": 10**6, "frees": 14 - live,
                       "live": live, "live_bytes": live_bytes, "managed_bytes": managed}}


def verdict(mine):
    return gpu_idea.judge(None, None, None, None, IDEA, mine, trace(), 10, "", None)


class Memory(unittest.TestCase):
    def test_everything_freed_passes(self):
        self.assertIsNone(verdict(trace()))

    def test_left_allocated_fails_with_the_numbers(self):
        problem = verdict(trace(live=6, live_bytes=4800))
        self.assertIn("left 4800 bytes of device memory allocated at exit", problem)
        self.assertIn("6 of its 14 allocations", problem)
        self.assertIn("the hint", problem)

    def test_managed_memory_fails(self):
        self.assertIn("managed memory", verdict(trace(managed=800)))

    def test_no_memory_records_is_not_held_against_it(self):
        self.assertIsNone(verdict(trace(allocations=0, live=0)))

    def test_summary_names_the_memory(self):
        self.assertIn("0 B left allocated at exit", gpu_idea.summary(trace()))


class Overlap(unittest.TestCase):
    def test_two_streams_at_once(self):
        # stream 1 runs 0-10; stream 2 starts at 5 (beside it) and at 20 (alone)
        ns, starts = gpu_idea.overlap([[0, 1, 0, 10], [0, 2, 5, 12], [0, 2, 20, 30]])
        self.assertEqual((ns, starts), (5, 1))

    def test_one_stream_never_overlaps(self):
        self.assertEqual(gpu_idea.overlap([[0, 1, 0, 10], [0, 1, 5, 12]]), (0, 0))


if __name__ == "__main__":
    unittest.main()
