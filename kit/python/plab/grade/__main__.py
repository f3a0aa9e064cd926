"""plab grade: grades a submission, or a class of them, with the kit's own code in a sandbox.

One submission (--submission): builds its stages with the kit's CMake in a sandbox, runs them
there under limits against public and hidden scenes, one step at a time and for speed, and writes
Gradescope's results.json (its leaderboard: the times the grader measured), JUnit XML and a
summary (with the hidden scenes' seed). A class (--class DIR): every submission of DIR graded by
its own grader in its own sandbox, J at a time, into OUT/gradebook.csv, OUT/summary.html,
OUT/leaderboard.html (anonymous names) and OUT/students/NAME/. Points, limits and the performance
scoring: kit/grade/rubric.json.

`./plab grade ...` runs `python3 -m plab.grade --kit-source KIT --kit-build BUILD ...` with its
arguments untouched (the seed excepted: it goes in the environment): every option is declared
here, once, and `plab grade --help` prints this parser's help.
"""
import argparse
import os
import pathlib
import shutil
import signal
import sys
import traceback

from plab import KIT
from plab.grade import classroom
from plab.grade.grader import Grader
from plab.grade.results import Results, atomic_write
from plab.grade.stage import Refused


def existing(kind):
    """An argparse type: a path that exists (kind "path") or a folder (kind "folder")."""
    def check(text):
        path = pathlib.Path(text)
        if not (path.is_dir() if kind == "folder" else path.exists()):
            raise argparse.ArgumentTypeError(f"no such {kind}: {text}")
        return text if kind == "path" else path
    return check


def stage_list(text):
    """--stages as the rubric names stages: "2,6-gpu" is "02,06-gpu"."""
    out = []
    for item in (t.strip() for t in text.split(",") if t.strip()):
        head, sep, tail = item.partition("-")
        out.append((head.zfill(2) if head.isdigit() else head) + sep + tail)
    return ",".join(out)


def parser():
    ap = argparse.ArgumentParser(
        prog="plab grade", description=__doc__.split("\n\n")[1].replace("\n", " "),
        allow_abbrev=False)  # `--stage 02` is a mistake to report, not `--stages 02`
    what = ap.add_mutually_exclusive_group(required=True)
    what.add_argument("--submission", metavar="PATH", type=existing("path"),
                      help="what the student uploaded: the kit folder, a stages/ folder, a zip of "
                           "either, or one stage's files flat")
    what.add_argument("--class", dest="klass", metavar="DIR", type=existing("folder"),
                      help="grade a class: a folder with one submission (folder or zip) per "
                           "student, each in its own sandbox; writes OUT/gradebook.csv, "
                           "OUT/summary.html, OUT/leaderboard.html and "
                           "OUT/students/NAME/results.json (resumable)")
    ap.add_argument("--jobs", type=int, metavar="J", default=max(1, (os.cpu_count() or 2) // 2),
                    help="with --class: submissions graded at a time (default: one per two cores)")
    ap.add_argument("--regrade", nargs="?", const="all", default=None, metavar="WHO",
                    help="with --class: grade again the submissions already graded (default: "
                         "resume): all of them, or WHO: students' names, comma-separated, or "
                         "'noisy' (those whose timing was too noisy)")
    ap.add_argument("--stages", default="", metavar="LIST", type=stage_list,
                    help="stages to grade, e.g. 01,06 (default: every stage the submission has; "
                         "06 means 06 on the CPU and, with a GPU, 06-gpu; 08 every entry of 08; "
                         "with an entry named alone, as in 06-gpu or 08,08-ranks3, the entries "
                         "named only)")
    ap.add_argument("--out", default=None,
                    help="results.json to write (default results.json; always written; the "
                         "summary goes beside it, NAME.summary.txt); with --class, the folder of "
                         "the class's results (default grades)")
    ap.add_argument("--junit", default="", help="JUnit XML to write (default: beside --out, .xml)")
    ap.add_argument("--seed", "--hidden-seed", dest="seed", type=int, default=None, metavar="K",
                    help="the hidden scenes' seed: replays a grading (default: random, recorded "
                         "in the summary and in results.json's extra_data). `plab grade` passes "
                         "it in the environment (PLAB_GRADE_SEED), which other users cannot read")
    ap.add_argument("--rubric", default=str(KIT / "kit" / "grade" / "rubric.json"),
                    help="the rubric: every point, limit and scene (default: the kit's "
                         "kit/grade/rubric.json)")
    ap.add_argument("--leaderboard-name", default="", metavar="NAME",
                    help="the name this submission's times carry on a class's leaderboard page "
                         "(--class gives each student an anonymous one)")
    ap.add_argument("--scratch", default="", help="where to build and run (default: the system's "
                                                  "temp)")
    ap.add_argument("--sandbox", choices=("auto", "bwrap", "user"), default="auto",
                    help="auto (the default: bubblewrap where namespaces are allowed, else an "
                         "unprivileged user), bwrap or user")
    ap.add_argument("--no-sandbox", action="store_true",
                    help="run student code with the grader's own rights (printed on every result)")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    ap.add_argument("--make-private", action="store_true",
                    help="with the unprivileged-user sandbox (no namespaces): take group and other "
                         "permissions from the kit's answers (solutions, goldens, build) before "
                         "grading; without it the grader refuses while they are readable")
    ap.add_argument("--races", action="store_true",
                    help="(the default) build the stages whose rubric marks races (03, 06) again "
                         "with ThreadSanitizer in the sandbox and report the first data race with "
                         "file and line")
    ap.add_argument("--no-races", action="store_true",
                    help="skip the ThreadSanitizer check (its points are then not given)")
    ap.add_argument("--kit-source", default=str(KIT), help=argparse.SUPPRESS)
    ap.add_argument("--kit-build", default=str(KIT / "build"), help=argparse.SUPPRESS)
    return ap


def grader_argv(a):
    """The options a class's batch hands each student's grader (all but the class's own)."""
    argv = ["--kit-source", a.kit_source, "--kit-build", a.kit_build, "--rubric", a.rubric,
            "--sandbox", a.sandbox]
    if a.scratch:
        argv += ["--scratch", a.scratch]
    if a.seed is not None:  # through the environment, as `plab grade` passes it
        os.environ["PLAB_GRADE_SEED"] = str(a.seed)
    argv += [flag for flag, on in (("--keep", a.keep), ("--no-sandbox", a.no_sandbox),
                                   ("--make-private", a.make_private), ("--races", a.races),
                                   ("--no-races", a.no_races)) if on]
    return argv


class Stopped(BaseException):
    """SIGTERM, SIGHUP or SIGINT arrived (a `timeout`, a closed terminal, Ctrl-C): the grading
    ends, its scratch folder (student code, builds) is removed, and its results.json says "not
    graded" instead of the tests run so far."""


def _stop(signum, _frame):
    raise Stopped(signum)


def grade_one(a):
    """Grades one submission; returns the exit status (0 graded, 2 refused, 1 the grader failed)."""
    a.out = a.out or "results.json"
    a.junit = a.junit or str(pathlib.Path(a.out).with_suffix(".xml"))
    summary_path = pathlib.Path(a.out).with_suffix(".summary.txt")
    g, status, stopped = None, 0, False
    try:
        g = Grader(a)
        g.grade()
    except Stopped as e:
        stopped = True
        if g is not None:  # results.json is rewritten after each test: no partial grade stays
            g.results.tests = []
            g.results.add("not graded", 0, 0, False, f"the grading was stopped (signal "
                          f"{e.args[0]}) before it ended: grade again")
        raise
    except Refused as e:
        status = 2
        if g is None:
            g = type("G", (), {})()
            g.results = Results(a.out, a.junit)
        g.results.notes.append(f"NOT GRADED: {e}")
        g.results.add("not graded", 0, 0, False, str(e))
        print(f"plab grade: {e}", file=sys.stderr)
    except BaseException:  # the grader's own failure still leaves a results.json
        status = 1
        if g is None:
            g = type("G", (), {})()
            g.results = Results(a.out, a.junit)
        # Not a grade: the stages graded before the failure, summed alone, would read as full
        # marks out of a smaller total (a stage it did not reach left out of the maximum)
        done = [f"{t['name']}: {t['score']:g}/{t['max_score']:g}" for t in g.results.tests]
        g.results.tests = []
        g.results.notes.append("NOT GRADED: the grader itself failed (its error in the test "
                               "'grader error'): grade this submission again")
        g.results.add("grader error", 0, 0, False, traceback.format_exc() + (
            "\nthe tests run before it (not a grade): " + "; ".join(done) if done else ""))
    finally:
        if stopped:
            if hasattr(g, "scratch") and not a.keep:
                shutil.rmtree(g.scratch, ignore_errors=True)
        elif g is not None:
            total, most = g.results.total()
            report = [f"total: {total:.2f} / {most:g}   (results: {a.out}, JUnit: {a.junit})"]
            report += [f"  {note}" for note in g.results.instructor_notes + g.results.notes]
            noisy = [t["name"] for t in g.results.tests if "TOO NOISY" in t.get("output", "")]
            if noisy:
                report.append(f"  timing TOO NOISY (spread above the rubric's limit) in "
                              f"{', '.join(noisy)}: its points were kept; grade again on a "
                              "quieter machine to measure it")
            failed = [t for t in g.results.tests  # a refusal is said once, in the notes
                      if t["status"] == "failed" and t["name"] != "not graded"]
            by_stage = {}
            for t in failed:
                by_stage.setdefault(t["name"].split(":")[0], []).append(t)
            for stage, tests in by_stage.items():
                # A public scene's failure carries the diagnosis (step, particle, field) and the
                # commands to reproduce it; the idea test, run first, only says that its hidden
                # scene's output differs. Show the first public scene the stage got wrong (not
                # one it got right that the failed idea test left without points), and say that
                # the idea test failed.
                own = [t for t in tests if not t["output"].startswith("counts 0 (it would earn")]
                t = next((t for t in own if ": public " in t["name"]), (own or tests)[0])
                report.append(f"\nfirst failure of stage {stage}: {t['name']}\n"
                              + "\n".join("  " + ln for ln in t["output"].splitlines()[:14]))
                idea = next((i for i in tests if ": idea (" in i["name"] and i is not t
                             and not i["output"].startswith("not run:")), None)
                if idea is not None:
                    first = (idea["output"].splitlines() or [""])[0]
                    report.append(f"  (its idea test failed too: {first}; the stage's other "
                                  "tests earn points only once it passes)")
            text = "\n".join(report)
            print("\n" + text)
            atomic_write(summary_path, text + "\n")  # the instructor's copy, seed included
            print(f"summary: {summary_path}")
            if hasattr(g, "scratch") and not a.keep:
                shutil.rmtree(g.scratch, ignore_errors=True)
    return status


def main(argv=None):
    # Ctrl-C too: a grader that read it as its own failure would leave a "not graded" result
    # that a resumed class batch keeps
    for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        signal.signal(sig, _stop)
    try:
        return _main(argv)
    except Stopped as e:
        klass = "--class" in (sys.argv[1:] if argv is None else argv)
        print(f"plab grade: stopped by signal {e.args[0]} ({signal.Signals(e.args[0]).name}); "
              + ("the students graded so far are kept: the same command resumes" if klass else
                 "nothing of this grading is kept"), file=sys.stderr)
        return 128 + e.args[0]


def _main(argv=None):
    ap = parser()
    a = ap.parse_args(argv)
    if a.seed is None and os.environ.get("PLAB_GRADE_SEED"):
        try:
            int(os.environ["PLAB_GRADE_SEED"])
        except ValueError:
            ap.error(f"the seed must be a whole number, not {os.environ['PLAB_GRADE_SEED']!r}")
    if a.jobs < 1:
        ap.error("--jobs must be at least 1")
    if a.scratch and not pathlib.Path(a.scratch).is_dir():
        ap.error(f"--scratch {a.scratch}: no such folder (the grader builds and runs in a new "
                 f"folder inside it)")
    if a.klass is not None:
        return classroom.run(a.klass, pathlib.Path(a.out or "grades"), a.jobs, a.stages,
                             a.regrade, grader_argv(a), a.rubric)
    return grade_one(a)


if __name__ == "__main__":
    sys.exit(main())
