#!/usr/bin/env python3
"""Doxygen's input filter for the Markdown pages (Doxyfile's FILTER_PATTERNS): the handouts are
plain Markdown, read as they are in an editor or on a forge, and this turns the little of it that
Doxygen 1.9 does not understand into its own markup, on the fly:

- `$...$` (inline maths) into `\\f$...\\f$`, and a `$$` line ... `$$` line into `\\f[ ... \\f]`;
- a link to another page, `[text](03-openmp.md)` or `[text](../docs/ARCHITECTURE.md)`, into
  `[text](@ref handout_03)`, the label the target's title declares (`# Title {#handout_03}`);
- an image of a figure the docs draw, `![caption](../build/docs/figures/NAME.png)` alone on its
  line, into `\\image html NAME.png "caption"`;
- a line that is only a link to a JSON file, `[rubric.json](../kit/grade/rubric.json)`, into
  `\\verbinclude rubric.json` (the file quoted whole, from Doxyfile's EXAMPLE_PATH);
- an `<iframe ...>` line into the same line between `\\htmlonly` and `\\endhtmlonly`.

Code (fenced blocks and `code spans`) is left as it is; so is what is already Doxygen's markup.
Usage (as Doxygen runs it): markdown_filter.py FILE, the filtered text on standard output.
"""
import pathlib
import re
import sys

FENCE = re.compile(r"^\s*(```|~~~)")
# Inline maths: `$`, no blank after it, no `$` inside, no blank before the closing `$`, which no
# digit follows (so "costs $5 and $6" stays text); a `$` escaped as `\$` or `\f$` is not one.
INLINE = re.compile(r"(?<![\\$])\$(?=[^\s$])([^$\n]*?[^\s\\$])\$(?![\d$])")
LINK = re.compile(r"\]\(([^()\s]+\.md)(#[\w-]+)?\)")
LABEL = re.compile(r"\{#(\w+)\}")


HANDOUTS = pathlib.Path(__file__).resolve().parent.parent / "handouts"
# A figure that `plab docs` draws (build/docs/figures, Doxyfile's IMAGE_PATH): a Markdown image in
# the handout, so that an editor's preview shows it once the docs are built.
FIGURE = re.compile(r"^!\[([^\]]*)\]\((?:[\w./-]*/)?build/docs/figures/([\w.-]+)\)\s*$")
# A file quoted whole in the docs: a line that is only a link to a JSON file.
QUOTED = re.compile(r"^\[[^\]]*\]\((?:[\w./-]*/)?([\w.-]+\.json)\)\s*$")


def label_of(here, target):
    """The page label that the Markdown file `target` (relative to the folder `here`, else a
    handout of that name: a page generated elsewhere quotes the handouts) declares in its first
    heading, or None."""
    for path in (here / target, HANDOUTS / pathlib.Path(target).name):
        try:
            with path.open(encoding="utf-8") as f:
                for line in f:
                    if line.startswith("#"):
                        m = LABEL.search(line)
                        return m.group(1) if m else None
        except OSError:
            continue
    return None


def text_part(s, here):
    """Inline maths and page links of a piece of text (no code in it)."""
    s = s.replace("\\f$", "\0")  # Doxygen's own inline maths stays as it is
    s = INLINE.sub(lambda m: f"\\f${m.group(1)}\\f$", s).replace("\0", "\\f$")

    def link(m):
        label = label_of(here, m.group(1))
        return f"](@ref {label})" if label else m.group(0)

    return LINK.sub(link, s)


def line_part(line, here):
    """One line outside a fenced block: the text between its code spans."""
    out, pos = [], 0
    for m in re.finditer(r"(`+)(?:.+?)\1", line):
        out.append(text_part(line[pos:m.start()], here))
        out.append(m.group(0))
        pos = m.end()
    out.append(text_part(line[pos:], here))
    return "".join(out)


def convert(text, here):
    """The whole page, as Doxygen reads it."""
    out, fence, maths = [], None, False
    for line in text.splitlines(keepends=True):
        m = FENCE.match(line)
        if fence:
            if m and m.group(1) == fence:
                fence = None
            out.append(line)
        elif m:
            fence = m.group(1)
            out.append(line)
        elif line.strip() == "$$":
            out.append(line.replace("$$", "\\f]" if maths else "\\f["))
            maths = not maths
        elif maths:
            out.append(line)
        elif m := FIGURE.match(line):
            caption = m.group(1).replace('"', "'")
            out.append(f'\\image html {m.group(2)} "{caption}"\n')
        elif m := QUOTED.match(line):
            out.append(f"\\verbinclude {m.group(1)}\n")
        elif line.lstrip().startswith("<iframe"):
            out.append(f"\\htmlonly\n{line.rstrip()}\n\\endhtmlonly\n")
        else:
            out.append(line_part(line, here))
    return "".join(out)


def main():
    path = pathlib.Path(sys.argv[1])
    text = path.read_text(encoding="utf-8")
    sys.stdout.write(convert(text, path.parent) if path.suffix == ".md" else text)


if __name__ == "__main__":
    main()
