"""plab grade --class: grades every submission of a class folder (one folder or zip per student),
each by its own grader process in its own sandbox, J at a time, and writes the gradebook.

  python3 -m plab.grade --class DIR --out OUT --jobs J [--stages 01,02] [--regrade [WHO]] [GRADER OPTIONS]

OUT/students/NAME/ holds each student's results.json (Gradescope's format), JUnit XML and the
summary a student is shown. A batch that was stopped starts again where it stopped: a student
whose results.json exists for the same upload, the same --stages, options and rubric (their hash
in OUT/students/NAME/upload.sha256) is not graded twice unless --regrade. At the end:
OUT/gradebook.csv (one row per student: each stage's points, the total, flags, the student's
anonymous leaderboard name), OUT/summary.html
(the score histogram of every stage) and OUT/leaderboard.html (plab.grade.leaderboard: the
grader's measured times under anonymous names; with the rubric's relative scoring, the
performance points against the class).
"""
import argparse
import base64
import concurrent.futures
import csv
import fcntl
import hashlib
import html
import io
import json
import os
import pathlib
import secrets
import subprocess
import sys
import threading
import time

from plab import KIT, python_env
from plab.grade import leaderboard



def upload_hash(entry):
    """The upload's content hash (files' names and bytes; links are not followed)."""
    h = hashlib.sha256()
    paths = [entry] if entry.is_file() else sorted(p for p in entry.rglob("*"))
    for p in paths:
        if p.is_symlink():
            h.update(b"link:" + str(p.relative_to(entry.parent)).encode())
        elif p.is_file():
            h.update(str(p.relative_to(entry.parent)).encode() + b"\0")
            h.update(p.read_bytes())
    return h.hexdigest()


def kit_hash(kit):
    """The grading kit's own content hash: every file the grader reads or builds a stage with
    (kit/, cmake/, the CMake files, stages/ and datasets/), so that a batch resumed after a `git
    pull` of the grader grades again what the old one graded."""
    h = hashlib.sha256()
    roots = [kit / d for d in ("kit", "cmake", "stages", "datasets")]
    files = [kit / "CMakeLists.txt", kit / "CMakePresets.json"]
    for root in roots:
        if root.is_dir():
            files += sorted(p for p in root.rglob("*") if p.is_file() and not p.is_symlink()
                            and "__pycache__" not in p.parts)
    for p in files:
        if p.is_file():
            h.update(str(p.relative_to(kit)).encode() + b"\0")
            h.update(p.read_bytes())
    return h.hexdigest()


def grading_key(entry, stages, grader_args, rubric_path, kit_version):
    """What a stored result must match to be kept on resume (OUT/students/NAME/upload.sha256):
    the upload's hash, the stages asked for, the grader's options, the rubric's bytes and the
    kit's (kit_hash()). A batch resumed with other --stages, another rubric or another version
    of the grader grades everyone again."""
    h = hashlib.sha256(json.dumps([stages, grader_args, kit_version]).encode())
    h.update(pathlib.Path(rubric_path).read_bytes())
    return upload_hash(entry) + " " + h.hexdigest()


def students(folder):
    """(name, path) of every upload in the class folder (folders and zips), and the names of the
    entries left out (links, other files: a tarball, a lone step.cpp), which the batch names."""
    out, left_out = [], []
    for p in sorted(folder.iterdir()):
        if p.name.startswith("."):
            continue
        if not p.is_symlink() and (p.is_dir() or p.suffix == ".zip"):
            out.append((p.stem if p.suffix == ".zip" else p.name, p))
        else:
            left_out.append(p.name + (" (a link)" if p.is_symlink() else ""))
    return out, left_out


def clock(seconds):
    seconds = int(seconds)
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m" if seconds >= 3600 else \
        f"{seconds // 60}m{seconds % 60:02d}s"


class Progress:
    """One line a finished student with the count, the elapsed time and an estimate of the rest."""

    def __init__(self, total, done_before):
        self.total, self.done, self.fresh = total, done_before, 0
        self.t0 = time.monotonic()
        self.lock = threading.Lock()

    def tick(self, name, text):
        with self.lock:
            self.done += 1
            self.fresh += 1
            spent = time.monotonic() - self.t0
            left = self.total - self.done
            eta = spent / self.fresh * left if self.fresh else 0
            width = 24
            bar = "#" * (width * self.done // max(1, self.total))
            print(f"[{bar:<{width}}] {self.done:>4}/{self.total} {100 * self.done // max(1, self.total):>3}%"
                  f"  elapsed {clock(spent)}  ETA {clock(eta)}  {name}: {text}", flush=True)


class Graders:
    """The grader processes running now, so that a stopped batch stops them too: a signal to the
    batch alone (`kill PID`, a scheduler's timeout) reaches no child, and a queued student must
    not start once the batch is stopping (else a resumed batch and the old one's leftovers grade
    the same student at once)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.running = set()
        self.stopping = False

    def start(self, cmd, **kw):
        with self.lock:
            if self.stopping:
                return None
            proc = subprocess.Popen(cmd, **kw)
            self.running.add(proc)
            return proc

    def done(self, proc):
        with self.lock:
            self.running.discard(proc)

    def stop(self):
        """No new grader starts; each running one gets SIGTERM (it removes its scratch folder and
        leaves a results.json that says "not graded") and is waited for."""
        with self.lock:
            self.stopping = True
            running = list(self.running)
        for proc in running:
            if proc.poll() is None:
                proc.terminate()
        for proc in running:
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


class KitChanged(Exception):
    """The grading kit's files changed while a class was graded (kit_hash() differs)."""

    def __init__(self, student):
        super().__init__(f"the kit changed (noticed after {student})")
        self.student = student


def grade_unless_changed(version, name, *args):
    """grade_one(name, *args), unless the kit is no longer `version` (kit_hash()): then no grader
    starts, and the batch stops on this student's result (None)."""
    if kit_hash(KIT) != version:
        return name, None, 0.0
    return grade_one(name, *args)


def grade_one(name, entry, out, grader_args, stages, jobs_cpu, key, graders):
    """Runs one grader on one upload (`key`: its grading_key(), stored with the results);
    returns (name, results dict or None, seconds)."""
    mine = out / "students" / name
    mine.mkdir(parents=True, exist_ok=True)
    results = mine / "results.json"
    cmd = [sys.executable, "-m", "plab.grade", "--submission", str(entry), "--out",
           str(results), *grader_args]
    if stages:
        cmd += ["--stages", stages]
    env = dict(python_env(), PLAB_BUILD_JOBS=str(jobs_cpu))
    t0 = time.monotonic()
    with open(mine / "grader.log", "w") as log:
        proc = graders.start(cmd, stdout=log, stderr=subprocess.STDOUT, env=env)
        if proc is None:  # the batch is stopping
            return name, None, 0.0
        print(f"  grading {name} (its log: {mine / 'grader.log'})", flush=True)
        try:
            returncode = proc.wait()
        finally:
            graders.done(proc)
    seconds = time.monotonic() - t0
    if returncode < 0 or returncode >= 128:  # stopped by a signal: graded again later
        return name, None, seconds
    try:
        data = json.loads(results.read_text())
    except (OSError, ValueError):
        return name, None, seconds
    (mine / "upload.sha256").write_text(key + "\n")
    return name, data, seconds


def stage_points(data):
    """{stage key: (score, max)} from a results.json (test names start 'KEY: ')."""
    per = {}
    for t in data.get("tests", []):
        key = t.get("name", "").split(":")[0].strip()
        if not key or " " in key:
            continue
        s, m = per.get(key, (0.0, 0.0))
        per[key] = (s + float(t.get("score", 0)), m + float(t.get("max_score", 0)))
    return per


def missing_stages(data):
    """The stage keys of a results.json that the upload had no folder for: their tests say so
    (those held back by them, a performance test's "not timed", say only that)."""
    missing = set()
    for t in data.get("tests", []):
        key = t.get("name", "").split(":")[0].strip()
        if key and " " not in key and "the submission has no stages/" in t.get("output", ""):
            missing.add(key)
    return missing


def flags(data):
    """Short words a TA scans for: not built, refused (goes around the kit's measurements), idea
    missed, a wrong output on the idea test's scene, race, limit hit, not graded, a timing too
    noisy to trust. A test held back by another failure flags nothing of its own."""
    words = set()
    for t in data.get("tests", []):
        n, o = t.get("name", ""), t.get("output", "")
        if "TOO NOISY" in o:  # points kept, but the timing says nothing: regrade on a quiet machine
            words.add("noisy")
        if t.get("status") != "failed":
            continue
        if n == "not graded" or n == "grader error":
            words.add("not-graded")
        if "does not compile" in o or "did not compile" in o:
            words.add("build")
        if "data race at" in o:  # found, even where its points were held back
            words.add("race")
        # A test that was not run, or whose points another failure holds back (the stage's build,
        # its idea test), flags nothing of its own (no "idea" for a stage that did not compile,
        # no "race" for a race test held back): the failure that stopped it does
        if o.startswith(("not run:", "counts 0 (it would earn", "not checked:",
                         "0 points: every correctness test")):
            continue
        if "goes around what the kit measures" in o:
            words.add("refused")
        if "idea" in n.lower():  # a wrong output on the idea's scene is not a missed idea
            words.add("wrong" if "differs from the reference" in o else "idea")
        elif ((": public " in n or ": hidden " in n or "one step at a time" in n) and
              not any(x in o for x in ("compile", " limit", "goes around what the kit measures"))):
            words.add("wrong")  # a correctness scene's output differs, or the stage crashed
        if "race" in n.lower():
            words.add("race")
        if "time limit" in o or "memory limit" in o or "output limit" in o:
            words.add("limit")
    return sorted(words)


def histogram_png(values, most, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4.2, 2.6))
    ax.hist(values, bins=min(20, max(5, len(set(values)))), range=(0, most or 1), color="#4c72b0")
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("points")
    ax.set_ylabel("students")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def row_flags(row):
    """A gradebook row's flags as written (the page's table and the CSV's column): its results'
    words, then missing:NN for each stage it had no folder for."""
    return " ".join([*row["flags"], *(f"missing:{k}" for k in sorted(row.get("missing", ())))])


def copies_section(found):
    """The summary page's part on copies: per stage, its flagged pairs and the students close to
    the kit's own solution, with a link to the side by side page."""
    from plab.similar import percent  # the pages' own rounding (down, as a flag's threshold)
    parts = ["<h2>Copies</h2><p>Pairs of students whose stage shares most of its code "
             "(plab similar: copydetect, names normalised, the starting point ignored). A flag is "
             "a reason to read both, not a verdict.</p><ul>"]
    for stage, doc in found:
        if isinstance(doc, str):
            parts.append(f"<li>stage {html.escape(stage)}: not compared ({html.escape(doc)})</li>")
            continue
        flagged = [p for p in doc["pairs"] if p["flagged"]]
        leaked = [k for k in doc["kit_solution"] if k["flagged"]]
        text = (f'<li><a href="similar-{stage}.html">stage {html.escape(stage)}</a>: '
                f"{len(doc['submissions'])} compared, {len(flagged)} pair(s) at or above "
                f"{doc['threshold']:.0%}")
        if flagged:
            text += ": " + ", ".join(f"{html.escape(p['a'])} / {html.escape(p['b'])} "
                                     f"{percent(p['similarity'])}" for p in flagged[:10])
            text += " ..." if len(flagged) > 10 else ""
        big = [g for g in doc.get("groups", []) if len(g) > 2]
        if big:  # many students from one source: a group says it once where its pairs are many
            text += "; joined by them: " + "; ".join(
                f"{len(g)} students ({', '.join(html.escape(x) for x in g)})" for g in big)
        if leaked:
            text += (f"; <b>at or above {doc['threshold']:.0%} of the kit's own solution</b>: "
                     + ", ".join(f"{html.escape(k['student'])} {percent(k['similarity'])}"
                                 for k in leaked))
        parts.append(text + "</li>")
    return "".join(parts) + "</ul>"


def write_outputs(out, rows, keys, found=()):
    with open(out / "gradebook.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["student", *keys, "total", "max", "flags", "leaderboard name"])
        for r in rows:
            w.writerow([r["name"], *[f"{r['per'].get(k, (0, 0))[0]:g}" for k in keys],
                        f"{r['total']:g}", f"{r['max']:g}",
                        row_flags(r),
                        r["anonymous"]])
    parts = [f"<h1>Class summary: {len(rows)} students</h1>",
             "<p>Score histograms per stage (points), from each student's results.json. "
             "The gradebook is gradebook.csv beside this page.</p><div>"]
    for k in keys:
        vals = [r["per"][k][0] for r in rows if k in r["per"]]
        most = max((r["per"][k][1] for r in rows if k in r["per"]), default=0)
        if not vals:
            continue
        img = histogram_png(vals, most, f"stage {k} (max {most:g})")
        mean = sum(vals) / len(vals)
        handed = sum(1 for r in rows if k in r["per"] and k not in r.get("missing", ()))
        parts.append(f'<figure style="display:inline-block;margin:0.5em">'
                     f'<img src="data:image/png;base64,{img}" alt="stage {html.escape(k)}">'
                     f"<figcaption>stage {html.escape(k)}: handed in by {handed} of {len(rows)} "
                     f"students, mean {mean:.1f} / {most:g} over the {len(vals)} graded"
                     f"</figcaption></figure>")
    parts.append("</div><h2>Flags</h2><table border=1 cellpadding=3><tr><th>student</th>"
                 "<th>total</th><th>flags</th></tr>")
    for r in rows:
        words = row_flags(r)
        if words:
            parts.append(f"<tr><td>{html.escape(r['name'])}</td><td>{r['total']:g}/{r['max']:g}</td>"
                         f"<td>{html.escape(words)}</td></tr>")
    parts.append("</table>")
    if found:
        parts.append(copies_section(found))
    (out / "summary.html").write_text("<!DOCTYPE html><html><head><meta charset='utf-8'>"
                                      "<title>plab grade --class</title></head><body "
                                      "style='font-family:sans-serif'>" + "".join(parts) +
                                      "</body></html>")


def anonymous_names(out, everyone):
    """{student: anonymous name} for the leaderboard, kept in OUT/leaderboard-names.json so that a
    resumed batch keeps them (random: a name says nothing about who it is; the instructor's
    gradebook.csv pairs them)."""
    path = out / "leaderboard-names.json"
    try:
        names = json.loads(path.read_text())
    except (OSError, ValueError):
        names = {}
    taken = set(names.values())
    for student, _ in everyone:
        while student not in names:
            name = f"anon-{secrets.token_hex(2)}"
            if name not in taken:
                names[student] = name
                taken.add(name)
    path.write_text(json.dumps(names, indent=1, sort_keys=True) + "\n")
    return names


def again(regrade, name, mine):
    """Whether --regrade asks for this student's stored results to be graded again: every
    student ("all"), those named (comma-separated), or those whose stored results hold a timing
    too noisy to trust ("noisy")."""
    if not regrade:
        return False
    wanted = regrade.split(",")
    if "all" in wanted or name in wanted:
        return True
    if "noisy" in wanted:
        try:
            return "noisy" in flags(json.loads((mine / "results.json").read_text()))
        except (OSError, ValueError):
            return False
    return False


def run(klass, out, jobs, stages, regrade, grader_args, rubric_path):
    """Grades the class folder into out; returns the exit status (1 if a grading left no
    results.json)."""
    if not klass.is_dir():
        sys.exit(f"plab grade --class: {klass} is not a folder")
    everyone, left_out = students(klass)
    if left_out:
        print(f"plab grade --class: left out, not a folder nor a .zip (a student's upload is one "
              f"of those): {', '.join(left_out)}", flush=True)
    if not everyone:
        sys.exit(f"plab grade --class: {klass} holds no submission (a folder or a zip per student)")
    rubric = json.loads(pathlib.Path(rubric_path).read_text())
    try:
        leaderboard.check_mode(rubric["performance"])
    except ValueError as e:
        sys.exit(f"plab grade --class: {e}")
    out.mkdir(parents=True, exist_ok=True)
    # One batch writes OUT at a time (two would grade the same student at once): the lock is
    # the kernel's, so a batch that was killed leaves none behind
    lock = open(out / ".grading.lock", "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        sys.exit(f"plab grade --class: another grading is writing to {out} now; wait for it to "
                 "end (or stop it): the same command then resumes where it stopped")
    anonymous = anonymous_names(out, everyone)
    version = kit_hash(KIT)
    todo, done, changed = [], [], 0
    keys = {}
    for name, entry in everyone:
        mine = out / "students" / name
        keys[name] = grading_key(entry, stages, grader_args, rubric_path, version)
        stored = (mine / "upload.sha256").read_text().split() \
            if (mine / "results.json").is_file() and (mine / "upload.sha256").is_file() else []
        same = stored == keys[name].split()
        changed += bool(stored) and not same
        (done if same and not again(regrade, name, mine) else todo).append((name, entry))
    cores = os.cpu_count() or 2
    per_job = max(1, cores // max(1, jobs))
    print(f"plab grade --class: {len(everyone)} submissions, {len(done)} graded already, "
          f"{len(todo)} to grade, {jobs} at a time ({per_job} core{'s' * (per_job > 1)} each)", flush=True)
    unknown = sorted(set(regrade.split(",")) - {n for n, _ in everyone} - {"all", "noisy"}) \
        if regrade else []
    if unknown:
        print(f"plab grade --class: --regrade names no submission of the class: "
              f"{', '.join(unknown)}", flush=True)
    if changed and regrade != "all":
        print(f"plab grade --class: {changed} graded before with another upload, other --stages, "
              "other options, another rubric or another version of the kit: graded again",
              flush=True)
    progress = Progress(len(everyone), len(done))
    failures = []
    completed = {name for name, _ in done}  # graded whole: resumed, or in this batch
    graders = Graders()
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=jobs)
    futures = []
    try:
        futures = [pool.submit(grade_unless_changed, version, n, e, out,
                               [*grader_args, "--leaderboard-name", anonymous[n]], stages, per_job,
                               keys[n], graders)
                   for n, e in todo]
        for fut in concurrent.futures.as_completed(futures):
            name, data, seconds = fut.result()
            if kit_hash(KIT) != version:  # a `git pull` or an edit mid-batch: no mixed grades
                raise KitChanged(name)
            if data is None:
                failures.append(name)
                progress.tick(name, f"NO RESULTS (see students/{name}/grader.log)")
            else:
                completed.add(name)
                per = stage_points(data)
                progress.tick(name, (f"NOT GRADED in {seconds:.0f} s (see students/{name}/"
                                     "results.summary.txt)") if "not-graded" in flags(data) else
                              f"{sum(s for s, _ in per.values()):g}/"
                              f"{sum(m for _, m in per.values()):g} in {seconds:.0f} s")
    except BaseException as stop:  # stopped (SIGTERM, Ctrl-C, the kit changed): no student
        graders.stop()               # starts, the running ones end
        pool.shutdown(wait=True, cancel_futures=True)
        if isinstance(stop, KitChanged):
            # Those graded with the kit as it was when the batch started keep their results
            # (their stored key names that kit): the same command grades everyone again with the
            # kit as it is now, resuming none of them
            completed = set()
            print(f"plab grade --class: STOPPED: the grading kit changed while the class was "
                  f"graded (a `git pull`, or an edit of its kit/, cmake/, stages/, datasets/ or "
                  f"CMake files), noticed when {stop.student} was done: one class is graded by one "
                  "version of the kit. Run the same command again once the kit stays as it is: "
                  "every student is graded again with it.", flush=True)
            write_class(out, everyone, anonymous, rubric, failures, completed, stopped=True)
            return 1
        # A student whose grader ended with results as the batch stopped, before this loop
        # read them, is graded too (its upload.sha256 is written: a resume keeps it), so the
        # gradebook so far says so
        for fut in futures:
            if fut.done() and not fut.cancelled() and fut.exception() is None \
                    and fut.result()[1] is not None:
                completed.add(fut.result()[0])
        # The gradebook of those graded so far (the others not-graded): a resume completes it
        try:
            write_class(out, everyone, anonymous, rubric, failures, completed, stopped=True)
        except Exception as e:  # the stop is what is reported
            print(f"plab grade --class: no gradebook written on stopping ({e})", flush=True)
        raise
    pool.shutdown(wait=True)
    return write_class(out, everyone, anonymous, rubric, failures, completed, klass=klass)


def copies(klass, out, stages):
    """Each stage's pairs of students by shared code (plab.similar, copydetect), in
    OUT/similar-NN.html and OUT/similar-NN.json; [(stage, its JSON document or the reason there
    is none)] for the summary page."""
    from plab import similar  # copydetect: loaded only when a class is compared
    found = []
    for stage in stages:
        page = out / f"similar-{stage}.html"
        print(f"plab grade --class: comparing the class's stage {stage} for copies", flush=True)
        try:
            doc = similar.compare(klass, stage, KIT, page)
        except ValueError as e:
            found.append((stage, str(e)))
            continue
        (out / f"similar-{stage}.json").write_text(json.dumps(doc, indent=1))
        found.append((stage, doc))
    return found


def write_class(out, everyone, anonymous, rubric, failures, completed, stopped=False,
                klass=None):
    """The class's gradebook, summary page and leaderboard from the results in OUT/students of
    the students in `completed` (a grading stopped part-way leaves a results.json of the tests
    run so far: not a grade); with `klass` (a batch that ended), each stage's copies too (see
    copies()). Returns the exit status (1 if a grading left no results.json)."""
    graded = {}
    for name, _ in everyone:
        if name not in completed:
            continue
        try:
            graded[name] = json.loads((out / "students" / name / "results.json").read_text())
        except (OSError, ValueError):
            pass
    board = leaderboard.rescore(graded, rubric["performance"])
    for name, data in graded.items():
        if name in board["changed"]:
            leaderboard.write_results(out / "students" / name / "results.json", data)
    rows = []
    for name, _ in everyone:
        if name not in graded:
            rows.append({"name": name, "anonymous": anonymous[name], "per": {}, "total": 0,
                         "flags": ["not-graded"]})
            continue
        data = graded[name]
        per = stage_points(data)
        rows.append({"name": name, "anonymous": anonymous[name], "per": per,
                     "total": sum(s for s, _ in per.values()), "flags": flags(data),
                     "missing": missing_stages(data)})
    keys = sorted({k for r in rows for k in r["per"]})
    # Every row out of the same most: a stage a student did not hand in (or an upload that held
    # none) counts 0 of that stage's points, not 0 of 0 (a spreadsheet's percentage divides by it).
    most = {k: max(r["per"][k][1] for r in rows if k in r["per"]) for k in keys}
    for r in rows:
        r["max"] = sum(most.values())
    found = copies(klass, out, sorted({k[:2] for k in keys})) if klass and not stopped else []
    write_outputs(out, rows, keys, found)
    leaderboard.write_page(out / "leaderboard.html", {anonymous[n]: d for n, d in graded.items()},
                           rubric["performance"])
    print(f"plab grade --class: {'stopped; so far: ' if stopped else ''}gradebook "
          f"{out / 'gradebook.csv'}, summary {out / 'summary.html'}"
          + ("" if stopped else " (copies: " + (", ".join(
              f"similar-{st}.html" for st, d in found if not isinstance(d, str)) or "none compared")
             + ")")
          + f", leaderboard {out / 'leaderboard.html'}"
          + (f"; {len(failures)} without results: {', '.join(failures)}" if failures else "")
          + ("; the same command resumes" if stopped else ""), flush=True)
    return 1 if failures else 0
