"""The correctness tests: public scenes against their golden files, hidden scenes from the
grading's seed, one step at a time from every printed state."""
import subprocess

from plab.grade import hidden as hidden_module
from plab.grade.build import unbuilt
from plab.grade.run import stderr_tail


class Correctness:
    """The correctness tests: a mixin of Grader (plab.grade.grader)."""

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
            how = (f"PYTHONPATH=kit/python python3 -m plab.grade.hidden --seed {self.seed} "
                   f"--stage {st.sid} --only {name} --out hidden.in && ")
            tests.append((name, scene, expected, corr["hidden_points_each"], True,
                          (how, "hidden.in", "expected.out")))
        return tests

    def add_correctness(self, st, test, score, points, passed, text, hidden=False, seconds=0.0):
        """A correctness test's result; none of its points when the stage's idea test failed."""
        failed = self.idea_failed.get(st.sid) or self.idea_failed.get(st.key)
        if failed and score:
            text = (f"counts 0 (it would earn {score:g}): {failed}\n{text}")
            score, passed = 0, False
        self.results.add(test, score, points, passed, text, hidden, seconds)

    def one_step(self, st, program, stopped, folder):
        """Each step started from the correct state of a hidden dense scene: how many steps are
        right. The states reach the program through a pipe, never as a file it could copy."""
        corr = self.rubric["correctness"]
        points = corr["one_step_points"]
        h = corr["one_step_scene"]
        test = f"{st.key}: one step at a time on a hidden dense box"
        if isinstance(program, str) or stopped:
            why = unbuilt(st.sid, program) if isinstance(program, str) else stopped
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
            text += f"; the run {run.reason or 'exited ' + str(run.rc)}: {stderr_tail(run.stderr)}"
        elif wrong:
            text += f"; wrong: steps {', '.join(map(str, wrong[:12]))}{' ...' if len(wrong) > 12 else ''}"
        ok = not wrong and not run.rc and not run.reason
        self.add_correctness(st, test, score, points, ok, text, False, run.seconds)
        return ok
