#!/usr/bin/env python3
"""The handouts read as plain Markdown (in an editor, on a forge): no Doxygen-only markup in them
(`\\f$`, `\\f[`, `\\ref`, `@ref`, `\\image`, `\\copydoc`, ...: docs/markdown_filter.py writes those
for Doxygen), maths as `$...$` or `$$` blocks that the filter turns into Doxygen's, and every link
to a local file resolves. Also checks the filter on a sample.

Usage: handouts_markdown_check.py KIT_ROOT
"""
import importlib.util
import pathlib
import re
import sys

# Doxygen commands a Markdown reader would show raw (outside code and maths).
DOXYGEN = re.compile(r"[\\@](?:f[$\[\]{}]|ref|copydoc|copybrief|image|verbinclude|include|snippet|"
                     r"htmlonly|endhtmlonly|page|subpage|section|subsection|anchor|brief|file|"
                     r"code|endcode|note|warning|see|param|return|li|em|c|p|b)(?![\w])")
LINK = re.compile(r"\]\(([^()\s]+)\)")


def text_lines(path):
    """(line number, text) of the lines outside fenced code and `$$` blocks, code spans and
    inline maths removed."""
    fence, maths = None, False
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = re.match(r"^\s*(```|~~~)", line)
        if fence:
            fence = None if m and m.group(1) == fence else fence
            continue
        if m:
            fence = m.group(1)
            continue
        if line.strip() == "$$":
            maths = not maths
            continue
        if maths:
            continue
        line = re.sub(r"(`+).+?\1", "", line)
        yield n, line


def main():
    root = pathlib.Path(sys.argv[1]).resolve()
    pages = sorted((root / "handouts").glob("*.md")) + [root / "docs" / "ARCHITECTURE.md"]
    spec = importlib.util.spec_from_file_location("markdown_filter",
                                                  root / "docs" / "markdown_filter.py")
    mdf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mdf)
    bad = []
    for page in pages:
        name = page.relative_to(root)
        for n, line in text_lines(page):
            maths = mdf.INLINE.sub("", line)
            for m in DOXYGEN.finditer(maths):
                bad.append(f"{name}:{n}: Doxygen-only markup {m.group(0)!r} (plain Markdown: "
                           f"$...$ for maths, [text](page.md) for a page): {line.strip()[:90]}")
            if "$" in maths.replace("\\$", ""):
                bad.append(f"{name}:{n}: a '$' that is not maths ($...$ on one line, no blank "
                           f"inside either end): {line.strip()[:90]}")
            for m in LINK.finditer(line):
                target = m.group(1).split("#")[0]
                if not target or re.match(r"^[a-z]+:", target) or "build/docs/" in target:
                    continue  # a web address, an anchor, or a figure the docs draw
                if not (page.parent / target).exists():
                    bad.append(f"{name}:{n}: the link to {target} does not resolve")

    here = root / "handouts"
    sample = ("Time $t_w = \\min(t_x, t_y)$, see [the model](model.md); costs $5 and $6.\n"
              "`$HOME \\ref x` stays\n$$\na = b\n$$\n"
              "![A figure](../build/docs/figures/x.png)\n<iframe src=\"v.html\"></iframe>\n")
    want = ("Time \\f$t_w = \\min(t_x, t_y)\\f$, see [the model](@ref model_page); costs $5 and "
            "$6.\n`$HOME \\ref x` stays\n\\f[\na = b\n\\f]\n\\image html x.png \"A figure\"\n"
            "\\htmlonly\n<iframe src=\"v.html\"></iframe>\n\\endhtmlonly\n")
    got = mdf.convert(sample, here)
    if got != want:
        bad.append(f"docs/markdown_filter.py: the sample gives\n{got}\nnot\n{want}")
    for line in bad:
        print(line)
    if bad:
        print(f"handouts: {len(bad)} problem(s)")
        return 1
    print(f"handouts: {len(pages)} pages read as plain Markdown; the filter's sample is right")
    return 0


if __name__ == "__main__":
    sys.exit(main())
