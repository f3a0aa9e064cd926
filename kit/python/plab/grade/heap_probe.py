"""Stage 02's heap (its exercises 1 to 3), measured outside the student's code.

The golden files compare bits, and any priority queue, or a scan of the candidates for their
least, gives the same bits as a heap. So the kit measures twice:

- **The heap alone** (judge()): a probe of the kit's own (kit/grade/probes/heap_probe.cpp,
  compiled beside the student's heap.hpp) drives the step's own type, MinHeap<model::Event,
  plab::EventOrder>, through the handout's example and a long random run of pushes and pops of
  events, and what it prints is compared with what the same probe prints of the kit's own heap:
  each pop the earliest event in (checked here), the heap order of every array it prints, the
  binary heap's array every 2000 operations (a sorted array, a scan, a list leave others), and the
  comparisons EventOrder counted and traced: as many, and the same pairs in the same order.
  libstdc++'s std::pop_heap (Floyd's way: the hole sunk to a leaf, the last item moved up) leaves
  the same arrays with fewer comparisons (152 821 against 213 158 on one run); a red team padded
  it to the exact count (its pairs are not the binary heap's: the trace tells); CLRS's
  MIN-HEAPIFY builds the same heap by other comparisons (told apart, and named).
- **The step** (judge_step()): the runner reports EventOrder's count and trace for a run of the
  stage (`--report`: order_comparisons, order_trace), which must be the kit's solution's on the
  same scene: the given candidates pushed in the given order into the student's heap, every event
  popped. A red team's step that sorted, scanned or kept a set while the probe saw a heap (told
  apart by a compiler flag or the probe's file name) failed here.

The heap alone is compared with a summary (summary(): the example's arrays, digests of the arrays
and of the pops, the comparisons and their trace). The grader makes it on each grading's seed
from the kit's solution (grade_probe(), the student's probe compiled and run in its sandbox) and
runs the step on its idea scene; the local test stage02.IMPL.Heap (`python3 -m
plab.grade.heap_probe PROBE --program ... --reference ... --scene ...`) reads the summary of a
fixed seed from kit/grade/probes/heap_probe.expected.json (tests/heap_probe_check.py keeps it the
kit's solution's) and runs the student's stage and the kit's (the reference program in a
student's copy) on one scene. Nothing here holds a heap.
"""
import bisect
import hashlib
import json
import math
import pathlib
import subprocess
import sys

#: The probe's source, in the kit.
PROBE = "kit/grade/probes/heap_probe.cpp"
#: The summary of the local test's run (seed, operations) of the kit's own heap.
EXPECTED = "kit/grade/probes/heap_probe.expected.json"

#: What the handout's example must leave: events at 5, 3, 8, 1 pushed; then one pop (times).
EXAMPLE = {"example-push": [1.0, 3.0, 8.0, 5.0], "example-pop": [3.0, 5.0, 8.0]}

MASK = 2**64 - 1

RULE = ("push: the new item at the end, then swapped with its parent ((k - 1) / 2) while it is "
        "less; pop: the last item in the root's place, then swapped with its lesser child while "
        "that child is less")


def digest(numbers):
    return hashlib.sha256(" ".join(map(repr, numbers)).encode()).hexdigest()[:16]


def parse(text):
    """The probe's output as {"example-push": [...], "example-pop": [...], "pops": [...],
    "layouts": {ops: [...]}, "comparisons": [all, pushes, their comparisons, pops, theirs,
    largest] or None} (times as floats); raises ValueError on a line that is not the probe's."""
    got = {"pops": [], "layouts": {}, "comparisons": None}
    for line in text.splitlines():
        words = line.split()
        if not words:
            continue
        try:
            if words[0] in EXAMPLE:
                got[words[0]] = [float.fromhex(w) for w in words[1:]]
            elif words[0] == "pop" and len(words) == 2:
                got["pops"].append(float.fromhex(words[1]))
            elif words[0] == "layout" and len(words) >= 2:
                got["layouts"][int(words[1])] = [float.fromhex(w) for w in words[2:]]
            elif words[0] == "comparisons" and len(words) == 8:
                got["comparisons"] = [int(w) for w in words[1:7]]
                got["trace"] = words[7]
            else:
                raise ValueError(line)
        except ValueError:
            raise ValueError(f"the heap probe printed {line[:80]!r}") from None
    return got


def summary(parsed, seed, ops):
    """What a run is compared with: the example's arrays, each checkpoint's array digest, the
    pops' digest and the comparisons (of the kit's own heap)."""
    return {"seed": seed, "ops": ops, **{k: parsed.get(k) for k in EXAMPLE},
            "layouts": {str(k): digest(v) for k, v in sorted(parsed["layouts"].items())},
            "pops": digest(parsed["pops"]), "comparisons": parsed["comparisons"],
            "trace": parsed.get("trace")}


def events(seed, ops):
    """The run's operations, as the probe makes them: an event (t, kind, lo, hi) to push, or None
    for a pop (heap_probe.cpp's next_event(); model.md's key order is the tuples' order)."""
    state, size, out = seed & MASK, 0, []
    for _ in range(ops):
        state = (state * 6364136223846793005 + 1442695040888963407) & MASK
        if size == 0 or (state >> 33) % 3 != 0:
            t = (state >> 11) * 2.0**-53
            lo = (state >> 3) % 4999
            if (state >> 2) & 1:
                out.append((t, 0, lo, lo))
            else:
                out.append((t, 1, lo, lo + 1 + (state >> 40) % (4999 - lo)))
            size += 1
        else:
            out.append(None)
            size -= 1
    return out


def judge(text, want, hint=""):
    """(problem or None, what was measured) for the probe's stdout `text`, against `want` (the
    summary() of the kit's own heap on the same seed and operations)."""
    try:
        got = parse(text)
    except ValueError as e:
        return f"{e}, not the probe's lines", ""
    show = lambda v: "[" + ", ".join(f"{x:g}" for x in v) + "]"  # noqa: E731
    for head, example in EXAMPLE.items():
        if head not in got:
            return f"the heap probe printed no {head} line (did it end early?)", ""
        if got[head] != example:
            what = "pushing events at times 5, 3, 8, 1" if head == "example-push" else \
                "pushing events at times 5, 3, 8, 1 and popping once"
            return (f"after {what}, items() holds the times {show(got[head])}; a binary heap's "
                    f"array is {show(example)} ({RULE}). {hint}").strip(), ""
    seed, ops = want["seed"], want["ops"]
    for at, items in sorted(got["layouts"].items()):  # the heap's order itself, where it broke
        k = next((k for k in range(1, len(items)) if items[k] < items[(k - 1) // 2]), None)
        if k is not None:
            return (f"in a run of {ops} random pushes and pops, after {at} operations items()[{k}] "
                    f"(t = {items[k]!r}) is earlier than its parent items()[{(k - 1) // 2}] "
                    f"(t = {items[(k - 1) // 2]!r}): the array is out of heap order (the parent of "
                    f"k is (k - 1) / 2, its children 2k + 1 and 2k + 2). {hint}").strip(), ""
    inside, pops = [], iter(got["pops"])  # each pop must take the least item in
    for k, event in enumerate(events(seed, ops)):
        if event is not None:
            bisect.insort(inside, event)
            continue
        mine = next(pops, None)
        if mine is None:
            return (f"the heap probe's run ended early (at operation {k + 1} of {ops}: no pop "
                    "printed)"), ""
        if mine != inside[0][0]:
            return (f"in a run of {ops} random pushes and pops, operation {k + 1} (a pop, with "
                    f"{len(inside)} items in) took the event at t = {mine!r} where the earliest "
                    f"was at t = {inside[0][0]!r}: top() is not the least (a push or an "
                    f"earlier pop left the array out of order). {hint}").strip(), ""
        inside.pop(0)
    if got["comparisons"] is None:
        return "the heap probe's run ended early (no comparison count)", ""
    for at, want_digest in want["layouts"].items():
        mine = got["layouts"].get(int(at))
        if mine is None:
            return f"the heap probe printed no array after {at} operations", ""
        if digest(mine) != want_digest:
            return (f"in a run of {ops} random pushes and pops, the right items come out, but "
                    f"after {at} operations items() is not the binary heap's array: not its "
                    f"moves ({RULE}; a sorted array, a scan or a list leave other arrays). "
                    f"{hint}").strip(), ""
    total, pushes, push_c, npops, pop_c, largest = got["comparisons"]
    kit = want["comparisons"][0]
    text = (f"the heap: the example and {ops} random pushes and pops leave a binary heap's "
            f"arrays, with {total} comparisons (the kit's heap: {kit}): "
            f"{push_c / max(1, pushes):.1f} a push, {pop_c / max(1, npops):.1f} a pop, the heap "
            f"up to {largest} items (log2 {math.log2(max(2, largest)):.1f})")
    if total < kit:  # the same arrays with fewer: another algorithm's moves
        return (f"{text}: fewer than the binary heap's moves make, so its pops are not those "
                f"moves (the library's std::pop_heap sinks the hole to the bottom first: the "
                f"heap is the exercise, not a library's). {hint}").strip(), text
    if total > kit:
        return (f"{text}: {total - kit} more than the binary heap's moves need (each level a "
                f"push climbs costs one comparison, and one stops it; each level a pop sinks "
                f"costs two, one to pick the lesser child, one to compare it; a comparison "
                f"beyond these, or a library heap padded with some, is not these moves). "
                f"{hint}").strip(), text
    if got.get("trace") != want.get("trace"):  # as many, but not the same events compared
        return (f"{text}, but not the comparisons of the binary heap's moves: other pairs "
                f"compared, or in another order. A push compares the new item with its parent "
                f"(either way round); a pop compares the two children, then the lesser with the "
                f"sinking item (comparing the item with each child in turn, as CLRS's "
                f"MIN-HEAPIFY does, builds the same heap by other comparisons; handout 02 asks "
                f"for these). {hint}").strip(), text
    return None, text


def judge_step(mine, theirs, hint=""):
    """(problem or None, what was measured) for the step's own heap: `mine`, the text of the
    stage's report of a run (its order_comparisons and order_trace: every comparison its step
    asked plab::EventOrder for, in order), against `theirs`, the path or text of the kit's own
    solution's report of the same scene. The same candidates pushed in the given order into a
    binary heap and popped one by one, as the kit's step does, compare the same events in the
    same order; a step that sorts, scans or keeps a set, or a heap that is not the binary heap
    in the step (whatever it was when probed), does not."""
    try:
        mine = json.loads(mine or "")
        theirs = json.loads(pathlib.Path(theirs).read_text() if isinstance(theirs, pathlib.Path)
                            else theirs)
        count, trace = int(mine["order_comparisons"]), str(mine["order_trace"])
        kit_count, kit_trace = int(theirs["order_comparisons"]), str(theirs["order_trace"])
    except (OSError, TypeError, ValueError, KeyError) as e:
        return f"its run left no report of its heap's comparisons ({e})", ""
    text = f"its step's heap: {count} comparisons through plab::EventOrder (the kit's: {kit_count})"
    if (count, trace) != (kit_count, kit_trace):
        why = ("none: the step does not order a heap with plab::EventOrder" if count == 0 else
               "the same number, other events compared" if count == kit_count else
               f"{count - kit_count:+d}")
        return (f"{text}, {why}: the step's events must come from your MinHeap, every given "
                f"candidate pushed in the given order and every event popped (a sort, a scan, "
                f"a set or another heap in the step compares other events, or as many in "
                f"another order). {hint}").strip(), text
    return None, f"{text}, the same events in the same order"


def run_probe(probe, seed, ops, timeout=60):
    """(stdout, problem or None) of the probe program run here (the local test, and the grader's
    run of the kit's own heap)."""
    try:
        done = subprocess.run([str(probe), str(seed), str(ops)], capture_output=True, text=True,
                              timeout=timeout)
    except subprocess.TimeoutExpired:
        return "", (f"the heap probe ({ops} pushes and pops) did not end in {timeout} s: a push "
                    "or pop that never ends?")
    if done.returncode != 0:
        past = " (an index past the array's end)" if "__n < this->size()" in done.stderr else ""
        return done.stdout, (f"the heap probe stopped (exit {done.returncode}){past}: "
                             f"{done.stderr.strip()[-400:] or 'no message'}")
    return done.stdout, None


def compiler_command(cxx, include, stage_dir, out):
    """The probe compiled beside the stage's heap.hpp in `stage_dir` (the stage build's own flags
    and definitions, cmake/PlabStage.cmake: a header cannot tell the probe from the stage), with
    the kit's EventOrder tallies (kit/src/tallies.cpp, beside `include`)."""
    # _GLIBCXX_ASSERTIONS: a read past the array's end (a child's bound off by one) stops the
    # probe with the library's message, where it would read a stale copy and pass
    return [str(cxx), "-std=c++17", "-O2", "-DNDEBUG", "-D_GLIBCXX_ASSERTIONS",
            '-DPLAB_STAGE_ID="02"',
            "-DPLAB_STAGE_NUMBER=2", "-I", str(stage_dir), "-I", str(include),
            f"{stage_dir}/heap_probe.cpp",
            str(pathlib.Path(include).parent / "src" / "tallies.cpp"), "-o", str(out)]


def grade_probe(g, st, idea):
    """Stage 02's heap measured by the grader `g`: the probe compiled and run in its sandbox beside
    the student's heap.hpp on the grading's seed, judged against the same probe of the kit's own
    heap (solutions/02-heap/heap.hpp, compiled and run outside: the kit's code). Returns (problem
    or None, what was measured)."""
    import shutil
    import tempfile
    ops = int(idea["heap_probe"].get("ops", 20000))
    seed = (g.seed * 31 + 2) % 2**32
    cxx, src, probe_dir = g.probe_beside(st, "CXX", "heap_probe.cpp",
                                         (g.kit / PROBE).read_text())
    if cxx is None:
        return "the kit's build names no C++ compiler to compile the heap probe with", ""
    folder = next((src / "stages").glob(f"{st.sid}-*"))
    # The kit's own heap, here
    with tempfile.TemporaryDirectory(prefix="plab-heap-") as tmp:
        tmp = pathlib.Path(tmp)
        shutil.copyfile(g.kit / "solutions" / folder.name / "heap.hpp", tmp / "heap.hpp")
        shutil.copyfile(g.kit / PROBE, tmp / "heap_probe.cpp")
        made = subprocess.run(compiler_command(cxx, g.kit / "kit" / "include", tmp, tmp / "probe"),
                              capture_output=True, text=True)
        if made.returncode != 0:
            raise RuntimeError(f"the kit's heap probe did not compile: {made.stderr[-600:]}")
        out, problem = run_probe(tmp / "probe", seed, ops)
        if problem:
            raise RuntimeError(f"the kit's own heap failed its probe: {problem}")
        want = summary(parse(out), seed, ops)
    # The student's, in the sandbox: compiled there (a header is the student's code) and run there
    cmd = compiler_command(cxx, "/plab/src/kit/include", "/plab/probe", "/plab/probe/probe")
    problem = g.compile_probe(cmd, src, probe_dir, "MinHeap (heap.hpp)")
    if problem:
        return problem, ""
    run = g.sandbox.run(["/plab/probe/probe", str(seed), str(ops)], {"/plab/probe": probe_dir}, {},
                        "/plab/probe", 60, 2**26)
    text = pathlib.Path(run.stdout).read_text(errors="replace")
    if run.rc != 0 or run.reason:
        past = " (an index past the array's end)" if "__n < this->size()" in run.stderr else ""
        return (f"the grader's probe of MinHeap (heap.hpp) stopped{past}: "
                f"{run.reason or ('exit ' + str(run.rc))}: {run.stderr.strip()[-300:]}"), ""
    return judge(text, want, idea.get("hint", ""))


def main():
    """`python3 -m plab.grade.heap_probe PROBE [--program STAGE --reference KIT_STAGE --scene S]`:
    the local test (stageNN.IMPL.Heap): the probe against the kit's summary of its own heap
    (EXPECTED), then, given the stage's program and the kit's (the reference program in a
    student's copy), the step's own heap comparisons on SCENE against the kit's. With
    `--write-expected`, writes EXPECTED from PROBE (the kit's solution's:
    tests/heap_probe_check.py)."""
    import argparse
    ap = argparse.ArgumentParser(prog="python3 -m plab.grade.heap_probe")
    ap.add_argument("probe")
    ap.add_argument("--program", help="the stage's program (plab-run-02-student)")
    ap.add_argument("--reference", help="the kit's stage 02 program (its solution's, compiled)")
    ap.add_argument("--scene", help="the scene both run (3 steps)")
    ap.add_argument("--write-expected", action="store_true")
    a = ap.parse_args()
    kit = pathlib.Path(__file__).resolve().parents[4]
    expected = kit / EXPECTED
    if a.write_expected:
        out, problem = run_probe(a.probe, 2019, 20000)
        if problem:
            sys.exit(f"FAILED: {problem}")
        expected.write_text(json.dumps(summary(parse(out), 2019, 20000), indent=1) + "\n")
        print(f"wrote {expected}")
        return
    hint = "(handout 02, exercises 1 to 3; the grader runs the same checks on scenes of its own)"
    want = json.loads(expected.read_text())
    out, problem = run_probe(a.probe, want["seed"], want["ops"])
    if problem is None:
        problem, text = judge(out, want, hint)
    if problem is None and a.program and a.reference and a.scene:
        import tempfile
        reports = []
        with tempfile.TemporaryDirectory(prefix="plab-heap-step-") as tmp:
            for k, program in enumerate((a.program, a.reference)):
                report = pathlib.Path(tmp) / f"report-{k}.json"
                done = subprocess.run([program, a.scene, "--steps", "3", "--quiet", "--out",
                                       "/dev/null", "--report", str(report)],
                                      capture_output=True, text=True, timeout=300)
                if done.returncode != 0:
                    sys.exit(f"FAILED: {program} on {a.scene} (3 steps) exited {done.returncode}: "
                             f"{done.stderr.strip()[-400:]}")
                reports.append(report.read_text())
        problem, measured = judge_step(reports[0], reports[1], hint)
        text += f"; on {pathlib.Path(a.scene).name}, 3 steps: {measured}"
    if problem:
        sys.exit(f"FAILED: {problem}")
    print(f"passed: {text}")


if __name__ == "__main__":
    main()
