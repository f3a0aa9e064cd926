#!/usr/bin/env python3
"""Checks `plab gradescope` for real (CTest labels grader, long): builds the autograder zip with
the command, unpacks it into a fake /autograder, and runs it as Gradescope does: setup.sh once
(offline: the packages must already be installed), then run_autograder on a submission laid out as
Gradescope lays it out (/autograder/submission holding what the student uploaded: a stages/ folder
with the solutions of stages 01 and 02). Checks /autograder/results/results.json: Gradescope's
format, full correctness marks on both stages (a performance test may say TOO NOISY on a loaded
machine, as in grader_selftest.py).

The fake /autograder never touches the real one: everything runs in a bubblewrap sandbox (as root)
whose root is a tmpfs holding binds of the real / 's top-level folders, except the kit's own
top-level folder (hidden, so that only the zip's copy of the kit can be used), a scratch /tmp and
the scratch /autograder; no network (setup.sh must not need apt-get). Without a GPU (as on
Gradescope) setup.sh is told to leave the CUDA stages out (PLAB_CMAKE_ARGS=-DPLAB_ENABLE_CUDA=OFF). /proc and /dev are the real
ones, bound, so the grader's own sandbox (bwrap as an unprivileged uid) works inside as outside.
The scratch is removed whatever the outcome.

  gradescope_check.py PLAB_PROGRAM KIT_SOURCE_DIR      (needs root and bwrap: skips otherwise)
"""
import json
import os
import pathlib
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import zipfile

SKIP = 77  # CTest's SKIP_RETURN_CODE
STAGES = {"01": "01-naive", "02": "02-heap"}
ROOT_FILES = ("setup.sh", "run_autograder")
VISIBILITY = {"visible", "hidden", "after_due_date", "after_published"}

plab, kit = sys.argv[1], pathlib.Path(sys.argv[2]).resolve()
if os.geteuid() != 0:
    print("SKIP: the fake /autograder needs root (Gradescope runs setup.sh as root)")
    sys.exit(SKIP)
if not shutil.which("bwrap"):
    print("SKIP: bwrap (Debian package bubblewrap) is not installed")
    sys.exit(SKIP)
signal.signal(signal.SIGTERM, lambda *_: sys.exit("stopped (SIGTERM)"))  # cleanup still runs


def run(cmd, log, timeout, what):
    """Runs cmd, its output into log; exits with the output's tail when it fails."""
    t0 = time.time()
    with open(log, "w") as f:
        try:
            done = subprocess.run([str(c) for c in cmd], stdout=f, stderr=subprocess.STDOUT,
                                  timeout=timeout)
            rc = done.returncode
        except subprocess.TimeoutExpired:
            rc = f"a time-out after {timeout} s"
    seconds = time.time() - t0
    if rc != 0:
        sys.exit(f"{what} failed ({rc}); the end of its output:\n"
                 + pathlib.Path(log).read_text(errors="replace")[-4000:])
    print(f"{what}: {seconds:.0f} s", flush=True)
    return seconds


def sandbox(scratch):
    """bwrap's arguments for the fake machine: the real / 's top-level entries but the kit's own
    folder, scratch/tmp at /tmp and scratch/autograder at /autograder."""
    hide = pathlib.Path("/") / kit.relative_to("/").parts[0]
    tools = [shutil.which(t) for t in ("python3", "cmake", "ninja", "g++", "bwrap")]
    if hide.name in ("usr", "etc", "opt", "var", "root", "home") or any(
            t and pathlib.Path(t).resolve().is_relative_to(hide) for t in tools):
        hide = None  # the kit lives beside the tools it needs: leave its folder visible
    args = ["bwrap", "--die-with-parent", "--unshare-net", "--tmpfs", "/"]
    for e in sorted(pathlib.Path("/").iterdir()):
        if e.name in ("proc", "dev", "tmp", "autograder") or e == hide:
            continue
        if e.is_symlink():
            args += ["--symlink", os.readlink(e), e]
        elif e.is_dir() or e.is_file():
            args += ["--bind", e, e]
    args += ["--bind", "/proc", "/proc", "--dev-bind", "/dev", "/dev",
             "--bind", scratch / "tmp", "/tmp", "--bind", scratch / "autograder", "/autograder",
             "--setenv", "TMPDIR", "/tmp", "--chdir", "/autograder"]
    if not shutil.which("nvidia-smi"):  # no GPU (as on Gradescope): no CUDA stages to build
        args += ["--setenv", "PLAB_CMAKE_ARGS", "-DPLAB_ENABLE_CUDA=OFF"]
    return args, hide


def check_zip(path):
    with zipfile.ZipFile(path) as z:
        infos = {i.filename: i for i in z.infolist()}
    mode = {n: (i.external_attr >> 16) & 0o777 for n, i in infos.items()}
    for name in ROOT_FILES + ("plab",):
        assert name in infos, f"the zip has no {name} at its root"
        assert mode[name] == 0o755, f"{name} has mode {oct(mode[name])} in the zip, not 0755"
    assert any(n.startswith("solutions/") for n in infos), "the zip has no solutions/"
    for bad in ("build/", ".git/", "build-"):
        assert not any(n.startswith(bad) for n in infos), f"the zip holds {bad}..."
    assert not any(n.endswith(".log") for n in infos), "the zip holds a log"
    tracked = subprocess.run(["git", "-C", kit, "ls-files"], capture_output=True, text=True)
    if tracked.returncode == 0:
        extra = set(infos) - set(ROOT_FILES) - set(tracked.stdout.split("\n"))
        assert not extra, f"the zip holds files git does not track: {sorted(extra)[:10]}"
    print(f"zip: {len(infos)} files, setup.sh and run_autograder (0755) at its root, solutions/ "
          f"in, no build trees, logs or untracked files")
    return infos


def unpack(path, dest):
    """As Gradescope does: into /autograder/source, keeping the modes."""
    with zipfile.ZipFile(path) as z:
        for i in z.infolist():
            target = z.extract(i, dest)
            os.chmod(target, ((i.external_attr >> 16) & 0o777) or 0o644)


def check_results(path):
    assert path.exists(), "run_autograder wrote no /autograder/results/results.json"
    doc = json.loads(path.read_text())
    assert isinstance(doc.get("score"), (int, float)), "results.json has no numeric score"
    tests = doc.get("tests")
    assert isinstance(tests, list) and tests, "results.json has no tests"
    for t in tests:
        for key, kind in (("name", str), ("score", (int, float)), ("max_score", (int, float)),
                          ("status", str), ("output", str), ("visibility", str)):
            assert isinstance(t.get(key), kind), f"test {t.get('name')!r}: bad or no {key}"
        assert t["status"] in ("passed", "failed"), f"{t['name']}: status {t['status']!r}"
        assert t["visibility"] in VISIBILITY, f"{t['name']}: visibility {t['visibility']!r}"
        assert 0 <= t["score"] <= t["max_score"] + 1e-9, f"{t['name']}: score out of range"
    total = sum(t["score"] for t in tests)
    assert abs(total - doc["score"]) <= 0.01 * len(tests), f"score {doc['score']} != sum {total}"
    names = {t["name"]: t for t in tests}
    assert "grader error" not in names, names.get("grader error", {}).get("output")
    later = [n for n in names if n.split(":")[0] not in STAGES]
    assert not later, f"plab gradescope --stages {','.join(STAGES)} graded other stages: {later[:4]}"
    for stage in STAGES:
        mine = {n: t for n, t in names.items() if n.startswith(f"{stage}:")}
        assert mine, f"no tests of stage {stage} in results.json"
        lost = {n: t for n, t in mine.items() if t["score"] < t["max_score"]}
        noisy = all("performance" in n and "TOO NOISY" in t["output"] for n, t in lost.items())
        assert not lost or noisy, "stage {} lost points: {}".format(
            stage, {n: t["output"][:300] for n, t in lost.items()})
        print(f"stage {stage}: full marks on {len(mine)} tests"
              + (f" ({len(lost)} performance test(s) TOO NOISY)" if lost else ""))
    print(f"results.json: Gradescope's format, {len(tests)} tests, score {doc['score']}")
    if "extra_data" in doc:
        print(f"extra_data: {json.dumps(doc['extra_data'])[:300]}")


def main():
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="plab-gradescope-check-"))
    try:
        t0 = time.time()
        zip_path = scratch / "autograder.zip"
        run([plab, "gradescope", "--out", zip_path, "--stages", ",".join(STAGES)],
            scratch / "gradescope.log", 300, "plab gradescope")
        check_zip(zip_path)
        fake = scratch / "autograder"
        (scratch / "tmp").mkdir(mode=0o1777)
        os.chmod(scratch / "tmp", 0o1777)
        unpack(zip_path, fake / "source")
        for folder in STAGES.values():  # the student's upload: their stages/ folder
            dest = fake / "submission" / "stages" / folder
            dest.mkdir(parents=True)
            for f in (kit / "solutions" / folder).iterdir():
                if f.is_file():
                    shutil.copy2(f, dest / f.name)
        # and a later stage's untouched starting point, which the autograder's --stages leaves out
        shutil.copytree(kit / "stages" / "03-openmp", fake / "submission" / "stages" / "03-openmp")
        (fake / "results").mkdir()
        box, hidden = sandbox(scratch)
        print(f"fake /autograder: {fake} (bwrap; the real {hidden or '(none)'} hidden)", flush=True)
        run(box + ["bash", "-c", "cd /autograder/source && ./setup.sh"], scratch / "setup.log",
            3000, "setup.sh (offline, builds the kit)")
        source = fake / "source"
        assert source.stat().st_mode & 0o077 == 0, "setup.sh left /autograder/source readable"
        assert (source / "build" / "bin" / "plab").exists(), "setup.sh did not build the kit"
        # Gradescope copies run_autograder to /autograder and runs it from there.
        run(box + ["bash", "-c", "cp /autograder/source/run_autograder /autograder/ && "
                                 "/autograder/run_autograder"],
            scratch / "run_autograder.log", 3000, "run_autograder (stages 01 and 02)")
        check_results(fake / "results" / "results.json")
        print(f"gradescope check passed in {time.time() - t0:.0f} s")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        if scratch.exists():
            print(f"warning: could not remove all of {scratch}", file=sys.stderr)


if __name__ == "__main__":
    main()
