"""The course guide for instructors and teaching assistants (a docs page, written when `plab docs`
builds the instructor's docs): per stage, the learning objectives, the expected hours, what the
student writes, the marking scheme as kit/grade/rubric.json gives it (read here, never retyped),
what the idea test checks and the hint it prints, the common mistakes (the grader's mutants with
the feedback of a real grading, kit/instructor/mistakes.json by tools/mistakes.py), the handout's
questions and the report's deliverable.

  python3 -m plab.guide --kit KIT --out PAGE.md
"""
import argparse
import json
import pathlib
import re


def questions(kit, stage):
    """The handout's questions section, as Markdown (empty when there is none)."""
    found = sorted((kit / "handouts").glob(f"{stage}-*.md"))
    if not found:
        return ""
    lines = found[0].read_text().splitlines()
    for k, line in enumerate(lines):
        m = re.match(r"(#+)\s+(.*)", line)
        if m and re.search(r"question", m[2], re.I):
            body = []
            for nxt in lines[k + 1:]:
                h = re.match(r"(#+)\s", nxt)
                if h and len(h[1]) <= len(m[1]):
                    break
                body.append(nxt)
            return "\n".join(body).strip()
    return ""


def mistakes(kit, stage):
    """The stage's common mistakes as Markdown lines: the grader's mutants, each with the points
    and the feedback of a real grading (kit/instructor/mistakes.json, by tools/mistakes.py)."""
    path = kit / "kit" / "instructor" / "mistakes.json"
    found = [m for m in json.loads(path.read_text())["mistakes"] if m["stage"] == stage] \
        if path.exists() else []
    out = []
    for m in found:
        gated = f", {m['tests_gated']} more right but gated by the idea test" \
            if m["tests_gated"] else ""
        out += ["", f"- **{m['mistake']}** (mutant `{m['name']}`): {m['score']:g} of "
                f"{m['max_score']:g} points; {m['tests_wrong']} of {m['tests']} tests wrong{gated}.",
                "", "  ```diff"]
        out += [f"  - {line}" for line in m["old"].rstrip("\n").splitlines()]
        out += [f"  + {line}" for line in m["new"].rstrip("\n").splitlines()] + ["  ```", ""]
        if m["idea_failed"]:
            out.append(f"  The idea test fails: \"{' '.join(m['idea_feedback'])[:300]}\"")
        if m["first_failed"]:
            out += [f"  The student reads first (`{m['first_failed']}`):", "", "  ```text"]
            out += [f"  {line}" for line in m["feedback"]] + ["  ```"]
    if out:
        doc = json.loads(path.read_text())
        out = ["", "**Common mistakes** (the grader's mutants of the solution, each graded alone "
               f"by `plab grade` at commit {doc['commit']}, {doc['date']}: "
               "`tools/mistakes.py` writes them):"] + out
    return out


def public_count(manifest, sizes):
    return sum(1 for d in manifest["scenes"] if d["size"] in sizes)


def scheme(rubric, manifest, key, conf):
    """The marking scheme of one graded stage as table rows."""
    corr, perf = rubric["correctness"], rubric["performance"]
    rows = []
    n_pub = public_count(manifest, conf["sizes"])
    rows.append(("public scenes (the kit's datasets, sizes " + ", ".join(conf["sizes"]) + ")",
                 f"{n_pub} x {corr['public_points_each']}", n_pub * corr["public_points_each"]))
    n_hid = len(corr.get("hidden_scenes", [])) + len(corr.get("hidden_families", []))
    rows.append((f"hidden scenes (random from the secret seed: {len(corr.get('hidden_scenes', []))} "
                 f"sizes, {len(corr.get('hidden_families', []))} families of hard cases)",
                 f"{n_hid} x {corr['hidden_points_each']}", n_hid * corr["hidden_points_each"]))
    if corr.get("one_step_points"):
        rows.append(("one step from every printed state", "", corr["one_step_points"]))
    if conf.get("races") and corr.get("races_points"):
        rows.append(("no data race (ThreadSanitizer; only for a correct stage)", "",
                     corr["races_points"]))
    if conf.get("performance"):
        mode = perf.get("relative", "reference")
        yardstick = {"reference": "the reference", "class_best": "the class's best time",
                     "curve": "the class"}.get(mode, mode)
        how = ("by rank in the class (the fastest gets full marks)" if mode == "curve" else
               f"full marks up to {perf['full_up_to_ratio']}x its time, none from "
               f"{perf['zero_at_ratio']}x")
        rows.append((f"speed against {yardstick} ({perf['runs']} timed runs, outputs compared; "
                     f"{how}; the grader's measured times go on the leaderboard)", "",
                     perf["points"]))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kit", type=pathlib.Path, required=True)
    ap.add_argument("--out", type=pathlib.Path, required=True)
    a = ap.parse_args()
    kit = a.kit
    course = json.loads((kit / "kit" / "guide" / "course.json").read_text())["stages"]
    rubric = json.loads((kit / "kit" / "grade" / "rubric.json").read_text())
    manifest = json.loads((kit / "datasets" / "manifest.json").read_text())
    graded = rubric["stages"]
    out = ["# Course guide for instructors and teaching assistants {#course_guide}", "",
           "Written by `plab docs` from `kit/guide/course.json` (objectives, hours, deliverables), "
           "`kit/grade/rubric.json` (every point and limit: change them there) and each stage's "
           "handout (its questions). Grading mechanics: \\ref instructors.", "",
           "| stage | hours | graded as |", "|---|---|---|"]
    for stage, c in sorted(course.items()):
        keys = [k for k, v in graded.items() if v.get("folder", k[:2]) == stage]
        out.append(f"| {stage} | {c['hours']} | {', '.join(keys) or 'not graded'} |")
    out.append(f"\nIn all: {sum(c['hours'] for c in course.values())} hours of a student's "
               "work, reading the handouts included.\n")
    for stage, c in sorted(course.items()):
        handout = sorted((kit / "handouts").glob(f"{stage}-*.md"))
        anchor = f" (\\ref handout_{stage})" if handout else ""
        out += [f"## Stage {stage}{anchor}", "", f"**Expected time:** about {c['hours']} hours.",
                "", "**Learning objectives.** The student can:", ""]
        out += [f"- {o}" for o in c["objectives"]]
        out += ["", "**What the student writes** (the EXERCISEs of the starting point):", ""]
        out += [f"{k}. {w}" for k, w in enumerate(c["writes"], 1)]
        for key, conf in sorted(graded.items()):
            if conf.get("folder", key[:2]) != stage or key[:2] != stage:
                continue
            rows = scheme(rubric, manifest, key, conf)
            total = sum(r[2] for r in rows)
            where = []
            if conf.get("ranks"):
                where.append(f"on {conf['ranks']} ranks")
            if conf.get("gpu"):
                where.append("on a GPU")
            if conf.get("threads", 1) > 1:
                where.append(f"{conf['threads']} threads")
            out += ["", f"**Marking scheme, `{key}`** ({', '.join(where) or 'one thread'}; "
                    f"{total:g} points):", "", "| part | count x points | points |", "|---|---|---|"]
            out += [f"| {r[0]} | {r[1]} | {r[2]:g} |" for r in rows]
            idea = conf.get("idea")
            if idea:
                out += ["", f"**The idea test** (it gates this stage's correctness points): "
                        f"{idea['what']}. A student who misses it reads: \"{idea['hint']}\""]
        out += mistakes(kit, stage)
        q = questions(kit, stage)
        if q:
            out += ["", "**The handout's questions** (for the report and the lab session):", "", q]
        out += ["", f"**The report's deliverable:** {c['deliverable']}. "
                f"`./plab report --stage {stage}` writes its skeleton: the student's own timings, "
                "figures and these questions.", ""]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text("\n".join(out) + "\n")
    print(f"course guide: {a.out}")


if __name__ == "__main__":
    main()
