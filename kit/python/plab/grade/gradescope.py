"""plab gradescope: writes Gradescope's autograder zip. At its root: setup.sh and run_autograder
(from kit/grade/gradescope/, mode 0755) and the instructor's kit: the files git tracks (`git
ls-files`, solutions/ included: the grader needs the reference), without build trees, logs or
scratch. Gradescope unpacks the zip into /autograder/source, runs setup.sh once (packages, build,
the kit made private to root) and run_autograder for each submission.

  python3 -m plab.grade.gradescope --kit-source DIR --out ZIP [--stages 01,02,03]

With --stages, run_autograder grades those stages only (one autograder per assignment);
without, every stage the upload has.
"""
import argparse
import fnmatch
import json
import pathlib
import re
import stat
import subprocess
import sys
import time
import zipfile

ROOT_FILES = ("setup.sh", "run_autograder")  # from kit/grade/gradescope/, into the zip's root
LEFT_OUT = ("*.log",)  # tracked but not the kit's (e.g. a committed build log)


def git(kit, *args):
    done = subprocess.run(["git", "-C", str(kit), *args], capture_output=True)
    if done.returncode != 0:
        sys.exit(f"plab gradescope: git {' '.join(args)} failed in {kit} (the zip holds the files "
                 f"git tracks, so the kit must be a git checkout):\n{done.stderr.decode()}")
    return done.stdout


def entry(name, mode, when):
    info = zipfile.ZipInfo(name, date_time=time.localtime(when)[:6])
    info.external_attr = (stat.S_IFREG | mode) << 16
    info.compress_type = zipfile.ZIP_DEFLATED
    return info


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kit-source", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--stages", help="the stages run_autograder grades, e.g. 01,02,03")
    a = ap.parse_args()
    kit, out = pathlib.Path(a.kit_source).resolve(), pathlib.Path(a.out).resolve()
    if a.stages is not None:
        known = sorted(json.loads((kit / "kit" / "grade" / "rubric.json").read_text())["stages"])
        asked = [s.strip() for s in a.stages.split(",") if s.strip()]
        wrong = [s for s in asked if s not in known]
        if not asked or wrong or not re.fullmatch(r"[\w,-]+", a.stages):
            sys.exit(f"plab gradescope: --stages {a.stages!r}: expected stages of the rubric, "
                     f"comma-separated ({', '.join(known)})")
        a.stages = ",".join(asked)
    if not (kit / "solutions").is_dir():
        sys.exit("plab gradescope: this kit has no solutions/ (a student copy); the grader needs them")
    tracked = [n for n in git(kit, "ls-files", "-z").decode().split("\0") if n]
    changed = git(kit, "status", "--porcelain", "--untracked-files=no").decode().rstrip()
    if changed:
        print("plab gradescope: note: tracked files with uncommitted changes go in as they are now:\n"
              + changed, file=sys.stderr)
    files, skipped = [], []
    for name in tracked:
        path = kit / name
        if any(fnmatch.fnmatch(pathlib.PurePath(name).name, p) for p in LEFT_OUT):
            skipped.append(name)
        elif name in ROOT_FILES:
            sys.exit(f"plab gradescope: the kit itself has a {name} at its root; it would clash")
        elif path.is_symlink() or not path.is_file():
            skipped.append(name)  # deleted in the working tree, or a link
        else:
            files.append(name)
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.name + ".partial")
    with zipfile.ZipFile(partial, "w") as z:
        for name in ROOT_FILES:
            src = kit / "kit" / "grade" / "gradescope" / name
            body = src.read_bytes()
            if name == "run_autograder" and a.stages:
                text = body.decode()
                line = "exec ./plab grade --submission /autograder/submission"
                if line not in text:
                    sys.exit(f"plab gradescope: {src} has no line '{line} ...' to add --stages to")
                text = text.replace(line, f"{line} --stages {a.stages}").replace(
                    "# No --stages: every stage the submission has is graded.",
                    f"# --stages {a.stages} (plab gradescope --stages): these stages only.")
                body = text.encode()
            z.writestr(entry(name, 0o755, src.stat().st_mtime), body)
        for name in files:
            path = kit / name
            st = path.stat()
            mode = 0o755 if st.st_mode & stat.S_IXUSR else 0o644
            z.writestr(entry(name, mode, st.st_mtime), path.read_bytes())
    partial.replace(out)
    print(f"wrote {out}: setup.sh, run_autograder and {len(files)} files of the kit "
          f"(git ls-files, solutions/ included); it grades "
          + (f"stages {a.stages}" if a.stages else "every stage an upload has"))
    if skipped:
        print(f"left out: {', '.join(skipped)}")
    print("Upload it as the autograder of a Gradescope programming assignment (Ubuntu image); "
          "students upload their stages/ folder. See handouts/instructors.md.")


if __name__ == "__main__":
    main()
