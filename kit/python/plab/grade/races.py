"""Race checks for the OpenMP stages (03, and 06's CPU path) with ThreadSanitizer.

What the autograder (and tests/tsan_mutant_check.py) imports:

  TSAN_CMAKE_ARGS       the extra cmake -D arguments of a thread-sanitized build of the kit
  TSAN_EXIT_CODE        the exit code of a program TSan stopped (tsan_env's exitcode=)
  SCHEDULES             the OpenMP schedules to run it with, in turn
  tsan_env(threads=3)   the environment to run a TSan-built program with
  first_race(stderr_text, source_names)   a one-line message about the first data race, or None
  toolchain_problem()   None when clang++, LLVM's OpenMP runtime and Archer are there, else a sentence

TSan understands OpenMP only with LLVM's runtime (libomp) and its Archer tool (libarcher.so,
Debian package libomp-dev), which tells TSan about OpenMP's barriers, reductions and tasks: the
build uses clang++ (-DPLAB_SANITIZE=thread, see CMakeLists.txt) and the run loads Archer through
OMP_TOOL_LIBRARIES. GCC's libgomp is not instrumented and gives false reports.
"""
from __future__ import annotations

import functools
import glob
import os
import re
import shutil
import subprocess
import tempfile

TSAN_EXIT_CODE = 66

#: The OpenMP schedules a stage is run with under TSan, in turn: static,1 first (every thread gets
#: iterations of every loop, whatever the timing: a race between threads is then always made),
#: then dynamic,1.
SCHEDULES = ("static,1", "dynamic,1")

TSAN_CMAKE_ARGS: list[str] = [
    "-DCMAKE_CXX_COMPILER=clang++",
    "-DCMAKE_BUILD_TYPE=RelWithDebInfo",  # -O2 -g: reports with file:line, not 10x slower than -O2
    "-DPLAB_SANITIZE=thread",
    "-DPLAB_ENABLE_CUDA=OFF",
    "-DPLAB_BUILD_TESTS=OFF",
]


@functools.lru_cache(maxsize=None)
def _llvm_lib_dirs() -> tuple[str, ...]:
    """Where clang++'s LLVM keeps libomp.so and libarcher.so (Debian: /usr/lib/llvm-NN/lib)."""
    dirs = []
    clang = shutil.which("clang++")
    if clang:
        try:
            resource = subprocess.run([clang, "-print-resource-dir"], capture_output=True,
                                      text=True, timeout=30).stdout.strip()
            if resource:  # .../lib/clang/14.0.6 -> .../lib
                dirs.append(os.path.dirname(os.path.dirname(os.path.realpath(resource))))
        except (OSError, subprocess.SubprocessError):
            pass
    dirs += sorted(glob.glob("/usr/lib/llvm-*/lib"), reverse=True)
    return tuple(dict.fromkeys(d for d in dirs if os.path.isdir(d)))


def _find_lib(name: str) -> str | None:
    for d in _llvm_lib_dirs():
        path = os.path.join(d, name)
        if os.path.exists(path):
            return path
    return None


def archer_path() -> str | None:
    """The full path of Archer (libarcher.so), or None."""
    return _find_lib("libarcher.so")


def tsan_env(threads: int = 3) -> dict[str, str]:
    """Environment variables for running a TSan-built program (add them to os.environ's copy).

    A race stops the program at its first report with exit code TSAN_EXIT_CODE (66);
    ignore_noninstrumented_modules keeps TSan quiet about libomp's own (uninstrumented) code;
    `threads` OpenMP threads (3: more than this 2-core machine's cores, an odd count), waiting
    passively so that the oversubscribed threads still make progress.
    """
    env = {
        "TSAN_OPTIONS": f"halt_on_error=1 exitcode={TSAN_EXIT_CODE} "
                        "ignore_noninstrumented_modules=1",
        "OMP_NUM_THREADS": str(threads),
        "OMP_WAIT_POLICY": "PASSIVE",
    }
    archer = archer_path()
    if archer:
        env["OMP_TOOL_LIBRARIES"] = archer
    return env


_RACE = re.compile(r"^WARNING: ThreadSanitizer: data race", re.M)
_ACCESS = re.compile(r"^\s+(Previous )?(atomic )?(read|write) of size \d+ at \S+ by "
                     r"(main thread|thread T\d+)", re.I)
_FRAME = re.compile(r"^\s+#\d+ .*? (\S+?):(\d+)(?::\d+)? \(")


def _pick_frame(frames: list[tuple[str, int]], source_names: list[str]) -> str | None:
    """file:line of the first frame in one of source_names, else the first outside system
    headers, else the first with a file at all."""
    def in_sources(path: str) -> bool:
        return any(path == s or path.endswith("/" + s.lstrip("/")) for s in source_names)

    for choose in (lambda p: in_sources(p), lambda p: not p.startswith("/usr/"), lambda p: True):
        for path, line in frames:
            if choose(path):
                return f"{os.path.basename(path)}:{line}"
    return None


def first_race(stderr_text: str, source_names: list[str]) -> str | None:
    """A short message about the first data race TSan reported in stderr_text, e.g.
    "data race at step.cpp:38 (write) against step.cpp:38 (read) in thread T2",
    naming frames in the student's files (source_names: file names or path suffixes) first;
    None when stderr_text has no data race report."""
    m = _RACE.search(stderr_text)
    if not m:
        return None
    block = stderr_text[m.end():]
    end = block.find("\nSUMMARY: ThreadSanitizer")
    if end >= 0:
        block = block[:end]
    accesses = []  # [kind, thread, frames]
    for line in block.splitlines():
        a = _ACCESS.match(line)
        if a:
            if len(accesses) == 2:
                break
            kind = ("atomic " if a.group(2) else "") + a.group(3).lower()
            accesses.append([kind, a.group(4), []])
            continue
        if not line.strip() and accesses and accesses[-1][2]:
            if len(accesses) == 2:
                break
            continue
        f = _FRAME.match(line)
        if f and accesses and not line.lstrip().startswith("Location"):
            accesses[-1][2].append((f.group(1), int(f.group(2))))
    if not accesses:
        return "data race (TSan's report has no access stack)"

    def describe(access) -> str:
        where = _pick_frame(access[2], source_names) or "an unknown place"
        return f"{where} ({access[0]})"

    thread = accesses[0][1]
    thread = "the main thread" if thread == "main thread" else thread
    message = "data race at " + describe(accesses[0])
    if len(accesses) > 1:
        message += " against " + describe(accesses[1])
    return message + " in " + thread


_LOCATION = re.compile(r"^\s+Location is (?:(stack) of (main thread|thread T\d+)|(heap) block of "
                       r"size (\d+)|(global) '([^']*)')", re.M)
_SIZE = re.compile(r"^\s+(?:Previous )?(?:atomic )?(?:read|write) of size (\d+)", re.I | re.M)


def race_location(stderr_text: str) -> str | None:
    """What the first data race's variable is, from TSan's "Location is ..." line, in words a
    student can match to the code (the access's line may be the parallel region's own when the
    compiler moved the store), e.g. "a local variable of 1 byte on the main thread's stack: a
    variable of the function that opens the parallel region, which every thread of the region
    shares"; None without a race or a location."""
    m = _RACE.search(stderr_text)
    if not m:
        return None
    block = stderr_text[m.end():]
    end = block.find("\nSUMMARY: ThreadSanitizer")
    block = block[:end] if end >= 0 else block
    where, size = _LOCATION.search(block), _SIZE.search(block)
    if not where:
        return None
    of = f" of {size.group(1)} byte{'s' if size.group(1) != '1' else ''}" if size else ""
    if where.group(1):
        owner = "the main thread's" if where.group(2) == "main thread" else f"{where.group(2)}'s"
        return (f"a local variable{of} on {owner} stack: a variable of the function that opens the "
                "parallel region, which every thread of the region shares unless a clause says "
                "otherwise (private, reduction)")
    if where.group(3):
        return (f"an element{of} of a block of {where.group(4)} bytes on the heap (an array or a "
                "vector's storage) that two threads touch")
    return f"the global variable '{where.group(6)}'{of}"


def tsan_summary(stderr_text: str) -> str | None:
    """TSan's last SUMMARY line without its program path and build id, e.g.
    "ThreadSanitizer: allocation-size-too-big in operator new(unsigned long)"; None without one."""
    lines = [l for l in stderr_text.splitlines() if l.startswith("SUMMARY: ThreadSanitizer:")]
    if not lines:
        return None
    text = lines[-1][len("SUMMARY: "):]
    return re.sub(r" \((?:BuildId: [0-9a-f]+|/[^()]*\+0x[0-9a-f]+)\)", "", text).strip()


def toolchain_problem() -> str | None:
    """None when a thread-sanitized OpenMP build can be made and run here (clang++, LLVM's OpenMP
    runtime, Archer); otherwise one sentence saying what is missing."""
    clang = shutil.which("clang++")
    if not clang:
        return "race check not available: clang++ not found (Debian package clang)"
    if not _find_lib("libomp.so"):
        return ("race check not available: LLVM's OpenMP runtime libomp.so not found next to "
                f"{clang} (Debian package libomp-dev)")
    if not archer_path():
        return ("race check not available: Archer (libarcher.so, TSan's OpenMP support) not found "
                "(Debian package libomp-dev)")
    with tempfile.TemporaryDirectory(prefix="plab-tsan-probe-") as d:
        src = os.path.join(d, "probe.cpp")
        with open(src, "w") as f:
            f.write("#include <omp.h>\nint main() { int n = 0;\n"
                    "#pragma omp parallel reduction(+ : n)\n  n += omp_get_thread_num() >= 0;\n"
                    "  return n > 0 ? 0 : 1; }\n")
        try:
            r = subprocess.run([clang, "-fopenmp=libomp", "-fsanitize=thread", src, "-o",
                                os.path.join(d, "probe")], capture_output=True, text=True,
                               timeout=120)
        except (OSError, subprocess.SubprocessError) as e:
            return f"race check not available: clang++ could not build an OpenMP program ({e})"
        if r.returncode != 0:
            last = (r.stderr.strip().splitlines() or ["no message"])[-1]
            return ("race check not available: clang++ -fopenmp -fsanitize=thread fails "
                    f"({last}; Debian packages clang and libomp-dev)")
    return None
