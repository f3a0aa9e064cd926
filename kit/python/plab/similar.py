"""plab similar: ranks the pairs of a class's submissions of one stage by how much code they share,
with copydetect (winnowed fingerprints of the token stream, names normalised, so renamed
identifiers, moved functions and changed comments do not hide a copy) and the stage's starting
point as boilerplate (the given code every student shares is ignored). Writes an offline HTML page
with the pairs side by side, the shared code highlighted.

A submission is a folder or a zip, one per student, read as `plab grade` reads an upload: the kit
folder, a stages/ folder, a zip of either, or one stage's files flat with their banner. Symbolic
links are never followed.
"""
import argparse
import html
import json
import pathlib
import re
import shutil
import sys
import tempfile

from copydetect import CopyDetector

from plab import KIT
from plab.grade import upload

EXTENSIONS = (".cpp", ".cu", ".cuh", ".hpp", ".h", ".cc")


KIT_SOLUTION = "(the kit's solution)"  #: the instructor copy's own solution, compared with each


def stage_folder(kit, stage):
    found = sorted((kit / "stages").glob(f"{stage}-*"))
    if not found:
        raise ValueError(f"the kit has no stage {stage} (stages/{stage}-*)")
    return found[0]


def percent(x):
    """A share as whole percent, rounded down: 74.77% shows as 74%, never as the 75% a flag at
    75% would then seem to have missed."""
    return f"{int(x * 100 + 1e-9)}%"


def concatenated(files):
    """One text of a submission's sources, each after a `// ---- NAME` line (what is compared)."""
    return "".join(f"// ---- {f.name}\n{f.read_text(errors='replace')}\n" for f in files)


def gather(submissions, stage_name, scratch):
    """{student: one file holding their stage's sources, in name order}, and the submissions left
    out with why. Each upload is read as `plab grade` reads it (plab.grade.upload: a zip, the kit
    folder, a stages/ folder, one stage's files flat with their banner; links, `__MACOSX` and
    dot files left out), so that a flat file of another stage is never taken for this one."""
    flat = scratch / "students"
    flat.mkdir()
    kit_folders = {d.name[:2]: d.name for d in (KIT / "stages").glob("[0-9][0-9]-*") if d.is_dir()}
    sid = stage_name[:2]
    out = {}
    skipped = []
    for k, entry in enumerate(sorted(submissions.iterdir())):
        if entry.is_symlink() or not (entry.is_dir() or entry.suffix == ".zip"):
            continue
        student = re.sub(r"\.zip$", "", entry.name)
        work = scratch / f"upload-{k}"
        work.mkdir()
        try:
            found, _ = upload.find_stages(entry, kit_folders, [], work)
        except (upload.UploadError, OSError) as e:
            skipped.append(f"{entry.name} ({str(e).splitlines()[0]})")
            continue
        files = upload.sources(found[sid]) if sid in found else []
        if not files:
            skipped.append(f"{entry.name} (no source file of {stage_name}: it has "
                           f"{', '.join(sorted(found)) or 'no stage'})")
            continue
        path = flat / f"{student}.cpp"
        path.write_text(concatenated(files))
        out[student] = path
    return out, skipped


def boilerplate(folder, scratch):
    """The starting point's files, concatenated the same way (one file per source, too)."""
    dest = scratch / "boilerplate"
    dest.mkdir()
    for f in sorted(folder.iterdir()):
        if f.suffix in EXTENSIONS:
            shutil.copy2(f, dest / (f.name + ".cpp"))
    return dest


def rank(files, boiler):
    """Every pair with its similarity (the larger of the two shares of shared code)."""
    det = CopyDetector(test_dirs=[str(next(iter(files.values())).parent)],
                       boilerplate_dirs=[str(boiler)], extensions=["cpp"], display_t=0.0,
                       autoopen=False, silent=True, noise_t=25, guarantee_t=25)
    det.run()
    student = {str(p): s for s, p in files.items()}
    pairs = {}
    for sim_a, sim_b, fa, fb, code_a, code_b, overlap in det.get_copied_code_list():
        a, b = student[str(fa)], student[str(fb)]
        if a == b:
            continue
        key = tuple(sorted((a, b)))
        score = max(sim_a, sim_b)
        if key not in pairs or score > pairs[key]["score"]:
            left = (code_a, sim_a) if key[0] == a else (code_b, sim_b)
            right = (code_b, sim_b) if key[0] == a else (code_a, sim_a)
            pairs[key] = {"a": key[0], "b": key[1], "score": float(score), "overlap": int(overlap),
                          "left": left, "right": right}
    # The most similar first; among equals (a class copied from one source: many pairs at 100%),
    # the pair sharing more code first, then by name, so that the order is the same every run.
    return sorted(pairs.values(), key=lambda p: (-p["score"], -p["overlap"], p["a"], p["b"]))


def groups(pairs, threshold):
    """The submissions that flagged pairs join, directly or through others (the connected parts
    of the flagged pairs), the largest first: five students who copied one source make ten
    flagged pairs and one group of five."""
    parent = {}

    def root(x):
        while parent.setdefault(x, x) != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for p in pairs:
        if p["score"] >= threshold:
            parent[root(p["a"])] = root(p["b"])
    parts = {}
    for x in parent:
        parts.setdefault(root(x), []).append(x)
    return sorted((sorted(g) for g in parts.values()), key=lambda g: (-len(g), g))


PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><title>plab similar: stage {stage}</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; }} table {{ border-collapse: collapse; }}
td, th {{ border: 1px solid #ccc; padding: 0.2em 0.6em; }} .flag {{ background: #fdd; }}
.pair {{ display: flex; gap: 1em; }} .pair pre {{ flex: 1; overflow: auto; max-height: 40em;
background: #f8f8f8; padding: 0.5em; font-size: 0.8em; }}
.highlight-red {{ background: #f99; }} .highlight-green {{ background: #9e9; }}
</style></head><body>
<h1>Stage {stage}: pairs of submissions by shared code</h1>
<p>{count} submissions, {npairs} pairs compared with copydetect (names normalised), the starting
point ignored as boilerplate. Flagged (at or above {threshold:.0%}): {nflag}. A flag is a reason to
read both, not a verdict.</p>{groups}{skipped}
<table><tr><th>#</th><th>pair</th><th>similarity</th><th>shared tokens</th></tr>{rows}</table>
{details}</body></html>"""


def write_page(path, stage, files, pairs, threshold, skipped, top, leaked=(), folder=""):
    rows, details = [], []
    for k, p in enumerate(pairs, 1):
        flag = ' class="flag"' if p["score"] >= threshold else ""
        link = f'<a href="#pair{k}">{html.escape(p["a"])} / {html.escape(p["b"])}</a>' if k <= top \
            else f'{html.escape(p["a"])} / {html.escape(p["b"])}'
        rows.append(f'<tr{flag}><td>{k}</td><td>{link}</td><td>{percent(p["score"])}</td>'
                    f'<td>{p["overlap"]}</td></tr>')
        if k <= top:
            details.append(
                f'<h2 id="pair{k}">{k}. {html.escape(p["a"])} and {html.escape(p["b"])}: '
                f'{percent(p["score"])}</h2><div class="pair">'
                f'<pre><b>{html.escape(p["a"])}</b> ({percent(p["left"][1])} of it shared)\n{p["left"][0]}</pre>'
                f'<pre><b>{html.escape(p["b"])}</b> ({percent(p["right"][1])} of it shared)\n{p["right"][0]}</pre>'
                f'</div>')
    note = ("<p>Not compared: " + html.escape("; ".join(skipped)) + "</p>") if skipped else ""
    if leaked:  # close to the kit's own solution: a leaked answer, whoever else shares it
        note += (f'<p class="flag">At or above {threshold:.0%} of the kit\'s own solution '
                 f"(solutions/{html.escape(folder)}): "
                 + ", ".join(f"{html.escape(k['student'])} {percent(k['similarity'])}"
                             for k in leaked) + "</p>")
    joined = groups(pairs, threshold)
    grouped = ("<p>Joined by flagged pairs (each group shares code, directly or through its "
               "others): " + "; ".join(f"{len(g)}: " + ", ".join(html.escape(x) for x in g)
                                       for g in joined) + "</p>") if joined else ""
    path.write_text(PAGE.format(stage=stage, count=len(files), npairs=len(files) * (len(files) - 1) // 2,
                                threshold=threshold, nflag=sum(p["score"] >= threshold for p in pairs),
                                groups=grouped, skipped=note, rows="".join(rows),
                                details="".join(details)))


def main():
    ap = argparse.ArgumentParser(prog="plab similar", description=__doc__.split("\n\n")[0])
    ap.add_argument("submissions", type=pathlib.Path, help="a folder with one folder or zip per student")
    ap.add_argument("--stage", required=True, help="the stage, e.g. 03")
    ap.add_argument("--out", type=pathlib.Path, default=None,
                    help="the HTML report (default: similar-NN.html)")
    ap.add_argument("--threshold", type=float, default=0.75,
                    help="flag pairs at or above this similarity (0..1; default %(default)s)")
    ap.add_argument("--json", type=pathlib.Path, default=None,
                    help="also write the ranking as JSON (pairs, similarity, flagged)")
    ap.add_argument("--show", type=int, default=20, help="pairs shown side by side (default %(default)s)")
    ap.add_argument("--kit", type=pathlib.Path, default=KIT,
                    help=argparse.SUPPRESS)
    a = ap.parse_args()
    if not a.submissions.is_dir():
        sys.exit(f"plab similar: {a.submissions} is not a folder")
    stage = a.stage.zfill(2)
    out = a.out or pathlib.Path(f"similar-{stage}.html")
    try:
        doc = compare(a.submissions, stage, a.kit, out, a.threshold, a.show, say=print)
    except ValueError as e:
        sys.exit(f"plab similar: {e}")
    if a.json:
        a.json.write_text(json.dumps(doc, indent=1))
    print(f"{'rank':>4}  {'similarity':>10}  pair")
    for k, p in enumerate(doc["pairs"][:10], 1):
        mark = "  FLAGGED" if p["flagged"] else ""
        print(f"{k:>4}  {percent(p['similarity']):>10}  {p['a']} / {p['b']}{mark}")
    close = [p for p in doc["kit_solution"] if p["flagged"]]
    if close:
        print(f"plab similar: {len(close)} submission(s) at or above {a.threshold:.0%} of the "
              f"kit's own solution (solutions/{doc['folder']}): "
              + ", ".join(f"{p['student']} {percent(p['similarity'])}" for p in close))
    for g in doc["groups"]:
        if len(g) > 2:  # a pair is in the list above
            print(f"plab similar: {len(g)} submissions joined by flagged pairs: {', '.join(g)}")
    for s in doc["not_compared"]:
        print(f"not compared: {s}")
    print(f"plab similar: {sum(p['flagged'] for p in doc['pairs'])} pair(s) at or above "
          f"{a.threshold:.0%}; side by side: {out}")


def compare(submissions, stage, kit, out, threshold=0.75, show=20, say=None):
    """Compares every submission of `stage` in the class folder `submissions`, writes the side by
    side page `out`, and returns the ranking as the JSON document `--json` writes (pairs,
    similarity, flagged; `kit_solution`: each student against the kit's own solution, in the
    instructor's copy). Raises ValueError when fewer than two submissions have the stage."""
    folder = stage_folder(kit, stage)
    with tempfile.TemporaryDirectory(prefix="plab-similar-") as tmp:
        scratch = pathlib.Path(tmp)
        files, skipped = gather(submissions, folder.name, scratch)
        if len(files) < 2:
            raise ValueError(f"{len(files)} submission(s) with stage {stage} in {submissions}: "
                             "nothing to compare" +
                             (f" (not compared: {'; '.join(skipped)})" if skipped else ""))
        if say:
            say(f"plab similar: comparing {len(files)} submissions of stage {stage} "
                f"({len(files) * (len(files) - 1) // 2} pairs)", flush=True)
        # In the instructor's copy the kit's own solution takes part, as one more "student": a
        # submission close to it is a leaked answer, which pairs among students would only show
        # as everyone alike.
        solution = sorted((kit / "solutions").glob(f"{stage}-*"))
        if solution:
            files[KIT_SOLUTION] = scratch / "students" / "__kit_solution__.cpp"
            files[KIT_SOLUTION].write_text(concatenated(
                f for f in sorted(solution[0].iterdir()) if f.suffix in EXTENSIONS))
        pairs = rank(files, boilerplate(folder, scratch))
        leaked = [p for p in pairs if KIT_SOLUTION in (p["a"], p["b"])]
        pairs = [p for p in pairs if KIT_SOLUTION not in (p["a"], p["b"])]
        files.pop(KIT_SOLUTION, None)
        kit_solution = [{"student": p["b"] if p["a"] == KIT_SOLUTION else p["a"],
                         "similarity": p["score"], "flagged": p["score"] >= threshold}
                        for p in leaked]
        write_page(out, stage, files, pairs, threshold, skipped, show,
                   [k for k in kit_solution if k["flagged"]], folder.name)
    return {"stage": stage, "folder": folder.name, "threshold": threshold,
            "submissions": sorted(files), "not_compared": skipped, "kit_solution": kit_solution,
            "groups": groups(pairs, threshold),
            "pairs": [{"a": p["a"], "b": p["b"], "similarity": p["score"],
                       "shared_tokens": p["overlap"], "flagged": p["score"] >= threshold}
                      for p in pairs]}


if __name__ == "__main__":
    main()
