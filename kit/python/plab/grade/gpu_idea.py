"""The GPU stages' idea tests (rubric: a GPU entry's "idea" of kind "gpu"), measured outside the
student's code by the kit's GPU trace (kit/gputrace/trace.cpp: a CUPTI injection library that
the CUDA driver loads into the stage's program through CUDA_INJECTION64_PATH and that writes
every kernel, copy and memset it saw, with its stream and device times, as JSON).

Each test generates a hidden scene from the grading's seed, runs the kit's solution of the stage
on it (traced: its time and device work are the yardstick) and the student's program in the
sandbox (traced), and requires the reference's output. Then, by the entry's keys:
  min_kernels_per_step             kernels launched a step (stage 04: the step runs as kernels);
  max_copy_bytes_per_particle_step bytes copied between host and device a particle and step
                                   (stage 04: the state stays on the device between steps; a
                                   program that steps on the host copies 48 or more);
  min_kernel_share                 the program's kernel time against the solution's (the
                                   kernels do the step's work, not a token launch);
  max_live_device_bytes            device memory the program left allocated at exit (stage 04:
                                   exercise 1's cudaFree of every field), and none managed
                                   (cudaMallocManaged is not the exercise);
  min_overlap_share                steps in which two kernels or copies ran at the same time on
                                   different streams (stage 05's streams), and none with
                                   `--off` `off_run` (the stepper's switch turns them off);
  branchless                       {"hint": ...}: the student's BranchlessWall, compiled by the
                                   grader's probe to PTX in the sandbox, leaves no more
                                   conditional branches than the model's wall times alone
                                   (stage 05's branchless wall; branches.py);
  seconds, multiple                the time limit: max(seconds, multiple x the solution's time)
                                   (stage 06's GPU path: a scene too large for O(N^2) pairs).
A failure takes the entry's correctness points (Grader.add_correctness). Without a GPU the whole
entry is skipped (Grader.grade says so); without the trace library (a toolkit without CUPTI) the
test says that it could not measure and is not held against the stage.
"""
import json
import os
import pathlib
import shutil
import subprocess
import time

from plab.grade import branches
from plab.grade.build import unbuilt

#: The trace library's name in the kit's build (kit/CMakeLists.txt: plab_gputrace).
LIBRARY = "libplab_gputrace.so"


def library(kit_build):
    """The kit's GPU trace library, or None when the kit was built without CUPTI."""
    path = pathlib.Path(kit_build) / "bin" / LIBRARY
    return path if path.is_file() else None


def read_trace(text):
    """The trace's JSON (a dict), or None when there is none or it is not the trace's."""
    try:
        doc = json.loads(text or "")
    except ValueError:
        return None
    return doc if isinstance(doc, dict) and "kernels" in doc and "intervals" in doc else None


def overlap(intervals):
    """(ns during which activities of two or more streams ran at once, the number of activities
    that started while one of another stream was running) over [[kind, stream, start, end], ...]."""
    events = []
    for _, stream, start, end in intervals:
        if end > start:
            events.append((start, 1, stream))
            events.append((end, 0, stream))  # at the same instant, ends come first
    events.sort()
    active, streams, overlapped, starts, last = {}, 0, 0, 0, None
    for t, is_start, stream in events:
        if last is not None and streams >= 2:
            overlapped += t - last
        last = t
        if is_start:
            if any(k != stream and v > 0 for k, v in active.items()):
                starts += 1
            active[stream] = active.get(stream, 0) + 1
        else:
            active[stream] -= 1
        streams = sum(1 for v in active.values() if v > 0)
    return overlapped, starts


def summary(doc):
    """One line of what a trace saw."""
    copies = doc["copies"]
    return (f"{doc['kernels']} kernels ({doc['kernel_ns'] / 1e6:.1f} ms on the device), copies "
            f"{copies['htod']} B to and {copies['dtoh']} B from the device, "
            f"{len(doc['streams'])} stream(s)" + (
                f", {doc['memory']['allocations']} device allocations, "
                f"{doc['memory']['live_bytes']} B left allocated at exit"
                if "memory" in doc else ""))


def run_own(g, st, scene, out, trace, lib):
    """The kit's solution of the stage on `scene`, traced: (seconds, trace dict or None)."""
    env = dict(os.environ, **st.env)
    if lib:
        env.update(CUDA_INJECTION64_PATH=str(lib), PLAB_GPU_TRACE=str(trace))
    start = time.time()
    r = subprocess.run([g.solution(st.sid), scene, "--quiet", "--out", out], capture_output=True,
                       text=True, env=env)
    seconds = time.time() - start
    if r.returncode != 0:
        raise RuntimeError(f"the kit's solution of stage {st.sid} failed on {scene}: {r.stderr}")
    return seconds, read_trace(trace.read_text()) if lib and trace.exists() else None


def run_traced(g, st, program, scene, limit, expected, lib, off=""):
    """The student's program on `scene` in the sandbox, traced. Returns (Run, trace or None)."""
    env = dict(st.env)
    ro = {}
    if lib:
        shared = g.sandbox.shared_dir("gputrace") / LIBRARY  # readable there, even when the
        if not shared.exists():  # kit's build is private
            shutil.copyfile(lib, shared)
            os.chmod(shared, 0o644)
        ro = {"/plab/gputrace.so": shared}
    args = ["--quiet", "--out", "/plab/out/out.txt", *(("--off", off) if off else ())]
    if lib:
        # Without namespaces the program sees the outside paths: the environment names those.
        env["CUDA_INJECTION64_PATH"] = ("/plab/gputrace.so" if g.sandbox.mode == "bwrap"
                                        else str(shared))
        env["PLAB_GPU_TRACE"] = "trace.json"  # in its working folder: the output folder
    cap = max(g.rubric["limits"]["output_min_mb"] * 2**20, 4 * len(expected))
    run = g.run_program(program, scene, args, limit, cap, st, env=env, extra_ro=ro)
    return run, read_trace(run.read_output("trace.json")) if lib else None


def idea_test(g, st, program, folder):
    """Grader.idea_test for a GPU entry (kind "gpu"): see the module's text. Records the test
    (0 points) and, on failure, g.idea_failed[st.key]."""
    idea = st.idea
    test = f"{st.key}: idea ({idea['what']})"
    if isinstance(program, str):
        g.results.add(test, 0, 0, False, f"not run: {unbuilt(st.sid, program)}")
        g.idea_failed[st.key] = unbuilt(st.sid, program, 1)
        return
    lib = library(g.kit_build)
    scene, what = g.idea_scene(st, folder)
    own_seconds, own = run_own(g, st, scene, folder / "idea.out", folder / "own-trace.json", lib)
    expected = (folder / "idea.out").read_text()
    limit = max(idea.get("seconds", 0), idea.get("multiple", 0) * own_seconds)
    run, mine = run_traced(g, st, program, scene, limit, expected, lib)
    text = f"the {what}: {run.seconds:.2f} s (the kit's solution: {own_seconds:.2f} s)"
    problem = g.idea_run_problem(run, what, limit, own_seconds, expected, idea["hint"])
    if problem is None and lib is None:
        text += ("; NOT MEASURED: the kit was built without its GPU trace (no CUPTI in the CUDA "
                 "toolkit), so the device work is not checked")
    elif problem is None and (mine is None or own is None):
        problem = ("its run left no GPU trace (the kit's trace library records every kernel and "
                   "copy; a program that ends without exit() or hides its CUDA work leaves none)")
    elif problem is None:
        text += f"; its device work: {summary(mine)}; the solution's: {summary(own)}"
        problem = judge(g, st, program, scene, idea, mine, own, limit, expected, lib)
    if "branchless" in idea and not problem:
        problem, measured = branch_probe(g, st, idea["branchless"].get("hint", ""))
        text += f"; {measured}"
    if problem:
        g.idea_failed[st.key] = f"the idea test of stage {st.key} failed: {problem}"
    g.results.add(test, 0, 0, problem is None, problem or text, False, run.seconds)


def judge(g, st, program, scene, idea, mine, own, limit, expected, lib):
    """The entry's measures of a traced run (None when it passes, else what failed)."""
    sc = idea["scene"]
    steps, n = sc["steps"], sc["n"]
    if "min_kernels_per_step" in idea and mine["kernels"] < idea["min_kernels_per_step"] * steps:
        return (f"it launched {mine['kernels']} kernels in {steps} steps (at least "
                f"{idea['min_kernels_per_step']} a step: the step's phases run as kernels). "
                f"{idea['hint']}")
    if "max_copy_bytes_per_particle_step" in idea:
        c = mine["copies"]
        per = (c["htod"] + c["dtoh"]) / (n * steps)
        if per > idea["max_copy_bytes_per_particle_step"]:
            return (f"it copied {per:.1f} bytes a particle and step between host and device (at "
                    f"most {idea['max_copy_bytes_per_particle_step']:g}: the state stays on the "
                    f"device between steps; the solution copies "
                    f"{(own['copies']['htod'] + own['copies']['dtoh']) / (n * steps):.1f}). "
                    f"{idea['hint']}")
    if "min_kernel_share" in idea and own["kernel_ns"] > 0:
        share = mine["kernel_ns"] / own["kernel_ns"]
        if share < idea["min_kernel_share"]:
            return (f"its kernels ran {mine['kernel_ns'] / 1e6:.2f} ms on the device, "
                    f"{100 * share:.0f}% of the solution's {own['kernel_ns'] / 1e6:.2f} ms (at "
                    f"least {100 * idea['min_kernel_share']:.0f}%: the kernels do the step's "
                    f"work). {idea['hint']}")
    if "max_live_device_bytes" in idea:
        m = mine.get("memory")
        if m is None:
            return "its GPU trace has no record of device memory (the kit's trace library is old)"
        # No allocation seen at all: CUPTI gave no memory records here (a GPU stage allocates),
        # so the memory is not measured rather than held against the stage.
        if m["allocations"] and m["managed_bytes"]:
            return (f"it allocated {m['managed_bytes']} bytes of managed memory "
                    f"(cudaMallocManaged): the state lives in device memory (cudaMalloc), copied "
                    f"with cudaMemcpy. {idea['hint']}")
        if m["allocations"] and m["live_bytes"] > idea["max_live_device_bytes"]:
            return (f"it left {m['live_bytes']} bytes of device memory allocated at exit, in "
                    f"{m['live']} of its {m['allocations']} allocations: every cudaMalloc needs "
                    f"its cudaFree (the stepper's destructor frees the state's fields). "
                    f"{idea['hint']}")
    if "min_overlap_share" in idea:
        _, starts = overlap(mine["intervals"])
        if starts < idea["min_overlap_share"] * steps:
            return (f"in {steps} steps, {starts} of its kernels or copies started while another "
                    f"stream's was running (at least {idea['min_overlap_share'] * steps:.0f}: "
                    f"the pair search on a second stream beside the wall times). {idea['hint']}")
        off = idea.get("off_run")
        if off:
            run, traced = run_traced(g, st, program, scene, limit, expected, lib, off)
            if run.reason or run.rc != 0 or traced is None:
                return (f"with --off {off} its run {run.reason or 'exited ' + str(run.rc)} or "
                        f"left no GPU trace: {run.stderr.strip()[-200:]}")
            _, off_starts = overlap(traced["intervals"])
            if off_starts:
                return (f"with --off {off}, {off_starts} of its kernels or copies still started "
                        f"beside another stream's (the switch must turn the second stream "
                        f"off, to measure what it buys). {idea['hint']}")
    return None


def branch_probe(g, st, hint):
    """The grader's probe of the student's branchless wall (branches.py), compiled to PTX in the
    sandbox beside the stage's sources with the nvcc that configured its build. Returns
    (problem or None, what was measured)."""
    nvcc, src, probe_dir = g.probe_beside(st, "CUDA", branches.SOURCE, branches.PROBE)
    if nvcc is None:
        return "the kit's build found no CUDA compiler to compile the branch probe with", ""
    cmd = branches.nvcc_command(nvcc, "/plab/src/kit/include", "/plab/probe")
    run = g.sandbox.run(cmd, {"/plab/src": src}, {"/plab/probe": probe_dir}, "/plab/probe",
                        300, 2**28, memory=False)
    out = probe_dir / branches.OUTPUT
    if run.rc != 0 or run.reason or not out.is_file() or out.is_symlink():
        log = pathlib.Path(run.stdout).read_text(errors="replace") + run.stderr
        return (f"the grader's probe of kernels::BranchlessWall (kernels.cuh) did not compile: "
                f"{(run.reason or log)[-600:]}"), ""
    return branches.judge(out.read_text(errors="replace"), hint)
