#!/usr/bin/env python3
"""Checks `plab view`'s page in a real browser: Debian's chromium, headless, driven by Selenium
through chromium-driver. Run by CTest (labels view and kit); skips (exit 77) with a message saying
what is missing where the browser, its driver or Selenium cannot be had (./plab installs them).

  view_check.py PLAB_PROGRAM DATASETS_DIR SCRATCH_DIR

The four checks: the page loads with no console error and no network request; the canvas at step 0
and at step 5 differ; a click on disk 0 of the head-on scene at step 2 shows its known event (a
pair with disk 1 at t = 0.125 in the step: the disks close 8.5 at speed 4); the compare view of a
mutant's output (particle 7's x moved at step 9) marks step 9 on the slider, names particle 7 and
its field, and rings disk 7 in red at step 9 and nothing at step 8.
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys

SKIP = 77
plab, datasets, scratch = sys.argv[1], pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])

browser = shutil.which("chromium") or shutil.which("chromium-browser")
driver = shutil.which("chromedriver")
missing = [name for name, found in (("chromium", browser), ("chromium-driver", driver))
           if not found]
try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
except ImportError:
    missing.append("selenium (python3 -m pip install selenium)")
if missing:
    print(f"SKIPPED: the browser test needs {', '.join(missing)}; ./plab test installs what it "
          "can (as root: apt-get install chromium chromium-driver; selenium from Debian or pip)")
    sys.exit(SKIP)

if scratch.exists():
    shutil.rmtree(scratch)
scratch.mkdir(parents=True)
# The browser's and its driver's scratch files go under ours, removed at the end.
(scratch / "tmp").mkdir()
os.environ["TMPDIR"] = str(scratch / "tmp")


def run(*args):
    done = subprocess.run([plab, *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"plab {' '.join(map(str, args))} exited {done.returncode}:\n{done.stderr}")
    return done.stdout


# The pages, from golden outputs (no stage runs: a student release's kit tests pass untouched):
# head-on with the events file every stage writes for it, and dense-box against a mutant of it.
head_on, events = scratch / "head-on.html", scratch / "head-on.events"
events.write_text("".join(f"{step} {i} {kind}\n" for step, kind in
                          ((2, "pair"), (6, "wall"), (10, "pair"), (14, "wall"), (18, "pair"))
                          for i in (0, 1)))
run("view", datasets / "golden" / "head-on.out", "--events", events, "--out", head_on)
scene = datasets / "scenes" / "dense-box.in"
expected, mutant = datasets / "golden" / "dense-box.out", scratch / "mutant.out"
mutant.write_text("".join(
    "9 7 " + " ".join(f"{float(v) + 0.5:.8f}" if k == 0 else v
                      for k, v in enumerate(line.split()[2:])) + "\n"
    if line.startswith("9 7 ") else line for line in expected.read_text().splitlines(True)))
compare = scratch / "compare.html"
said = run("view", mutant, "--scene", scene, "--compare", expected, "--out", compare)
assert "step 9, particle 7, field x" in said, said

# Bad pairings are refused, saying why, where the page would show another run's data: an output
# with another scene, an events file of another run (indices past N; another run of the same
# scene: velocities that collisions leave unchanged), --events beside a scene.
def refused(*args):
    done = subprocess.run([plab, *map(str, args)], capture_output=True, text=True)
    assert done.returncode != 0, f"plab {' '.join(map(str, args))} was accepted"
    return done.stderr


said = refused("view", datasets / "golden" / "course-2.out", "--scene", scene, "--out",
               scratch / "x.html")
assert "give the scene it was run on" in said, said
far = scratch / "far.events"  # a particle dense-box does not have
far.write_text("2 0 pair\n2 1 pair\n3 512 wall\n")
said = refused("view", expected, "--scene", scene, "--events", far, "--out", scratch / "x.html")
assert "far.events:3: particle 512, but the run has 40 particles" in said, said
strangers = scratch / "strangers.events"  # dense-box's particles in steps they move freely
strangers.write_text("0 2 wall\n0 12 wall\n1 0 wall\n1 2 wall\n")
said = refused("view", expected, "--scene", scene, "--events", strangers, "--out", scratch / "x.html")
assert "velocity as it was" in said, said
said = refused("view", scene, "--events", events, "--out", scratch / "x.html")
assert "--events is for an output" in said, said
# A run cut short: alone, its header says so; against the whole run, the first difference past
# its end is marked at the last step both print
short = scratch / "dense-box.out"  # named as its scene: found without --scene
short.write_text("".join(line for line in expected.read_text().splitlines(True)
                         if int(line.split()[0]) < 50))
alone, cut = scratch / "short.html", scratch / "cut.html"
run("view", short, "--scene", scene, "--out", alone)
run("view", short, "--scene", scene, "--compare", expected, "--out", cut)
print("plab view: another scene, another run's events and --events beside a scene refused")

options = webdriver.ChromeOptions()
options.binary_location = browser
for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
             "--window-size=1200,800", "--no-first-run", "--disable-extensions",
             f"--user-data-dir={scratch / 'profile'}"):
    options.add_argument(flag)
options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
try:
    browser_session = webdriver.Chrome(options=options, service=Service(driver))
except Exception as e:  # noqa: BLE001 (any failure to start the browser is a skip, said why)
    print(f"SKIPPED: chromium did not start headless here: {str(e).splitlines()[0]}")
    shutil.rmtree(scratch, ignore_errors=True)
    sys.exit(SKIP)


def load(page):
    """Opens `page`; returns the console errors and the network requests other than the page."""
    b.get("about:blank")  # what came before (the browser's own start page) is left out
    b.get_log("browser")
    b.get_log("performance")
    b.get(page.as_uri())
    b.execute_script("return window.plab.draw()")
    errors = [e["message"] for e in b.get_log("browser") if e["level"] == "SEVERE"]
    requests = []
    for entry in b.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message["method"] == "Network.requestWillBeSent":
            url = message["params"]["request"]["url"]
            if url != page.as_uri():
                requests.append(url)
    return errors, requests


def canvas_png():
    return b.find_element(By.ID, "view").screenshot_as_png


def set_step(step):
    frame = b.execute_script(f"return window.plab.frameOfStep({step})")
    assert frame >= 0, f"step {step} is not in the page"
    b.execute_script(f"window.plab.setFrame({frame}); window.plab.draw()")


def click_disk(i):
    x, y = b.execute_script(f"return window.plab.clientOf({i})")
    ActionChains(b).move_to_element_with_offset(b.find_element(By.TAG_NAME, "body"), 0, 0).perform()
    body = b.find_element(By.TAG_NAME, "body")
    rect = body.rect
    ActionChains(b).move_to_element_with_offset(
        body, int(x - rect["x"] - rect["width"] / 2), int(y - rect["y"] - rect["height"] / 2)
    ).click().perform()
    b.execute_script("window.plab.draw()")
    return b.find_element(By.ID, "info").text


b = browser_session
try:
    for page in (head_on, compare, alone, cut):
        errors, requests = load(page)
        assert not errors, f"{page.name}: console errors: {errors}"
        assert not requests, f"{page.name}: network requests: {requests}"
        print(f"{page.name}: loaded, no console error, no network request")

    load(head_on)
    set_step(0)
    first = canvas_png()
    set_step(5)
    fifth = canvas_png()
    assert first != fifth, "the canvas at step 0 and at step 5 are the same image"
    print("head-on: the canvas at step 0 and at step 5 differ")

    set_step(2)
    text = click_disk(0)
    assert "disk 0 at step 2" in text, text
    assert "pair with 1 at t = 0.1250" in text, text
    print("head-on: a click on disk 0 at step 2 shows 'pair with 1 at t = 0.1250'")

    load(compare)
    header = b.find_element(By.ID, "title").text
    assert "first difference: step 9, particle 7, x" in header, header
    first_frame = b.execute_script("return window.plab.firstFrame")
    assert first_frame == b.execute_script("return window.plab.frameOfStep(9)"), first_frame
    mark = b.find_element(By.ID, "first-mark")
    assert mark.is_displayed(), "no first-difference mark on the slider"
    b.find_element(By.ID, "goto-first").click()
    assert b.execute_script("return window.plab.frame()") == first_frame - 1

    def red_near(i):
        """Red ring pixels around disk i's centre on the canvas."""
        return b.execute_script(f"""
            const c = document.getElementById('view'), [x, y] = window.plab.clientOf({i});
            const r = c.getBoundingClientRect(), d = window.devicePixelRatio || 1;
            const img = c.getContext('2d').getImageData(Math.round((x - r.left) * d) - 30,
                                                        Math.round((y - r.top) * d) - 30, 60, 60);
            let red = 0;
            for (let k = 0; k < img.data.length; k += 4)
              if (img.data[k] > 180 && img.data[k + 1] < 80 && img.data[k + 2] < 80) red++;
            return red;""")

    b.execute_script("window.plab.draw()")
    assert red_near(7) == 0, "disk 7 ringed at step 8, before the difference"
    b.find_element(By.ID, "forward").click()
    b.execute_script("window.plab.draw()")
    assert b.execute_script("return window.plab.frame()") == first_frame
    assert red_near(7) > 20, "disk 7 not ringed in red at step 9"
    text = click_disk(7)
    assert "disk 7 at step 9" in text and "differs at this step" in text, text
    print("compare: step 9 marked on the slider, particle 7 and x named, disk 7 ringed at step 9 "
          "and not at step 8, its values shown for both runs")

    load(alone)
    header = b.find_element(By.ID, "title").text
    assert "this output ends at step 49, its scene has 100 steps" in header, header
    load(cut)
    header = b.find_element(By.ID, "title").text
    assert "first difference: step 50 (past step 49, the last both runs print" in header, header
    assert b.find_element(By.ID, "first-mark").is_displayed(), "no mark for a run that ends early"
    b.find_element(By.ID, "goto-first").click()
    last = b.execute_script("return window.plab.frameOfStep(49)")
    assert b.execute_script("return window.plab.frame()") == last, "not at the last shared step"
    print("a run cut short: its header says so; compared, its end marked at step 49")
finally:
    b.quit()
shutil.rmtree(scratch, ignore_errors=True)
print("view check: 6 of 6")
