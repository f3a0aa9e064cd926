#!/usr/bin/env python3
"""Checks stage 02's heap probe (plab.grade.heap_probe): the local test's stored summary
(kit/grade/probes/heap_probe.expected.json) is the kit's own heap's, and the shortcuts a student
could take for the heap each fail it, with a message that names what is wrong: a library heap
(std::push_heap / std::pop_heap: the same arrays with fewer comparisons), the same padded with
dummy comparisons (more than the binary heap's moves: a student trial's shortcut), a sorted array, an
unsorted array whose least is kept in front (a scan per pop), a pop that sinks towards the greater
child, and a push that moves the new item up one level at most. Run by CTest (label kit; the
instructor's copy: it reads solutions/).

  heap_probe_check.py CXX KIT_SOURCE SOLUTION_PROBE SCRATCH_DIR
"""
import json
import pathlib
import shutil
import subprocess
import sys

cxx, kit, solution_probe, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), sys.argv[3], \
    pathlib.Path(sys.argv[4])
sys.path.insert(0, str(kit / "kit" / "python"))
from plab.grade import heap_probe  # noqa: E402

shutil.rmtree(scratch, ignore_errors=True)
scratch.mkdir(parents=True)
want = json.loads((kit / heap_probe.EXPECTED).read_text())
out, problem = heap_probe.run_probe(solution_probe, want["seed"], want["ops"])
assert problem is None, problem
assert heap_probe.summary(heap_probe.parse(out), want["seed"], want["ops"]) == want, \
    f"{heap_probe.EXPECTED} is not the kit's heap's summary: run python3 -m plab.grade.heap_probe " \
    "build/bin/plab-heap-probe-02-solution --write-expected"
assert heap_probe.judge(out, want)[0] is None, heap_probe.judge(out, want)
# The probe's heap is the step's own type: what the step uses is what is measured
probe_text = (kit / heap_probe.PROBE).read_text()
assert "plab::MinHeap<plab::model::Event, plab::EventOrder>" in probe_text
assert "MinHeap<model::Event, EventOrder> heap;" in (kit / "stages/02-heap/step.cpp").read_text()

from heap_shortcuts import honest_heaps, shortcut_heaps  # noqa: E402  (beside this file)


def probe_problem(name, text):
    """The probe's verdict (problem or None) on heap.hpp written as `text`, compiled and run in a
    scratch folder of its own."""
    folder = scratch / "".join(c if c.isalnum() else "-" for c in name)
    folder.mkdir()
    (folder / "heap.hpp").write_text(text)
    shutil.copyfile(kit / heap_probe.PROBE, folder / "heap_probe.cpp")
    made = subprocess.run(heap_probe.compiler_command(cxx, kit / "kit" / "include", folder,
                                                      folder / "probe"),
                          capture_output=True, text=True)
    assert made.returncode == 0, f"{name}: did not compile:\n{made.stderr[-2000:]}"
    out, problem = heap_probe.run_probe(folder / "probe", want["seed"], want["ops"])
    return problem or heap_probe.judge(out, want)[0]


solved = (kit / "solutions" / "02-heap" / "heap.hpp").read_text()
shortcuts = shortcut_heaps(solved)
for name, (text, said) in shortcuts.items():
    problem = probe_problem(name, text)
    assert problem and said in problem, f"{name}: {problem!r} (expected it to say {said!r})"
    print(f"{name}: fails: {problem[:110]}...")
for name, text in honest_heaps(solved).items():
    problem = probe_problem(name, text)
    assert problem is None, f"an honest heap ({name}) fails the probe: {problem}"
    print(f"{name}: passes (honest)")
shutil.rmtree(scratch)
print(f"heap probe: the kit's heap passes ({want['comparisons'][0]} comparisons), "
      f"{len(shortcuts)} shortcuts fail")
