"""plabio: the kit's files and programs for its Python tools, through the kit's own C++ programs.

One parser per format: scene files, model.md's output and the runner's events file are read by
kit/src/io.cpp only. The Python tools (kit/grade, kit/render, kit/stress, kit/accuracy) never
split those texts themselves; they call the programs below and read their JSON (or their files).

Calls go one way, never back up:

    ./plab (bash)  ->  plab COMMAND (C++)  ->  TOOL.py (Python)  ->  leaf C++ programs

The leaves, which never start Python:
    plab read --json FILE   a scene, an output or an events file, or an error (kit/cli/read.cpp)
    plab gen ...            a reproducible random scene (kit/cli/gen.cpp)
    plab diff [--json] A B  where two outputs differ, also step by step (kit/cli/diff.cpp)
    plab built --json       the stages, their programs and what stops one from running, and the
                            kit's folders (kit/cli/built.cpp; it asks the build tool, in a dry
                            run, whether each program is up to date, and starts nothing else)
    plab-run-NN-IMPL        a stage's runner (kit/runner/main.cpp), run by the tools directly or,
                            for student code, in the grader's sandbox (plab.grade.sandbox)
    plab bench ...          a stage's runs timed, medians into a CSV (kit/cli/bench.cpp; it
                            starts the stage runners only), for plab.report
The `plab` commands that start Python (render, report, grade, accuracy, stress, release, similar,
gradescope; test through CTest's Python checks, docs through its figure and offline scripts) are never called
from a tool: a tool that needs what one of them does calls the leaves it is made of. (Before this
module the tools called `plab gen` and `plab diff`, both leaves, and split the texts themselves.)
The test drivers under tests/ stand where a user stands: they run `plab` commands from the top,
as `./plab test` does; they are not tools.
"""
import json
import pathlib
import subprocess

from plab import KIT  # the kit's source folder


class FormatError(Exception):
    """A file is not a valid scene, output or events file: the reader's own message,
    `FILE:LINE: expected ..., found ...`."""


class ProgramError(Exception):
    """A kit program failed (not a format error): its command line, exit status and stderr."""


def default_plab():
    """The plab program of the kit's default build folder (build/bin/plab)."""
    return KIT / "build" / "bin" / "plab"


def _check(done, argv):
    if done.returncode != 0:
        raise ProgramError(f"{' '.join(map(str, argv))} exited {done.returncode}: "
                           f"{done.stderr.strip()[-1500:]}")
    return done


class Plab:
    """The kit's `plab` program (its leaf commands only)."""

    def __init__(self, program=None):
        self.program = str(program or default_plab())

    def _run(self, *args):
        argv = [self.program, *map(str, args)]
        return subprocess.run(argv, capture_output=True, text=True, errors="replace"), argv

    # -- reading (plab read --json) ----------------------------------------------------------------
    def read(self, path, kind="auto", steps=None):
        """The file as the reader's JSON (see `plab read --help`). `steps`: (first, last) keeps
        the blocks or events of those steps only (the whole file is checked all the same).
        Raises FormatError when the file is malformed (or cannot be read)."""
        args = ["read", "--json", "--kind", kind, path]
        if steps is not None:
            args += ["--steps", f"{steps[0]}:{steps[1]}"]
        done, argv = self._run(*args)
        if done.returncode == 1:
            message = done.stderr.strip()
            raise FormatError(message[len("error: "):] if message.startswith("error: ") else message)
        return json.loads(_check(done, argv).stdout)

    def read_scene(self, path):
        """{kind, file, n, L, r, steps, mode, generated, x, y, vx, vy} (the particle arrays are
        empty when the file has none: `generated`)."""
        return self.read(path, "scene")

    def read_output(self, path, steps=None):
        """{kind, file, n, first_step, last_step, blocks: [{step, counters, x, y, vx, vy[, pc,
        wc]}]}, blocks in step order; `counters` (with pc and wc) on the final block of a run."""
        return self.read(path, "output", steps)

    def read_events(self, path, steps=None):
        """{kind, file, count, events: [{step, particle, kind: "wall" or "pair"}]}."""
        return self.read(path, "events", steps)

    # -- the kit's stages (plab built --json) ------------------------------------------------------
    def built(self, impl=None, stages=()):
        """{impl, source, build, bin, exact_stage, stages: [{id, name, program, exists, problem}]}:
        every stage of `impl` (default: as for `plab run`), or those named; `problem` is "" when
        the stage is built from its current code, else the reason it cannot run."""
        args = ["built", "--json"] + (["--impl", impl] if impl else [])
        if stages:
            args += ["--stage", ",".join(stages)]
        done, argv = self._run(*args)
        if done.returncode != 0:
            message = done.stderr.strip()
            raise ProgramError(message[len("error: "):] if message.startswith("error: ") else message)
        return json.loads(done.stdout)

    def stage_program(self, stage, impl=None):
        """A stage's program; ProgramError saying why there is none (no such stage, not built, or
        not built from its current code)."""
        found = self.built(impl, [stage])["stages"][0]
        if found["problem"]:
            raise ProgramError(found["problem"])
        return found["program"]

    # -- making and comparing ----------------------------------------------------------------------
    def gen(self, out, *args):
        """Writes a random scene to `out` (`plab gen ARGS --out OUT`); returns `out`."""
        done, argv = self._run("gen", *args, "--out", out)
        _check(done, argv)
        return out

    def diff(self, expected, actual):
        """`plab diff --json`: {equal, text (plab diff's report), first (line; step and particle,
        ints or None where the line's word is not a number; field; expected and actual, the
        printed text; differing_lines; None when equal), steps: [{step, equal}] (for
        every step the expected output prints, whether the actual prints it the same),
        comparable}. Two files that are not outputs of the same scene (a scene, another N: exit
        2) are not equal: `comparable` is False, `text` says why, `first` is None."""
        done, argv = self._run("diff", "--json", expected, actual)
        if done.returncode not in (0, 1, 2) or not done.stdout.strip():
            _check(done, argv)
        return json.loads(done.stdout)


def run_stage(program, scene, *args, env=None):
    """Runs a stage's runner (plab-run-NN-IMPL) on a scene; returns the finished process (check
    its returncode: 3 is an exercise not done, 4 no CUDA device)."""
    return subprocess.run([str(program), str(scene), *map(str, args)], capture_output=True,
                          text=True, env=env)
