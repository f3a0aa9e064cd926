"""plab grade: builds a submission's stages against the kit's own code, checks them against the
reference, and writes Gradescope's results.json, JUnit XML and a readable summary.

`./plab grade --submission DIR` runs `python3 -m plab.grade` (plab/grade/__main__.py: the options,
one grading or a class's) with the kit's folders; see `./plab grade --help`.
Every threshold and point comes from the rubric (kit/grade/rubric.json). results.json is written
after every test, so whatever happens later (a crash, a hang, the grader itself failing) the tests
already run keep their results.
"""
import json
import os
import pathlib
import secrets
import shutil
import subprocess
import tempfile

from plab import plabio  # the kit's formats, read and compared by its C++ programs
from plab.grade import gpu_idea
from plab.grade import sandbox as isolation
from plab.grade import upload
from plab.grade.build import Build
from plab.grade.correctness import Correctness
from plab.grade.ideas import Ideas
from plab.grade.performance import Performance
from plab.grade.racecheck import RaceCheck
from plab.grade.results import Results
from plab.grade.run import Run
from plab.grade.stage import Refused, Stage
from plab.grade.build import unbuilt


class Grader(Build, Run, Correctness, Ideas, RaceCheck, Performance):
    """One grading of one submission: the sandbox, the stages built, each stage's tests (the
    mixins' methods, one module per concern), results.json."""

    def __init__(self, a):
        self.a = a
        self.kit = pathlib.Path(a.kit_source).resolve()
        self.kit_build = pathlib.Path(a.kit_build).resolve()
        self.rubric = json.loads(pathlib.Path(a.rubric).read_text())
        self.results = Results(a.out, a.junit)
        self.scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-grade-", dir=a.scratch or None))
        self.private = self.scratch / "private"  # expected outputs, hidden scenes: never mounted
        self.private.mkdir(mode=0o700)
        self.plab = self.kit_build / "bin" / "plab"
        # The kit's own programs that a grading compares with and counts by, copied once: a
        # rebuild of the kit during a long grading (a TA's ./plab test while a class is graded)
        # never changes, or removes, the reference under a submission's tests.
        self.kit_bin = self.private / "kit-bin"
        self.kit_bin.mkdir()
        for f in sorted((self.kit_build / "bin").glob("plab-run-*-solution")) + [
                self.kit_build / "bin" / n for n in ("plab-rounds", "libplab-ompcount.so")]:
            if f.is_file():
                shutil.copy2(f, self.kit_bin / f.name)
        self.kit_programs = plabio.Plab(self.plab)  # its leaf commands: gen, diff, read
        self.manifest = json.loads((self.kit / "datasets" / "manifest.json").read_text())
        given = a.seed if a.seed is not None else os.environ.pop("PLAB_GRADE_SEED", None)
        self.seed = int(given) if given is not None else secrets.randbelow(2**32)
        self.results.extra.update(seed=self.seed, replay=f"./plab grade --submission "
                                  f"{a.submission} --seed {self.seed}")
        self.notes = self.results.notes
        self.idea_failed, self.idea_done = {}, set()  # stage folder -> why its idea test failed
        self.idea_slow = {}  # stage folder -> its idea test's result, when it ran out of time
        if a.leaderboard_name:
            self.notes.append(f"your name on the class's leaderboard: {a.leaderboard_name}")
        self.results.instructor_notes.append(f"hidden scenes from seed {self.seed} (replay: "
                                             f"./plab grade --submission SUBMISSION --seed "
                                             f"{self.seed})")
        self.isolate()
        for sid in {self.manifest["reference_stage"], "01"}:
            if not self.solution(sid).exists():
                raise RuntimeError(f"the kit's reference program {self.solution(sid)} is not "
                                   "built: run ./plab once in the kit")

    # -- isolation -------------------------------------------------------------------------------
    def isolate(self):
        """Chooses the sandbox, or refuses to grade without one."""
        request = "none" if self.a.no_sandbox else self.a.sandbox
        mode, why = isolation.choose(request, self.scratch)
        if mode is None:
            raise Refused(f"no sandbox can run student code here ({why}). Install bubblewrap "
                          "where namespaces are allowed, run the grader as root (it then runs "
                          "student code as an unprivileged user), or pass --no-sandbox to grade "
                          "with the grader's own rights (printed on every result).")
        if mode == "user":
            private = [self.kit / "solutions", self.kit / "datasets" / "golden",
                       self.kit_build / "bin", self.kit / "kit" / "grade" / "rubric.json",
                       self.kit / "kit" / "instructor", self.private]
            # No namespaces: the sandbox's uid reads every file others may read. The grader
            # refuses while the kit's answers (its solutions, goldens, builds) are readable by
            # others, and says how to close them (`--make-private` does it); it never changes
            # them unasked: other gradings of this kit (a class, the tests) may be using them.
            if self.a.make_private:
                isolation.make_private(private[:-1] + [self.kit_build])
            seen = isolation.private_readable(private)
            if seen:
                raise Refused(
                    f"a sandbox without namespaces (--sandbox user, or none on this machine): "
                    f"student code would run as uid {isolation.SANDBOX_UID}, "
                    f"which can read {', '.join(seen)}. Make the kit private first "
                    f"(chmod -R go-rwx {self.kit} {self.kit_build}, or grade with --make-private; "
                    "the Gradescope setup.sh does).")
            copies = isolation.readable_copies(skip=[self.kit / "solutions", self.kit_build,
                                                     self.scratch, pathlib.Path(
                                                         self.a.submission).resolve()])
            if copies:
                raise Refused(
                    f"a sandbox without namespaces (--sandbox user, or none on this machine): "
                    f"student code would run as uid {isolation.SANDBOX_UID}, "
                    f"which can read other copies of the kit's answers: {', '.join(copies[:6])}"
                    f"{' ...' if len(copies) > 6 else ''}; remove them or make them private "
                    "(chmod -R go-rwx FOLDER) first.")
            self.notes.append(
                f"sandbox without namespaces: student code runs as uid {isolation.SANDBOX_UID} and "
                "can still read every world-readable file of this machine (the system, /tmp, other "
                "users' public files) and reach the network; no copy of the kit's answers was "
                "found readable (searched 6 folders deep from /)")
            print(self.notes[-1], flush=True)
        self.sandbox = isolation.Sandbox(self.scratch, self.rubric["limits"], mode)
        self.results.extra["sandbox"] = mode
        self.notes.append(f"sandbox: {isolation.NAMES[mode]}")
        if mode == "none":
            self.results.banner = "[UNSANDBOXED: graded with --no-sandbox] "
        print(f"sandbox: {isolation.NAMES[mode]}", flush=True)

    # -- the kit's programs ----------------------------------------------------------------------
    def solution(self, sid):
        return self.kit_bin / f"plab-run-{sid}-solution"

    def gpu_here(self):
        """Whether this machine has a CUDA device (the kit's stage 04 says so)."""
        if not hasattr(self, "_gpu"):
            probe = self.solution("04")
            self._gpu = probe.exists() and subprocess.run(
                [probe, self.kit / "datasets/scenes/course-1.in", "--quiet", "--out", os.devnull],
                capture_output=True).returncode != 4
        return self._gpu

    # -- one stage: its tests in order (the mixins' methods) --------------------------------------
    def grade_stage(self, st, program):
        if isinstance(program, str):
            self.notes.append(f"{st.title}: " + " ".join(program.splitlines()[:2]))
        limits = self.rubric["limits"]
        stopped = None  # why no later run of this stage is started (a second time-out)
        # After a first time-out on a scene of N particles: (N, why) no later scene of N or more
        # is started (each would take the whole limit), but the smaller ones still are, so a
        # stage that hangs only on large scenes keeps the points of the small ones
        too_large = None
        folder = self.private / f"stage{st.key}"
        folder.mkdir()
        if st.gpu and st.idea and st.idea["kind"] == "gpu" and st.key not in self.idea_done:
            self.idea_done.add(st.key)  # a GPU entry's own idea, traced (gpu_idea.py)
            gpu_idea.idea_test(self, st, program, folder)
        if st.sid not in self.idea_done:  # once per stage folder, before its correctness tests
            self.idea_done.add(st.sid)
            idea = next((e for e in self.entries([st.sid])
                         if e.idea and e.idea["kind"] != "gpu"), None)
            if idea is not None:
                self.idea_test(idea, program, folder)
        tests = self.public_tests(st) + self.hidden_tests(st, folder)
        all_right, any_right = True, False
        faked = None  # a run on several ranks with the right text whose ranks did not share
        for name, scene, expected, points, hidden, how in tests:
            test = f"{st.key}: {'hidden' if hidden else 'public'} {name}"
            n = self.scene_n(scene) if too_large else None  # (read only after a time-out)
            held = stopped or (too_large[1] if too_large and (n is None or n >= too_large[0])
                               else None)
            if isinstance(program, str) or held:
                why = unbuilt(st.sid, program) if isinstance(program, str) else held
                self.results.add(test, 0, points, False, f"not run: {why}", hidden)
                all_right = False
                continue
            budget = max(limits["min_seconds"],
                         limits["time_multiple"] * self.ref_seconds(st, scene))
            cap = max(limits["output_min_mb"] * 2**20, limits["output_multiple"] * len(expected))
            reported = st.ranks > 1 or self.compares_rounds(st)
            report = ["--report", "/plab/out/report.json"] if reported else []
            run = self.run_program(program, scene, ["--quiet", "--threads", st.threads, "--out",
                                                    "/plab/out/out.txt", *report], budget, cap, st)
            verdict = self.verdict(st, run, scene, expected, how)
            if verdict is None and reported and not self.idea_failed.get(st.sid):
                # the right text (and the idea test passed): did every rank step its slab, did
                # the rounds make their comparisons?
                verdict = (self.ranks_work(st, run, scene, folder / f"ranks-{name}")
                           if st.ranks > 1 else self.rounds_compared(st, run, scene))
                if verdict:  # the idea faked off its test's scene: the folder's points go
                    faked = faked or f"{name}: {verdict}"
            if run.reason and "time limit" in run.reason:
                n = n if too_large else self.scene_n(scene)
                if too_large is None and n is not None:
                    too_large = (n, f"an earlier test of stage {st.key} ran out of time ({name}, "
                                    f"N = {n}): no later scene of {n} particles or more is started")
                else:
                    stopped = (f"a second test of stage {st.key} ran out of time ({name}): no "
                               "later test is started")
                self.idea_not_to_blame(st, name, budget, self.ref_seconds(st, scene))
            self.add_correctness(st, test, points if verdict is None else 0, points,
                                 verdict is None, verdict or "same text as the reference, bit for bit",
                                 hidden, run.seconds)
            all_right &= verdict is None
            any_right |= verdict is None
        if faked:
            self.void_folder(st, faked)
        one_step_n = int(self.rubric["correctness"]["one_step_scene"]["n"])
        all_right &= self.one_step(st, program, stopped or (
            too_large[1] if too_large and one_step_n >= too_large[0] else None), folder)
        stopped = stopped or (too_large[1] if too_large else None)
        correct = (all_right and not stopped and not self.idea_failed.get(st.sid)
                   and not self.idea_failed.get(st.key))
        if st.conf.get("races") and not self.a.no_races:
            self.race_check(st, program, folder, correct, any_right)
        if st.conf.get("performance"):
            idea = self.idea_failed.get(st.sid) or self.idea_failed.get(st.key)
            self.performance(st, program, correct,
                             "its idea test must pass first" if all_right and not stopped and idea
                             else "every correctness test must pass first")

    def scene_n(self, scene):
        """The number of particles of `scene` (the kit's reader), None if it cannot be read."""
        try:
            return int(self.kit_programs.read_scene(scene)["n"])
        except (plabio.FormatError, plabio.ProgramError, KeyError, ValueError):
            return None

    def void_folder(self, st, why):
        """Stage folder st.sid fails its idea after all (`why`: a correctness scene on several
        ranks, Ideas.ranks_work(), or stage 03's comparisons, Ideas.rounds_compared()): every result
        of the folder so far counts 0, its idea test says why, and later results count 0 too
        (idea_failed), as when the idea test fails."""
        failed = f"the idea test of stage {st.sid} failed on the correctness scene {why}"
        self.idea_failed[st.sid] = failed
        for t in self.results.tests:
            if t["name"].split(":")[0].split("-")[0] != st.sid:
                continue
            if t["name"].startswith(f"{st.sid}: idea"):
                t["status"] = "failed"
                t["output"] = f"{failed}\n(on its own scene: {t['output']})"
            elif t["score"]:
                t["output"] = f"counts 0 (it would earn {t['score']:g}): {failed}\n{t['output']}"
                t["score"], t["status"] = 0, "failed"
        self.results.write()

    # -- the whole grading -----------------------------------------------------------------------
    def entries(self, ids):
        """The rubric's entries for stage folder ids ("06": "06" and "06-gpu"), or Refused."""
        out = []
        for sid in ids:
            keys = [k for k, c in self.rubric["stages"].items()
                    if k == sid or c.get("folder") == sid]
            if sid not in self.kit_folders or not keys:
                raise Refused(f"no stage {sid} in the kit's rubric (it grades stages "
                              f"{', '.join(sorted(self.rubric['stages']))})")
            out += [Stage(k, self.rubric["stages"][k], self.manifest) for k in keys]
        return out

    def untouched(self, sid, folder):
        """Whether the upload's stage folder holds the kit's starting point of stage `sid`, byte
        for byte (the same source files, the same bytes)."""
        given = upload.sources(self.kit / "stages" / self.kit_folders[sid])
        theirs = upload.sources(folder)
        return [p.name for p in given] == [p.name for p in theirs] and all(
            a.read_bytes() == b.read_bytes() for a, b in zip(given, theirs))

    def grade(self):
        self.kit_folders = {p.name[:2]: p.name for p in sorted((self.kit / "stages").iterdir())
                            if p.is_dir() and p.name[:2].isdigit()}
        named = self.a.stages.split(",") if self.a.stages else []
        # Each stage once, in order ("08,08-ranks2" names stage 08 twice: it was graded twice, and
        # the second grading found the first's folders and ended in a grader error).
        wanted = list(dict.fromkeys(s.split("-")[0] for s in named))
        for sid in wanted:
            self.entries([sid])  # a stage the rubric does not know: refused before any work
        try:
            found, layout = upload.find_stages(self.a.submission, self.kit_folders, wanted,
                                               self.private)
        except upload.UploadError as e:
            raise Refused(f"the upload is not a submission: {e}")
        self.notes.append(f"submission: {layout}")
        print(f"submission: {layout}", flush=True)
        if not wanted:
            # Every stage the upload has, less the untouched starting points: a whole copy of the
            # kit handed in in week 3 holds stages 04 to 08 as given, not handed in (their idea
            # tests alone would take minutes and put zeros in the total). --stages grades them.
            given = [sid for sid in sorted(found) if self.untouched(sid, found[sid])]
            if given and len(given) < len(found):
                many = len(given) > 1
                note = (f"stage{'s' * many} {', '.join(given)}: the untouched starting "
                        f"point{'s' * many}, not graded (not handed in; --stages grades "
                        f"{'them' if many else 'it'})")
                self.notes.append(note)
                print(note, flush=True)
                found = {sid: f for sid, f in found.items() if sid not in given}
        stages = self.entries(wanted or sorted(found))
        if any("-" in s for s in named):  # entries named one by one: those only
            stages = [s for s in stages if s.key in named]
        runnable = []
        for st in stages:
            if st.gpu and not self.gpu_here():
                idea = " and its idea test" if st.idea else ""
                self.notes.append(f"{st.title}{idea}: not graded: no CUDA device on this machine")
                print(f"{st.title}{idea}: skipped: no CUDA device on this machine", flush=True)
            else:
                runnable.append(st)
        built = self.build(runnable, found) if runnable else {}
        for st in runnable:
            print(st.title, flush=True)
            self.grade_stage(st, built[st.sid])
