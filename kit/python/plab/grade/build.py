"""Building a submission's stages with the kit's own CMake, kit and runner, in the sandbox."""
import json
import os
import pathlib
import shutil

from plab.grade import symbols, upload


def unbuilt(sid, program, lines=8):
    """Why stage `sid` has no program, for a test it could not run: "stage 02: it does not
    compile:" and the compiler's first error lines (at most `lines` in all), or the refusal."""
    return f"stage {sid}: " + "\n".join(program.splitlines()[:lines])


def readable_by_all(folder):
    """Folders 0755 and files 0644 (0755 where the owner may run them) under `folder`: a copy that
    the sandbox's uid can read whatever the modes of what it was copied from."""
    for path in [folder, *folder.rglob("*")]:
        if path.is_symlink():
            continue
        mode = path.stat().st_mode
        os.chmod(path, 0o755 if path.is_dir() or mode & 0o100 else 0o644)


class Build:
    """Building: a mixin of Grader (plab.grade.grader)."""

    def stage_uses_mpi(self, sid):
        """Whether the kit's stage.json of stage `sid` declares needs_mpi (stage 08)."""
        declared = self.kit / "stages" / self.kit_folders[sid] / "stage.json"
        try:
            return bool(json.loads(declared.read_text()).get("needs_mpi"))
        except (OSError, ValueError):
            return False

    # -- building --------------------------------------------------------------------------------
    def refused_calls(self, sid):
        """The groups of calls (symbols.CALL_GROUPS) that the rubric's entries of stage folder
        `sid` refuse in its code (`refuse_calls`)."""
        return symbols.refused_groups(self.rubric, sid)

    def probe_beside(self, st, lang, name, source):
        """A grader's probe of the student's code (stage 05's branch probe, stage 02's heap
        probe): the compiler that configured the stages' build for `lang` ("CXX" or "CUDA"), and
        a writable folder in the sandbox holding the stage's built sources with the probe's
        `source` beside them as `name` (readable and writable by the sandbox's user). Returns
        (compiler or None, the sources' folder, the probe's folder)."""
        import re
        src, build = self.built_in
        folder = next((src / "stages").glob(f"{st.sid}-*"))
        cache = (build / "CMakeCache.txt").read_text(errors="replace")
        found = re.search(rf"^CMAKE_{lang}_COMPILER:\w+=(.+)$", cache, re.M)
        if not found:
            return None, src, None
        probe_dir = self.sandbox.writable_dir(self.sandbox.box, "probe-")
        for f in folder.iterdir():  # the stage's sources (read-only there) and the probe beside
            if f.is_file():
                shutil.copyfile(f, probe_dir / f.name)
        (probe_dir / name).write_text(source)
        for f in probe_dir.iterdir():
            os.chmod(f, 0o666)
        return found.group(1).strip(), src, probe_dir

    def compile_probe(self, cmd, src, probe_dir, what):
        """Runs the compiler command `cmd` of a probe in the sandbox (the submission's sources
        read-only at /plab/src, the probe's folder from probe_beside() writable at /plab/probe),
        which must write /plab/probe/probe. Returns None, or why it did not compile."""
        made = self.sandbox.run(cmd, {"/plab/src": src}, {"/plab/probe": probe_dir}, "/plab/probe",
                                300, 2**28, memory=False)
        program = probe_dir / "probe"
        if made.rc != 0 or made.reason or not program.is_file() or program.is_symlink():
            log = pathlib.Path(made.stdout).read_text(errors="replace") + made.stderr
            return f"the grader's probe of {what} did not compile: {(made.reason or log)[-600:]}"
        return None

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
            if sid not in found:  # no folder for it: the kit's CMake would find no sources
                built[sid] = f"the submission has no stages/{folders[sid]}/"
                continue
            dest = src / "stages" / folders[sid]
            dest.mkdir(parents=True)
            for declared in ("CMakeLists.txt", "stage.json"):  # never theirs
                shutil.copy2(self.kit / "stages" / folders[sid] / declared, dest)
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
        self.built_in = (src, build)  # for probes compiled later (branches.py)
        print(f"building stages {', '.join(sorted({s.sid for s in stages}))} "
              + ("(no sandbox: --no-sandbox)" if self.sandbox.mode == "none" else "in the sandbox"),
              flush=True)
        # The kit and the runner's command line, compiled once already outside the sandbox from
        # the kit's own sources: a submission's build compiles its stage and run.cpp alone.
        prebuilt = []
        for option, name in (("PLAB_PREBUILT_KIT", "libplab_kit.a"),
                             ("PLAB_PREBUILT_RUNNER", "libplab_runner_base.a")):
            lib = self.kit_build / "kit" / name
            if lib.is_file():
                shutil.copyfile(lib, self.sandbox.shared_dir("kitlib") / name)
                mounts[0]["/plab/kitlib"] = self.sandbox.box / "kitlib"
                prebuilt.append(f"-D{option}=/plab/kitlib/{name}")
        # No stage graded on a GPU (none here): the CPU paths only, without nvcc's minutes
        cuda = [] if any(s.gpu for s in stages) else ["-DPLAB_ENABLE_CUDA=OFF"]
        conf = self.sandbox.run(["cmake", "-S", "/plab/src", "-B", "/plab/build", "-G", "Ninja",
                                 "-DCMAKE_BUILD_TYPE=Release", "-DPLAB_BUILD_TESTS=OFF",
                                 "-DPLAB_CCACHE=OFF", *cuda, *prebuilt], *mounts, "/plab/build",
                                600, 2**30, memory=False)
        if conf.rc != 0 or conf.reason:
            log = pathlib.Path(conf.stdout).read_text(errors="replace") + conf.stderr
            error = log.find("CMake Error")  # CMake's own words, not its progress lines
            said = log[error:error + 1500] if error >= 0 else log[-1500:]
            return {sid: built.get(sid, "the kit's build could not be configured: " +
                                   (conf.reason or said)) for sid in folders}
        bin_dir = self.sandbox.shared_dir("bin")
        for sid in sorted({s.sid for s in stages}):
            if sid in built:
                continue
            target = f"plab-run-{sid}-student"
            b = self.sandbox.run(["cmake", "--build", "/plab/build", "--target", target, "-j",
                                  os.environ.get("PLAB_BUILD_JOBS") or str(os.cpu_count() or 2)], *mounts, "/plab/build", 900, 2**30,
                                 memory=False)
            program = build / "bin" / target
            # What the stage's objects call and define, read before anything of it runs: code
            # that goes around the libraries the kit measures through is refused (symbols.py).
            mpi = build / "kit" / "libplab_mpi.a"  # built from the kit's sources for stage 08
            refused = (symbols.check(build / "stages" / folders[sid] / f"libplab_stage_{sid}_student.a",
                                     mpi if self.stage_uses_mpi(sid) else None,
                                     self.refused_calls(sid))
                       if b.rc == 0 and not b.reason else [])
            if refused:
                built[sid] = ("it is refused, its compiled code goes around what the kit measures "
                              "(handouts/working.md, How a stage is graded): "
                              + "\n".join(refused[:10]))
            elif b.rc == 0 and not b.reason and program.is_file() and not program.is_symlink():
                mine = bin_dir / f"stage{sid}"  # a copy student code cannot change
                shutil.copyfile(program, mine)
                os.chmod(mine, 0o755)
                built[sid] = mine
            else:
                log = pathlib.Path(b.stdout).read_text(errors="replace") + b.stderr
                errors = [ln for ln in log.splitlines() if "error" in ln.lower() or
                          "multiple definition" in ln or "undefined reference" in ln]
                text = b.reason or "\n".join((errors or log.splitlines()[-25:])[:25])
                if "multiple definition of `plab::" in log and self.stage_uses_mpi(sid):
                    text = ("its step.cpp defines what the kit's kit/mpi/stage_entry.cpp defines "
                            "(make_stepper(), stage_worker()): stage 08 writes plab::dist::step() "
                            "only; delete the others\n" + text)
                built[sid] = "it does not compile:\n" + text.replace("/plab/src/", "")
        return built
