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
  - defines or uses a C name of the kit's own measurements (plab_*: the OpenMP counter's loops'
    clock, plab_omp_epoch, say), which only the kit's library reads: code that asks whether it
    is measured could work one way where it is and another elsewhere;
  - makes a system call by its own instructions (inline assembly: `syscall`, `sysenter`,
    `int $0x80`, found by objdump), which names no function for the rules here to read;
  - looks a symbol or a loaded library up by name or address (dlopen, dlsym, dlvsym, dladdr,
    dl_iterate_phdr): the only way left to reach a library's function without naming it. In C++
    and CUDA objects alike: the kit compiles a stage's CUDA code without NVTX
    (cmake/PlabStage.cmake: CUB's NVTX ranges would start NVTX's loader, which calls dlopen and
    dlsym from the stage's own objects), so none of the kit's calls them (a student's trial
    reached popen through dlsym in a host function of step.cu when CUDA objects were left out of
    this rule);
  - on MPI (stage 08), calls an MPI function that kit/mpi neither counts nor refuses (it defines
    its own MPI_Send, MPI_Alltoallv, ... which count the bytes, and MPI_Win_create, ... which
    stop the run) and that is not in NO_DATA, the calls that move no data of the stage between
    ranks (ranks and sizes, waits and tests, receives, barriers, datatypes, communicators):
    MPI_Ialltoallw, MPI_Neighbor_allgatherv or MPI_Comm_spawn, say, are refused; and, on MPI,
    calls that hand MPI a function of the stage's own to run inside a later MPI call (a
    reduction's MPI_Op_create, error handlers, attribute keyvals, generalized requests:
    CALLBACKS), where the kit counts the CPU time as time in MPI, not as work. Stage 08 is
    compiled against the MPI C API only (OMPI_SKIP_MPICXX), so its objects name exactly the calls
    it makes.

A stage entry of rubric.json may also name groups of calls its code may not make at all
(`refuse_calls`, CALL_GROUPS): stages 01 to 07 start no other program (`processes`: a stage that
runs the compiled reference, whose `--explain --json` answers every step, or another stage, does
none of its own work; the grader's sandbox holds neither, but a student learned that only from
the grade) and open no file, map no memory and change no descriptor (`files`: a red-team stage
03 read the OpenMP counter's secret from /proc/self/maps and took its file over with dup2);
the stages given one thread (01, 02, 04, 05, 07) start no thread (`one_thread`: their time is
compared with the reference's on one thread); stage 08's ranks, whose work the kit measures and
whose messages
it counts, open no files and map no memory (which would move particles between ranks past the
count, or change the kit's report), change no signal or timer (the kit reads each rank's CPU
clock, which an armed process timer makes coarse), and
start no thread or process (work beside a rank's MPI wait).

The names are read from the symbol tables the compiler wrote, so a macro or a wrapper in the
source does not hide them. What stays open is said in handouts/instructors.md.
"""
import argparse
import json
import pathlib
import re
import subprocess
import sys

# (pattern, kind of symbol: "U" undefined (called) or "D" defined and global, reason)
RULES = [
    (re.compile(r"PMPI_\w+$"), "U",
     "calls {name}, the MPI profiling interface, which passes by the kit's count of the bytes "
     "the ranks send: call {plain} (kit/mpi counts it, then calls {name} itself)"),
    (re.compile(r"(P?MPI_|GOMP_|omp_|kmp_|__kmpc_|cupti|cuda[A-Z]|cu[A-Z])\w*$"), "D",
     "defines {name}, a function of the MPI, OpenMP or CUDA libraries: it would replace the "
     "library's own (and the kit's measurement of it); give your function another name"),
    (re.compile(r"plab_\w+$"), "D",
     "defines {name}, a name of the kit's own measurements (the OpenMP counter's loops' clock, "
     "say): it would replace the kit's; give yours another name"),
    (re.compile(r"plab_\w+$"), "U",
     "uses {name}, a name of the kit's own measurements (the OpenMP counter's loops' clock, say), "
     "which only the kit reads: a stage's work does not depend on whether it is measured"),
    (re.compile(r"cupti\w*$"), "U",
     "calls {name}: CUPTI is how the kit traces the GPU's work, not for a stage"),
    (re.compile(r".*mpi_stage_any_cut"), "U",
     "calls the instructor's engine's driver (mpi_stage_any_cut), which does not check that each "
     "rank owns its slab's particles: call plab::dist::mpi_stage()"),
    (re.compile(r"(dlopen|dlsym|dlvsym|dlmopen|dladdr|dladdr1|dlinfo|dl_iterate_phdr|_r_debug)$"),
     "U", "calls {name}: looking functions or loaded libraries up by name or address passes by "
     "the kit's measurements; call them by name in the code"),
]
GLOBAL = set("TWDBRVGSiu")  # nm -P types of a global symbol the object defines
# nm -P types of a symbol the object uses and does not define: undefined, or weak undefined (a
# red-team stage 02 declared pthread_create weak, which nm prints as "w", and the linker still
# bound it to the C library's)
UNDEFINED = set("Uwv")
C_FUNCTION = set("TWi")  # nm -P types of a global function (text, weak, indirect) it defines

# The calls that start a thread, one pattern for every group that refuses threads: pthread_create
# under the C library's names too, C11's, clone, OpenMP's regions, std::thread (std::async and
# std::jthread start theirs through it), TBB, and the C library's calls that start a thread of
# their own to run a function or a request (SIGEV_THREAD timers and notifications, asynchronous
# I/O and name lookups)
THREAD_STARTS = (r"(\w*pthread_create\w*|thrd_create|(__)?clone3?|GOMP_\w+|timer_create|mq_notify|"
                 r"aio_\w+|lio_listio\w*|getaddrinfo_a)$"
                 r"|.*St6thread15_M_start_thread.*|_ZN(6oneapi)?3tbb\w*")

# Calls a stage's code may be refused by group (a rubric entry's `refuse_calls`): (pattern of the
# called symbol's name, as nm prints it, mangled; the reason)
CALL_GROUPS = {
    "processes": (re.compile(
        r"(fork|vfork|clone|clone3|execve|execveat|fexecve|execv|execvp|execvpe|execl|execlp|"
        r"execle|posix_spawn|posix_spawnp|system|popen|syscall)$"
        # the process's and threads' names and CPUs, by which the grader reads each thread's CPU
        # time from /proc (a process renamed would hide its threads' work)
        r"|(prctl|pthread_setname_np|sched_setaffinity|pthread_setaffinity_np|"
        r"pthread_attr_setaffinity_np)$"),
        "calls {name}: a stage starts no other program (a step is the stage's own work: the kit's "
        "reference program, its --explain and the other stages are not part of an answer) and "
        "leaves its process's and threads' names and CPUs as the kit started them (the grader "
        "reads each thread's CPU time by them)"),
    "files": (re.compile(
        r"(open|open64|openat|openat64|creat|creat64|fopen|fopen64|freopen|freopen64|fdopen|"
        r"mmap|mmap64|shm_open|memfd_create|shmget|shmat|mkstemp|mkstemp64|mkostemp|tmpfile|"
        r"tmpfile64|truncate|ftruncate|rename|unlink|syscall|dup|dup2|dup3|mprotect|"
        r"pkey_mprotect|process_vm_readv|process_vm_writev|opendir|fdopendir)$"
        # the C library's other doors to a file (__open_2, _IO_fopen, fts_open, __mmap, ...);
        # (not dlopen: RULES refuses it, with its own reason)
        r"|(?!_Z)(?!dl)\w*(open|mmap)\w*$"
        r"|.*(basic_ofstream|basic_ifstream|basic_fstream|basic_filebuf|St10filesystem).*"
        # the kit's own functions that read or write files: a red-team stage 08 read the scene on
        # every rank with plab::load_scene() (its path from /proc/self/cmdline, plab::read_file())
        r"|_Z\w*4plab\w*(9read_file|10load_scene|13load_manifest|10OutputFile|"
        r"22keep_stdout_for_output|11with_status)"),
        "calls {name}: a stage's step gets its particles from the kit and gives them back to it, "
        "and opens no file, maps no memory and changes no descriptor of its own (a file could "
        "hold an answer or change what the kit measures; on MPI, files and shared memory would "
        "move particles between ranks past the kit's count of the bytes they send); print to "
        "stderr to debug"),
    "signals": (re.compile(
        r"(signal|sigaction|sigprocmask|pthread_sigmask|sigset|sysv_signal|__sysv_signal|"
        r"bsd_signal|setitimer|timer_create|timer_settime|timer_delete|alarm|ualarm)$"),
        "calls {name}: the kit measures where each rank's CPU time goes by reading the process's "
        "CPU clock, which a process timer makes coarse, and keeps a handler for SIGPROF; a stage "
        "changes no signal and no timer"),
    "threads": (re.compile(
        r"(fork|vfork|execve|execv|execvp|execvpe|execl|execlp|execle|posix_spawn|posix_spawnp|"
        r"system|popen)$|" + THREAD_STARTS),
        "calls {name}: each rank is one thread of one process (the kit samples its CPU time as "
        "work or as time in MPI calls: another thread's work would look like a wait)"),
    # A stage given one thread (rubric: "threads": 1) is timed against the reference on one
    # thread: a red-team stage 02 split its pair loop over two std::threads and was timed at 0.55
    # of the reference's time, every correctness point kept
    "one_thread": (re.compile(THREAD_STARTS),
        "calls {name}: this stage runs on the one thread it is given (its time is compared with "
        "the reference's on one thread); threads are stage 03's idea"),
}

# MPI calls that move no data of the stage from one rank to another (or only receive what another
# rank's counted call sent): a stage may call them though kit/mpi does not count them. Not the
# communicators made from each rank's own arguments (MPI_Comm_split's colour and key,
# MPI_Comm_create's group): every call moves a few numbers of each rank to all the others.
NO_DATA = set("""
MPI_Init MPI_Init_thread MPI_Initialized MPI_Finalize MPI_Finalized MPI_Abort MPI_Query_thread
MPI_Is_thread_main MPI_Get_processor_name MPI_Get_version MPI_Get_library_version MPI_Wtime
MPI_Wtick MPI_Error_string MPI_Error_class MPI_Comm_rank MPI_Comm_size MPI_Comm_dup
MPI_Comm_free MPI_Comm_group MPI_Comm_compare MPI_Comm_set_name
MPI_Comm_get_name MPI_Comm_set_errhandler MPI_Comm_get_errhandler MPI_Comm_test_inter
MPI_Recv MPI_Irecv MPI_Mrecv MPI_Imrecv MPI_Probe MPI_Iprobe MPI_Mprobe MPI_Improbe MPI_Get_count
MPI_Get_elements MPI_Get_elements_x MPI_Wait MPI_Waitall MPI_Waitany MPI_Waitsome MPI_Test
MPI_Testall MPI_Testany MPI_Testsome MPI_Test_cancelled MPI_Request_free MPI_Request_get_status
MPI_Cancel MPI_Barrier MPI_Ibarrier MPI_Op_free MPI_Op_commutative MPI_Get_address
MPI_Pack MPI_Unpack MPI_Pack_size MPI_Alloc_mem MPI_Free_mem MPI_Dims_create MPI_Cart_create
MPI_Cart_coords MPI_Cart_rank MPI_Cart_shift MPI_Cart_get MPI_Cartdim_get MPI_Cart_sub
MPI_Topo_test MPI_Status_set_elements MPI_Status_set_cancelled
""".split())
NO_DATA_PREFIXES = ("MPI_Type_", "MPI_Group_", "MPI_Info_", "MPI_Errhandler_")

# MPI calls that hand the library a function of the stage's own, which MPI then runs inside a
# later call (a reduction's operation, an error handler, an attribute's copy or delete, a
# generalized request's query): kit/mpi counts the CPU time spent inside its calls as time in
# MPI, so work done there would pass for waiting. A stage on MPI may not make them.
CALLBACKS = re.compile(r"MPI_(Op_create|\w*_create_errhandler|Errhandler_create|\w*_create_keyval|"
                       r"Keyval_create|Grequest_start|Register_datarep)$")


def problems(nm_lines, mpi_kit=None, refuse_calls=()):
    """The reasons to refuse, from `nm -A -P` lines ('ARCHIVE[MEMBER]: NAME TYPE ...'), one per
    (object, symbol), in order. `mpi_kit`: the MPI functions kit/mpi defines (counted or refused),
    for a stage on MPI; None for the others. `refuse_calls`: CALL_GROUPS' names whose calls are
    refused."""
    found = []
    groups = [(g, *CALL_GROUPS[g]) for g in refuse_calls]
    said = set()  # (source, group): one reason each, naming the first such call
    for line in nm_lines:
        head, _, rest = line.partition(": ")
        fields = rest.split()
        if len(fields) < 2:
            continue
        name, kind = fields[0], fields[1]
        member = head[head.find("[") + 1:-1] if head.endswith("]") else head
        if member.startswith(("stage_info.cpp", "no_gpu_path.cpp", "stage_entry.cpp")):
            continue  # the kit's own objects in the stage's library
        source = member[:-2] if member.endswith(".o") else member  # step.cpp.o: step.cpp
        group = next((g for g in groups if kind in UNDEFINED and g[1].match(name)), None)
        if group is not None:
            if (source, group[0]) not in said:
                said.add((source, group[0]))
                found.append(f"{source} " + group[2].format(name=demangled(name)))
            continue
        for pattern, want, reason in RULES:
            if not pattern.match(name) or ((kind in UNDEFINED) == (want == "D")):
                continue
            if want == "D" and kind not in GLOBAL:
                continue  # a local symbol replaces nothing
            plain = name[1:] if name.startswith("PMPI_") else name
            found.append(f"{source} " + reason.format(name=name, plain=plain))
            break
        else:
            if (kind in C_FUNCTION and not name.startswith(("_Z", "__clang_")) and name != "main"
                    and not member.endswith(".cu.o")):  # (clang's __clang_call_terminate)
                found.append(f"{source} defines {name}, a function with a C name: it would "
                             f"replace the C library's or the kit's function of that name in the "
                             f"whole program, the kit's measurements included (a red-team stage "
                             f"08 replaced clock_gettime, with which the kit measures each rank's "
                             f"work); give it a C++ name (no extern \"C\")")
            elif mpi_kit is not None and kind in UNDEFINED and CALLBACKS.match(name):
                found.append(f"{source} calls {name}: MPI would run a function of the stage's "
                             f"own inside its calls, where the kit counts the CPU time as time in "
                             f"MPI, not as work. Use MPI's predefined operations (MPI_MAX, "
                             f"MPI_MIN, MPI_SUM, MPI_LOR, ...) and its default error handling")
            elif (mpi_kit is not None and kind in UNDEFINED and name.startswith("MPI_")
                    and name not in mpi_kit and name not in NO_DATA
                    and not name.startswith(NO_DATA_PREFIXES)):
                found.append(f"{source} calls {name}, which the kit does not count: it could move "
                             f"data between ranks past the count of the bytes they send. Use the "
                             f"point-to-point messages or the collectives the kit counts "
                             f"(handouts/08-mpi.md)")
    return list(dict.fromkeys(found))


def demangled(name):
    """A C++ symbol's name as the source reads it (c++filt), or `name` itself."""
    if not name.startswith("_Z"):
        return name
    try:
        done = subprocess.run(["c++filt", name], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return name
    return done.stdout.strip() or name


def symbol_lines(archive, seconds=60):
    """`nm -A -P` of `archive` as lines, or a str saying why it cannot be read."""
    if not archive.is_file() or archive.is_symlink():
        return f"its library {archive.name} was not built"
    try:
        done = subprocess.run(["nm", "-A", "-P", str(archive)], capture_output=True, text=True,
                              errors="replace", timeout=seconds)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"its objects could not be read (nm: {e})"
    if done.returncode != 0:
        return f"its objects could not be read (nm exited {done.returncode}: {done.stderr.strip()[:300]})"
    return done.stdout.splitlines()


# A system call made by the stage's own instructions (inline assembly), not through the C
# library: every rule above reads the calls' names, and this one has none. Honest code never
# holds one (the C library's wrappers are not inlined into a stage's objects).
RAW_SYSCALL = re.compile(r"\s(syscall|sysenter|int\s+\$0x80)\s*$")


def raw_syscalls(archive, seconds=60):
    """The objects of `archive` whose code holds a system call instruction (objdump), as reasons
    to refuse; [] when there is none or the archive cannot be disassembled (nm's check says that)."""
    try:
        done = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(archive)],
                              capture_output=True, text=True, errors="replace", timeout=seconds)
    except (OSError, subprocess.TimeoutExpired):
        return []
    found, member = [], None
    for line in done.stdout.splitlines():
        if line.startswith("In archive") or not line.strip():
            continue
        if ":     file format" in line:
            member = line.split(":")[0].strip()
            continue
        if member and RAW_SYSCALL.search(line):
            source = member[:-2] if member.endswith(".o") else member
            if not source.startswith(("stage_info.cpp", "no_gpu_path.cpp", "stage_entry.cpp")):
                found.append(f"{source} makes a system call by its own instructions (inline "
                             "assembly): a stage calls no kernel directly, it calls the C library "
                             "and the kit")
            member = None  # one reason an object
    return found


def check(archive, mpi_library=None, refuse_calls=()):
    """The reasons to refuse the stage whose library is `archive` (its objects only: the kit's
    libraries are linked later), or [] when there is none; a list of one line when the archive
    cannot be read. `mpi_library`: kit/mpi's library, for a stage on MPI (the MPI functions it
    defines are the ones counted or refused); `refuse_calls`: CALL_GROUPS' names."""
    lines = symbol_lines(archive)
    if isinstance(lines, str):
        return [lines]
    mpi_kit = None
    if mpi_library is not None:
        kit_lines = symbol_lines(mpi_library)
        if isinstance(kit_lines, str):
            return [f"the kit's MPI layer could not be read: {kit_lines}"]
        mpi_kit = {f[0] for f in (ln.partition(": ")[2].split() for ln in kit_lines)
                   if len(f) >= 2 and f[0].startswith("MPI_") and f[1] in GLOBAL}
    return problems(lines, mpi_kit, refuse_calls) + raw_syscalls(archive)


def refused_groups(rubric, sid):
    """The groups of calls (CALL_GROUPS) that the rubric's entries of stage folder `sid` refuse in
    its code (`refuse_calls`)."""
    groups = []
    for key, conf in rubric["stages"].items():
        if conf.get("folder", key) == sid:
            groups += [g for g in conf.get("refuse_calls", []) if g not in groups]
    unknown = [g for g in groups if g not in CALL_GROUPS]
    if unknown:
        raise ValueError(f"rubric: stage {sid}'s refuse_calls names {unknown}, not one of "
                         f"{sorted(CALL_GROUPS)}")
    return groups


def main(argv=None):
    """`python3 -m plab.grade.symbols --kit SRC --build BUILD --stage NN --impl IMPL`: the checks
    the grader makes of a stage's compiled objects, on this copy's build (what `plab built`, every
    stage test's first check, runs): the reasons on stdout and exit 1, or exit 0."""
    ap = argparse.ArgumentParser(prog="plab.grade.symbols", description=main.__doc__)
    ap.add_argument("--kit", required=True, type=pathlib.Path, help="the kit's source folder")
    ap.add_argument("--build", required=True, type=pathlib.Path, help="its build folder")
    ap.add_argument("--stage", required=True, help="the stage's number, e.g. 01")
    ap.add_argument("--impl", default="student", choices=("student", "solution"))
    a = ap.parse_args(argv)
    tree = "stages" if a.impl == "student" else "solutions"
    folders = sorted((a.kit / tree).glob(a.stage + "-*"))
    if not folders:
        print(f"there is no stage {a.stage} in {tree}/")
        return 1
    folder = folders[0]
    rubric = json.loads((a.kit / "kit" / "grade" / "rubric.json").read_text())
    try:
        needs_mpi = bool(json.loads((folder / "stage.json").read_text()).get("needs_mpi"))
    except (OSError, ValueError):
        needs_mpi = False
    refused = check(a.build / tree / folder.name / f"libplab_stage_{a.stage}_{a.impl}.a",
                    a.build / "kit" / "libplab_mpi.a" if needs_mpi else None,
                    refused_groups(rubric, a.stage))
    if not refused:
        return 0
    print(f"stage {a.stage} is refused, as the grader refuses it (handouts/working.md, How a stage "
          f"is graded): {refused[0]}")
    for line in refused[1:10]:
        print("  and " + line)
    return 1


if __name__ == "__main__":
    sys.exit(main())
