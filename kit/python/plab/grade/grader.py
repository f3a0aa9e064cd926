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
import re
import secrets
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from xml.sax.saxutils import escape, quoteattr

from plab import plabio  # the kit's formats, read and compared by its C++ programs
from plab.grade import hidden as hidden_module
from plab.grade import leaderboard
from plab.grade import races
from plab.grade import sandbox as isolation
from plab.grade import upload


class Results:
    """The tests so far, written out (JSON for Gradescope, JUnit XML) after each one."""

    def __init__(self, json_path, junit_path):
        self.json_path, self.junit_path = pathlib.Path(json_path), pathlib.Path(junit_path)
        self.tests, self.notes, self.start = [], [], time.time()
        self.extra = {}  # results.json's extra_data: for the instructor, not shown to students
        self.leaderboard = []  # results.json's leaderboard: the grader's measured times
        self.banner = ""  # printed before every test's output (--no-sandbox)
        self.write()

    def add(self, name, score, max_score, passed, output, hidden=False, seconds=0.0):
        output = self.banner + output
        self.tests.append({"name": name, "score": round(score, 3), "max_score": max_score,
                           "status": "passed" if passed else "failed", "output": output,
                           "visibility": "after_published" if hidden else "visible",
                           "seconds": round(seconds, 3)})
        mark = "ok  " if passed else "FAIL"
        print(f"  {mark} {score:5.2f}/{max_score:<4g} {name}", flush=True)
        self.write()

    def write(self):
        total = sum(t["score"] for t in self.tests)
        most = sum(t["max_score"] for t in self.tests)
        summary = "\n".join(self.notes + [f"total: {total:.2f} / {most:g}"])
        doc = {"score": round(total, 3), "execution_time": round(time.time() - self.start, 1),
               "output": summary, "visibility": "visible", "stdout_visibility": "hidden",
               "extra_data": self.extra,
               **({"leaderboard": self.leaderboard} if self.leaderboard else {}),
               "tests": [{k: v for k, v in t.items() if k != "seconds"} for t in self.tests]}
        atomic_write(self.json_path, json.dumps(doc, indent=2) + "\n")
        failures = sum(t["status"] == "failed" for t in self.tests)
        cases = []
        for t in self.tests:
            stage = t["name"].split(":")[0]
            body = "" if t["status"] == "passed" else (
                f"<failure message={quoteattr(t['output'].splitlines()[0] if t['output'] else 'failed')}>"
                f"{escape(t['output'])}</failure>")
            cases.append(f'  <testcase classname={quoteattr(stage)} name={quoteattr(t["name"])} '
                         f'time="{t["seconds"]}">{body}</testcase>')
        atomic_write(self.junit_path,
                     '<?xml version="1.0" encoding="UTF-8"?>\n'
                     f'<testsuite name="plab grade" tests="{len(self.tests)}" '
                     f'failures="{failures}">\n' + "\n".join(cases) + "\n</testsuite>\n")

    def total(self):
        return sum(t["score"] for t in self.tests), sum(t["max_score"] for t in self.tests)


def atomic_write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    temp = path.with_name(path.name + ".partial")
    temp.write_text(text)
    os.replace(temp, path)


def implied(before, after):
    """What a particle did in a step, from its printed velocities (vx, vy) before and after."""
    v0, v1 = list(before), list(after)
    if v0 == v1:
        return "moved freely (velocity unchanged)"
    if [abs(v) for v in v0] == [abs(v) for v in v1]:
        return "hit a wall (a velocity component flipped)"
    return f"changed velocity as in a pair collision ({v0[0]:.8f}, {v0[1]:.8f}) -> ({v1[0]:.8f}, {v1[1]:.8f})"


def velocities(plab, path, step, i):
    """Particle i's printed (vx, vy) in the block of `step` of an output, or None when the output
    has no such block or particle, or is not an output at all (a student's may be anything)."""
    try:
        blocks = plab.read_output(path, steps=(step, step))["blocks"]
    except plabio.FormatError:
        return None
    if not blocks or i >= len(blocks[0]["vx"]):
        return None
    return blocks[0]["vx"][i], blocks[0]["vy"][i]


def readable_by_all(folder):
    """Folders 0755 and files 0644 (0755 where the owner may run them) under `folder`: a copy that
    the sandbox's uid can read whatever the modes of what it was copied from."""
    for path in [folder, *folder.rglob("*")]:
        if path.is_symlink():
            continue
        mode = path.stat().st_mode
        os.chmod(path, 0o755 if path.is_dir() or mode & 0o100 else 0o644)


class Refused(Exception):
    """The grader will not grade (no sandbox, a private file readable, a stage it does not know):
    the text says why and what to do."""


class Stage:
    """One graded entry of the rubric: a stage folder of the kit, on a device, against a
    reference. `key` is the rubric's name ("06", "06-gpu"), `sid` the folder's number."""

    def __init__(self, key, conf, manifest):
        self.key, self.conf = key, conf
        self.sid = conf.get("folder", key)
        self.gpu = conf.get("gpu", False)
        self.threads = str(conf.get("threads", 1))
        self.reference = conf.get("reference", manifest["reference_stage"])
        self.exact = conf.get("golden") == "exact"
        self.env = {"PLAB_DEVICE": conf["device"]} if "device" in conf else {}
        self.ranks = int(conf.get("ranks", 1))  # a stage on several processes: mpirun starts them
        self.idea = conf.get("idea")  # the stage's idea test (Grader.idea_test), or None
        self.title = f"stage {key}"


class Grader:
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
        self.kit_programs = plabio.Plab(self.plab)  # its leaf commands: gen, diff, read
        self.manifest = json.loads((self.kit / "datasets" / "manifest.json").read_text())
        given = a.seed if a.seed is not None else os.environ.pop("PLAB_GRADE_SEED", None)
        self.seed = int(given) if given is not None else secrets.randbelow(2**32)
        self.results.extra.update(seed=self.seed, replay=f"./plab grade --submission "
                                  f"{a.submission} --seed {self.seed}")
        self.notes = self.results.notes
        self.idea_failed, self.idea_done = {}, set()  # stage folder -> why its idea test failed
        if a.leaderboard_name:
            self.notes.append(f"your name on the class's leaderboard: {a.leaderboard_name}")
        self.notes.append(f"hidden scenes from seed {self.seed} (replay: ./plab grade "
                          f"--submission SUBMISSION --seed {self.seed})")
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
                    f"no namespaces here, so student code would run as uid {isolation.SANDBOX_UID}, "
                    f"which can read {', '.join(seen)}. Make the kit private first "
                    f"(chmod -R go-rwx {self.kit} {self.kit_build}, or grade with --make-private; "
                    "the Gradescope setup.sh does).")
            copies = isolation.readable_copies(skip=[self.kit / "solutions", self.kit_build,
                                                     self.scratch, pathlib.Path(
                                                         self.a.submission).resolve()])
            if copies:
                raise Refused(
                    f"no namespaces here, so student code would run as uid {isolation.SANDBOX_UID}, "
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
        return self.kit_build / "bin" / f"plab-run-{sid}-solution"

    def gpu_here(self):
        """Whether this machine has a CUDA device (the kit's stage 04 says so)."""
        if not hasattr(self, "_gpu"):
            probe = self.solution("04")
            self._gpu = probe.exists() and subprocess.run(
                [probe, self.kit / "datasets/scenes/course-1.in", "--quiet", "--out", os.devnull],
                capture_output=True).returncode != 4
        return self._gpu

    # -- building --------------------------------------------------------------------------------
    def build(self, stages, found):
        """Builds each stage's program from the submission's sources and the kit's own CMake, kit
        and runner, in the sandbox (the compiler sees the system, the kit's public part and the
        submission, nothing else: not the kit's greedy oracle, a whole step that a stage could
        call or include, so the runner is built there without it). Returns {folder id: program
        path or error text}."""
        folders = self.kit_folders
        src = self.sandbox.shared_dir("src")
        for item in ("CMakeLists.txt", "CMakePresets.json", "cmake", "kit", "docs"):
            source = self.kit / item
            if source.is_dir():
                shutil.copytree(source, src / item, ignore=shutil.ignore_patterns(
                    "grade", "__pycache__", "instructor"))
            else:
                shutil.copy2(source, src / item)
        built = {}
        limit_kb = self.rubric["limits"]["source_kb"]
        for sid in sorted({s.sid for s in stages}):
            dest = src / "stages" / folders[sid]
            dest.mkdir(parents=True)
            for declared in ("CMakeLists.txt", "stage.json"):  # never theirs
                shutil.copy2(self.kit / "stages" / folders[sid] / declared, dest)
            if sid not in found:
                built[sid] = f"the submission has no stages/{folders[sid]}/"
                continue
            sources = upload.sources(found[sid])
            size = sum(f.stat().st_size for f in sources)
            if size > limit_kb * 1024:  # room for any solution, not for an embedded program
                built[sid] = (f"its sources are {size // 1024} KB, more than the rubric's "
                              f"{limit_kb} KB (the kit's solution of a stage is under 40 KB)")
                continue
            for f in sources:
                shutil.copy2(f, dest / f.name)
            # A given file the solution does not change lives once, in the starting point (the
            # kit's solutions/NN-name leaves it out): an upload without it gets the kit's.
            given = self.kit / "stages" / folders[sid]
            for f in sorted(given.iterdir()):
                if (f.is_file() and not (self.kit / "solutions" / folders[sid] / f.name).exists()
                        and not (dest / f.name).exists()):
                    shutil.copy2(f, dest / f.name)
        readable_by_all(src)  # the kit may be private (Gradescope's setup.sh makes it so)
        build = self.sandbox.writable_dir(self.sandbox.box, "build-")
        mounts = ({"/plab/src": src}, {"/plab/build": build})
        print(f"building stages {', '.join(sorted({s.sid for s in stages}))} in the sandbox",
              flush=True)
        kit_lib = self.kit_build / "kit" / "libplab_kit.a"  # the kit, compiled once already
        prebuilt = []
        if kit_lib.is_file():
            shutil.copyfile(kit_lib, self.sandbox.shared_dir("kitlib") / kit_lib.name)
            mounts[0]["/plab/kitlib"] = self.sandbox.box / "kitlib"
            prebuilt = [f"-DPLAB_PREBUILT_KIT=/plab/kitlib/{kit_lib.name}"]
        # No stage graded on a GPU (none here): the CPU paths only, without nvcc's minutes
        cuda = [] if any(s.gpu for s in stages) else ["-DPLAB_ENABLE_CUDA=OFF"]
        conf = self.sandbox.run(["cmake", "-S", "/plab/src", "-B", "/plab/build", "-G", "Ninja",
                                 "-DCMAKE_BUILD_TYPE=Release", "-DPLAB_BUILD_TESTS=OFF",
                                 "-DPLAB_CCACHE=OFF", *cuda, *prebuilt], *mounts, "/plab/build",
                                600, 2**30, memory=False)
        if conf.rc != 0 or conf.reason:
            log = pathlib.Path(conf.stdout).read_text(errors="replace") + conf.stderr
            return {sid: built.get(sid, "the kit's build could not be configured: " +
                                   (conf.reason or log[-1500:])) for sid in folders}
        bin_dir = self.sandbox.shared_dir("bin")
        for sid in sorted({s.sid for s in stages}):
            if sid in built:
                continue
            target = f"plab-run-{sid}-student"
            b = self.sandbox.run(["cmake", "--build", "/plab/build", "--target", target, "-j",
                                  os.environ.get("PLAB_BUILD_JOBS") or str(os.cpu_count() or 2)], *mounts, "/plab/build", 900, 2**30,
                                 memory=False)
            program = build / "bin" / target
            if b.rc == 0 and not b.reason and program.is_file() and not program.is_symlink():
                mine = bin_dir / f"stage{sid}"  # a copy student code cannot change
                shutil.copyfile(program, mine)
                os.chmod(mine, 0o755)
                built[sid] = mine
            else:
                log = pathlib.Path(b.stdout).read_text(errors="replace") + b.stderr
                errors = [ln for ln in log.splitlines() if "error" in ln.lower()]
                text = b.reason or "\n".join((errors or log.splitlines()[-25:])[:25])
                built[sid] = "it does not compile:\n" + text.replace("/plab/src/", "")
        return built

    # -- running student code --------------------------------------------------------------------
    def run_program(self, program, scene, args, seconds, cap, st, stdin_text=None, env=None,
                    memory=True, watch=False, ranks=None):
        """Runs a stage program in the sandbox on one scene, under its neutral names (`ranks`:
        how many processes mpirun starts, default the stage's; `watch`: Run.cpu)."""
        ranks = st.ranks if ranks is None else ranks
        run_dir = pathlib.Path(tempfile.mkdtemp(prefix="run-", dir=self.sandbox.box))
        os.chmod(run_dir, 0o755)
        shutil.copyfile(scene, run_dir / "scene.in")
        os.chmod(run_dir / "scene.in", 0o644)
        out = self.sandbox.writable_dir(run_dir, "out-")
        ro = {"/plab/stage": program, "/plab/scene.in": run_dir / "scene.in"}
        argv = ["/plab/stage", "/plab/scene.in", *args]
        if stdin_text is not None:  # read through a pipe, never a file the program could reopen
            argv = ["/plab/stage", "/plab/scene.in", *[a if a != "STDIN" else "/dev/stdin"
                                                       for a in args]]
        if ranks > 1:  # every rank in the same sandbox, under the same limits
            argv = [shutil.which("mpirun") or "mpirun", "--quiet", "--oversubscribe", "-np",
                    str(ranks), *argv]
        log = pathlib.Path(tempfile.mkdtemp(prefix="log-", dir=self.private))
        return self.sandbox.run(argv, ro, {"/plab/out": out}, "/plab/out", seconds, cap,
                                gpu=st.gpu, env=env or st.env, log_dir=log, stdin_text=stdin_text,
                                memory=memory, watch=watch)

    # -- one stage -------------------------------------------------------------------------------
    def expected_for(self, st, scene, out):
        """The reference's output of a scene (computed now, in the grader's private folder)."""
        r = subprocess.run([self.solution(st.reference), scene, "--quiet", "--out", out],
                           capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"the reference failed on {scene}: {r.stderr}")
        return pathlib.Path(out).read_text()

    def public_tests(self, st):
        corr = self.rubric["correctness"]
        golden_dir = self.kit / "datasets" / "golden" / ("exact" if st.exact else "")
        tests = []  # (name, scene, expected text, points, hidden, (setup, scene arg, expected arg))
        for d in self.manifest["scenes"]:
            if d["size"] in st.conf["sizes"]:
                scene = self.kit / "datasets" / "scenes" / f"{d['name']}.in"
                golden = golden_dir / f"{d['name']}.out"
                tests.append((d["name"], scene, golden.read_text(), corr["public_points_each"],
                              False, ("", str(scene.relative_to(self.kit)),
                                      str(golden.relative_to(self.kit)))))
        return tests

    def hidden_tests(self, st, folder):
        """The hidden scenes of this grading's seed (plab.grade.hidden: the rubric's random
        scenes and the public edge cases' families drawn afresh), with the reference's output."""
        corr = self.rubric["correctness"]
        tests = []
        for name, scene in hidden_module.hidden_scenes(self.seed, st.sid, self.rubric, self.plab,
                                                       folder):
            expected = self.expected_for(st, scene, folder / f"{name}.out")
            how = (f"PYTHONPATH=kit/python python3 -m plab.grade.hidden --seed {self.seed} --stage {st.sid} --only {name} "
                   "--out hidden.in && ")
            tests.append((name, scene, expected, corr["hidden_points_each"], True,
                          (how, "hidden.in", "expected.out")))
        return tests

    def add_correctness(self, st, test, score, points, passed, text, hidden=False, seconds=0.0):
        """A correctness test's result; none of its points when the stage's idea test failed."""
        failed = self.idea_failed.get(st.sid)
        if failed and score:
            text = (f"counts 0 (it would earn {score:g}): {failed}\n{text}")
            score, passed = 0, False
        self.results.add(test, score, points, passed, text, hidden, seconds)

    def grade_stage(self, st, program):
        if isinstance(program, str):
            self.notes.append(f"{st.title}: {program.splitlines()[0]}")
        limits = self.rubric["limits"]
        stopped = None  # why later runs of this stage are not started (a time-out)
        folder = self.private / f"stage{st.key}"
        folder.mkdir()
        if st.sid not in self.idea_done:  # once per stage folder, before its correctness tests
            self.idea_done.add(st.sid)
            idea = next((e for e in self.entries([st.sid]) if e.idea), None)
            if idea is not None:
                self.idea_test(idea, program, folder)
        tests = self.public_tests(st) + self.hidden_tests(st, folder)
        all_right, any_right = True, False
        for name, scene, expected, points, hidden, how in tests:
            test = f"{st.key}: {'hidden' if hidden else 'public'} {name}"
            if isinstance(program, str) or stopped:
                why = f"stage {st.sid} {program}" if isinstance(program, str) else stopped
                self.results.add(test, 0, points, False, f"not run: {why}", hidden)
                all_right = False
                continue
            budget = max(limits["min_seconds"],
                         limits["time_multiple"] * self.ref_seconds(st, scene))
            cap = max(limits["output_min_mb"] * 2**20, limits["output_multiple"] * len(expected))
            run = self.run_program(program, scene, ["--quiet", "--threads", st.threads, "--out",
                                                    "/plab/out/out.txt"], budget, cap, st)
            verdict = self.verdict(st, run, scene, expected, how)
            if run.reason and "time limit" in run.reason:
                stopped = f"an earlier test of stage {st.key} ran out of time ({name})"
            self.add_correctness(st, test, points if verdict is None else 0, points,
                                 verdict is None, verdict or "same text as the reference, bit for bit",
                                 hidden, run.seconds)
            all_right &= verdict is None
            any_right |= verdict is None
        all_right &= self.one_step(st, program, stopped, folder)
        correct = all_right and not stopped and not self.idea_failed.get(st.sid)
        if st.conf.get("races") and not self.a.no_races:
            self.race_check(st, program, folder, correct, any_right)
        if st.conf.get("performance"):
            self.performance(st, program, correct)

    # -- the stage's idea, measured outside its code -----------------------------------------------
    def idea_test(self, st, program, folder):
        """The stage's idea, measured by the grader outside the student's code (rubric: the
        stage's "idea"); a failure takes every correctness point of the stage folder.
          scale:   a hidden scene too large for the idea the stage replaces (stage 02: O(N^3)
                   selection; 06: O(N^2) pair tests), under a time limit that the kit's solution
                   meets many times over, with the reference's output;
          threads: the stage on `threads` OpenMP threads (waiting passively): at least two
                   threads each used `share` of the program's CPU time (read from /proc);
          ranks:   the stage under mpirun on `ranks` processes: every rank used `share` of the
                   ranks' CPU time (read from /proc), so rank 0 does not step everything.
        Both watched kinds also take `max_share`: the most that one thread or rank may use."""
        idea = st.idea
        test = f"{st.sid}: idea ({idea['what']})"
        if isinstance(program, str):
            self.results.add(test, 0, 0, False, f"not run: stage {st.sid} {program.splitlines()[0]}")
            self.idea_failed[st.sid] = f"stage {st.sid} {program.splitlines()[0]}"
            return
        sc = idea["scene"]
        scene = folder / "idea.in"
        speed = ("--speed", sc["speed"]) if "speed" in sc else ()
        self.kit_programs.gen(scene, "--n", sc["n"], "--l", sc["L"], "--r", sc["r"], "--steps",
                              sc["steps"], "--mode", "perf", "--seed",
                              (self.seed * 13 + int(st.sid)) % 2**32, *speed)
        own = self.solution(st.sid)  # the stage's own solution: the same bits, its speed
        start = time.time()
        r = subprocess.run([own, scene, "--quiet", "--threads", str(idea.get("threads", 1)),
                            "--out", folder / "idea.out"], capture_output=True, text=True,
                           env=dict(os.environ, **st.env))
        own_seconds = time.time() - start
        if r.returncode != 0:
            raise RuntimeError(f"the kit's solution of stage {st.sid} failed on {scene}: {r.stderr}")
        expected = (folder / "idea.out").read_text()
        kind = idea["kind"]
        limit = max(idea.get("seconds", 0), idea.get("multiple", 0) * own_seconds)
        threads = str(idea.get("threads", st.threads))
        env = dict(st.env, OMP_WAIT_POLICY="passive") if kind == "threads" else st.env
        # Ranks: the kit's MPI layer (not the student's code) counts the bytes the ranks send.
        report = ["--report", "/plab/out/report.json"] if kind == "ranks" else []
        run = self.run_program(program, scene, ["--quiet", "--threads", threads, "--out",
                                                "/plab/out/out.txt", *report], limit,
                               max(self.rubric["limits"]["output_min_mb"] * 2**20,
                                   4 * len(expected)), st, env=env, watch=kind != "scale",
                               ranks=idea.get("ranks", st.ranks))
        what = f"hidden scene N = {sc['n']}, L = {sc['L']}, S = {sc['steps']}"
        problem = None
        if run.reason and "time limit" in run.reason:
            problem = (f"it did not finish the {what} in {limit:.0f} s (the kit's solution takes "
                       f"{own_seconds:.2f} s): {idea['hint']}")
        elif run.reason or run.rc != 0:
            problem = f"the run on the {what} {run.reason or 'exited ' + str(run.rc)}: " \
                      f"{run.stderr.strip()[-300:]}"
        elif run.read_output() != expected:
            problem = f"its output on the {what} differs from the reference's"
        text = f"the {what}: {run.seconds:.2f} s (the kit's solution: {own_seconds:.2f} s)"
        if problem is None and kind == "ranks" and "max_bytes_per_particle_step" in idea:
            problem, text = self.bytes_sent(idea, run, text)  # counted, so decided first
        if problem is None and kind != "scale":
            problem, text = self.work_shared(idea, run, text)
        if problem:
            self.idea_failed[st.sid] = f"the idea test of stage {st.sid} failed: {problem}"
        self.results.add(test, 0, 0, problem is None, problem or text, False, run.seconds)

    def bytes_sent(self, idea, run, text):
        """(problem or None, text): the bytes the ranks sent a particle and step, counted by the
        kit's MPI layer, against the rubric's most. The halo and the rounds' messages of a
        slow scene are a few bytes; every particle sent to one rank and back, about 75."""
        sc, most = idea["scene"], idea["max_bytes_per_particle_step"]
        try:
            sent = float(json.loads(run.read_output("report.json") or "")["bytes_sent"])
        except (ValueError, KeyError, TypeError):
            return "its run left no report of the bytes its ranks sent", text
        per = sent / (sc["n"] * sc["steps"])
        text += f"; its ranks sent {per:.1f} bytes a particle and step"
        if per > most:
            return (f"its ranks sent {per:.1f} bytes a particle and step (at most {most:g} may: "
                    f"the halo and the rounds' messages; every particle sent to one rank and "
                    f"back is about 75). {idea['hint']}"), text
        return None, text

    def work_shared(self, idea, run, text):
        """(problem or None, text) of a watched run: who did the work, threads or ranks."""
        share = idea["share"]
        if idea["kind"] == "threads":
            pids = {pid for pid, _ in run.cpu}
            if len(pids) != 1:
                return f"expected one process, saw {len(pids)}", text
            parts = sorted(run.cpu.values(), reverse=True)
            who = "threads"
        else:
            per_rank = {}
            for (pid, _), seconds in run.cpu.items():
                per_rank[pid] = per_rank.get(pid, 0) + seconds
            parts = sorted(per_rank.values(), reverse=True)
            who = "ranks"
        total = sum(parts)
        shown = ", ".join(f"{x:.2f}" for x in parts[:8])
        text += f"; CPU seconds of its {who}: {shown} (total {total:.2f})"
        if total < idea["min_cpu_seconds"]:
            return None, text + " (too little to judge: not held against it)"
        need = 2 if idea["kind"] == "threads" else idea["ranks"]
        real = [x for x in parts if x >= share * total]
        if len(real) < need:
            return (f"{len(real)} of its {who} did a real share of the work (at least "
                    f"{100 * share:.0f}% of its CPU time each); {need} must. CPU seconds of its "
                    f"{who}: {shown} (total {total:.2f}). {idea['hint']}"), text
        most = idea.get("max_share", 1.0)
        if parts[0] > most * total:
            return (f"one of its {who} did {100 * parts[0] / total:.0f}% of the work (at most "
                    f"{100 * most:.0f}% may). CPU seconds of its {who}: {shown} (total "
                    f"{total:.2f}). {idea['hint']}"), text
        return None, text

    def race_check(self, st, program, folder, correct, any_right):
        """The stage built again with ThreadSanitizer (clang, LLVM's OpenMP and Archer), in the
        sandbox, and run on a hidden crowded scene with 3 threads: the first data race with file
        and line. A race found costs the rubric's races_points (a racy program is wrong even when
        the race did not change a printed bit on this machine); visible, so that the student
        learns where it is. Not checked (no clang here, the build failed): no points either way.
        Run once the stage passes a correctness test (a race is reported to a stage still
        being fixed); its points only when every correctness test (and the idea test) passed:
        no race in a program that does nothing is worth nothing."""
        test = f"{st.key}: data races (ThreadSanitizer, 3 threads)"
        points = self.rubric["correctness"].get("races_points", 0)
        if not any_right:
            self.results.add(test, 0, points, False, "not checked: the stage passes no "
                             "correctness test yet (its points need every one passed)")
            return
        problem = races.toolchain_problem()
        if isinstance(program, str) or problem:
            why = problem or f"stage {st.sid} {program.splitlines()[0]}"
            self.results.add(test, 0, 0, problem is not None, f"not checked: {why}")
            return
        build = self.sandbox.writable_dir(self.sandbox.box, "build-tsan-")
        mounts = ({"/plab/src": self.sandbox.box / "src"}, {"/plab/build": build})
        target = f"plab-run-{st.sid}-student"
        for argv in (["cmake", "-S", "/plab/src", "-B", "/plab/build", "-G", "Ninja",
                      "-DPLAB_CCACHE=OFF", *races.TSAN_CMAKE_ARGS],
                     ["cmake", "--build", "/plab/build", "--target", target]):
            b = self.sandbox.run(argv, *mounts, "/plab/build", 900, 2**30, memory=False)
            if b.rc != 0 or b.reason:
                self.results.add(test, 0, 0, False, "not checked: the ThreadSanitizer build "
                                 f"failed: {b.reason or b.stderr.strip()[-300:]}")
                return
        tsan = self.sandbox.shared_dir("bin") / f"stage{st.sid}-tsan"
        built = build / "bin" / target
        if built.is_symlink() or not built.is_file():
            self.results.add(test, 0, 0, False, "not checked: no ThreadSanitizer program built")
            return
        shutil.copyfile(built, tsan)
        os.chmod(tsan, 0o755)
        h = self.rubric["correctness"]["hidden_scenes"][2]
        scene = folder / "races.in"
        self.kit_programs.gen(scene, "--n", h["n"], "--l", h["L"], "--r", h["r"], "--steps",
                              h["steps"], "--seed", self.seed + 11)
        env = dict(races.tsan_env(threads=3), **st.env)
        sources = [f.name for f in (self.sandbox.box / "src" / "stages" /
                                    self.kit_folders[st.sid]).iterdir()]
        # ThreadSanitizer reports two unordered accesses of different threads, however far apart
        # in time; but a thread must make them. Under a dynamic schedule on a busy machine one
        # thread may take every chunk of a small loop and the race goes unseen (CI saw it).
        # static,1 deals the iterations round-robin, so every thread works in every loop
        # whatever the timing; dynamic,1 then covers a stage that fixes its own schedule.
        for schedule in races.SCHEDULES:
            run = self.run_program(tsan, scene, ["--quiet", "--threads", "3", "--schedule",
                                                 schedule, "--out", "/plab/out/out.txt"], 300,
                                   2**28, st, env=env, memory=False)
            report = (pathlib.Path(run.stdout).parent / "stderr").read_text(errors="replace")
            race = races.first_race(report, sources)
            if race or run.reason or run.rc not in (0, 3):
                break
        if race:
            self.results.add(test, 0, points, False, race, False, run.seconds)
        elif run.reason or (run.rc not in (0, 3)):
            self.results.add(test, 0, 0, False, "not checked: the ThreadSanitizer run "
                             f"{run.reason or 'exited ' + str(run.rc)}: {report.strip()[-300:]}")
        else:
            text = (f"no data race found (3 threads, schedules {' and '.join(races.SCHEDULES)}, "
                    f"one hidden scene of N = {h['n']}, {h['steps']} steps)")
            if not correct:
                text = "0 points: every correctness test (and the idea test) must pass; " + text
            self.results.add(test, points if correct else 0, points, correct, text, False,
                             run.seconds)


    def ref_seconds(self, st, scene):
        """How long the reference takes on a scene (measured once per scene)."""
        cache = getattr(self, "_ref_times", {})
        self._ref_times = cache
        if (st.reference, scene) not in cache:
            t = time.time()
            subprocess.run([self.solution(st.reference), scene, "--quiet", "--out", os.devnull],
                           capture_output=True)
            cache[st.reference, scene] = time.time() - t
        return cache[st.reference, scene]

    def verdict(self, st, run, scene, expected, how):
        """None when the run printed the expected text, else what went wrong and why."""
        if run.reason:
            return f"{run.reason}\n{run.stderr[-1500:]}".strip()
        if run.rc == 3:
            return run.stderr.strip().splitlines()[-1]  # "stage NN: EXERCISE n (...) is not done yet"
        if run.rc != 0:
            return f"exited with status {run.rc}:\n{run.stderr[-1500:]}".strip()
        actual = run.read_output()
        if actual is None:
            return "exited 0 but wrote no output (a plain file /plab/out/out.txt)"
        if actual == expected:
            return None
        return self.diagnose(st, scene, expected, actual, how)

    def diagnose(self, st, scene, expected, actual, how):
        work = pathlib.Path(tempfile.mkdtemp(prefix="diff-", dir=self.private))
        (work / "expected.out").write_text(expected)
        (work / "actual.out").write_text(actual)
        diff = self.kit_programs.diff(work / "expected.out", work / "actual.out")
        lines = [diff["text"]]
        first = diff["first"] or {}
        reference = self.solution(st.reference)
        if re.fullmatch(r"\d+", first.get("step", "")) and re.fullmatch(r"\d+", first.get("particle", "")):
            k, i = int(first["step"]), int(first["particle"])
            before = velocities(self.kit_programs, work / "expected.out", k - 1, i) if k >= 1 else None
            after = velocities(self.kit_programs, work / "actual.out", k, i) if before else None
            if before and after:
                # The partner from the reference's JSON; the student reads its English lines
                try:
                    said = hidden_module.explain(reference, scene, k - 1, [i]).get(i, {})
                except (subprocess.CalledProcessError, ValueError):
                    said = {}
                ids = [i, said["partner"]] if said.get("event") == "pair" else [i]
                ref = "\n  ".join(subprocess.run(
                    [reference, scene, "--explain", f"{k - 1}:{','.join(map(str, ids))}"],
                    capture_output=True, text=True).stdout.strip().splitlines())
                lines.append(f"In step {k - 1} (from the correct state at its start) the reference "
                             f"has:\n  {ref}")
                lines.append(f"Yours: particle {i} {implied(before, after)}.")
        setup, scene_arg, expected_arg = how
        if setup:  # a hidden scene: regenerate it and its expected output with the solution
            setup += (f"./plab run --stage {st.reference} --impl solution hidden.in --out "
                      f"expected.out && ")
        lines.append(f"Reproduce: {setup}./plab run --stage {st.sid} --impl student {scene_arg} "
                     f"--out mine.out && ./plab diff {expected_arg} mine.out")
        shutil.rmtree(work, ignore_errors=True)
        return "\n".join(lines)

    def one_step(self, st, program, stopped, folder):
        """Each step started from the correct state of a hidden dense scene: how many steps are
        right. The states reach the program through a pipe, never as a file it could copy."""
        corr = self.rubric["correctness"]
        points = corr["one_step_points"]
        h = corr["one_step_scene"]
        test = f"{st.key}: one step at a time on a hidden dense box"
        if isinstance(program, str) or stopped:
            why = f"stage {st.sid} {program}" if isinstance(program, str) else stopped
            self.results.add(test, 0, points, False, f"not run: {why}")
            return False
        scene = folder / "one-step.in"
        self.kit_programs.gen(scene, "--n", h["n"], "--l", h["L"], "--r", h["r"], "--steps",
                              h["steps"], "--seed", (self.seed * 7 + int(st.sid)) % 2**32)
        states = self.expected_for(st, scene, folder / "one-step.full")
        # Every other state (steps 0, 2, 4, ...), each a start: the state a step must reach is
        # never in the input (the run's own output would otherwise be the next block).
        blocks, kept = {}, []
        for line in states.splitlines():
            words = line.split()
            blocks.setdefault(words[0], []).append(" ".join(words[:6]))
        for k, lines in blocks.items():
            if int(k) % 2 == 0 and int(k) < int(h["steps"]):
                kept += lines
        states = "\n".join(kept) + "\n"
        (folder / "one-step.states").write_text(states)
        reference = self.solution(st.reference)
        ref = subprocess.run([reference, scene, "--step-from-each", folder / "one-step.states"],
                             capture_output=True, text=True, check=True).stdout
        limits = self.rubric["limits"]
        run = self.run_program(program, scene, ["--threads", st.threads, "--step-from-each",
                                                "STDIN", "--out", "/plab/out/out.txt"],
                               max(limits["min_seconds"], 10 * limits["time_multiple"]),
                               max(limits["output_min_mb"] * 2**20, 4 * len(ref)), st,
                               stdin_text=states)
        text_out = run.read_output() if run.rc == 0 and not run.reason else None
        # Step by step, word for word (plab diff --json; its output may be anything, and a step
        # it printed wrong or not at all is a wrong step): one call per stage, not per test.
        (folder / "one-step.expected").write_text(ref)
        (folder / "one-step.actual").write_text(text_out or "")
        steps = self.kit_programs.diff(folder / "one-step.expected",
                                       folder / "one-step.actual")["steps"]
        want = [m["step"] for m in steps]
        right = [m["step"] for m in steps if m["equal"]]
        wrong = sorted(set(want) - set(right))
        score = points * len(right) / max(1, len(want))
        text = (f"{len(right)} of {len(want)} steps right when each starts from the correct state "
                "(every other step's start given)")
        if run.reason or run.rc:
            text += f"; the run {run.reason or 'exited ' + str(run.rc)}: {run.stderr.strip()[-300:]}"
        elif wrong:
            text += f"; wrong: steps {', '.join(map(str, wrong[:12]))}{' ...' if len(wrong) > 12 else ''}"
        ok = not wrong and not run.rc and not run.reason
        self.add_correctness(st, test, score, points, ok, text, False, run.seconds)
        return ok

    def performance(self, st, program, correct):
        perf = self.rubric["performance"]
        test = f"{st.key}: performance"
        if isinstance(program, str) or not correct:
            self.results.add(test, 0, perf["points"], False,
                             "not timed: every correctness test must pass first")
            return
        s = perf["scene"]
        scene = self.private / f"perf-{st.key}.in"
        # The grading's secret seed: a program cannot recognise the timed scene and skip the work
        self.kit_programs.gen(scene, "--n", s["n"], "--l", s["L"], "--r", s["r"], "--steps",
                              s["steps"], "--mode", "perf", "--seed",
                              (self.seed * 31 + int(st.sid) + 1) % 2**32)
        limits = self.rubric["limits"]
        own = self.solution(st.sid)
        kit_prog = own if own.exists() else self.solution(self.manifest["reference_stage"])
        r = subprocess.run([kit_prog, scene, "--quiet", "--threads", st.threads, "--out",
                            self.private / f"perf-{st.key}.out"], capture_output=True, text=True,
                           env=dict(os.environ, **st.env))
        if r.returncode != 0:
            raise RuntimeError(f"the reference failed on {scene}: {r.stderr}")
        expected = (self.private / f"perf-{st.key}.out").read_text()
        ref_prog = self.sandbox.shared_dir("bin") / f"reference-{st.key}"  # the sandbox's uid
        shutil.copyfile(kit_prog, ref_prog)  # may not read the kit's build folder
        os.chmod(ref_prog, 0o755)
        args = ["--quiet", "--threads", st.threads, "--out", "/plab/out/out.txt"]
        cap = limits["output_min_mb"] * 2**20
        # Runs alternate (reference, submission, ...) so that a change in the machine's load
        # falls on both alike; the reference runs in the same sandbox, paying its costs alike.
        ref, mine = [], []
        try:
            self.timed_runs(st, program, ref_prog, scene, args, cap, ref, mine, expected)
        finally:
            ref_prog.unlink()  # no later stage may find a correct program beside its own
        if len(mine) < perf["runs"]:
            return
        self.score_performance(st, test, ref, mine)

    def timed_runs(self, st, program, ref_prog, scene, args, cap, ref, mine, expected):
        """Alternate runs of the reference and the submission; each of the submission's outputs
        is compared with the reference's like any other run's (a fast wrong program earns
        nothing)."""
        limits, perf = self.rubric["limits"], self.rubric["performance"]
        test = f"{st.key}: performance"
        for _ in range(perf["runs"]):
            r = self.run_program(ref_prog, scene, args, 3600, cap, st)
            if r.rc != 0:
                raise RuntimeError(f"the reference failed on {scene}: {r.stderr}")
            ref.append(r.seconds)
            r = self.run_program(program, scene, args,
                                 max(limits["min_seconds"], limits["time_multiple"] * max(ref)),
                                 cap, st)
            if r.rc != 0 or r.reason:
                self.results.add(test, 0, perf["points"], False,
                                 f"the timed run {r.reason or 'exited ' + str(r.rc)}")
                return
            if r.read_output() != expected:
                self.results.add(test, 0, perf["points"], False,
                                 "the timed run's output differs from the reference's (the "
                                 "timed scene is a hidden one: every run must be right)")
                return
            mine.append(r.seconds)

    def score_performance(self, st, test, ref, mine):
        perf, s = self.rubric["performance"], self.rubric["performance"]["scene"]
        rm, mm = statistics.median(ref), statistics.median(mine)
        spread = max((max(ref) - min(ref)) / rm, (max(mine) - min(mine)) / mm)
        ratio = mm / max(rm, 1e-3)
        # Full points up to full_up_to, none from zero_at_ratio, linear in log(ratio) between:
        # bounded, continuous, and no division by a small time (the reference's is >= 1 ms).
        full, zero = perf["full_up_to_ratio"], perf["zero_at_ratio"]
        fraction = leaderboard.fraction(ratio, full, zero)
        text = (f"median {mm:.3f} s against the reference's {rm:.3f} s (ratio {ratio:.2f}; full "
                f"points up to {full}, none from {zero}), {perf['runs']} runs each on "
                f"N = {s['n']}, S = {s['steps']}, {st.threads} thread(s); spread {100 * spread:.0f}%")
        if spread > perf["noisy_spread"]:
            text += f". TOO NOISY (spread above {100 * perf['noisy_spread']:.0f}%): rerun on a quieter machine"
        if perf.get("relative", "reference") != "reference":
            text += (f". The rubric scores these points against the class ({perf['relative']}): "
                     "plab grade --class gives them again from every student's time")
        # The leaderboard holds the time the grader measured, never one the program printed
        self.results.leaderboard.append(leaderboard.entry(st.key, mm))
        self.results.add(test, perf["points"] * fraction, perf["points"], fraction >= 0.999, text,
                         False, sum(mine))

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

    def grade(self):
        self.kit_folders = {p.name[:2]: p.name for p in sorted((self.kit / "stages").iterdir())
                            if p.is_dir() and p.name[:2].isdigit()}
        wanted = [s.split("-")[0] for s in self.a.stages.split(",")] if self.a.stages else []
        for sid in wanted:
            self.entries([sid])  # a stage the rubric does not know: refused before any work
        try:
            found, layout = upload.find_stages(self.a.submission, self.kit_folders, wanted,
                                               self.private)
        except upload.UploadError as e:
            raise Refused(f"the upload is not a submission: {e}")
        self.notes.append(f"submission: {layout}")
        print(f"submission: {layout}", flush=True)
        stages = self.entries(wanted or sorted(found))
        if self.a.stages and any("-" in s for s in self.a.stages.split(",")):
            stages = [s for s in stages if s.key in self.a.stages.split(",")]
        runnable = []
        for st in stages:
            if st.gpu and not self.gpu_here():
                self.notes.append(f"{st.title}: not graded: no CUDA device on this machine")
                print(f"{st.title}: skipped: no CUDA device on this machine", flush=True)
            else:
                runnable.append(st)
        built = self.build(runnable, found) if runnable else {}
        for st in runnable:
            print(st.title, flush=True)
            self.grade_stage(st, built[st.sid])

