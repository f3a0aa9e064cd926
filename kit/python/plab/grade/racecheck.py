"""The race check's points: the stage built again under ThreadSanitizer in the sandbox and run
on a crowded scene (plab.grade.races holds TSan's build, environment and report)."""
import os
import pathlib
import shutil

from plab.grade import races


class RaceCheck:
    """The data-race test: a mixin of Grader (plab.grade.grader)."""

    def race_check(self, st, program, folder, correct, any_right):
        """The stage built again with ThreadSanitizer (clang, LLVM's OpenMP and Archer), in the
        sandbox, and run on a hidden crowded scene with 3 threads: the first data race with file
        and line. A race found costs the rubric's races_points (a racy program is wrong even when
        the race did not change a printed bit on this machine); visible, so that the student
        learns where it is. A program that fails under TSan before a race is named (a crash, a
        corrupted allocation) loses them too. Not checked (no clang here, the build failed, a
        limit of the run): no points either way.
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
        h = self.rubric["correctness"]["races_scene"]
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
        # whatever the timing. A loop with a schedule of its own ignores both: the scene's 600
        # disks give such a loop several chunks (4 steps, so that TSan's slow runs stay short).
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
        elif run.reason:  # a limit of the run (TSan is slow): the program is not to blame
            self.results.add(test, 0, 0, False, "not checked: the ThreadSanitizer run "
                             f"{run.reason}: {report.strip()[-300:]}")
        elif run.rc not in (0, 3):
            # The program failed under TSan before any race was named: often the race itself
            # (threads appending to one vector corrupt it, and the next allocation asks for
            # petabytes). No race points for a program that fails on 3 threads.
            self.results.add(test, 0, points, False, "the program failed under ThreadSanitizer "
                             f"(3 threads) before a race was named (exit {run.rc}): "
                             f"{races.tsan_summary(report) or report.strip()[-300:]}. A program "
                             "that works on 1 thread and fails on 3 usually has a data race.",
                             False, run.seconds)
        else:
            text = (f"no data race found (3 threads, schedules {' and '.join(races.SCHEDULES)}, "
                    f"one hidden scene of N = {h['n']}, {h['steps']} steps)")
            if not correct:
                text = "0 points: every correctness test (and the idea test) must pass; " + text
            self.results.add(test, points if correct else 0, points, correct, text, False,
                             run.seconds)
