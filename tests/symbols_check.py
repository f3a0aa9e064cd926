#!/usr/bin/env python3
"""The grader's reading of a stage's compiled objects (plab.grade.symbols; CTest test
grader.symbols, label kit): small objects compiled here with g++, each put in a stage library
as the kit's build names it, are refused or let through as a student's would be.

  symbols_check.py [KIT_BUILD_DIR]   (with it, the kit's own stage libraries too: none refused,
                                     but stage 08's engine for its driver)
"""
import json
import pathlib
import shutil
import subprocess
import sys
import tempfile

from plab.grade import symbols

MPI = 'extern "C" int MPI_Allreduce(const void*, void*, int, int, int, int);\n' \
      'extern "C" int PMPI_Allreduce(const void*, void*, int, int, int, int);\n'
# (name, object name, source, expected: None to pass, or a text the reason must hold)
CASES = [
    ("honest MPI call", "step.cpp.o", MPI + "int f(double* a, double* b) { return MPI_Allreduce(a, b, 1, 0, 0, 0); }", None),
    ("PMPI call", "step.cpp.o", MPI + "int f(double* a, double* b) { return PMPI_Allreduce(a, b, 1, 0, 0, 0); }",
     "step.cpp calls PMPI_Allreduce, the MPI profiling interface"),
    ("PMPI behind a macro", "step.cpp.o", MPI + "#define VIA(c) P##c\nint f(double* a, double* b) { return VIA(MPI_Allreduce)(a, b, 1, 0, 0, 0); }",
     "call MPI_Allreduce"),
    ("MPI function defined", "step.cpp.o", 'extern "C" int MPI_Send(const void*, int, int, int, int, int) { return 0; }',
     "defines MPI_Send"),
    ("OpenMP function defined", "helpers.cpp.o", 'extern "C" int omp_get_num_threads() { return 2; }',
     "helpers.cpp defines omp_get_num_threads"),
    ("libgomp entry defined", "step.cpp.o", 'extern "C" void GOMP_barrier() {}', "defines GOMP_barrier"),
    ("CUDA runtime function defined", "step.cpp.o", 'extern "C" int cudaMalloc(void**, unsigned long) { return 0; }',
     "defines cudaMalloc"),
    ("a static C function of that name replaces nothing", "step.cpp.o",
     'extern "C" { static int omp_helper() { return 1; } }\nint g() { return omp_helper(); }', None),
    ("a C++ function named like a library's", "step.cpp.o", "int cudaHelper(int x) { return x + 1; }\nint MPI_thing(int x) { return x; }", None),
    ("CUPTI call", "step.cpp.o", 'extern "C" int cuptiActivityFlushAll(unsigned);\nint f() { return cuptiActivityFlushAll(0); }',
     "calls cuptiActivityFlushAll"),
    ("dlsym from C++", "step.cpp.o", '#include <dlfcn.h>\nvoid* f() { return dlsym(RTLD_NEXT, "MPI_Send"); }', "calls dlsym"),
    ("the engine's driver that does not check the slabs", "step.cpp.o",
     "namespace plab::dist { int mpi_stage_any_cut(int); }\nint f() { return plab::dist::mpi_stage_any_cut(1); }",
     "calls the instructor's engine's driver (mpi_stage_any_cut)"),
    ("a raw system call by inline assembly (fork with no symbol)", "step.cpp.o",
     'long f() { long r; asm volatile("syscall" : "=a"(r) : "a"(57L) : "rcx", "r11", "memory"); return r; }',
     "step.cpp makes a system call by its own instructions"),
    ("the loaded libraries walked (to find the kit's counter in memory)", "step.cpp.o",
     '#include <link.h>\nint f() { return dl_iterate_phdr([](dl_phdr_info*, size_t, void*) { return 0; }, nullptr); }',
     "calls dl_iterate_phdr"),
    ("the C library's clock replaced (a red-team stage 08 hid its work so)", "step.cpp.o",
     '#include <time.h>\nextern "C" int clock_gettime(clockid_t, timespec* t) { t->tv_sec = 0; t->tv_nsec = 0; return 0; }',
     "defines clock_gettime, a function with a C name"),
    ("the OpenMP counter's clock defined (its comparisons filed in one loop)", "step.cpp.o",
     '#include <atomic>\nextern "C" std::atomic<long long> plab_omp_epoch{0};', "defines plab_omp_epoch"),
    ("asks whether the OpenMP counter is loaded (rounds only where measured)", "step.cpp.o",
     '#include <atomic>\nextern "C" __attribute__((weak)) std::atomic<long long> plab_omp_epoch;\n'
     'bool counted() { return &plab_omp_epoch != nullptr; }', "uses plab_omp_epoch"),
    ("a helper of its own with a C name", "helpers.cpp.o", 'extern "C" int add_one(int x) { return x + 1; }',
     "helpers.cpp defines add_one, a function with a C name"),
    ("a global variable and a C++ function", "step.cpp.o", "int calls = 0;\nint f() { return ++calls; }", None),
    ("clang's own helper (a noexcept function's terminate, in the TSan build)", "step.cpp.o",
     'extern "C" __attribute__((weak, visibility("hidden"))) void __clang_call_terminate(void*) {}', None),
    ("dlsym in a host function of a CUDA object (popen reached without its name: a student's trial)",
     "step.cu.o", '#include <dlfcn.h>\nvoid* f() { return dlsym(RTLD_DEFAULT, "po" "pen"); }',
     "step.cu calls dlsym"),
]


# Stages 01 to 07's refused groups (rubric.json's refuse_calls: processes, files): no other
# program, no file.
PROCESS_CASES = [
    ("the compiled reference run from the step (--explain --json: every step's answer)", "step.cpp.o",
     '#include <cstdlib>\nint f() { return std::system("kit/reference/bin/plab-reference s.in --explain 0:0 --json"); }',
     "step.cpp calls system: a stage starts no other program"),
    ("popen", "step.cpp.o", '#include <cstdio>\nint f() { return pclose(popen("true", "r")); }', "calls popen"),
    ("execv", "helpers.cpp.o", '#include <unistd.h>\nint f(char** a) { return execv(a[0], a); }',
     "helpers.cpp calls execv"),
    ("posix_spawn", "step.cpp.o",
     '#include <spawn.h>\nint f(pid_t* p, char** a) { return posix_spawn(p, a[0], nullptr, nullptr, a, nullptr); }',
     "calls posix_spawn"),
    ("fork in a CUDA stage's host code", "step.cu.o", '#include <unistd.h>\nint f() { return fork(); }',
     "calls fork: a stage starts no other program"),
]


# Stage 08's calls, against a stand-in for kit/mpi that defines MPI_Send and MPI_Alltoallv.
MPI_KIT = 'extern "C" int MPI_Send(const void*, int, int, int, int, int) { return 0; }\n' \
          'extern "C" int MPI_Alltoallv(const void*, const int*, const int*, int, void*, const int*, const int*, int, int) { return 0; }'
MPI_CASES = [
    ("a call kit/mpi counts", 'extern "C" int MPI_Send(const void*, int, int, int, int, int);\nint f() { return MPI_Send(0, 0, 0, 0, 0, 0); }', None),
    ("a receive, a wait, a datatype", 'extern "C" { int MPI_Irecv(void*, int, int, int, int, int, void*); int MPI_Waitall(int, void*, void*); int MPI_Type_contiguous(int, int, int*); }\n'
     'int f(int* t) { MPI_Type_contiguous(4, 0, t); MPI_Waitall(0, 0, 0); return MPI_Irecv(0, 0, 0, 0, 0, 0, 0); }', None),
    ("a collective kit/mpi does not count", 'extern "C" int MPI_Ialltoallw(const void*, const int*, const int*, const int*, void*, const int*, const int*, const int*, int, void*);\n'
     'int f() { return MPI_Ialltoallw(0, 0, 0, 0, 0, 0, 0, 0, 0, 0); }', "calls MPI_Ialltoallw, which the kit does not count"),
    ("a neighbourhood collective", 'extern "C" int MPI_Neighbor_allgatherv(const void*, int, int, void*, const int*, const int*, int, int);\n'
     'int f() { return MPI_Neighbor_allgatherv(0, 0, 0, 0, 0, 0, 0, 0); }', "calls MPI_Neighbor_allgatherv"),
    ("a reduction of its own (its code would run inside MPI_Allreduce)", 'extern "C" int MPI_Op_create(void (*)(void*, void*, int*, int*), int, int*);\n'
     'void sum(void*, void*, int*, int*) {}\nint f(int* op) { return MPI_Op_create(sum, 1, op); }', "calls MPI_Op_create: MPI would run a function of the stage's own"),
    ("a datatype attribute's callbacks", 'extern "C" int MPI_Type_create_keyval(void*, void*, int*, void*);\n'
     'int f(int* k) { return MPI_Type_create_keyval(0, 0, k, 0); }', "calls MPI_Type_create_keyval"),
    ("the default error handling set", 'extern "C" int MPI_Comm_set_errhandler(int, int);\n'
     'int f() { return MPI_Comm_set_errhandler(0, 0); }', None),
    ("a communicator split by a colour of each rank's own (data to every rank, uncounted)",
     'extern "C" int MPI_Comm_split(int, int, int, int*);\nint f(int* c) { return MPI_Comm_split(0, 7, 0, c); }',
     "calls MPI_Comm_split, which the kit does not count"),
    ("new processes", 'extern "C" int MPI_Comm_spawn(const char*, char**, int, int, int, int, int*, int*);\n'
     'int f() { return MPI_Comm_spawn(0, 0, 1, 0, 0, 0, 0, 0); }', "calls MPI_Comm_spawn"),
]

# Stages 01-07 refuse files too: the kit's counter's file taken over (attempted on 2026-12-07 by
# a red-team session, with the count forged at exit)
PROCESS_CASES += [
    ("a descriptor taken over", "step.cpp.o", '#include <unistd.h>\nint f(int a, int b) { return dup2(a, b); }',
     "calls dup2"),
    ("the process renamed (the grader reads its threads' CPU time by its name)", "step.cpp.o",
     '#include <sys/prctl.h>\nint f() { return prctl(PR_SET_NAME, "x", 0, 0, 0); }', "calls prctl"),
    ("/proc/self/maps read", "step.cpp.o",
     '#include <fstream>\n#include <string>\nstd::string f() { std::ifstream m("/proc/self/maps"); std::string s; m >> s; return s; }',
     "opens no file"),
]

# Stage 08's groups of refused calls (rubric.json's refuse_calls: files, signals, threads).
GROUPS = ("files", "signals", "threads")
GROUP_CASES = [
    ("debug output on stderr", "step.cpp.o", '#include <cstdio>\nvoid f(int k) { std::fprintf(stderr, "%d\\n", k); }', None),
    ("a file written through std::ofstream", "step.cpp.o",
     '#include <fstream>\nvoid f() { std::ofstream("/plab/out/report.json") << "{}"; }', "opens no file"),
    ("fopen", "step.cpp.o", '#include <cstdio>\nvoid f() { std::fclose(std::fopen("x", "w")); }', "calls fopen"),
    ("a file every rank maps", "step.cpp.o",
     '#include <fcntl.h>\n#include <sys/mman.h>\nvoid* f() { return mmap(0, 4096, PROT_READ, MAP_SHARED, open("/tmp/x", O_RDWR), 0); }',
     "maps no memory"),
    ("a raw system call", "step.cpp.o", '#include <unistd.h>\nlong f() { return syscall(39); }', "calls syscall"),
    ("open declared weak", "step.cpp.o",
     'extern "C" int open(const char*, int, ...) __attribute__((weak));\nint f() { return open("x", 0); }',
     "calls open"),
    ("SIGPROF ignored", "step.cpp.o", '#include <csignal>\nvoid f() { std::signal(SIGPROF, SIG_IGN); }', "changes no signal"),
    ("the profiling timer stopped", "step.cpp.o",
     '#include <sys/time.h>\nint f() { itimerval t{}; return setitimer(ITIMER_PROF, &t, nullptr); }', "calls setitimer"),
    ("a thread that steps beside an MPI wait", "step.cpp.o",
     '#include <thread>\nvoid f() { std::thread t([] {}); t.join(); }', "one thread of one process"),
    ("pthread_create", "step.cpp.o",
     '#include <pthread.h>\nint f() { pthread_t t; return pthread_create(&t, nullptr, [](void*) -> void* { return nullptr; }, nullptr); }',
     "calls pthread_create"),
    ("fork", "step.cpp.o", '#include <unistd.h>\nint f() { return fork(); }', "calls fork"),
    ("the C library's fortified open", "step.cpp.o",
     'extern "C" int __open_2(const char*, int);\nint f() { return __open_2("/proc/self/cmdline", 0); }',
     "calls __open_2"),
    ("the C library's internal fopen", "step.cpp.o",
     '#include <cstdio>\nextern "C" FILE* _IO_fopen(const char*, const char*);\nvoid* f() { return _IO_fopen("x", "r"); }',
     "calls _IO_fopen"),
    ("the kit's own reader: every rank reads the scene itself (a red team's stage 08)", "step.cpp.o",
     '#include <string>\nnamespace plab { std::string read_file(const std::string&); }\n'
     'std::string f() { return plab::read_file("/proc/self/cmdline"); }', "opens no file"),
    ("the kit's scene loader", "step.cpp.o",
     '#include <cstdint>\n#include <string>\nnamespace plab { struct Scene; struct GenParams; '
     'Scene load_scene(const std::string&, std::uint64_t, const GenParams*); }\n'
     'void* f() { return reinterpret_cast<void*>(&plab::load_scene); }', "opens no file"),
    ("a function of its own named like a reader", "step.cpp.o",
     'namespace mine { int read_file_count(int); }\nint f() { return mine::read_file_count(2); }', None),
    ("dlopen in a CUDA object (the kit compiles CUDA without NVTX, whose loader called it)",
     "step.cu.o", '#include <dlfcn.h>\nvoid* f() { return dlopen("libnvToolsExt.so", RTLD_LAZY); }',
     "step.cu calls dlopen"),
    ("the kit's entry points (kit/mpi/stage_entry.cpp) are the kit's", "stage_entry.cpp.o",
     '#include <fstream>\nvoid f() { std::ofstream("x") << 1; }', None),
]


# The stages given one thread (01, 02, 04, 05, 07: rubric.json's one_thread), timed against the
# reference on one thread: a red-team stage 02 split its pair loop over two std::threads (ratio
# 0.55, every point kept). (name, source, expected; compiled with -fopenmp)
ONE_THREAD_CASES = [
    ("a pair loop split over two std::threads (a red team's stage 02)",
     '#include <thread>\nvoid f() { std::thread t([] {}); t.join(); }', "runs on the one thread"),
    ("std::async", '#include <future>\nint f() { return std::async(std::launch::async, [] { return 1; }).get(); }',
     "runs on the one thread"),
    ("an OpenMP loop", 'void f(double* a, int n) {\n#pragma omp parallel for\n  for (int i = 0; i < n; ++i) a[i] *= 2;\n}',
     "calls GOMP_parallel"),
    ("pthread_create",
     '#include <pthread.h>\nint f() { pthread_t t; return pthread_create(&t, nullptr, [](void*) -> void* { return nullptr; }, nullptr); }',
     "calls pthread_create"),
    ("pthread_create declared weak (nm prints w; a red team's stage 02)",
     '#include <pthread.h>\nextern "C" int pthread_create(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*) __attribute__((weak));\n'
     'int f() { pthread_t t; return pthread_create(&t, nullptr, [](void*) -> void* { return nullptr; }, nullptr); }',
     "calls pthread_create"),
    ("the C library's own name for pthread_create",
     'extern "C" int __pthread_create_2_1(void*, const void*, void* (*)(void*), void*);\nint f() { return __pthread_create_2_1(nullptr, nullptr, nullptr, nullptr); }',
     "calls __pthread_create_2_1"),
    ("a timer whose expiry runs a function on a thread of the C library's (SIGEV_THREAD)",
     '#include <csignal>\n#include <ctime>\nint f() { sigevent e{}; e.sigev_notify = SIGEV_THREAD; timer_t t; return timer_create(CLOCK_MONOTONIC, &e, &t); }',
     "calls timer_create"),
    ("a heap of its own, std::sort, a mutex-free vector (no thread)",
     '#include <algorithm>\n#include <queue>\n#include <vector>\nint f(std::vector<int> v) { std::sort(v.begin(), v.end()); std::priority_queue<int> q(v.begin(), v.end()); return q.top(); }',
     None),
]


def library(work, member, source, flags=()):
    """A stage library holding one object named `member`, compiled from `source`."""
    cpp = work / "unit.cpp"
    cpp.write_text(source + "\n")
    obj = work / member
    subprocess.run(["g++", "-O0", *flags, "-c", str(cpp), "-o", str(obj)], check=True)
    lib = work / "libplab_stage_99_student.a"
    lib.unlink(missing_ok=True)
    subprocess.run(["ar", "rcs", str(lib), str(obj)], check=True)
    obj.unlink()
    return lib


failures = []
work = pathlib.Path(tempfile.mkdtemp(prefix="plab-symbols-"))
try:
    for name, member, source, expected in CASES:
        said = symbols.check(library(work, member, source))
        ok = not said if expected is None else any(expected in s for s in said)
        print(f"{'ok  ' if ok else 'FAIL'} {name}: {said or 'let through'}")
        if not ok:
            failures.append(name)
    for name, member, source, expected in PROCESS_CASES:
        said = symbols.check(library(work, member, source), None, ("processes", "files"))
        ok = any(expected in s for s in said)
        print(f"{'ok  ' if ok else 'FAIL'} stages 01-07's refused calls: {name}: {said or 'let through'}")
        if not ok:
            failures.append(f"processes: {name}")
    for name, source, expected in ONE_THREAD_CASES:
        said = symbols.check(library(work, "step.cpp.o", source, ("-fopenmp",)), None,
                             ("processes", "files", "one_thread"))
        ok = not said if expected is None else any(expected in s for s in said)
        print(f"{'ok  ' if ok else 'FAIL'} a stage given one thread: {name}: {said or 'let through'}")
        if not ok:
            failures.append(f"one thread: {name}")
    kit_mpi = library(work, "ranks.cpp.o", MPI_KIT).rename(work / "libplab_mpi.a")
    for name, source, expected in MPI_CASES:
        said = symbols.check(library(work, "step.cpp.o", source), kit_mpi)
        ok = not said if expected is None else any(expected in s for s in said)
        print(f"{'ok  ' if ok else 'FAIL'} MPI: {name}: {said or 'let through'}")
        if not ok:
            failures.append(f"MPI: {name}")
    for name, member, source, expected in GROUP_CASES:
        said = symbols.check(library(work, member, source), kit_mpi, GROUPS)
        ok = not said if expected is None else any(expected in s for s in said)
        print(f"{'ok  ' if ok else 'FAIL'} stage 08's refused calls: {name}: {said or 'let through'}")
        if not ok:
            failures.append(f"refused calls: {name}")
    said = symbols.check(library(work, "step.cpp.o", '#include <thread>\nvoid f() { std::thread t([] {}); t.join(); }'))
    print(f"{'ok  ' if not said else 'FAIL'} a thread where no group is refused: {said or 'let through'}")
    if said:
        failures.append("a thread refused without refuse_calls")
    missing = symbols.check(work / "libplab_stage_98_student.a")
    if not (missing and "was not built" in missing[0]):
        failures.append(f"a missing library: {missing}")
    if len(sys.argv) > 1:  # the kit's own stage libraries (solutions, starting points, engine)
        libs = sorted(pathlib.Path(sys.argv[1]).glob("*/*/libplab_stage_*.a"))
        mpi = pathlib.Path(sys.argv[1]) / "kit" / "libplab_mpi.a"
        rubric = json.loads((pathlib.Path(__file__).parents[1] / "kit/grade/rubric.json").read_text())
        for lib in libs:
            on_mpi = "_08_" in lib.name and mpi.is_file()
            sid = lib.name.split("_")[2]  # libplab_stage_NN_IMPL.a
            # each stage library against its stage's refused groups in the rubric (the engines,
            # never graded, are faster than one thread: only stage 08's is judged, for its MPI)
            groups = (() if "_engine" in lib.name else
                      GROUPS if on_mpi else symbols.refused_groups(rubric, sid))
            said = symbols.check(lib, mpi if on_mpi else None, groups)
            # stage 08's engine (never graded) owns blocks, not slabs: its driver is refused
            if lib.name == "libplab_stage_08_engine.a":
                if not said or any("mpi_stage_any_cut" not in s for s in said):
                    failures.append(f"{lib}: expected only its driver refused, got {said}")
            elif said:
                failures.append(f"{lib}: {said}")
        print(f"{'ok  ' if libs else 'FAIL'} the kit's {len(libs)} stage libraries: none refused "
              "(stage 08's engine only for its driver, which does not check the slabs)")
        if not libs:
            failures.append("no stage library found in the kit's build")
finally:
    shutil.rmtree(work, ignore_errors=True)
if failures:
    sys.exit("symbols check FAILED: " + "; ".join(failures))
print(f"{len(CASES) + len(PROCESS_CASES) + len(ONE_THREAD_CASES) + len(MPI_CASES) + len(GROUP_CASES) + 1} "
      "objects judged as expected")
