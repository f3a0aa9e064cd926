#!/usr/bin/env python3
"""Checks `plab read` (the kit's one reader of its formats, as JSON for its Python tools) and
`plab diff --json`: reals come back with the same bits, each kind is recognised, a step range is
kept, and a malformed file is refused with exit 1 and FILE:LINE: expected ..., found .... Run by
CTest (label kit).

  read_check.py PLAB_PROGRAM DATASETS_DIR SCRATCH_DIR
"""
import json
import pathlib
import subprocess
import sys

plab, datasets, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
scratch.mkdir(parents=True, exist_ok=True)


def run(*args):
    return subprocess.run([plab, *map(str, args)], capture_output=True, text=True)


def read(path, *args):
    done = run("read", "--json", *args, path)
    assert done.returncode == 0, f"plab read {path} exited {done.returncode}: {done.stderr}"
    return json.loads(done.stdout)


# Reals that a careless reader or writer would change: one ulp above 1, the smallest subnormal,
# the largest double, a negative zero, values with 17 significant digits.
values = [("1.0000000000000002", "98.999999999999986", "5e-324", "-1.7976931348623157e308"),
          ("3.1415926535897931", "2.7182818284590451", "0.1", "-0")]
scene = scratch / "exact.in"
scene.write_text("2\n100\n1\n7\nperf\n" + "".join(
    f"{i} {' '.join(v)}\n" for i, v in enumerate(values)))
s = read(scene)
assert (s["kind"], s["n"], s["L"], s["r"], s["steps"], s["mode"], s["generated"]) == \
    ("scene", 2, 100.0, 1.0, 7, "perf", False), s
for i, v in enumerate(values):
    for field, text in zip(("x", "y", "vx", "vy"), v):
        got, want = s[field][i], float(text)
        assert got.hex() == want.hex(), f"{field}[{i}]: {text} came back as {got!r}"
print("scene: every real back with the same bits (subnormal, largest, -0, 17 digits)")

golden = datasets / "golden" / "course-1.out"
o = read(golden)
assert o["kind"] == "output" and o["n"] == 2 and len(o["blocks"]) == o["last_step"] + 1, o["n"]
assert o["blocks"][-1]["counters"] and "pc" in o["blocks"][-1] and "pc" not in o["blocks"][0]
part = read(golden, "--steps", "3:5")
assert [b["step"] for b in part["blocks"]] == [3, 4, 5], part
assert part["blocks"][0] == o["blocks"][3]
print(f"output: {len(o['blocks'])} blocks, the last with counters; --steps 3:5 keeps 3 blocks")

events = scratch / "run.events"
events.write_text("0 1 wall\n0 4 pair\n3 4 pair\n")
e = read(events)
assert e["kind"] == "events" and e["count"] == 3, e
assert e["events"][1] == {"step": 0, "particle": 4, "kind": "pair"}, e
assert len(read(events, "--steps", "1:9")["events"]) == 1
(scratch / "none.events").write_text("")
assert read(scratch / "none.events", "--kind", "events")["events"] == []
print("events: read, and an empty events file with --kind events")

said = run("read", golden)
assert said.returncode == 0 and "an output: 101 blocks" in said.stdout, said.stdout

bad = [("scene", "3\n10\n1\n5\nprint\n0 5 5 1 1\n1 5 5 1 1\n", "bad.in:8: expected 3 particle lines"),
       ("output", "0 0 1.0 2.0 3.0 4.0\n0 1 1.0 2.0 3.0 x\n",
        "bad.out:2: expected a finite number for vy, found 'x'"),
       ("output", "0 0 1.0 2.0 3.0 4.0\nhello\n", "bad.out:2: expected a line 'step i x y vx vy'"),
       ("events", "0 1 wall\n0 1 bounce\n", "bad.events:2: expected the kind 'wall' or 'pair'")]
for kind, text, message in bad:
    path = scratch / ("bad." + {"scene": "in", "output": "out", "events": "events"}[kind])
    path.write_text(text)
    done = run("read", "--json", "--kind", kind, path)
    assert done.returncode == 1 and done.stdout == "", (kind, done.returncode, done.stdout)
    assert message in done.stderr, f"{kind}: {done.stderr!r} does not say {message!r}"
done = run("read", scratch / "missing.out")
assert done.returncode == 1 and "cannot open" in done.stderr, done.stderr
print("malformed scene, output and events files: exit 1 with FILE:LINE: expected ..., found ...")

actual = scratch / "actual.out"
actual.write_text(golden.read_text().replace("\n5 1 ", "\n5 1 9", 1))
d = json.loads(run("diff", "--json", golden, actual).stdout)
assert not d["equal"] and d["first"]["step"] == 5 and d["first"]["particle"] == 1, d["first"]
wrong = [m["step"] for m in d["steps"] if not m["equal"]]
assert wrong == [5] and len(d["steps"]) == 101, wrong
assert d["text"] == run("diff", golden, actual).stdout.strip()
print("diff --json: the first difference, and step 5 alone wrong of 101")
