"""plab release: writes the student version of the kit into a new folder, from what git's HEAD
holds (never the working folder): the kit without the solutions, the instructor's CI, logs, build
and scratch files; a README written for students; the reference stage's solution as a compiled
program (kit/reference/bin/plab-reference, never its source), so that a student's stage-against-
stage tests run; and the HTML docs built from the release itself (they show the starting points,
never a solution). Before anything is written it builds the release and checks that every stage
is its untouched starting point (its program stops with "stage NN: EXERCISE n (...) is not done
yet", exit code 3). The release is made in a temporary folder beside OUT and renamed to OUT at the
end: one that fails part-way leaves nothing behind. No hidden-test seed is stored anywhere in the
kit: `plab grade` takes it at grading time.

  python3 -m plab.grade.release --kit-source DIR --out DIR [--allow-dirty] [--through NN] [--files-only]

--through NN makes a weekly release: stages 01..NN only, with their handouts and specs (a given
file of a later stage may hold an earlier stage's answer, so a week's copy holds nothing past its
week); the index's rows of later stages are left out and references to their handouts become
plain text. --files-only writes the files a release ships and stops (no build, no check, no
reference program, no docs): what the shortcut tests (tests/shortcut_check.py) compile against.

It refuses when stages/ has uncommitted changes or untracked files, unless --allow-dirty is given:
then it releases HEAD's stages/ and names the changes it left out.
"""
import argparse
import fnmatch
import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import tempfile

# Tracked paths that are the instructor's, never a student's: the solutions, the CI, the student
# README's own source (it becomes README.md), the instructor-only code, the instructor's README
# (replaced), the instructor's pages (the measurement logs of the reference solutions and of the
# kit's engine: the handouts ask the student to measure; the grading mechanics: how each idea is
# measured and what a forged count could still pass; a student's own page on how a stage is
# graded is working.md's) and the similarity test's submissions
# (independent stage 03 solutions), the course guide (its data and its writer), the
# instructors' TSan runs of the engine and the solutions (tests/tsan_runs_check.py), the grader's
# red team (its honest submissions are whole stages: answers) and the instructor-only code's own
# tests (kit/instructor's specifications, which compile only beside it).
INSTRUCTOR_ONLY = ("solutions/", ".ci/", "kit/release/", "kit/instructor/", "README.md",
                   "handouts/measurements.md", "handouts/engine.md", "handouts/engine-gpu.md",
                   "handouts/engine-08.md", "handouts/instructors.md", "tests/similar/",
                   "kit/guide/", "kit/python/plab/guide.py", "tools/engine-modes.sh",
                   "tests/tsan_runs_check.py", "tests/grader_redteam.py", "tests/greedy_test.cpp",
                   "tests/sweep_test.cpp", "tests/heap_probe_check.py")
# Files that belong to nobody's copy even when tracked by mistake: logs, build folders, scratch.
SCRATCH = ("*.log", "*.partial", "*.orig", "*.rej", "*.swp", "*~", "*.pyc", "__pycache__/*",
           "build/*", "build-*/*", ".configure.log")
STUDENT_README = "kit/release/README.student.md"
REFERENCE = "kit/reference/bin/plab-reference"
REFERENCE_NOTE = """# The reference program

`bin/plab-reference` is the compiled reference stage's solution (stage {stage}) of this kit, built
by `plab release` from commit {commit}. The stage-against-stage tests (`AgainstOtherStage`, part of
`./plab test`) run it on fresh random scenes and check that your stage prints exactly the same
text. It takes the arguments of `./plab run`'s stage programs:

```sh
kit/reference/bin/plab-reference datasets/scenes/course-1.in --out reference.out
```

It was built for the machine the release was made on (Debian, x86-64, g++ with OpenMP).
"""
ROUNDS_TOOLS = [("plab-rounds", "plab-rounds"), ("plab-ompcount", "libplab-ompcount.so")]
ROUNDS_NOTE = """
`bin/plab-rounds SCENE` prints how many mutual-earliest rounds each step of a scene needs, and
`bin/libplab-ompcount.so` counts the OpenMP synchronisations of a program it is preloaded into:
the test `stage03.student.Rounds` (`python3 -m plab.rounds_check`) runs your stage 03 with both,
as the grade does, to tell whether its events are selected in rounds of parallel loops.
"""
NOT_DONE = r"stage {id}: EXERCISE [0-9]+ \([^)]+\) is not done yet"


def fail(message):
    sys.exit(f"plab release: {message}")


def run(cmd, what, **kw):
    """Runs cmd; on failure stops with what failed and the end of its output."""
    done = subprocess.run([str(c) for c in cmd], capture_output=True, **kw)
    if done.returncode != 0:
        out = done.stdout if isinstance(done.stdout, str) else done.stdout.decode(errors="replace")
        err = done.stderr if isinstance(done.stderr, str) else done.stderr.decode(errors="replace")
        fail(f"{what} failed ({' '.join(map(str, cmd))}, exit {done.returncode}):\n"
             f"{out[-3000:]}{err[-3000:]}")
    return done


def git(kit, *args):
    return run(["git", "-C", kit, *args], f"git {args[0]}", text=True).stdout


def stage_of(path):
    """The stage a path belongs to (stages/NN-*, handouts/NN-*.md, tests/spec/NN-*), or None."""
    m = re.match(r"(?:stages/|handouts/|tests/spec/)([0-9][0-9])-", path)
    return int(m.group(1)) if m else None


def left_out(path, ignored, through=None):
    """Why a tracked file of HEAD is not shipped (None: it is)."""
    stage = stage_of(path)
    if through is not None and stage is not None and stage > through:
        return f"a stage after week {through:02d}"
    for prefix in INSTRUCTOR_ONLY:
        if path == prefix or (prefix.endswith("/") and path.startswith(prefix)):
            return "instructor only"
    if path in ignored:
        return "listed in .gitignore"
    name = path.rsplit("/", 1)[-1]
    if any(fnmatch.fnmatch(name, p) or fnmatch.fnmatch(path, p) for p in SCRATCH):
        return "log, build or scratch file"
    return None


def configure(source, build, *extra):
    gen = ["-G", "Ninja"] if shutil.which("ninja") else []
    run(["cmake", "-S", source, "-B", build, *gen, "-DCMAKE_BUILD_TYPE=Release",
         "-DPLAB_BUILD_TESTS=OFF", "-DPLAB_ENABLE_CUDA=OFF", *extra],
        f"configuring {source.name}", text=True)


def is_gpu_stage(folder):
    """A CUDA stage (needs_gpu in its stage.json): not compiled without a CUDA compiler."""
    return json.loads((folder / "stage.json").read_text()).get("needs_gpu", False)


def check_starting_points(release, build):
    """Every stage of the release must be its untouched starting point: its program stops with
    its "not done yet" message (exit 3). A CUDA stage is not compiled here (the check builds
    without CUDA): its sources must still hold the exercises that stop it."""
    scene = release / "datasets" / "scenes" / "course-1.in"
    said = []
    for folder in sorted((release / "stages").glob("[0-9][0-9]-*")):
        if not (folder / "CMakeLists.txt").exists():
            continue
        sid = folder.name[:2]
        program = build / "bin" / f"plab-run-{sid}-student"
        pattern = NOT_DONE.format(id=sid)
        if not program.exists():
            gpu = is_gpu_stage(folder)
            sources = " ".join(p.read_text(errors="replace") for p in folder.iterdir()
                               if p.suffix in (".cpp", ".cu", ".cuh", ".hpp", ".h"))
            if not gpu:
                fail(f"stage {sid}'s starting point did not compile (stages/{folder.name})")
            if "PLAB_EXERCISE(" not in sources:
                fail(f"stage {sid} (CUDA) has no PLAB_EXERCISE left in stages/{folder.name}: "
                     "it is not its untouched starting point")
            said.append(f"  stage {sid}: CUDA, not compiled here; its sources still stop at "
                        "PLAB_EXERCISE")
            continue
        done = subprocess.run([str(program), str(scene)], capture_output=True, text=True)
        if done.returncode == 4 and "no CUDA device" in done.stderr:
            said.append(f"  stage {sid}: built; it needs a GPU to run")
            continue
        found = re.search(pattern, done.stderr)
        if found and done.returncode == -signal.SIGABRT and "plab::NotDone" in done.stderr:
            # Thrown inside an OpenMP parallel region, where the runner cannot catch it: the
            # starting point is untouched, but it aborts instead of exiting 3.
            said.append(f"  stage {sid}: {found.group(0)} (but aborted: NotDone thrown inside "
                        "an OpenMP parallel region, not reported with exit 3 by the runner)")
            continue
        if done.returncode != 3 or not found:
            fail(f"stage {sid} in HEAD's stages/{folder.name} is not its untouched starting point: "
                 f"its program should stop with 'stage {sid}: EXERCISE n (...) is not done yet' "
                 f"(exit 3); it exited {done.returncode} with:\n{done.stderr[-1500:]}")
        said.append(f"  stage {sid}: {found.group(0)}")
    return said


# A reference to a stage's handout: a Markdown link to it ([text](NN-name.md), the handouts' own
# form) or to its label ([text](@ref handout_NN)), or Doxygen's \ref handout_NN (kit headers).
LATER_REF = re.compile(r"(?:\[([^\]]*)\]\((?:@ref handout_([0-9][0-9])|(?:[\w./-]*/)?([0-9][0-9])-[\w-]*"
                       r"\.md(?:#[\w-]*)?)\))|(?:[\\@]ref handout_([0-9][0-9]))")


def cut_later_stages(release, through):
    """A weekly release: the table rows of later stages go (the index's and the README's), and
    every reference to a later stage's handout (not shipped) becomes plain text, so that the docs
    build without warnings."""
    for index in (release / "handouts" / "index.md", release / "README.md"):
        if not index.exists():
            continue
        lines = [l for l in index.read_text().splitlines(keepends=True)
                 if not ((m := re.match(r"\| ([0-9][0-9]) \|", l)) and int(m.group(1)) > through)]
        index.write_text("".join(lines))

    def plain(m):
        stage = int(m.group(2) or m.group(3) or m.group(4))
        if stage <= through:
            return m.group(0)
        return m.group(1) if m.group(1) is not None else f"handout {stage:02d} (a later week)"

    for f in release.rglob("*"):
        if f.is_file() and f.suffix in (".md", ".hpp", ".cpp", ".cuh", ".cu", ".h"):
            text = f.read_text(errors="replace")
            new = LATER_REF.sub(plain, text)
            if new != text:
                f.write_text(new)


# A Markdown link to an instructor-only page: [text](instructors.md), [text](../handouts/engine.md).
INSTRUCTOR_LINK = re.compile(r"\[([^\]]*)\]\((?:[\w./-]*/)?(" + "|".join(
    re.escape(p.rsplit("/", 1)[-1]) for p in INSTRUCTOR_ONLY
    if p.startswith("handouts/") and p.endswith(".md")) + r")(?:#[\w-]*)?\)")


def cut_instructor_links(release):
    """Every link in a shipped page to an instructor-only page (not shipped) becomes its text
    followed by "(instructor's copy only)", so that the docs build without warnings and a student
    is not sent to a page that is not there."""
    for f in list((release / "handouts").glob("*.md")) + list((release / "docs").glob("*.md")):
        text = f.read_text(errors="replace")
        new = INSTRUCTOR_LINK.sub(lambda m: f"{m.group(1)} (instructor's copy only)", text)
        if new != text:
            f.write_text(new)


# What the docs' main page says to instructors only: its section, and the commands that need the
# instructor's copy (solutions/ and the grader), which a student's copy would only refuse.
INSTRUCTOR_SECTION = "## An instructor starts here"
INSTRUCTOR_ROWS = ("| `./plab golden", "| `./plab grade", "| `./plab release")


def cut_instructor_parts(release):
    """handouts/index.md without its section for instructors and the table rows of the commands
    only an instructor's copy runs (a student found `plab grade` and `plab release` listed, and
    `plab grade` then answered that it needs the instructor's kit)."""
    index = release / "handouts" / "index.md"
    if not index.exists():
        return
    kept, skipping = [], False
    for line in index.read_text().splitlines(keepends=True):
        if line.startswith("## "):
            skipping = line.strip() == INSTRUCTOR_SECTION
        if not skipping and not line.startswith(INSTRUCTOR_ROWS):
            kept.append(line)
    index.write_text("".join(kept))


def copy_files(kit, head, work, say, through=None):
    """Writes the files of the release (from HEAD) into work / "release"; returns (the full HEAD
    tree, the release folder)."""
    full, release = work / "head", work / "release"
    full.mkdir()
    tar = subprocess.run(["git", "-C", str(kit), "archive", "--format=tar", head],
                         capture_output=True)
    if tar.returncode != 0:
        fail(f"git archive {head} failed:\n{tar.stderr.decode(errors='replace')}")
    run(["tar", "-x", "-C", full], "unpacking git archive", input=tar.stdout)

    files = git(kit, "ls-tree", "-r", "-z", "--name-only", head).split("\0")
    files = [f for f in files if f]
    # Tracked files that .gitignore lists (committed by mistake, like a build log): left out.
    check = subprocess.run(["git", "-C", str(kit), "check-ignore", "--no-index", "--stdin"],
                           input="\n".join(files) + "\n", capture_output=True, text=True)
    if check.returncode not in (0, 1):
        fail(f"git check-ignore failed:\n{check.stderr}")
    ignored = set(check.stdout.splitlines())
    if not (full / STUDENT_README).exists():
        fail(f"HEAD has no {STUDENT_README} (the release's README)")
    dropped = {}
    for f in files:
        why = left_out(f, ignored, through)
        if why:
            dropped.setdefault(why, []).append(f)
            continue
        src = full / f
        if src.is_symlink() or not src.is_file():
            continue
        dst = release / f
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    shutil.copy2(full / STUDENT_README, release / "README.md")
    cut_instructor_links(release)
    cut_instructor_parts(release)
    for why, paths in sorted(dropped.items()):
        tops = sorted({p.split("/")[0] + "/" if p.startswith(("solutions/", ".ci/")) else
                       "/".join(p.split("/")[:2]) + "/" if p.startswith("stages/") else p
                       for p in paths})
        say(f"left out ({why}): {', '.join(tops)}")
    if through is not None:
        cut_later_stages(release, through)
        say(f"weekly release: stages 01..{through:02d} only")
    return full, release


def build_release(kit, head, work, say, through=None):
    """Writes the release into work / "release" and returns that folder."""
    full, release = copy_files(kit, head, work, say, through)
    build = work / "build-release"
    say("building the release's starting points to check them", flush=True)
    configure(release, build)
    # The stage programs only (the CUDA stages are not configured here), each that compiles
    # (-k 0): a stage that does not is named by the check below.
    programs = [f"plab-run-{d.name[:2]}-student" for d in sorted((release / "stages").glob("[0-9][0-9]-*"))
                if (d / "CMakeLists.txt").exists() and not is_gpu_stage(d)]
    keep_going = ["--", "-k", "0"] if shutil.which("ninja") else []
    subprocess.run(["cmake", "--build", str(build), "--target", *programs, *keep_going],
                   capture_output=True)
    for line in check_starting_points(release, build):
        say(line)

    manifest = json.loads((full / "datasets" / "manifest.json").read_text())
    stage = manifest["reference_stage"]
    say(f"building the reference program (stage {stage}'s solution at HEAD)", flush=True)
    build_ref = work / "build-reference"
    configure(full, build_ref)
    # and, where the week has stage 03, the instruments of its local rounds check
    # (plab.rounds_check: stage03.student.Rounds), compiled too
    rounds = (ROUNDS_TOOLS
              if (release / "stages" / "03-openmp" / "stage.json").exists() else [])
    run(["cmake", "--build", build_ref, "--target", f"plab-run-{stage}-solution",
         *[target for target, _ in rounds]], f"building stage {stage}'s solution", text=True)
    reference = release / REFERENCE
    reference.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(build_ref / "bin" / f"plab-run-{stage}-solution", reference)
    for _, name in rounds:
        shutil.copy2(build_ref / "bin" / name, reference.parent / name)
    (reference.parent.parent / "README.md").write_text(
        REFERENCE_NOTE.format(stage=stage, commit=head) + (ROUNDS_NOTE if rounds else ""))
    say(f"reference program: {REFERENCE} (stage {stage}'s solution, compiled; no source)"
        + (f"; {', '.join(n for _, n in rounds)} beside it" if rounds else ""))

    say("building the student docs from the release itself (Doxygen)", flush=True)
    run(["cmake", "--build", build, "--target", "docs"], "building the docs", text=True)
    # The docs of a release must publish no solution: Doxygen reads the release's own handouts,
    # kit/include and stages/ only (never solutions/ or kit/instructor/, which it does not have).
    doxy_input = next((l.split("=", 1)[1].split() for l in
                       (build / "docs" / "Doxyfile").read_text().splitlines()
                       if l.startswith("INPUT ")), [])
    shown = [str(pathlib.Path(i).relative_to(release)) if pathlib.Path(i).is_relative_to(release)
             else i for i in doxy_input]
    if any(not pathlib.Path(i).is_relative_to(release) or
           pathlib.Path(i).relative_to(release).parts[:1] in (("solutions",),) or
           "instructor" in pathlib.Path(i).parts for i in doxy_input):
        fail(f"the release's docs would read files that are not the release's: {doxy_input}")
    say(f"docs input (Doxygen INPUT): {' '.join(shown)}")
    shutil.copytree(build / "docs" / "html", release / "docs" / "html")
    return release


def main():
    ap = argparse.ArgumentParser(prog="plab release", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kit-source", required=True, help=argparse.SUPPRESS)  # `plab` gives its own
    ap.add_argument("--kit", metavar="DIR",
                    help="the kit checkout to release (default: this one)")
    ap.add_argument("--out", required=True, help="a new (or empty) folder")
    ap.add_argument("--allow-dirty", action="store_true",
                    help="release HEAD's stages/ even when stages/ has uncommitted changes (they "
                         "are left out, and named)")
    ap.add_argument("--through", type=int, metavar="NN",
                    help="a weekly release: stages 01..NN only, with their handouts (a later "
                         "stage's given files may hold an earlier stage's answer); default: "
                         "every stage")
    ap.add_argument("--files-only", action="store_true",
                    help="only the files a release ships: no build, check, reference or docs")
    a = ap.parse_args()
    kit, out = pathlib.Path(a.kit or a.kit_source).resolve(), pathlib.Path(a.out).resolve()
    if not kit.is_dir():
        fail(f"--kit {kit}: no such folder")
    if a.through is not None and not 1 <= a.through <= 99:
        fail(f"--through {a.through}: a stage number, 1 to 99")
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        fail(f"{out} exists and is not empty; name a new folder")
    if out.is_relative_to(kit):
        fail("write the release outside the kit's own folder")
    try:  # its parents made, as `mkdir -p` would: a student copy's place is often new
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        fail(f"cannot make {out.parent}: {e.strerror}")
    inside = subprocess.run(["git", "-C", str(kit), "rev-parse", "--show-toplevel"],
                            capture_output=True, text=True)
    if inside.returncode != 0 or pathlib.Path(inside.stdout.strip()).resolve() != kit:
        fail(f"{kit} is not the top of a git checkout: a release is made from git's HEAD")
    head = git(kit, "rev-parse", "HEAD").strip()
    subject = git(kit, "log", "-1", "--format=%s", head).strip()
    dirty = git(kit, "status", "--porcelain=v1", "--untracked-files=all", "--", "stages").splitlines()
    if dirty and not a.allow_dirty:
        fail("stages/ has changes that are not committed:\n" + "\n".join(f"  {d}" for d in dirty) +
             "\nCommit them (the release is made from HEAD), or give --allow-dirty to release "
             "HEAD's stages/ without them.")
    print(f"releasing HEAD {head[:12]} ({subject}): the files git holds there, not the working "
          "folder", flush=True)
    if dirty:
        print("--allow-dirty: stages/ as committed at HEAD is included; these uncommitted changes "
              "are not:\n" + "\n".join(f"  {d}" for d in dirty))

    work = pathlib.Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    try:
        if a.files_only:
            release = copy_files(kit, head, work, print, a.through)[1]
        else:
            release = build_release(kit, head, work, print, a.through)
        if out.exists():
            out.rmdir()
        os.rename(release, out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if a.files_only:
        print(f"release files (no build, no docs): {out}")
        return
    print(f"docs: {out / 'docs' / 'html' / 'index.html'}")
    print(f"release ready: cd {out} && ./plab test --impl student   (fails until the exercises are done)")


if __name__ == "__main__":
    main()
