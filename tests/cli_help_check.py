#!/usr/bin/env python3
"""Every `plab` command answers --help (CTest test cli.help, label kit).

`plab --help` lists the commands under their groups; each `plab COMMAND --help` must exit 0 and
print its usage and options, whether the command's options are declared in C++ (CLI11) or in the
Python module it hands them to (render, report, grade, release, similar, accuracy, stress). No
help text may name this machine's folders (the kit's source or build path).

  cli_help_check.py PLAB_PROGRAM KIT_SOURCE
"""
import re
import subprocess
import sys

plab, source = sys.argv[1], sys.argv[2]


def help_of(*command):
    done = subprocess.run([plab, *command, "--help"], capture_output=True, text=True, timeout=120)
    return done.returncode, done.stdout + done.stderr


rc, top = help_of()
if rc != 0:
    sys.exit(f"plab --help exited {rc}:\n{top}")
commands = re.findall(r"^  ([a-z][a-z-]*) {2,}\S", top, re.MULTILINE)
if len(commands) < 15:
    sys.exit(f"plab --help lists {len(commands)} commands ({commands}); expected every command:\n{top}")
failed = []
for name in commands:
    rc, text = help_of(name)
    usage = re.search(r"^usage: plab " + re.escape(name) + r"\b", text, re.IGNORECASE | re.MULTILINE)
    if rc != 0 or not usage or text.count("\n") < 4:
        failed.append(f"plab {name} --help exited {rc}, usage line {'found' if usage else 'missing'}:\n"
                      f"{text[:800]}")
    elif source in text:
        failed.append(f"plab {name} --help names this machine's folder {source}")
    else:
        print(f"ok   plab {name} --help ({text.count(chr(10))} lines)")
if source in top:
    failed.append(f"plab --help names this machine's folder {source}")
if failed:
    sys.exit("\n".join(failed))
print(f"{len(commands)} commands answer --help")
