"""plab: the kit's Python, one package (the grader, the similarity check, the report, the course
guide, the stress and accuracy suites, the renderer) beside its C++ programs.

It imports without any path set by hand: the `plab` command puts kit/python on PYTHONPATH once
for every program it starts, and the tests do the same (`PYTHONPATH=kit/python python3 -m
plab.grade --help`). Nothing here computes the model's physics: event times, scenes and outputs
come from the kit's C++ programs, read as JSON (plab.plabio).
"""
import importlib.util
import os
import pathlib

#: kit/python, the folder this package lives in (what PYTHONPATH names).
PYTHON_DIR = pathlib.Path(__file__).resolve().parent.parent
#: The kit's source folder (the repository's root).
KIT = PYTHON_DIR.parent.parent


def python_env(env=None):
    """A copy of env (default: this process's) whose PYTHONPATH names kit/python first, for a
    child `python3 -m plab...` started by one of these modules."""
    env = dict(os.environ if env is None else env)
    rest = env.get("PYTHONPATH", "")
    env["PYTHONPATH"] = str(PYTHON_DIR) + (os.pathsep + rest if rest else "")
    return env


def load_module(path):
    """The Python file at path as a module (the handouts' figure script, which lives with its
    data, not in this package), loaded without touching sys.path."""
    spec = importlib.util.spec_from_file_location(pathlib.Path(path).stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
