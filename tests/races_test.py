#!/usr/bin/env python3
"""Unit test of plab.grade.races's first_race() on a real TSan report (tests/tsan/).

mutant03-report.txt: the stderr of stage 03's solution with `found[0]` in place of
`found[omp_get_thread_num()]` (tests/tsan_mutant_check.py's mutant), clang 14, libomp + Archer,
three threads, on dense-box.in. Usage: races_test.py [SOURCE_DIR]
"""
import pathlib
import sys
import unittest

SOURCE_DIR = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else
                          pathlib.Path(__file__).resolve().parent.parent)
from plab.grade import races  # noqa: E402  (PYTHONPATH=kit/python: CTest sets it)

REPORT = (SOURCE_DIR / "tests" / "tsan" / "mutant03-report.txt").read_text()


class FirstRace(unittest.TestCase):
    def test_student_file_preferred_over_library_headers(self):
        self.assertEqual(races.first_race(REPORT, ["step.cpp"]),
                         "data race at step.cpp:38 (read) against step.cpp:38 (write) in thread T1")

    def test_path_suffix_names_match(self):
        self.assertEqual(races.first_race(REPORT, ["kit/src/driver.cpp"]),
                         "data race at step.cpp:38 (read) against driver.cpp:108 (write) in thread T1")
        # A suffix matches whole path components only: "ver.cpp" is not driver.cpp.
        self.assertEqual(races.first_race(REPORT, ["ver.cpp"]),
                         "data race at step.cpp:38 (read) against step.cpp:38 (write) in thread T1")

    def test_without_student_files_the_first_frame_outside_system_headers(self):
        # The top frames are in /usr/.../vector.tcc; the first of the program's own is step.cpp.
        self.assertEqual(races.first_race(REPORT, []),
                         "data race at step.cpp:38 (read) against step.cpp:38 (write) in thread T1")

    def test_kit_file_named(self):
        # Only the previous access's stack reaches the kit's driver.cpp.
        self.assertEqual(races.first_race(REPORT, ["driver.cpp"]),
                         "data race at step.cpp:38 (read) against driver.cpp:108 (write) in thread T1")

    def test_no_race(self):
        self.assertIsNone(races.first_race("", ["step.cpp"]))
        self.assertIsNone(races.first_race("[  PASSED  ] 29 tests.\n", ["step.cpp"]))

    def test_main_thread_named(self):
        text = REPORT.replace("by thread T1:", "by main thread:", 1)
        self.assertTrue(races.first_race(text, ["step.cpp"]).endswith("in the main thread"))


class Location(unittest.TestCase):
    def test_heap_block_of_the_report(self):
        self.assertTrue(races.race_location(REPORT).startswith(
            "an element of 8 bytes of a block of 72 bytes on the heap"))

    def test_a_flag_on_the_main_threads_stack(self):
        # A shared bool written by every thread (a missing reduction): the access's line may be
        # the region's pragma, the location says what the variable is
        text = ("WARNING: ThreadSanitizer: data race (pid=1)\n"
                "  Write of size 1 at 0x7ffc by main thread:\n"
                "    #0 .omp_outlined. step.cpp:60:1 (p+0x1)\n\n"
                "  Previous write of size 1 at 0x7ffc by thread T2:\n"
                "    #0 .omp_outlined. step.cpp:60:1 (p+0x1)\n\n"
                "  Location is stack of main thread.\n\n"
                "SUMMARY: ThreadSanitizer: data race step.cpp:60:1 in .omp_outlined.\n")
        self.assertTrue(races.race_location(text).startswith(
            "a local variable of 1 byte on the main thread's stack"))
        self.assertIn("reduction", races.race_location(text))

    def test_global_and_none(self):
        text = ("WARNING: ThreadSanitizer: data race (pid=1)\n"
                "  Read of size 4 at 0x55 by thread T1:\n"
                "  Location is global 'counter' of size 4 at 0x55 (p+0x5)\n")
        self.assertEqual(races.race_location(text), "the global variable 'counter' of 4 bytes")
        self.assertIsNone(races.race_location("no race here\n"))


class Summary(unittest.TestCase):
    def test_an_error_before_any_race(self):
        # What the grader's self-test saw: the race mutant's shared vector corrupted under TSan,
        # the next allocation too big, and no race named first.
        text = ("==2==ERROR: ThreadSanitizer: requested allocation size 0xfffffffffffffff8 ...\n"
                "SUMMARY: ThreadSanitizer: allocation-size-too-big (/plab/stage+0xd94d6) "
                "(BuildId: f00d9abc7bac9ae41ccdee5e7d480d747bac025c) in operator new(unsigned long)\n")
        self.assertEqual(races.tsan_summary(text),
                         "ThreadSanitizer: allocation-size-too-big in operator new(unsigned long)")
        self.assertIsNone(races.first_race(text, ["step.cpp"]))

    def test_none_without_a_summary(self):
        self.assertIsNone(races.tsan_summary("Segmentation fault\n"))


class Environment(unittest.TestCase):
    def test_env_stops_at_first_race_with_the_exit_code(self):
        env = races.tsan_env()
        self.assertIn("halt_on_error=1", env["TSAN_OPTIONS"])
        self.assertIn(f"exitcode={races.TSAN_EXIT_CODE}", env["TSAN_OPTIONS"])
        self.assertGreaterEqual(int(env["OMP_NUM_THREADS"]), 2)
        self.assertIn("-DPLAB_SANITIZE=thread", races.TSAN_CMAKE_ARGS)


if __name__ == "__main__":
    unittest.main(verbosity=2)
