"""Running student code in the sandbox, the reference's expected outputs, and the verdict of a
run (with its diagnosis: where it first differs and what the reference did there)."""
import os
import pathlib
import shutil
import subprocess
import tempfile
import time

from plab import plabio  # the kit's formats, read and compared by its C++ programs
from plab.grade import hidden as hidden_module


def implied(before, after):
    """What a particle did in a step, from its printed velocities (vx, vy) before and after."""
    v0, v1 = list(before), list(after)
    if v0 == v1:
        return "moved freely (velocity unchanged)"
    if [abs(v) for v in v0] == [abs(v) for v in v1]:
        return "hit a wall (a velocity component flipped)"
    return f"changed velocity as in a pair collision ({v0[0]:.8f}, {v0[1]:.8f}) -> ({v1[0]:.8f}, {v1[1]:.8f})"


def pair_partner(plab, before_path, after_path, step, i):
    """The particle that particle i collided with in `step`, as the student's output shows it:
    the one whose velocity also changed, not as a wall flips it, with the pair's momentum the same
    before and after (equal masses; the outputs print 8 decimals), or None."""
    try:
        b = plab.read_output(before_path, steps=(step - 1, step - 1))["blocks"]
        a = plab.read_output(after_path, steps=(step, step))["blocks"]
    except plabio.FormatError:
        return None
    if not b or not a or len(b[0]["vx"]) != len(a[0]["vx"]) or i >= len(b[0]["vx"]):
        return None
    b, a = b[0], a[0]
    best, off = None, None
    for j in range(len(b["vx"])):
        v0, v1 = (b["vx"][j], b["vy"][j]), (a["vx"][j], a["vy"][j])
        if j == i or v0 == v1 or [abs(v) for v in v0] == [abs(v) for v in v1]:
            continue
        d = max(abs(b["vx"][i] + v0[0] - a["vx"][i] - v1[0]), abs(b["vy"][i] + v0[1] - a["vy"][i] - v1[1]))
        if off is None or d < off:
            best, off = j, d
    scale = max(1.0, *(abs(v) for v in (b["vx"][i], b["vy"][i])))
    return best if off is not None and off <= 1e-6 * scale else None


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


#: Open MPI inside the sandbox: the ranks of one machine talk through its shared-memory transport.
#: Its default (UCX) probes the network devices and /sys, which the sandbox hides, and spent 1.4 s
#: of every run doing so: a stage 08 run of a small scene took 1.6 s, and 0.2 s with these (Open
#: MPI 4.1, the kit's 2-core machine, 2026-12-06). The bytes the ranks send are counted in the MPI
#: calls, whatever carries them.
MPI_IN_SANDBOX = {"OMPI_MCA_pml": "ob1", "OMPI_MCA_btl": "self,vader",
                  # hwloc's "failed to find sysfs cpu topology directory, aborting linux
                  # discovery": the sandbox hides /sys; not the student's error
                  "HWLOC_HIDE_ERRORS": "2"}


def stderr_tail(text, limit=300):
    """The last whole lines of a run's stderr within `limit` characters, without the MPI
    libraries' notes about the sandbox (hwloc's topology discovery): what a student reads as
    the reason their run failed."""
    lines = [ln for ln in (text or "").strip().splitlines()
             if ln.strip() and "hwloc" not in ln and "aborting linux discovery" not in ln]
    out = []
    for ln in reversed(lines):
        if out and sum(len(x) + 1 for x in out) + len(ln) > limit:
            break
        out.insert(0, ln if len(ln) <= limit else "..." + ln[-limit:])
    return "\n".join(out)


def launcher_crashed(run):
    """Whether mpirun itself (not a rank) crashed in its forwarding of stdin: its backtrace."""
    return bool(run.reason and "signal" in run.reason and "mca_iof" in (run.stderr or ""))


class Run:
    """Running and judging one run: a mixin of Grader (plab.grade.grader)."""

    # -- running student code --------------------------------------------------------------------
    def run_program(self, program, scene, args, seconds, cap, st, stdin_text=None, env=None,
                    memory=True, watch=False, ranks=None, extra_ro=None):
        """Runs a stage program in the sandbox on one scene, under its neutral names (`ranks`:
        how many processes mpirun starts, default the stage's; `watch`: Run.cpu)."""
        ranks = st.ranks if ranks is None else ranks
        run_dir = pathlib.Path(tempfile.mkdtemp(prefix="run-", dir=self.sandbox.box))
        os.chmod(run_dir, 0o755)
        shutil.copyfile(scene, run_dir / "scene.in")
        os.chmod(run_dir / "scene.in", 0o644)
        out = self.sandbox.writable_dir(run_dir, "out-")
        ro = {"/plab/stage": program, "/plab/scene.in": run_dir / "scene.in", **(extra_ro or {})}
        argv = ["/plab/stage", "/plab/scene.in", *args]
        if stdin_text is not None:  # read through a pipe, never a file the program could reopen
            argv = ["/plab/stage", "/plab/scene.in", *[a if a != "STDIN" else "/dev/stdin"
                                                       for a in args]]
        if ranks > 1:  # every rank in the same sandbox, under the same limits
            argv = [shutil.which("mpirun") or "mpirun", "--quiet", "--oversubscribe", "-np",
                    str(ranks), *argv]
            env = {**(env or st.env), **MPI_IN_SANDBOX}
        for attempt in range(3):
            log = pathlib.Path(tempfile.mkdtemp(prefix="log-", dir=self.private))
            run = self.sandbox.run(argv, ro, {"/plab/out": out}, "/plab/out", seconds, cap,
                                   gpu=st.gpu, env=env or st.env, log_dir=log,
                                   stdin_text=stdin_text, memory=memory, watch=watch)
            if not (ranks > 1 and launcher_crashed(run)):
                break
            # Open MPI 4.1's mpirun itself crashes now and then while it forwards a pipe on stdin
            # to rank 0 (orte_iof_hnp_read_local_handler: 3 runs in 30 of the one-step test,
            # the kit's own solution): not the stage's doing, so the run is made again.
            shutil.rmtree(out, ignore_errors=True)
            out = self.sandbox.writable_dir(run_dir, "out-")
        return run

    # -- the reference's outputs, a run's verdict ---------------------------------------------------
    def expected_for(self, st, scene, out):
        """The reference's output of a scene (computed now, in the grader's private folder)."""
        limit = self.rubric["limits"].get("reference_max_seconds", 600)
        try:  # the kit's own program, but a scene may still be one it cannot finish: never hang
            r = subprocess.run([self.solution(st.reference), scene, "--quiet", "--out", out],
                               capture_output=True, text=True, timeout=limit)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"the reference ({st.reference}) did not finish {scene} in "
                               f"{limit} s") from None
        if r.returncode != 0:
            raise RuntimeError(f"the reference failed on {scene}: {r.stderr}")
        return pathlib.Path(out).read_text()

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
        # The reference's --explain is the stepped model's oracle (one event a particle a step):
        # a stage of another model (07, continuous time) is not explained by it
        if (not st.exact and isinstance(first.get("step"), int)
                and isinstance(first.get("particle"), int)):
            k, i = first["step"], first["particle"]
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
                yours = implied(before, after)
                if yours.startswith("changed velocity as in a pair collision"):
                    j = pair_partner(self.kit_programs, work / "expected.out", work / "actual.out", k, i)
                    if j is not None:
                        yours = yours.replace("a pair collision", f"a pair collision with {j}", 1)
                lines.append(f"Yours: particle {i} {yours}.")
        setup, scene_arg, expected_arg = how
        if setup and st.released_reference:  # a hidden scene: regenerate it, and its expected
            # output with the reference program of the student's copy (`plab release` builds it;
            # the instructor's copy has `./plab run --stage NN --impl solution` too)
            setup += "kit/reference/bin/plab-reference hidden.in --out expected.out && "
        elif setup:  # a stage with a model of its own (07): its solution (the instructor's)
            setup += (f"./plab run --stage {st.reference} --impl solution hidden.in --out "
                      f"expected.out && ")
        # As it was run here: on its threads (a difference that only threads make may come and
        # go from run to run) or its ranks
        ran = (f"--ranks {st.ranks} " if st.ranks > 1 else
               f"--threads {st.threads} " if st.threads != "1" else "")
        lines.append(f"Reproduce: {setup}./plab run --stage {st.sid} --impl student {ran}"
                     f"{scene_arg} --out mine.out && ./plab diff {expected_arg} mine.out")
        if st.threads != "1" and st.ranks <= 1:
            lines.append(f"It ran on {st.threads} threads: if that command prints the right text, "
                         "run it again, or with --threads 3 --schedule dynamic,1 (a data race or a "
                         "missing barrier shows in some runs only; ./plab test --impl student "
                         f"--stage {st.sid} --races).")
        shutil.rmtree(work, ignore_errors=True)
        return "\n".join(lines)
