#!/usr/bin/env python3
"""plab release: writes the student version of the kit into a new folder: everything but the
solutions, the instructor's CI and build folders, with the HTML docs built from that very copy
(so that they show the starting points, never a solution). No hidden-test seed is stored
anywhere in the kit: `plab grade` takes it at grading time.

  release.py --kit-source DIR --out DIR
"""
import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

LEFT_OUT = (".git", "build", "build-*", "solutions", ".ci", "__pycache__", "*.partial",
            "*.png", ".gl", ".whl")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kit-source", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    kit, out = pathlib.Path(a.kit_source), pathlib.Path(a.out).resolve()
    if out.exists() and any(out.iterdir()):
        sys.exit(f"plab release: {out} exists and is not empty; name a new folder")
    if out.is_relative_to(kit.resolve()):
        sys.exit("plab release: write the release outside the kit's own folder")
    shutil.copytree(kit, out, ignore=shutil.ignore_patterns(*LEFT_OUT), dirs_exist_ok=True)
    print(f"copied the kit without {', '.join(LEFT_OUT)} into {out}")
    print("building the student docs from the release itself (Doxygen)", flush=True)
    with tempfile.TemporaryDirectory(prefix="plab-release-docs-") as build:
        gen = ["-G", "Ninja"] if shutil.which("ninja") else []
        steps = [["cmake", "-S", out, "-B", build, *gen, "-DCMAKE_BUILD_TYPE=Release",
                  "-DPLAB_BUILD_TESTS=OFF", "-DPLAB_ENABLE_CUDA=OFF"],
                 ["cmake", "--build", build, "--target", "docs"]]
        for step in steps:
            done = subprocess.run([str(s) for s in step], capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"plab release: {' '.join(map(str, step))} failed:\n"
                         f"{done.stdout[-3000:]}{done.stderr[-3000:]}")
        shutil.copytree(pathlib.Path(build) / "docs" / "html", out / "docs" / "html")
    print(f"docs: {out / 'docs' / 'html' / 'index.html'}")
    print(f"release ready: cd {out} && ./plab test --impl student   (fails until the exercises are done)")


if __name__ == "__main__":
    main()
