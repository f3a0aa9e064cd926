#!/usr/bin/env python3
"""Rewrites Doxygen-only markup in handouts/*.md as plain Markdown, in place (what the handouts
were converted with; rerun it on a handout written or merged in the old form):
\f$x\f$ -> $x$, a \f[ ... \f] block -> $$ lines, \ref label / [text](@ref label) -> a link to the
page's file, \image html F "caption" -> a Markdown image of build/docs/figures/F. Code spans and
fenced blocks are left as they are. docs/markdown_filter.py turns it back for Doxygen; the test
docs.markdown (tests/handouts_markdown_check.py) says what is left.

  tools/handouts_to_markdown.py   (from the kit's root)
"""
import pathlib
import re

# Pages that are not handouts of a stage: label -> (file, relative to handouts/; link text).
PAGES = {"model_page": ("model.md", "the model"),
         "architecture_page": ("../docs/ARCHITECTURE.md", "the architecture page"),
         "student_page": ("working.md", "How a student works"),
         "instructors": ("instructors.md", "Instructors"),
         "viewer_page": ("viewer.md", "plab view")}


def pages():
    """Every page label -> (its file, the link text): PAGES and each stage's handout."""
    found = dict(PAGES)
    for f in pathlib.Path("handouts").glob("*.md"):
        label = re.search(r"\{#(\w+)\}", f.read_text().splitlines()[0]).group(1)
        if label.startswith("handout_"):
            found[label] = (f.name, "handout " + label[-2:])
    return found


def convert_text(t, files):
    """Inline maths and references of a piece of text (no code in it)."""
    t = re.sub(r"\\f\$\s*(.*?)\s*\\f\$", lambda m: "$" + m.group(1) + "$", t)
    t = re.sub(r'\\ref (\w+) "([^"]*)"', lambda m: f"[{m.group(2)}]({files[m.group(1)][0]})", t)
    t = re.sub(r"\\ref (\w+)", lambda m: f"[{files[m.group(1)][1]}]({files[m.group(1)][0]})", t)
    return re.sub(r"\]\(@ref (\w+)\)", lambda m: f"]({files[m.group(1)][0]})", t)


def convert_line(s, files):
    """One line outside fenced code: the text between its code spans."""
    out, pos = [], 0
    for m in re.finditer(r"(`+)(?:.+?)\1", s):
        out += [convert_text(s[pos:m.start()], files), m.group(0)]
        pos = m.end()
    return "".join(out) + convert_text(s[pos:], files)


def convert(src, files):
    """One handout."""
    out, fence = [], False
    for line in src.splitlines(keepends=True):
        if re.match(r"^\s*(```|~~~)", line):
            fence = not fence
            out.append(line)
            continue
        if fence:
            out.append(line)
            continue
        if line.strip() in ("\\f[", "\\f]"):
            out.append("$$\n")
            continue
        m = re.match(r"^\\f\[ (.*)$", line)
        if m:
            line = "$$\n" + m.group(1) + "\n"
        m = re.match(r"^(.*?) ?\\f\]$", line.rstrip("\n"))
        if m and "\\f[" not in line:
            line = m.group(1) + "\n$$\n"
        line = re.sub(r'^\\image html (\S+) "([^"]*)"$',
                      lambda m: f"![{m.group(2)}](../build/docs/figures/{m.group(1)})", line)
        out.append(convert_line(line, files))
    return "".join(out)


def main():
    files = pages()
    for f in sorted(pathlib.Path("handouts").glob("*.md")):
        src = f.read_text()
        new = convert(src, files)
        if new != src:
            f.write_text(new)
            print("converted", f)


if __name__ == "__main__":
    main()
