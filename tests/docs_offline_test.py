#!/usr/bin/env python3
"""docs/offline.py's check can fail: a page that loads a script, a style sheet or a font from a
remote address is refused (naming file and line); local loads and plain links pass.
Usage: docs_offline_test.py KIT_SOURCE_DIR"""
import pathlib
import subprocess
import sys
import tempfile

checker = pathlib.Path(sys.argv[1]) / "docs" / "offline.py"
PAGES = {
    "remote script": ('<script src="https://cdn.example.org/MathJax.js"></script>', 1),
    "remote style": ('<link rel="stylesheet" href="//fonts.example.org/a.css">', 1),
    "remote font": ('<style>@font-face { src: url("http://example.org/f.woff"); }</style>', 1),
    "local loads and a link": ('<script src="search/search.js"></script>'
                               '<a href="https://www.doxygen.org/">Doxygen</a>', 0),
}
failures = []
for name, (body, expected) in PAGES.items():
    with tempfile.TemporaryDirectory() as html:
        pathlib.Path(html, "page.html").write_text(f"<html><body>\n{body}\n</body></html>\n")
        rc = subprocess.run([sys.executable, str(checker), html, "--check-only"],
                            capture_output=True, text=True)
        ok = (rc.returncode != 0) == bool(expected) and (not expected or "page.html:2" in rc.stdout)
        print(("ok   " if ok else "FAIL ") + f"{name}: exit {rc.returncode} {rc.stdout.strip()[:120]}")
        if not ok:
            failures.append(name)
sys.exit(f"failed: {failures}" if failures else 0)
