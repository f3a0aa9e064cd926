#!/usr/bin/env python3
"""Makes the generated HTML docs work offline, then proves it.

1. Copies the part of Debian's MathJax 2 (package libjs-mathjax) that the pages use into
   HTML_DIR/mathjax/ (Doxyfile: MATHJAX_RELPATH = mathjax, MATHJAX_FORMAT = HTML-CSS): the loader,
   the TeX input, the HTML-CSS output with its TeX web fonts, the extensions and their config.
2. Reads every page, script and style sheet of HTML_DIR and fails, naming file and line, if any
   of them loads a script, a style sheet, a font or an image from a remote address (plain links
   to web pages are fine: a reader follows them or not). It also fails if a page uses MathJax and
   the local copy is missing.

Usage: offline.py HTML_DIR [--mathjax /usr/share/javascript/mathjax] [--check-only]
"""
import argparse
import pathlib
import re
import shutil
import sys

#: What the pages need of MathJax 2: the rest (other outputs, fonts, localizations, the unpacked
#: sources) is 40 MB that no page loads.
MATHJAX_PARTS = ["MathJax.js", "extensions", "jax/input/TeX", "jax/element",
                 "jax/output/HTML-CSS/jax.js", "jax/output/HTML-CSS/config.js", "jax/output/HTML-CSS/autoload",
                 "jax/output/HTML-CSS/fonts/TeX", "localization/en",
                 "fonts/HTML-CSS/TeX/woff"]

#: A load from a remote address: <script src=...>, <link href=...> (style sheets, icons, fonts),
#: <img src=...>, CSS url(...) and @import, and a script that sets a MathJax or font root.
REMOTE_LOAD = re.compile(
    r"""(<script[^>]*\bsrc\s*=\s*["']?\s*(https?:)?//)"""
    r"""|(<link[^>]*\bhref\s*=\s*["']?\s*(https?:)?//)"""
    r"""|(<(img|iframe|source|embed)[^>]*\bsrc\s*=\s*["']?\s*(https?:)?//)"""
    r"""|(url\(\s*["']?\s*(https?:)?//)"""
    r"""|(@import\s+["']\s*(https?:)?//)""", re.IGNORECASE)


def copy_mathjax(source, html):
    """Copies MATHJAX_PARTS from `source` into html/mathjax (replacing an older copy)."""
    dest = html / "mathjax"
    if dest.exists():
        shutil.rmtree(dest)
    for part in MATHJAX_PARTS:
        src = source / part
        if not src.exists():
            sys.exit(f"offline docs: {src} is missing (Debian package libjs-mathjax)")
        target = dest / part
        target.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, target, symlinks=False)
        else:
            shutil.copyfile(src, target)
    return dest


def scan(html):
    """([(file, line number, text)] of every remote load in the docs' own pages, scripts and
    styles, whether a page loads MathJax). The local MathJax copy is Debian's and loads nothing
    remote in this configuration."""
    found, uses_mathjax = [], False
    for path in sorted(html.rglob("*")):
        if path.suffix not in (".html", ".htm", ".js", ".css", ".svg") or "mathjax" in path.parts:
            continue
        text = path.read_text(errors="replace")
        uses_mathjax = uses_mathjax or (path.suffix == ".html" and "MathJax.js" in text)
        for number, line in enumerate(text.splitlines(), 1):
            if REMOTE_LOAD.search(line):
                found.append((path.relative_to(html), number, line.strip()[:160]))
    return found, uses_mathjax


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("html", type=pathlib.Path, help="the HTML folder Doxygen wrote")
    ap.add_argument("--mathjax", type=pathlib.Path, default=pathlib.Path("/usr/share/javascript/mathjax"),
                    help="Debian's MathJax 2 (default: %(default)s)")
    ap.add_argument("--check-only", action="store_true", help="check, copy nothing")
    args = ap.parse_args()
    if not args.check_only:
        copy_mathjax(args.mathjax, args.html)
    loads, uses_mathjax = scan(args.html)
    problems = [f"{f}:{n}: loads from a remote address: {t}" for f, n, t in loads]
    if uses_mathjax and not (args.html / "mathjax" / "MathJax.js").is_file():
        problems.append("the pages load mathjax/MathJax.js but the docs have no local copy")
    if problems:
        print("offline docs: {} problem(s); the docs must work without a network:".format(len(problems)))
        print("\n".join("  " + p for p in problems[:20]))
        sys.exit(1)
    pages = sum(1 for _ in args.html.glob("*.html"))
    print(f"offline docs: {pages} pages, nothing loaded from the network"
          + (", formulas by the local MathJax" if uses_mathjax else ""))


if __name__ == "__main__":
    main()
