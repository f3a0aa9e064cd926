"""The grader's results: Gradescope's results.json (with its leaderboard) and JUnit XML,
written again after every test, so that the tests already run keep their results whatever
happens later."""
import json
import os
import pathlib
import threading
import time
from xml.sax.saxutils import escape, quoteattr



class Results:
    """The tests so far, written out (JSON for Gradescope, JUnit XML) after each one."""

    def __init__(self, json_path, junit_path):
        self.json_path, self.junit_path = pathlib.Path(json_path), pathlib.Path(junit_path)
        self.tests, self.notes, self.start = [], [], time.time()
        self.extra = {}  # results.json's extra_data: for the instructor, not shown to students
        # Lines of the summary file (results.summary.txt) only, never in results.json's output,
        # which Gradescope shows to the student at once: the hidden scenes' seed (the hidden
        # tests' own outputs, shown once grades are published, say how to replay theirs)
        self.instructor_notes = []
        self.leaderboard = []  # results.json's leaderboard: the grader's measured times
        self.banner = ""  # printed before every test's output (--no-sandbox)
        self.write()

    def add(self, name, score, max_score, passed, output, hidden=False, seconds=0.0):
        output = self.banner + output
        self.tests.append({"name": name, "score": round(score, 3), "max_score": max_score,
                           "status": "passed" if passed else "failed", "output": output,
                           "visibility": "after_published" if hidden else "visible",
                           "seconds": round(seconds, 3)})
        mark = "ok  " if passed else "FAIL"
        print(f"  {mark} {score:5.2f}/{max_score:<4g} {name}", flush=True)
        self.write()

    def write(self):
        total = sum(t["score"] for t in self.tests)
        most = sum(t["max_score"] for t in self.tests)
        summary = "\n".join(self.notes + [f"total: {total:.2f} / {most:g}"])
        doc = {"score": round(total, 3), "execution_time": round(time.time() - self.start, 1),
               "output": summary, "visibility": "visible", "stdout_visibility": "hidden",
               "extra_data": self.extra,
               **({"leaderboard": self.leaderboard} if self.leaderboard else {}),
               "tests": [{k: v for k, v in t.items() if k != "seconds"} for t in self.tests]}
        atomic_write(self.json_path, json.dumps(doc, indent=2) + "\n")
        failures = sum(t["status"] == "failed" for t in self.tests)
        cases = []
        for t in self.tests:
            stage = t["name"].split(":")[0]
            body = "" if t["status"] == "passed" else (
                f"<failure message={quoteattr(t['output'].splitlines()[0] if t['output'] else 'failed')}>"
                f"{escape(t['output'])}</failure>")
            cases.append(f'  <testcase classname={quoteattr(stage)} name={quoteattr(t["name"])} '
                         f'time="{t["seconds"]}">{body}</testcase>')
        atomic_write(self.junit_path,
                     '<?xml version="1.0" encoding="UTF-8"?>\n'
                     f'<testsuite name="plab grade" tests="{len(self.tests)}" '
                     f'failures="{failures}">\n' + "\n".join(cases) + "\n</testsuite>\n")

    def total(self):
        return sum(t["score"] for t in self.tests), sum(t["max_score"] for t in self.tests)


def atomic_write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    # A name of this process's own: a second grader writing the same file never renames this one's
    temp = path.with_name(f"{path.name}.{os.getpid()}.{threading.get_ident()}.partial")
    temp.write_text(text)
    os.replace(temp, path)
