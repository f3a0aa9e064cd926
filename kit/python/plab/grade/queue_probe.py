"""Stage 07's event queue (exercise 1) driven alone by the grader (rubric: the idea's
"queue_probe"): the kit's probe (kit/grade/probes/queue_probe.cpp, also the local test
stage07.IMPL.Queue) compiled in the sandbox with the student's step.cpp in it, linked with the
kit's library from the same sandboxed build, and run there. It changes one particle's predicted
time at a time on queues of 1 to 1000 particles and, after each change, asks top() for the
earliest event and reads the queue's own arrays (heap_ in heap order, each particle in it once,
at_ saying where). A queue that is not the indexed binary heap the starting point declares (a
library set or heap kept beside it, a scan) fails here, however fast the step is.
"""
import pathlib
import shutil

PROBE = "kit/grade/probes/queue_probe.cpp"


def compiler_command(cxx, include, probe_dir, out):
    """The probe compiled with the stage's step.cpp (in `probe_dir`, beside the probe and the
    kit's library), with the library's bounds checks on."""
    return [str(cxx), "-std=c++20", "-O2", "-DNDEBUG", "-D_GLIBCXX_ASSERTIONS", "-fopenmp",
            "-ffp-contract=off", '-DPLAB_STAGE_ID="07"',
            f'-DPLAB_STEP_SOURCE="{probe_dir}/step.cpp"', "-I", str(include),
            f"{probe_dir}/queue_probe.cpp", f"{probe_dir}/libplab_kit.a", "-lpthread", "-o",
            str(out)]


def grade_probe(g, st, idea):
    """Stage 07's queue measured by the grader `g`. Returns (problem or None, what was
    measured)."""
    cxx, src, probe_dir = g.probe_beside(st, "CXX", "queue_probe.cpp",
                                         (g.kit / PROBE).read_text())
    if cxx is None:
        return "the kit's build names no C++ compiler to compile the queue probe with", ""
    # The kit's library: the one the sandboxed build linked (prebuilt from the kit's sources
    # outside the sandbox), else the one it built
    library = next((lib for lib in (g.kit_build / "kit" / "libplab_kit.a",
                                    g.built_in[1] / "kit" / "libplab_kit.a") if lib.is_file()), None)
    if library is None:
        raise RuntimeError("no kit library (libplab_kit.a) to link the queue probe with")
    shutil.copyfile(library, probe_dir / library.name)
    cmd = compiler_command(cxx, "/plab/src/kit/include", "/plab/probe", "/plab/probe/probe")
    problem = g.compile_probe(cmd, src, probe_dir, "the event queue (EventQueue in step.cpp)")
    if problem:
        return problem, ""
    run = g.sandbox.run(["/plab/probe/probe"], {"/plab/probe": probe_dir}, {}, "/plab/probe", 120,
                        2**26)
    text = pathlib.Path(run.stdout).read_text(errors="replace").strip()
    if run.rc != 0 or run.reason:
        said = text.splitlines()[-1] if text else (run.reason or f"exit {run.rc}")
        said = said.removeprefix("FAILED: ")
        return f"the grader's probe of the event queue: {said}. {idea.get('hint', '')}", ""
    return None, "the event queue driven alone: every answer the earliest, its arrays a heap"
