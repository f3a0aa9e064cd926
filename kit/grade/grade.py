#!/usr/bin/env python3
"""plab grade: builds a submission's stages against the kit's own code, checks them against the
reference, and writes Gradescope's results.json, JUnit XML and a readable summary.

`./plab grade --submission DIR` starts this with the kit's folders; see `./plab grade --help`.
Every threshold and point comes from the rubric (kit/grade/rubric.json). results.json is written
after every test, so whatever happens later (a crash, a hang, the grader itself failing) the tests
already run keep their results.
"""
import argparse
import json
import math
import os
import pathlib
import re
import resource
import secrets
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from xml.sax.saxutils import escape, quoteattr

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import hidden as hidden_module  # noqa: E402  (kit/grade/hidden.py: the hidden scenes)

SOURCES = ("*.cpp", "*.hpp", "*.h", "*.cu", "*.cuh")  # what is taken from a submission's stage


class Results:
    """The tests so far, written out (JSON for Gradescope, JUnit XML) after each one."""

    def __init__(self, json_path, junit_path):
        self.json_path, self.junit_path = pathlib.Path(json_path), pathlib.Path(junit_path)
        self.tests, self.notes, self.start = [], [], time.time()
        self.write()

    def add(self, name, score, max_score, passed, output, hidden=False, seconds=0.0):
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


class Run:
    """One run of an untrusted program, ended by its limits."""

    def __init__(self, rc, seconds, reason, stdout, stderr, work):
        self.rc, self.seconds, self.reason = rc, seconds, reason
        self.stdout, self.stderr, self.work = stdout, stderr, work


class Sandbox:
    """Starts programs with a wall-time limit, a memory limit, a cap on output, a process limit and
    a fresh working directory; kills the whole process group at the limit."""

    def __init__(self, scratch, limits):
        self.scratch, self.limits = scratch, limits

    def run(self, make_command, seconds, output_bytes, gpu=False):
        work = pathlib.Path(tempfile.mkdtemp(prefix="run-", dir=self.scratch))
        command = [str(c) for c in make_command(work)]
        memory = self.limits["memory_mb"] * 2**20
        processes = self.limits["processes"]

        def limit():
            if not gpu:  # CUDA reserves far more address space than it uses
                resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
            resource.setrlimit(resource.RLIMIT_FSIZE, (output_bytes, output_bytes))
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
            try:
                resource.setrlimit(resource.RLIMIT_NPROC, (processes, processes))
            except (ValueError, OSError):
                pass

        env = dict(os.environ, OMP_WAIT_POLICY="PASSIVE")
        start = time.time()
        with open(work / "stdout", "wb") as out, open(work / "stderr", "wb") as err:
            proc = subprocess.Popen(command, cwd=work, stdout=out, stderr=err, env=env,
                                    preexec_fn=limit, start_new_session=True)
            reason = None
            try:
                proc.wait(timeout=seconds)
            except subprocess.TimeoutExpired:
                reason = f"stopped after {seconds:.0f} s (the time limit): an endless loop?"
            finally:
                try:
                    os.killpg(proc.pid, signal.SIGKILL)  # the program and anything it started
                except ProcessLookupError:
                    pass
                proc.wait()
        took = time.time() - start
        rc = proc.returncode
        if reason is None and rc < 0:
            sig = signal.Signals(-rc)
            if sig == signal.SIGXFSZ:
                reason = f"stopped: it wrote more than {output_bytes / 2**20:.0f} MB (the output cap)"
            else:
                reason = f"crashed with signal {-rc} ({sig.name})"
        stderr = (work / "stderr").read_bytes()[-4000:].decode(errors="replace")
        if reason is None and rc != 0 and ("bad_alloc" in stderr or "memory" in stderr.lower()):
            reason = f"ran out of memory (limit {self.limits['memory_mb']} MB)"
        return Run(rc, took, reason, work / "stdout", stderr, work)


def blocks(text):
    """{step: [line fields]} of a print-mode output."""
    found = {}
    for line in text.splitlines():
        parts = line.split()
        if len(parts) >= 6:
            found.setdefault(int(parts[0]), []).append(parts)
    return found


def implied(before, after):
    """What a particle did in a step, from its velocities before and after (printed fields)."""
    v0 = [float(v) for v in before[4:6]]
    v1 = [float(v) for v in after[4:6]]
    if v0 == v1:
        return "moved freely (velocity unchanged)"
    if [abs(v) for v in v0] == [abs(v) for v in v1]:
        return "hit a wall (a velocity component flipped)"
    return f"changed velocity as in a pair collision ({v0[0]:.8f}, {v0[1]:.8f}) -> ({v1[0]:.8f}, {v1[1]:.8f})"


class Grader:
    def __init__(self, a):
        self.a = a
        self.kit = pathlib.Path(a.kit_source)
        self.kit_build = pathlib.Path(a.kit_build)
        self.rubric = json.loads(pathlib.Path(a.rubric).read_text())
        self.results = Results(a.out, a.junit)
        self.scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-grade-",
                                                     dir=a.scratch or None))
        self.sandbox = Sandbox(self.scratch, self.rubric["limits"])
        self.plab = self.kit_build / "bin" / "plab"
        self.manifest = json.loads((self.kit / "datasets" / "manifest.json").read_text())
        self.seed = a.hidden_seed if a.hidden_seed is not None else secrets.randbelow(2**32)
        self.cpu_reference = (self.kit_build / "bin" /
                              f"plab-run-{self.manifest['reference_stage']}-solution")
        if not self.cpu_reference.exists():
            raise RuntimeError(f"the kit's reference program {self.cpu_reference} is not built: "
                               "run ./plab once in the kit")

    # -- building -------------------------------------------------------------------------------
    def build(self, stages):
        """Builds each stage's plab-run-NN-student from the submission's sources and the kit's
        own CMake, kit and runner. Returns {stage: program or error text}."""
        src, build = self.scratch / "src", self.scratch / "build"
        src.mkdir(parents=True)
        for item in ("CMakeLists.txt", "CMakePresets.json", "cmake", "kit", "docs"):
            source = self.kit / item
            if source.is_dir():
                shutil.copytree(source, src / item)
            else:
                shutil.copy2(source, src / item)
        built = {}
        for stage, folder in stages.items():
            ours = self.kit / "stages" / folder
            theirs = pathlib.Path(self.a.submission) / "stages" / folder
            dest = src / "stages" / folder
            dest.mkdir(parents=True)
            shutil.copy2(ours / "CMakeLists.txt", dest / "CMakeLists.txt")  # never theirs
            if not theirs.is_dir():
                built[stage] = f"the submission has no stages/{folder}/"
                continue
            for pattern in SOURCES:
                for f in theirs.glob(pattern):
                    shutil.copy2(f, dest / f.name)
        print(f"building the submission's stages {', '.join(stages)} in {build}", flush=True)
        gen = ["-G", "Ninja"] if shutil.which("ninja") else []
        conf = subprocess.run(["cmake", "-S", src, "-B", build, *gen, "-DCMAKE_BUILD_TYPE=Release",
                               "-DPLAB_BUILD_TESTS=OFF"], capture_output=True, text=True)
        if conf.returncode != 0:
            return {s: "configuring failed:\n" + conf.stdout[-3000:] + conf.stderr[-3000:]
                    for s in stages}
        for stage in stages:
            if stage in built:
                continue
            target = f"plab-run-{stage}-student"
            try:
                b = subprocess.run(["cmake", "--build", build, "--target", target, "-j",
                                    str(os.cpu_count() or 2)], capture_output=True, text=True,
                                   timeout=900)
                ok, log = b.returncode == 0, b.stdout + b.stderr
            except subprocess.TimeoutExpired:
                ok, log = False, "the build took more than 15 minutes"
            program = build / "bin" / target
            if ok and program.exists():
                built[stage] = program
            else:
                errors = [ln for ln in log.splitlines() if "error" in ln.lower()]
                built[stage] = "it does not compile:\n" + "\n".join((errors or log.splitlines())[:25])
        return built

    # -- one stage --------------------------------------------------------------------------------
    def reference(self, stage):
        own = self.kit_build / "bin" / f"plab-run-{stage}-solution"
        cpu = self.kit_build / "bin" / f"plab-run-{self.manifest['reference_stage']}-solution"
        return own if own.exists() else cpu

    def expected_for(self, stage, scene, out):
        """The reference's output of a scene (computed now, in the grader's own folder)."""
        ref = self.cpu_reference
        r = subprocess.run([ref, scene, "--quiet", "--out", out], capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"the reference failed on {scene}: {r.stderr}")
        return pathlib.Path(out).read_text()

    def grade_stage(self, stage, program, conf):
        name_of = f"stage {stage}"
        if isinstance(program, str):
            self.results.notes.append(f"{name_of}: {program.splitlines()[0]}")
        gpu = conf.get("gpu", False)
        threads = str(conf.get("threads", 1))
        limits = self.rubric["limits"]
        stopped = None  # why later runs of this stage are not started (a time-out)
        stage_scratch = self.scratch / f"stage{stage}"
        stage_scratch.mkdir()
        corr = self.rubric["correctness"]
        tests = []  # (test name, scene, expected text, points, hidden, how to make the scene)
        for d in self.manifest["scenes"]:
            if d["size"] in conf["sizes"]:
                scene = self.kit / "datasets" / "scenes" / f"{d['name']}.in"
                golden = self.kit / "datasets" / "golden" / f"{d['name']}.out"
                tests.append((d["name"], scene, golden.read_text(), corr["public_points_each"],
                              False, ("", str(scene.relative_to(self.kit)))))
        for name, scene in hidden_module.hidden_scenes(self.seed, stage, self.rubric, self.plab,
                                                       stage_scratch):
            expected = self.expected_for(stage, scene, stage_scratch / f"{name}.out")
            how = (f"python3 kit/grade/hidden.py --seed {self.seed} --stage {stage} --only {name} "
                   "--out hidden.in && ")
            tests.append((name, scene, expected, corr["hidden_points_each"], True,
                          (how, "hidden.in")))
        all_right = True
        for name, scene, expected, points, hidden, how in tests:
            test = f"{stage}: {'hidden' if hidden else 'public'} {name}"
            if isinstance(program, str):
                self.results.add(test, 0, points, False, f"not run: stage {stage} {program}", hidden)
                all_right = False
                continue
            if stopped:
                self.results.add(test, 0, points, False, f"not run: {stopped}", hidden)
                all_right = False
                continue
            budget = max(limits["min_seconds"], limits["time_multiple"] * self.ref_seconds(scene))
            cap = max(limits["output_min_mb"] * 2**20, limits["output_multiple"] * len(expected))
            run = self.sandbox.run(lambda w: [program, scene, "--quiet", "--threads", threads,
                                              "--out", w / "out.txt"], budget, cap, gpu)
            verdict = self.verdict(stage, run, scene, expected, how)
            if run.reason and "time limit" in run.reason:
                stopped = f"an earlier test of stage {stage} ran out of time ({name})"
            self.results.add(test, points if verdict is None else 0, points, verdict is None,
                             verdict or "same text as the reference, bit for bit", hidden,
                             run.seconds)
            all_right &= verdict is None
        self.one_step(stage, program, conf, stopped, gpu, threads)
        if conf.get("performance"):
            self.performance(stage, program, conf, all_right and not stopped, gpu, threads)

    def ref_seconds(self, scene):
        """How long the reference takes on a scene (measured once per scene)."""
        cache = getattr(self, "_ref_times", {})
        self._ref_times = cache
        if scene not in cache:
            t = time.time()
            subprocess.run([self.cpu_reference, scene, "--quiet", "--out", os.devnull],
                           capture_output=True)
            cache[scene] = time.time() - t
        return cache[scene]

    def verdict(self, stage, run, scene, expected, how):
        """None when the run printed the expected text, else what went wrong and why."""
        if run.reason:
            return f"{run.reason}\n{run.stderr[-1500:]}".strip()
        if run.rc == 3:
            return run.stderr.strip().splitlines()[-1]  # "stage NN: EXERCISE n (...) is not done yet"
        if run.rc != 0:
            return f"exited with status {run.rc}:\n{run.stderr[-1500:]}".strip()
        out = run.work / "out.txt"
        if not out.exists():
            return "exited 0 but wrote no output"
        actual = out.read_text(errors="replace")
        if actual == expected:
            return None
        return self.diagnose(stage, scene, expected, actual, out, how)

    def diagnose(self, stage, scene, expected, actual, actual_path, how):
        expected_path = actual_path.with_name("expected.out")
        expected_path.write_text(expected)
        diff = subprocess.run([self.plab, "diff", expected_path, actual_path],
                              capture_output=True, text=True).stdout.strip()
        lines = [diff]
        m = re.search(r"step (\d+), particle (\d+)", diff)
        if m:
            k, i = int(m.group(1)), int(m.group(2))
            exp_blocks, act_blocks = blocks(expected), blocks(actual)
            if k >= 1 and k - 1 in exp_blocks and k in act_blocks and i < len(act_blocks[k]):
                ref = subprocess.run([self.cpu_reference, scene, "--explain", f"{k - 1}:{i}"],
                                     capture_output=True, text=True).stdout.strip()
                partner = re.search(r"with (\d+)", ref)
                if partner:
                    j = int(partner.group(1))
                    ref += "\n  " + subprocess.run(
                        [self.cpu_reference, scene, "--explain", f"{k - 1}:{j}"],
                        capture_output=True, text=True).stdout.strip()
                lines.append(f"In step {k - 1} (from the correct state at its start) the reference "
                             f"has:\n  {ref}")
                lines.append(f"Yours: particle {i} {implied(exp_blocks[k - 1][i], act_blocks[k][i])}.")
        setup, scene_arg = how
        lines.append(f"Reproduce: {setup}./plab run --stage {stage} --impl student {scene_arg} "
                     f"--out mine.out && ./plab diff EXPECTED mine.out")
        return "\n".join(lines)

    def one_step(self, stage, program, conf, stopped, gpu, threads):
        """Each step started from the correct state: how many steps are right."""
        corr = self.rubric["correctness"]
        points = corr["one_step_points"]
        name = corr["one_step_dataset"]
        test = f"{stage}: one step at a time on {name}"
        if isinstance(program, str) or stopped:
            why = f"stage {stage} {program}" if isinstance(program, str) else stopped
            self.results.add(test, 0, points, False, f"not run: {why}")
            return
        scene = self.kit / "datasets" / "scenes" / f"{name}.in"
        golden = self.kit / "datasets" / "golden" / f"{name}.out"
        ref = subprocess.run([self.cpu_reference, scene, "--step-from-each", golden],
                             capture_output=True, text=True, check=True).stdout
        limits = self.rubric["limits"]
        run = self.sandbox.run(lambda w: [program, scene, "--threads", threads, "--step-from-each",
                                          golden, "--out", w / "out.txt"],
                               max(limits["min_seconds"], 10 * limits["time_multiple"]),
                               max(limits["output_min_mb"] * 2**20, 4 * len(ref)), gpu)
        want = blocks(ref)
        got = blocks((run.work / "out.txt").read_text(errors="replace")) if (
            run.rc == 0 and (run.work / "out.txt").exists()) else {}
        right = [s for s in want if got.get(s) == want[s]]
        wrong = sorted(set(want) - set(right))
        score = points * len(right) / max(1, len(want))
        text = f"{len(right)} of {len(want)} steps right when each starts from the correct state"
        if run.reason or run.rc:
            text += f"; the run {run.reason or 'exited ' + str(run.rc)}: {run.stderr.strip()[-300:]}"
        elif wrong:
            text += f"; wrong: steps {', '.join(map(str, wrong[:12]))}{' ...' if len(wrong) > 12 else ''}"
        self.results.add(test, score, points, not wrong and not run.rc, text, False, run.seconds)

    def performance(self, stage, program, conf, correct, gpu, threads):
        perf = self.rubric["performance"]
        test = f"{stage}: performance"
        if isinstance(program, str) or not correct:
            self.results.add(test, 0, perf["points"], False,
                             "not timed: every correctness test must pass first")
            return
        s = perf["scene"]
        scene = self.scratch / f"perf-{stage}.in"
        subprocess.run([str(x) for x in [self.plab, "gen", "--n", s["n"], "--l", s["L"], "--r",
                                         s["r"], "--steps", s["steps"], "--mode", "perf",
                                         "--seed", 1, "--out", scene]], check=True)
        limits = self.rubric["limits"]
        ref_prog = self.reference(stage)

        # Runs alternate (reference, submission, ...) so that a change in the machine's load
        # falls on both alike.
        ref, mine = [], []
        for _ in range(perf["runs"]):
            # the reference runs under the same sandbox, so both pay its (small) costs alike
            r = self.sandbox.run(lambda w: [ref_prog, scene, "--quiet", "--threads", threads,
                                            "--out", os.devnull], 3600, 2**30, gpu)
            if r.rc != 0:
                raise RuntimeError(f"the reference failed on {scene}: {r.stderr}")
            ref.append(r.seconds)
            r = self.sandbox.run(lambda w: [program, scene, "--quiet", "--threads", threads,
                                            "--out", os.devnull],
                                 max(limits["min_seconds"], limits["time_multiple"] * max(ref)),
                                 limits["output_min_mb"] * 2**20, gpu)
            if r.rc != 0 or r.reason:
                self.results.add(test, 0, perf["points"], False,
                                 f"the timed run {r.reason or 'exited ' + str(r.rc)}")
                return
            mine.append(r.seconds)
        rm, mm = statistics.median(ref), statistics.median(mine)
        spread = max((max(ref) - min(ref)) / rm, (max(mine) - min(mine)) / mm)
        ratio = mm / max(rm, 1e-3)
        # Full points up to full_up_to, none from zero_at_ratio, linear in log(ratio) between:
        # bounded, continuous, and no division by a small time (the reference's is >= 1 ms).
        full, zero = perf["full_up_to_ratio"], perf["zero_at_ratio"]
        fraction = min(1.0, max(0.0, 1 - math.log(max(ratio, full) / full) / math.log(zero / full)))
        text = (f"median {mm:.3f} s against the reference's {rm:.3f} s (ratio {ratio:.2f}; full "
                f"points up to {full}, none from {zero}), {perf['runs']} runs each on "
                f"N = {s['n']}, S = {s['steps']}, {threads} thread(s); spread {100 * spread:.0f}%")
        if spread > perf["noisy_spread"]:
            text += f". TOO NOISY (spread above {100 * perf['noisy_spread']:.0f}%): rerun on a quieter machine"
        self.results.add(test, perf["points"] * fraction, perf["points"], fraction >= 0.999, text,
                         False, sum(mine))

    def grade(self):
        folders = {p.name[:2]: p.name for p in sorted((self.kit / "stages").iterdir())
                   if p.is_dir() and p.name[:2].isdigit()}
        wanted = self.a.stages.split(",") if self.a.stages else sorted(folders)
        for s in wanted:
            if s not in folders or s not in self.rubric["stages"]:
                raise SystemExit(f"plab grade: no stage {s} in the kit's rubric")
        stages = {s: folders[s] for s in wanted}
        self.results.notes.append(f"submission: {self.a.submission}; stages {', '.join(stages)}; "
                                  f"hidden scenes from this grading's secret seed")
        built = self.build(stages)
        for stage in stages:
            conf = self.rubric["stages"][stage]
            if conf.get("gpu") and subprocess.run(
                    [self.reference(stage), self.kit / "datasets/scenes/course-1.in", "--quiet",
                     "--out", os.devnull], capture_output=True).returncode == 4:
                self.results.notes.append(f"stage {stage}: not graded: no CUDA device here")
                continue
            print(f"stage {stage}", flush=True)
            self.grade_stage(stage, built[stage], conf)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--submission", required=True)
    ap.add_argument("--stages", default="")
    ap.add_argument("--out", default="results.json")
    ap.add_argument("--junit", default="")
    ap.add_argument("--hidden-seed", type=int)
    ap.add_argument("--rubric", required=True)
    ap.add_argument("--kit-source", required=True)
    ap.add_argument("--kit-build", required=True)
    ap.add_argument("--scratch", default="")
    ap.add_argument("--keep", action="store_true")
    a = ap.parse_args()
    a.junit = a.junit or str(pathlib.Path(a.out).with_suffix(".xml"))
    g = None
    try:
        g = Grader(a)
        g.grade()
    except SystemExit:
        raise
    except BaseException:  # the grader's own failure still leaves a results.json
        if g is None:
            g = type("G", (), {})()
            g.results = Results(a.out, a.junit)
        g.results.add("grader error", 0, 0, False, traceback.format_exc())
    finally:
        if g is not None:
            total, most = g.results.total()
            print(f"\ntotal: {total:.2f} / {most:g}   (results: {a.out}, JUnit: {a.junit})")
            for note in g.results.notes:
                print(f"  {note}")
            failed = [t for t in g.results.tests if t["status"] == "failed"]
            shown = set()
            for t in failed:
                stage = t["name"].split(":")[0]
                if stage not in shown:
                    shown.add(stage)
                    print(f"\nfirst failure of stage {stage}: {t['name']}\n"
                          + "\n".join("  " + ln for ln in t["output"].splitlines()[:14]))
            if hasattr(g, "scratch") and not a.keep:
                shutil.rmtree(g.scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
