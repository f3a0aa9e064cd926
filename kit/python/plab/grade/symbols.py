"""What a stage's compiled code calls and defines, read from its object files (`nm`) by the grader,
outside the student's code, before anything of the stage runs.

The kit measures a stage's idea through the libraries' ordinary entry points: the bytes the ranks
of stage 08 send through kit/mpi's MPI_* layer, the OpenMP synchronisations of stages 03 and 06
through libgomp's GOMP_* functions, the GPU work of stages 04 to 06 through CUPTI. Code that goes
around them would not be seen, so a stage whose objects do any of the following is refused (it
counts as not compiling, with the reason):

  - calls the MPI profiling interface (PMPI_*): the MPI library's second name for every call,
    which passes by the kit's count;
  - defines a function of the MPI, OpenMP, CUDA or CUPTI libraries itself (MPI_*, PMPI_*,
    GOMP_*, omp_*, kmp_*, __kmpc_*, cuda*, cu* of the driver, cupti*): it would replace the
    library's own, and the kit's layer with it;
  - calls CUPTI (cupti*), the interface the kit's GPU trace is written with;
  - looks a symbol up by name (dlopen, dlsym, dlvsym) from C++ code: the only way left to reach a
    library's function without naming it. CUDA objects (*.cu.o) are left out of this rule: the
    CUDA runtime's own start-up code, compiled into every one, calls them.

The names are read from the symbol tables the compiler wrote, so a macro or a wrapper in the
source does not hide them. What stays open is said in handouts/instructors.md.
"""
import re
import subprocess

# (pattern, kind of symbol: "U" undefined (called) or "D" defined and global, reason, whether
# CUDA objects are left out)
RULES = [
    (re.compile(r"PMPI_\w+$"), "U",
     "calls {name}, the MPI profiling interface, which passes by the kit's count of the bytes "
     "the ranks send: call {plain} (kit/mpi counts it, then calls {name} itself)", False),
    (re.compile(r"(P?MPI_|GOMP_|omp_|kmp_|__kmpc_|cupti|cuda[A-Z]|cu[A-Z])\w*$"), "D",
     "defines {name}, a function of the MPI, OpenMP or CUDA libraries: it would replace the "
     "library's own (and the kit's measurement of it); give your function another name", False),
    (re.compile(r"cupti\w*$"), "U",
     "calls {name}: CUPTI is how the kit traces the GPU's work, not for a stage", False),
    (re.compile(r"(dlopen|dlsym|dlvsym|dlmopen)$"), "U",
     "calls {name}: looking functions up by name passes by the kit's measurements; call them "
     "by name in the code", True),
]
GLOBAL = set("TWDBRVGSiu")  # nm -P types of a global symbol the object defines


def problems(nm_lines):
    """The reasons to refuse, from `nm -A -P` lines ('ARCHIVE[MEMBER]: NAME TYPE ...'), one per
    (object, symbol), in order."""
    found = []
    for line in nm_lines:
        head, _, rest = line.partition(": ")
        fields = rest.split()
        if len(fields) < 2:
            continue
        name, kind = fields[0], fields[1]
        member = head[head.find("[") + 1:-1] if head.endswith("]") else head
        if member.startswith("stage_info.cpp") or member.startswith("no_gpu_path.cpp"):
            continue  # the kit's own objects in the stage's library
        for pattern, want, reason, not_cuda in RULES:
            if not pattern.match(name) or (kind == "U" if want == "D" else kind != "U"):
                continue
            if (want == "D" and kind not in GLOBAL) or (not_cuda and member.endswith(".cu.o")):
                continue  # a local symbol replaces nothing; CUDA's start-up code calls dlsym
            plain = name[1:] if name.startswith("PMPI_") else name
            source = member[:-2] if member.endswith(".o") else member  # step.cpp.o: step.cpp
            found.append(f"{source} " + reason.format(name=name, plain=plain))
            break
    return list(dict.fromkeys(found))


def check(archive, seconds=60):
    """The reasons to refuse the stage whose library is `archive` (its objects only: the kit's
    libraries are linked later), or [] when there is none; a list of one line when the archive
    cannot be read."""
    if not archive.is_file() or archive.is_symlink():
        return [f"its library {archive.name} was not built"]
    try:
        done = subprocess.run(["nm", "-A", "-P", str(archive)], capture_output=True, text=True,
                              errors="replace", timeout=seconds)
    except (OSError, subprocess.TimeoutExpired) as e:
        return [f"its objects could not be read (nm: {e})"]
    if done.returncode != 0:
        return [f"its objects could not be read (nm exited {done.returncode}: "
                f"{done.stderr.strip()[:300]})"]
    return problems(done.stdout.splitlines())
