"""The leaderboard: the performance runs' times as the grader measured them (the median wall time
of the timed runs in the sandbox, never a number the student's program prints), in results.json's
`leaderboard` (Gradescope's format: a list of {"name", "value", "order"}), on a class's offline
page (OUT/leaderboard.html, anonymous names, nothing loaded from the network), and the rubric's
relative scoring of the performance points.

The rubric's `performance.relative` chooses how the performance points are given:
  "reference"   (the default) the median time against the kit's reference's, measured in the same
                sandbox run after run: full points up to `full_up_to_ratio`, none from
                `zero_at_ratio`, linear in log(ratio) between (`fraction`);
  "class_best"  the same bands, against the class's best (with --class);
  "curve"       by rank in the class (with --class): the fastest gets full points, the k-th of n
                (k from 1) gets (n - k + 1) / n of them; equal values share a rank.
The class is compared by each submission's time over the reference's timed in its own grading
(class_measures()), not by the raw times, which the machine's load of the moment moves.
A submission graded alone is always scored against the reference; `plab grade --class` then
scores the class's performance tests again from the times in their results.json.
"""
import html
import json
import math

from plab.grade.results import atomic_write

#: The words of a performance test's output that the class's rescoring writes (and replaces).
CLASS_NOTE = "\nscored against the class"


def metric(key):
    """The leaderboard's name of stage key's time."""
    return f"{key}: time (s)"


def entry(key, seconds):
    """results.json's leaderboard entry of a stage's measured median time (lower is better)."""
    return {"name": metric(key), "value": round(seconds, 4), "order": "asc"}


def fraction(ratio, full, zero):
    """The share of the performance points at ratio (time over the yardstick's): 1 up to full,
    0 from zero, linear in log(ratio) between (bounded and continuous)."""
    return min(1.0, max(0.0, 1 - math.log(max(ratio, full) / full) / math.log(zero / full)))


RATIO = ": time / reference"


def ratio_entry(key, ratio):
    """results.json's leaderboard entry of a stage's median time over the kit's reference's,
    measured in the same grading, run after run (lower is better)."""
    return {"name": f"{key}{RATIO}", "value": round(ratio, 4), "order": "asc"}


def _values(data, suffix):
    out = {}
    for e in data.get("leaderboard", []):
        name = str(e.get("name", ""))
        if name.endswith(suffix) and isinstance(e.get("value"), (int, float)):
            out[name[:-len(suffix)]] = float(e["value"])
    return out


def times(data):
    """{stage key: measured seconds} of a results.json's leaderboard."""
    return _values(data, ": time (s)")


def ratios(data):
    """{stage key: measured time over the reference's} of a results.json's leaderboard."""
    return _values(data, RATIO)


def class_measures(graded):
    """{stage key: ({student: value}, unit)}: what a class is ranked by, per stage. The ratio to
    the reference timed in the same grading, where every student's results.json has one: a
    machine busier for one student than another slows the reference alike, so the ratio is
    steadier than the time (the same code graded twice a minute apart: 1.085 and 1.442 s).
    Otherwise (results.json from before the ratio) the times."""
    timed = {s: times(d) for s, d in graded.items()}
    rated = {s: ratios(d) for s, d in graded.items()}
    out = {}
    for key in sorted({k for t in timed.values() for k in t}):
        by_ratio = {s: r[key] for s, r in rated.items() if key in r}
        by_time = {s: t[key] for s, t in timed.items() if key in t}
        out[key] = (by_ratio, "x") if len(by_ratio) == len(by_time) else (by_time, "s")
    return out


MODES = ("reference", "class_best", "curve")


def check_mode(perf):
    """The rubric's performance.relative, or ValueError naming the choices."""
    mode = perf.get("relative", "reference")
    if mode not in MODES:
        raise ValueError(f"the rubric's performance.relative is {mode!r}: one of {', '.join(MODES)}")
    return mode


def class_fractions(by_student, perf):
    """{student: share of the points} of one stage, from {student: time or ratio to the
    reference} (lower is better), under the rubric's relative mode (class_best or curve)."""
    mode = check_mode(perf)
    if not by_student:
        return {}
    if mode == "class_best":
        best = max(min(by_student.values()), 1e-3)
        return {s: fraction(t / best, perf["full_up_to_ratio"], perf["zero_at_ratio"])
                for s, t in by_student.items()}
    if mode == "curve":
        n = len(by_student)
        return {s: (n - sum(u < t for u in by_student.values())) / n
                for s, t in by_student.items()}
    return {s: 1.0 for s in by_student}  # reference: the points stay as graded


def rescore(graded, perf):
    """Gives the class's performance points again under the rubric's relative mode, in place in
    graded ({student: results.json's data}); returns {"changed": the students whose data
    changed}. Nothing changes under "reference"."""
    changed = set()
    if check_mode(perf) == "reference":
        return {"changed": changed}
    for key, (by_student, unit) in class_measures(graded).items():
        shares = class_fractions(by_student, perf)
        ranked = sorted(by_student.values())
        what = "the time over the reference's" if unit == "x" else "the time"
        for student, share in shares.items():
            for t in graded[student].get("tests", []):
                if t.get("name") != f"{key}: performance":
                    continue
                rank = 1 + sum(u < by_student[student] for u in ranked)
                base = t["output"].split(CLASS_NOTE)[0]
                t["output"] = (f"{base}{CLASS_NOTE} ({perf['relative']}, by {what}): "
                               f"{by_student[student]:.3f} {unit}, rank {rank} of {len(ranked)}, "
                               f"the class's best {ranked[0]:.3f} {unit}: "
                               f"{perf['points'] * share:.2f} of {t['max_score']:g} points")
                t["score"] = round(perf["points"] * share, 3)
                t["status"] = "passed" if share >= 0.999 else "failed"
                changed.add(student)
    for student in changed:
        data = graded[student]
        data["score"] = round(sum(t.get("score", 0) for t in data.get("tests", [])), 3)
    return {"changed": changed}


def write_results(path, data):
    """Writes a results.json again (atomically)."""
    atomic_write(path, json.dumps(data, indent=2) + "\n")


def write_page(path, by_name, perf):
    """The class's leaderboard page: per stage, the graded submissions ranked by the grader's
    measured time over the reference's (class_measures()), under their anonymous names; one
    self-contained file (inline style, no script, nothing fetched)."""
    measures = class_measures(by_name)
    mode = perf.get("relative", "reference")
    parts = ["<h1>Leaderboard</h1>",
             "<p>The median wall time of each correct submission's timed runs, measured by the "
             f"grader in its sandbox ({perf['runs']} runs on a hidden scene of N = "
             f"{perf['scene']['n']}, {perf['scene']['steps']} steps), and that time over the "
             "kit's reference's, timed run after run in the same grading: the rank follows the "
             "ratio, which a busier machine changes less than the time. A program's own printed "
             "times play no part. Names are anonymous. Performance points: "
             + {"reference": "against the kit's reference time", "class_best":
                "against the class's best time", "curve": "by rank in the class"}.get(mode, mode)
             + ".</p>"]
    if not measures:
        parts.append("<p>No submission reached a performance run.</p>")
    for key, (by_name_value, _) in measures.items():
        rows = sorted((value, name, by_name[name]) for name, value in by_name_value.items())
        parts.append(f"<h2>Stage {html.escape(key)}</h2><table><tr><th>rank</th><th>name</th>"
                     "<th>time / reference</th><th>time (s)</th><th>points</th>"
                     "<th>timing</th></tr>")
        for value, name, data in rows:
            rank = 1 + sum(v < value for v, _, _ in rows)
            test = next((t for t in data.get("tests", [])
                         if t.get("name") == f"{key}: performance"), {})
            points = (f"{test['score']:g} / {test['max_score']:g}" if "score" in test else "")
            ratio = ratios(data).get(key)
            # A spread above the rubric's limit: the rank says little (a busy machine)
            noisy = "noisy: time again" if "TOO NOISY" in test.get("output", "") else ""
            parts.append(f"<tr><td>{rank}</td><td>{html.escape(name)}</td><td>"
                         + (f"{ratio:.3f}" if ratio is not None else "") +
                         f"</td><td>{times(data)[key]:.3f}</td><td>{points}</td>"
                         f"<td>{noisy}</td></tr>")
        parts.append("</table>")
    style = ("body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
             "td,th{border:1px solid #999;padding:0.2em 0.6em;text-align:right}")
    path.write_text("<!DOCTYPE html><html><head><meta charset='utf-8'><title>plab leaderboard"
                    f"</title><style>{style}</style></head><body>" + "".join(parts) +
                    "</body></html>\n")
