#!/usr/bin/env python3
"""Checks `plab release` (CTest label release) on a scratch clone of the kit's HEAD.

1. stages/ with an uncommitted change and an untracked file: the release is refused and writes
   nothing;
2. the same with --allow-dirty: released from HEAD (the dirty change and the untracked file are
   not in it, and it says what it included); no solutions/, CI, logs, build or scratch files,
   only files HEAD holds (plus the docs and the reference program); a README for a student with
   no instructor-only command or folder; docs built from itself (no solution's line in them);
   kit/reference/bin/plab-reference, compiled, with its note;
3. the release builds on its own; its kit tests pass; the tests of stages 01-03 fail on the
   untouched starting points with "stage NN: EXERCISE n (...) is not done yet", stage 01's
   stage-against-stage tests too; with a solution's step.cpp copied into stages/01-naive, those
   tests run against the reference program (not skipped) and pass; stage 03's Rounds test (the
   compiled plab-rounds and OpenMP counter the release ships) passes a solution and fails the
   same without its OpenMP pragmas;
4. the student README's quick start (its ```sh block under "Student quick start"), run line by
   line as written in the release with ./plab, as tests/readme_check.py runs README.md's: the
   test before `$EDITOR` fails with "EXERCISE 1 (...) is not done yet", every other line exits 0;
5. a commit whose stages/01-naive is not the starting point: the release fails part-way and
   leaves no folder behind (neither the target nor its temporary folder);
6. a weekly release (--through 03): stages 01-03 and their handouts and specs only, no later
   stage's file, the index without later rows, its docs built (no reference to a later handout
   left), and the same proof that its docs publish no solution.

The docs (2 and 6): Doxygen's input, as the release says it, is the release's handouts, kit/include
and stages/ only (no solutions/, no kit/instructor/), and the HTML has no page of an
instructor-only header (greedy.hpp, plan_team.hpp, oracle.hpp) and no solution's line.

The scratch folder is removed whatever the outcome.

  release_check.py PLAB_PROGRAM [--kit DIR] [--keep]
"""
import argparse
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

# Words of the instructor's kit that a student's README must not show.
INSTRUCTOR_ONLY = (r"solutions/", r"golden --check", r"plab golden", r"plab grade",
                   r"plab release", r"gradescope", r"\.ci\b", r"--hidden-seed")


def run(*cmd, ok=True, **kw):
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    if ok and done.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))} exited {done.returncode}:\n"
                 f"{done.stdout[-3000:]}{done.stderr[-3000:]}")
    return done


def check(condition, message):
    if not condition:
        sys.exit(f"release check FAILED: {message}")


def git(repo, *args, ok=True):
    return run("git", "-C", repo, *args, ok=ok)


def refused(plab, clone, scratch, name, what, must_say):
    """Runs a release that must fail: non-zero exit, every word of must_say in what it says, and
    neither the target folder nor its temporary folder left behind."""
    out = scratch / name
    r = run(plab, "release", "--kit", clone, "--out", out, ok=False)
    said = r.stdout + r.stderr
    check(r.returncode != 0, f"a release with {what} was not refused")
    check(all(s in said for s in must_say), f"the refusal of {what} does not say {must_say}:\n"
                                            f"{said[-2000:]}")
    check(not out.exists(), f"the refused release ({what}) left its folder behind")
    check(not list(scratch.glob(f".{name}.*")), f"the refused release ({what}) left a temporary folder")


def refused_when_dirty(plab, clone, scratch):
    (clone / "stages" / "01-naive" / "step.cpp").write_text(
        (clone / "stages" / "01-naive" / "step.cpp").read_text() + "\n// a change not committed\n")
    (clone / "stages" / "02-heap" / "notes.txt").write_text("an untracked scratch file\n")
    refused(plab, clone, scratch, "refused", "uncommitted changes in stages/",
            ["stages/01-naive/step.cpp", "stages/02-heap/notes.txt"])
    print("dirty stages/: refused, naming the changed and the untracked file; nothing written")


def released_allow_dirty(plab, clone, scratch):
    out = scratch / "student-kit"
    r = run(plab, "release", "--kit", clone, "--out", out, "--allow-dirty")
    check("stages/01-naive/step.cpp" in r.stdout and "not" in r.stdout,
          f"--allow-dirty does not say what it left out:\n{r.stdout}")
    head = git(clone, "rev-parse", "HEAD").stdout.strip()
    check(head[:12] in r.stdout, "the release does not say which commit it was made from")
    check("a change not committed" not in (out / "stages/01-naive/step.cpp").read_text(),
          "--allow-dirty shipped an uncommitted change")
    check(not (out / "stages/02-heap/notes.txt").exists(), "--allow-dirty shipped an untracked file")
    print(f"--allow-dirty: released HEAD {head[:12]}, without the uncommitted change and file")
    docs_input(r.stdout)
    return out


def docs_input(said):
    """The release's docs read the release's own files only: never solutions/ or kit/instructor/."""
    line = next((l for l in said.splitlines() if l.startswith("docs input (Doxygen INPUT):")), None)
    check(line is not None, f"the release does not say what its docs were built from:\n{said}")
    inputs = line.split(":", 1)[1].split()
    check(inputs and all(not i.startswith(("/", "solutions")) and "instructor" not in i
                         for i in inputs), f"the release's docs read more than the release: {line}")
    check("stages" in inputs and "solutions" not in inputs, f"the docs' input is not stages/: {line}")
    print(f"the docs' input is the release's own: {' '.join(inputs)}")


def weekly(plab, clone, scratch):
    """plab release --through 03: stages 01..03 only, and docs that still build."""
    out = scratch / "week-03"
    r = run(plab, "release", "--kit", clone, "--out", out, "--allow-dirty", "--through", "3")
    docs_input(r.stdout)
    stages = sorted(p.name[:2] for p in (out / "stages").glob("[0-9][0-9]-*"))
    check(stages == ["01", "02", "03"], f"the week-03 release holds stages {stages}")
    later = [p.relative_to(out).as_posix() for p in out.rglob("*")
             if p.is_file() and re.match(r"(stages|handouts|tests/spec)/(0[4-9]|[1-9][0-9])-",
                                         p.relative_to(out).as_posix())]
    check(not later, f"the week-03 release holds later stages' files: {later[:5]}")
    index = (out / "handouts" / "index.md").read_text()
    check(not re.search(r"^\| 0[4-9] \|", index, re.M), "the week-03 index lists later stages")
    readme = (out / "README.md").read_text()
    check(not re.search(r"^\| 0[4-9] \|", readme, re.M), "the week-03 README lists later stages")
    later_said = re.search(r"[Ss]tages? 0[4-9]\b.*", readme)
    check(not later_said, f"the week-03 README speaks of a later stage: {later_said and later_said.group(0)}")
    check("An instructor starts here" not in index and "./plab grade" not in index
          and "./plab release" not in index, "the student's index.md shows instructors' commands")
    check(not re.search(r"ref handout_0[4-9]|\]\((?:[\w./-]*/)?0[4-9]-[\w-]*\.md", " ".join(
        p.read_text(errors="replace") for p in out.rglob("*.md"))),
          "the week-03 release refers to a later stage's handout")
    docs_and_reference(out)
    print("--through 03: stages 01-03 with their handouts and specs only; docs built from them")


def ships_only_students_files(clone, out):
    tracked = set(git(clone, "ls-tree", "-r", "--name-only", "HEAD").stdout.splitlines())
    shipped = [p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()]
    for path in shipped:
        top = path.split("/")[0]
        check(top not in ("solutions", ".ci", "build") and not top.startswith("build-"),
              f"the release ships {path}")
        check(not re.search(r"(\.log|\.partial|\.orig|\.rej|\.swp|~|\.pyc)$", path)
              and "__pycache__" not in path, f"the release ships a log or scratch file: {path}")
        check(path in tracked or path == "README.md" or path.startswith(("docs/html/", "kit/reference/")),
              f"the release ships {path}, which HEAD does not hold")
    check(not (out / "kit" / "release").exists(), "the release ships kit/release/")
    # The red team's honest and cheating submissions are whole stages (stage 03's rounds, a heap
    # selection): answers; the instructor-only code's specifications compile only beside it
    for answer in ("tests/grader_redteam.py", "tests/greedy_test.cpp", "tests/sweep_test.cpp"):
        check(answer not in shipped, f"the release ships {answer}")
    # The instructors' page says how each idea test measures and what a forged count could still
    # pass; the measurement logs answer the handouts' measuring questions
    for page in ("instructors", "measurements", "engine", "engine-gpu", "engine-08"):
        check(f"handouts/{page}.md" not in shipped, f"the release ships handouts/{page}.md")
    pages = " ".join((out / p).read_text(errors="replace") for p in shipped
                     if p.endswith(".md") and p.startswith(("handouts/", "docs/")))
    linked = re.search(r"\]\((?:[\w./-]*/)?(instructors|measurements|engine(?:-gpu|-08)?)\.md", pages)
    check(not linked, f"a shipped page links to the instructor-only {linked and linked.group(1)}.md")
    check("build-asan.log" not in shipped, "the release ships build-asan.log")
    print(f"ships {len(shipped)} files: HEAD's, less solutions/, .ci, logs, build and scratch "
          "files; plus the docs and the reference program")


def student_readme(out):
    text = (out / "README.md").read_text()
    for word in INSTRUCTOR_ONLY:
        found = re.search(word, text, re.IGNORECASE)
        check(not found, f"the student README shows the instructor's '{found and found.group(0)}'")
    for needed in ("./plab test --impl student --stage 01", "--out mine.out",
                   "./plab diff datasets/golden/course-1.out mine.out", "handouts/",
                   "docs/html/index.html", "kit/reference/bin/plab-reference"):
        check(needed in text, f"the student README does not say '{needed}'")
    for folder in sorted((out / "stages").glob("[0-9][0-9]-*")):
        check(f"stages/{folder.name}" in text, f"the student README does not list {folder.name}")
    print("README.md is the student's: the kit, the commands, every stage in order, testing, "
          "handouts; no instructor-only command or folder")


def docs_and_reference(out):
    index = out / "docs" / "html" / "index.html"
    check(index.exists(), "no docs in the release")
    html = " ".join(p.read_text(errors="replace") for p in (out / "docs" / "html").glob("*.html"))
    for line in ("mine.push_back", "items_.push_back(x)"):  # solution-only: 02, 03 and 06
        check(line not in html, f"the release's docs show a solution's '{line}'")
    for page in ("greedy_8hpp.html", "plan__team_8hpp.html", "oracle_8hpp.html"):
        check(not (out / "docs" / "html" / page).exists(),
              f"the release's docs document an instructor-only header ({page})")
    sources = " ".join(p.read_text(errors="replace") for p in (out / "stages").rglob("*.?pp"))
    check("items_.push_back(x)" not in sources, "the release's stages/ hold a solution's line")
    reference = out / "kit" / "reference" / "bin" / "plab-reference"
    check(reference.is_file() and os.access(reference, os.X_OK), "no reference program")
    check((out / "kit" / "reference" / "README.md").exists(), "no note beside the reference program")
    ran = run(reference, out / "datasets" / "scenes" / "course-1.in", "--quiet")
    check(ran.stdout == (out / "datasets" / "golden" / "course-1.out").read_text(),
          "the reference program does not print the golden output")
    print("docs built from the release (no solution's line); the reference program prints the "
          "golden output of course-1")


def release_tests(out, kit):
    build = out / "build"
    run("cmake", "-S", out, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
        "-DPLAB_ENABLE_CUDA=OFF")
    run("cmake", "--build", build, "-j", "2")
    print("the release configures and builds on its own")
    listed = run(build / "bin" / "plab", "--help").stdout
    for command in ("grade", "release", "gradescope", "golden", "similar"):
        check(not re.search(rf"^\s+{command}\s", listed, re.MULTILINE),
              f"the release's `plab --help` lists the instructor's command {command}:\n{listed}")
    for command in ("test", "run", "diff", "demo"):
        check(re.search(rf"^\s+{command}\s", listed, re.MULTILINE),
              f"the release's `plab --help` does not list {command}:\n{listed}")
    print("its `plab --help` lists a student's commands and demo, no instructor's command")
    r = run("ctest", "--test-dir", build, "-L", "^kit$", "--output-on-failure")  # render too
    print("its kit tests pass: " + next((l for l in r.stdout.splitlines() if "tests passed" in l), ""))
    for stage in ("01", "02", "03"):
        r = run("ctest", "--test-dir", build, "-L", f"^stage{stage}$", "-LE", "long",
                "--output-on-failure", ok=False)
        check(r.returncode != 0, f"stage {stage}'s tests pass on an untouched starting point")
        said = f"stage {stage}: EXERCISE 1 ("
        check(said in r.stdout, f"stage {stage}'s failing tests do not say '{said}...':\n{r.stdout[-2000:]}")
        print(f"stage {stage}: tests fail on the starting point, saying '{said}...) is not done yet'")
    against = r"^stage01\.student\.AgainstOtherStage$"
    r = run("ctest", "--test-dir", build, "-R", against, "--output-on-failure", ok=False)
    check(r.returncode != 0 and "EXERCISE" in r.stdout,
          f"stage 01's stage-against-stage tests do not fail on the starting point:\n{r.stdout[-2000:]}")
    # copyfile, not copy2: a new mtime, so that the build sees the change
    shutil.copyfile(kit / "solutions" / "01-naive" / "step.cpp", out / "stages" / "01-naive" / "step.cpp")
    run("cmake", "--build", build, "-j", "2")
    r = run("ctest", "--test-dir", build, "-R", against, "-V", ok=False)
    passed = re.search(r"\[  PASSED  \] (\d+) test", r.stdout)
    check(r.returncode == 0 and passed and int(passed.group(1)) > 0,
          f"stage 01's stage-against-stage tests fail with a solution's step.cpp:\n{r.stdout[-3000:]}")
    check("[  SKIPPED ]" not in r.stdout,
          f"stage 01's stage-against-stage tests skip:\n{r.stdout[-3000:]}")
    print(f"stage 01 finished: its {passed.group(1)} stage-against-stage tests run against "
          "kit/reference/bin/plab-reference and pass, none skipped")
    # Stage 03's rounds, counted as the grade counts them, with the compiled instruments the
    # release ships (kit/reference/bin): a solution passes, the same made serial fails.
    solution = (kit / "solutions" / "03-openmp" / "step.cpp").read_text()
    local_idea_test(build, out, kit, "03-openmp/step.cpp", "Rounds", solution,
                    solution.replace("#pragma omp", "// #pragma omp"), "were expected")
    print("stage 03's Rounds test runs with the release's kit/reference/bin: a solution passes, "
          "the same without its OpenMP pragmas fails")
    # Stage 02's heap, driven alone by the kit's probe as the grade drives it (the stored summary
    # the release ships): a solution's heap passes, one whose pop sinks towards the greater child
    # fails, naming the handout's example
    solved = (kit / "solutions" / "02-heap" / "heap.hpp").read_text()
    # (the step measured too: the solution's step.cpp, its heap the one under test)
    shutil.copyfile(kit / "solutions" / "02-heap" / "step.cpp", out / "stages" / "02-heap" / "step.cpp")
    local_idea_test(build, out, kit, "02-heap/heap.hpp", "Heap", solved,
                    solved.replace("less_(items_[right], items_[left]) ? right : left",
                                   "less_(items_[left], items_[right]) ? right : left"),
                    "and popping once, items() holds the times [5, 3, 8]")
    # A warning in the student's own code is said by ./plab as the build that compiled it ends
    (out / "stages" / "02-heap" / "heap.hpp").write_text(solved.replace(
        "    items_.push_back(x);\n", "    items_.push_back(x);\n    int plab_unused_here = 0;\n"))
    r = run(out / "plab", "built", "--stage", "02", ok=False)
    check("plab: the compiler warns about your code (1;" in r.stderr and
          "stages/02-heap/heap.hpp:" in r.stderr and "plab_unused_here" in r.stderr,
          f"./plab did not say the compiler's warning about the student's heap.hpp:\n{r.stderr}")
    shutil.copyfile(kit / "stages" / "02-heap" / "heap.hpp", out / "stages" / "02-heap" / "heap.hpp")
    shutil.copyfile(kit / "stages" / "02-heap" / "step.cpp", out / "stages" / "02-heap" / "step.cpp")
    print("stage 02's Heap test runs with the release's stored summary: a solution's heap passes, "
          "a pop towards the greater child fails; ./plab says a warning in the student's heap.hpp")


def local_idea_test(build, out, kit, path, test, right, wrong, wrong_says):
    """A stage's local check of its idea (stageNN.student.TEST), in the release built at `build`:
    passes with the file stages/`path` written as `right`, fails saying `wrong_says` with `wrong`;
    the starting point's file is put back."""
    stage = path.split("-")[0]
    name = f"stage{stage}.student.{test}"
    for text, want in ((right, 0), (wrong, 1)):
        (out / "stages" / path).write_text(text)
        run("cmake", "--build", build, "-j", "2")
        r = run("ctest", "--test-dir", build, "-R", f"^{re.escape(name)}$", "--output-on-failure",
                ok=False)
        check(name in r.stdout and (r.returncode == 0) == (want == 0)
              and (want == 0 or wrong_says in r.stdout),
              f"{name} on {'a solution' if want == 0 else 'a wrong one'}:\n{r.stdout[-2000:]}")
    shutil.copyfile(kit / "stages" / path, out / "stages" / path)


def student_quick_start(out, clone, kit, scratch):
    """The student README's own quick start, in the release built above (readme_check's runner)."""
    import readme_check  # beside this file (the script's own folder is on sys.path)
    (out / "stages" / "01-naive" / "step.cpp").write_text(  # the starting point again
        git(clone, "show", "HEAD:stages/01-naive/step.cpp").stdout)
    lines = readme_check.block((out / "README.md").read_text(), "Student quick start",
                               "the student README")
    solution = kit / "solutions" / "01-naive" / "step.cpp"
    home = scratch / "home"
    home.mkdir(exist_ok=True)
    env = readme_check.scratch_home_env(home, EDITOR=f"cp {solution}")
    print("the student README's quick start, in the release:", flush=True)
    readme_check.student_block(lines, out, solution, env, "the student README's quick start")


def failed_part_way(plab, clone, kit, scratch):
    git(clone, "checkout", "-q", "--", "stages")
    git(clone, "clean", "-q", "-fd", "stages")
    shutil.copyfile(kit / "solutions" / "01-naive" / "step.cpp", clone / "stages" / "01-naive" / "step.cpp")
    git(clone, "commit", "-q", "-am", "stage 01 done (not a starting point)")
    refused(plab, clone, scratch, "broken", "a finished stage 01 committed",
            ["stage 01", "not its untouched starting point"])
    print("a committed stage that is not its starting point: the release fails part-way, names "
          "stage 01, and leaves no folder behind")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("plab", help="the plab program (build/bin/plab)")
    ap.add_argument("--kit", default=str(pathlib.Path(__file__).resolve().parents[1]),
                    help="the instructor's kit, a git checkout (default: the one of this script)")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    a = ap.parse_args()
    kit = pathlib.Path(a.kit)
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-release-check-"))
    try:
        clone = scratch / "kit"
        run("git", "clone", "-q", kit, clone)
        git(clone, "config", "user.email", "release-check@plab.invalid")
        git(clone, "config", "user.name", "release check")
        refused_when_dirty(a.plab, clone, scratch)
        out = released_allow_dirty(a.plab, clone, scratch)
        ships_only_students_files(clone, out)
        student_readme(out)
        docs_and_reference(out)
        release_tests(out, kit)
        student_quick_start(out, clone, kit, scratch)
        failed_part_way(a.plab, clone, kit, scratch)
        git(clone, "reset", "-q", "--hard", "HEAD~1")  # the starting points again
        weekly(a.plab, clone, scratch)
    finally:
        if a.keep:
            print(f"kept {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    print("release check passed")


if __name__ == "__main__":
    main()
