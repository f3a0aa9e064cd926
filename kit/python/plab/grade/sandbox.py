"""Where `plab grade` runs student code: the compiler and every run of a submission's program.

Three isolations, chosen once per grading (`choose()`), strongest first:

- **bubblewrap**: each build and run gets its own mount, PID, network, IPC, UTS and user
  namespaces (`bwrap --unshare-all`), a read-only view of /usr (system and toolchain), of the
  paths it is given and nothing else (no /home, no /root, no kit, no /sys, a private /tmp),
  a clean environment, and runs as an unprivileged user (when the grader is root, as the dedicated
  uid `SANDBOX_UID`; inside, as `nobody`). When the first process of its PID namespace exits or is
  killed, the kernel ends everything it started: `setsid()` does not escape.
- **unprivileged user** (where namespaces are not allowed, as in some containers; needs root): the
  program runs as `SANDBOX_UID` (one of SANDBOX_UIDS, its own for this grading) with a clean environment; the expected outputs and the kit's
  private parts must be unreadable to that uid (checked before grading, `private_readable()`).
  After each run every process of that uid is killed (`kill -1` as that uid). The network is not
  isolated in this mode.
- **none** (`--no-sandbox`, the instructor's explicit choice): the grader's own rights.

On top of each: wall time, address space (CPU runs), output size, process count (`setrlimit`),
no core dumps.
"""
import glob
import os
import pathlib
import resource
import shutil
import signal
import stat
import subprocess
import tempfile
import threading
import time

#: The uids that student code runs as when the grader is root (no account uses them): one per
#: grading running at the same time, held with a lock, so that killing every process of one
#: grading's uid never touches another's.
SANDBOX_UIDS = range(64900, 65000)


def _lock_dir():
    """Where the uid locks live: the machine's own lock folder, which every grading on the machine
    sees, even one whose /tmp is private (a grading inside a container or a bubblewrap sandbox of
    its own, as the Gradescope test's fake /autograder is); the temporary folder otherwise."""
    for d in ("/run/lock", "/var/lock"):
        if os.path.isdir(d) and os.access(d, os.W_OK):
            return pathlib.Path(d)
    return pathlib.Path(tempfile.gettempdir())


def _hold_uid():
    """A uid of SANDBOX_UIDS that no other grading holds; held until this process ends."""
    import fcntl
    for uid in SANDBOX_UIDS:
        lock = open(_lock_dir() / f"plab-sandbox-uid-{uid}.lock", "a")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        _hold_uid.lock = lock  # kept open: the lock lasts as long as the grader
        return uid
    raise RuntimeError(f"every sandbox uid ({SANDBOX_UIDS.start}-{SANDBOX_UIDS.stop - 1}) is in use")


SANDBOX_UID = _hold_uid() if os.geteuid() == 0 else os.geteuid()
#: The environment of student code (nothing of the grader's own).
CLEAN_ENV = {"PATH": "/usr/local/cuda/bin:/usr/local/bin:/usr/bin:/bin", "HOME": "/tmp",
             "LANG": "C.UTF-8", "OMP_WAIT_POLICY": "PASSIVE", "TMPDIR": "/tmp"}
#: What every mode is called in summaries and results.json.
NAMES = {"bwrap": "bubblewrap (mount, PID, network, IPC, UTS and user namespaces; "
                  "an unprivileged uid; read-only system; clean environment)",
         "user": f"unprivileged user (uid {SANDBOX_UID}, clean environment; no namespaces: "
                 "the network is not isolated)",
         "none": "NONE: --no-sandbox, student code ran with the grader's own rights"}


class Run:
    """One run of an untrusted program, ended by its limits. `cpu`: when the run was watched,
    {(process id, thread id): CPU seconds} of its program's threads (see `program_cpu()`);
    `cpu_total`: {process id: CPU seconds of all its threads, those that ended included}."""

    def __init__(self, rc, seconds, reason, stdout, stderr, out_dir, cpu=None, cpu_total=None):
        self.rc, self.seconds, self.reason = rc, seconds, reason
        self.stdout, self.stderr, self.out_dir = stdout, stderr, out_dir
        self.cpu = cpu or {}
        self.cpu_total = cpu_total or {}

    def read_output(self, name="out.txt"):
        """The text of a file the program wrote into its output folder, or None. Never follows a
        link and takes only a plain file: a program must not pass off another file (a golden
        output, say) as its own."""
        path = self.out_dir / name
        try:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
        except OSError:
            return None
        with os.fdopen(fd, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
                return None
            return f.read().decode(errors="replace")


TOOLS = ("cmake", "ninja", "c++", "g++", "gcc", "nvcc", "clang++")  # what a build inside runs


def _toolchain():
    """(folders to bind read-only, PATH) for build tools installed outside /usr (a cmake from
    PyPI in /usr/local/bin linking to /opt, say): each tool's install prefix, never a home."""
    binds, path = [], CLEAN_ENV["PATH"].split(":")
    for tool in TOOLS:
        found = shutil.which(tool)
        if not found:
            continue
        for p in (pathlib.Path(found), pathlib.Path(os.path.realpath(found))):
            prefix = p.parent.parent
            if not str(p).startswith("/usr/") and not str(prefix).startswith(("/home", "/root")) \
                    and str(prefix) != "/" and str(prefix) not in binds:
                binds.append(str(prefix))
            if str(p.parent) not in path:
                path.append(str(p.parent))
    return binds, ":".join(path)


def _feed(pipe, text):
    """Writes `text` into a program's stdin and closes it (the program may stop reading)."""
    try:
        pipe.write(text.encode())
        pipe.close()
    except (BrokenPipeError, OSError):
        pass


def _root():
    return os.geteuid() == 0


TICK = os.sysconf("SC_CLK_TCK")


def _seconds(stat_text):
    """User + system CPU seconds from a /proc stat line (of a thread, or of a whole process:
    then its threads that ended are counted too)."""
    fields = stat_text[stat_text.rfind(")") + 2:].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def program_cpu(root_pid, name="stage", totals=None):
    """{(pid, tid): CPU seconds (user + system)} of every thread of the processes below
    `root_pid` whose command name starts with `name` (a stage program runs as /plab/stage, or
    under the grader's own name stageNN). Read from the host's /proc, outside the program: what
    the kernel counted, whatever the program says. Threads that ended are not seen; `totals`
    (a dict), when given, gets {pid: CPU seconds of the whole process}, which counts them (a
    red-team stage started a thread for a millisecond inside every step, which no reading of
    its threads saw)."""
    parents, names = {}, {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            text = pathlib.Path(f"/proc/{entry.name}/stat").read_text()
        except OSError:
            continue
        comm_end = text.rfind(")")
        fields = text[comm_end + 2:].split()
        parents[int(entry.name)] = int(fields[1])
        names[int(entry.name)] = text[text.find("(") + 1:comm_end]
    below, todo = {root_pid}, [root_pid]  # the program itself, without a sandbox
    while todo:
        pid = todo.pop()
        for child, parent in parents.items():
            if parent == pid and child not in below:
                below.add(child)
                todo.append(child)
    cpu = {}
    for pid in below:
        if not names.get(pid, "").startswith(name):
            continue
        try:
            tasks = os.listdir(f"/proc/{pid}/task")
            if totals is not None:
                totals[pid] = _seconds(pathlib.Path(f"/proc/{pid}/stat").read_text())
        except OSError:
            continue
        for tid in tasks:
            try:
                text = pathlib.Path(f"/proc/{pid}/task/{tid}/stat").read_text()
            except OSError:
                continue
            cpu[pid, int(tid)] = _seconds(text)
    return cpu


class Sandbox:
    """Builds and runs student code under the chosen isolation. `scratch` is the grader's own
    folder: `box/` below it (readable by the sandbox's uid) holds what student code may see,
    everything else stays private (mode 0700)."""

    def __init__(self, scratch, limits, mode):
        self.scratch, self.limits, self.mode = pathlib.Path(scratch), limits, mode
        self.box = self.scratch / "box"
        self.box.mkdir(exist_ok=True)
        os.chmod(self.scratch, 0o711)  # the sandbox's uid may pass through, never list
        os.chmod(self.box, 0o711)

    # -- what student code may write ----------------------------------------------------------
    def writable_dir(self, parent, prefix):
        """A new empty folder that student code may write (owned by the sandbox's uid)."""
        d = pathlib.Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        os.chmod(d, 0o755)
        if self.mode != "none" and _root():
            os.chown(d, SANDBOX_UID, SANDBOX_UID)
        return d

    def shared_dir(self, name):
        """A folder in box/ that student code may read, not write."""
        d = self.box / name
        d.mkdir(parents=True, exist_ok=True)
        os.chmod(d, 0o711 if name == "bin" else 0o755)  # programs: reached by name, never listed
        return d

    # -- command lines -------------------------------------------------------------------------
    def _as_sandbox_user(self):
        return ["setpriv", f"--reuid={SANDBOX_UID}", f"--regid={SANDBOX_UID}", "--clear-groups",
                "--no-new-privs"] if _root() else []

    def _bwrap(self, ro, rw, chdir, gpu):
        """bwrap's arguments: the system read-only, `ro` and `rw` ({inside: outside}) bound, and
        nothing else of the host."""
        args = ["bwrap", "--unshare-all", "--die-with-parent", "--new-session", "--clearenv",
                "--uid", "65534", "--gid", "65534", "--hostname", "sandbox",
                "--proc", "/proc", "--dev", "/dev", "--tmpfs", "/tmp", "--ro-bind", "/usr", "/usr"]
        for top in ("bin", "sbin", "lib", "lib32", "lib64", "libx32"):
            p = pathlib.Path("/" + top)
            if p.is_symlink():
                args += ["--symlink", os.readlink(p), str(p)]
            elif p.is_dir():
                args += ["--ro-bind", str(p), str(p)]
        for etc in ("/etc/alternatives", "/etc/ld.so.cache", "/etc/ld.so.conf",
                    "/etc/ld.so.conf.d"):
            args += ["--ro-bind-try", etc, etc]
        tool_binds, _ = _toolchain()
        for prefix in tool_binds:
            args += ["--ro-bind", prefix, prefix]
        if gpu:
            for dev in sorted(glob.glob("/dev/nvidia*")):
                args += ["--dev-bind", dev, dev]
        for inside, outside in ro.items():
            args += ["--ro-bind", str(outside), str(inside)]
        for inside, outside in rw.items():
            args += ["--bind", str(outside), str(inside)]
        for key, value in dict(CLEAN_ENV, PATH=_toolchain()[1]).items():
            args += ["--setenv", key, value]
        return args + ["--chdir", str(chdir), "--"]

    def command(self, argv, ro, rw, chdir, gpu=False, env=None):
        """(command line, cwd, environment) for `argv`, whose paths are the inside ones of `ro`
        and `rw` ({inside path: outside path}); in the modes without namespaces the inside paths
        are replaced by the outside ones."""
        extra = dict(env or {})
        if self.mode == "bwrap":
            setenv = [a for k, v in extra.items() for a in ("--setenv", k, v)]
            line = self._as_sandbox_user() + self._bwrap(ro, rw, chdir, gpu)
            # bwrap itself (the namespace's first process, whose environment student code can
            # read) starts with the clean environment too, never the grader's
            return line[:-1] + setenv + ["--"] + [str(a) for a in argv], "/", dict(CLEAN_ENV)
        mapping = {str(k): str(v) for k, v in {**ro, **rw}.items()}

        def outside(a):
            a = str(a)
            key, eq, value = a.partition("=")  # -DNAME=/plab/...: the value is a path too
            if eq and key.startswith("-"):
                return key + eq + outside(value)
            for inside in sorted(mapping, key=len, reverse=True):
                if a == inside or a.startswith(inside + "/"):
                    return mapping[inside] + a[len(inside):]
            return a
        line = [outside(a) for a in argv]
        env_all = dict(CLEAN_ENV, PATH=_toolchain()[1], **extra)
        if self.mode == "user":
            return self._as_sandbox_user() + line, outside(chdir), env_all
        return line, outside(chdir), env_all

    # -- running -------------------------------------------------------------------------------
    def run(self, argv, ro, rw, chdir, seconds, output_bytes, gpu=False, memory=True, env=None,
            log_dir=None, stdin_text=None, watch=False):
        """Runs `argv` in the sandbox with the limits; stdout and stderr go to files the program
        cannot see, `stdin_text` (if any) comes through a pipe. `watch`: read the CPU time of
        every thread of the program from /proc while it runs (Run.cpu). Returns a Run; anything
        it started is dead when this returns."""
        line, cwd, environ = self.command(argv, ro, rw, chdir, gpu, env)
        pass_fds, args_fd = (), None
        if self.mode == "bwrap":  # bwrap's own arguments (the outside paths) through a pipe:
            split = line.index("bwrap")  # its command line, readable inside, shows none of them
            cut = len(line) - len(argv) - 1
            read_end, args_fd = os.pipe()
            os.write(args_fd, b"".join(a.encode() + b"\0" for a in line[split + 1:cut]))
            os.close(args_fd)
            line = line[:split + 1] + ["--args", str(read_end)] + line[cut:]
            pass_fds = (read_end,)
        log_dir = pathlib.Path(log_dir or tempfile.mkdtemp(prefix="log-", dir=self.scratch))
        memory_bytes = self.limits["memory_mb"] * 2**20
        processes = self.limits["processes"]

        def limit():
            if memory and not gpu:  # CUDA reserves far more address space than it uses
                resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
            resource.setrlimit(resource.RLIMIT_FSIZE, (output_bytes, output_bytes))
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
            try:
                resource.setrlimit(resource.RLIMIT_NPROC, (processes, processes))
            except (ValueError, OSError):
                pass

        start = time.time()
        with open(log_dir / "stdout", "wb") as out, open(log_dir / "stderr", "wb") as err:
            stdin, feed = subprocess.DEVNULL, None
            if stdin_text is not None:  # a pipe the sandbox's uid may open as /dev/stdin
                stdin, feed_fd = os.pipe()
                os.fchmod(stdin, 0o666)
                feed = os.fdopen(feed_fd, "wb")
            proc = subprocess.Popen(line, cwd=cwd, stdout=out, stderr=err, env=environ,
                                    stdin=stdin, preexec_fn=limit, start_new_session=True,
                                    pass_fds=pass_fds)
            for fd in pass_fds + ((stdin,) if feed else ()):
                os.close(fd)
            if feed:
                threading.Thread(target=_feed, args=(feed, stdin_text), daemon=True).start()
            reason, cpu, totals = None, {}, {}
            try:
                if watch:  # the last reading of each thread before it ended (every 50 ms)
                    while proc.poll() is None and time.time() - start < seconds:
                        cpu.update(program_cpu(proc.pid, totals=totals))
                        time.sleep(0.05)
                proc.wait(timeout=max(0.0, seconds - (time.time() - start)))
            except subprocess.TimeoutExpired:
                reason = f"stopped after {seconds:.0f} s (the time limit): an endless loop?"
            finally:
                self.end_everything(proc)
        took = time.time() - start
        rc = proc.returncode
        stderr = (log_dir / "stderr").read_bytes()[-4000:].decode(errors="replace")
        signum = -rc if rc < 0 else None
        if self.mode == "bwrap" and 128 < rc < 128 + signal.NSIG:  # bwrap passes a signal on
            signum = rc - 128  # as 128 + its number, as a shell does
        if reason is None and signum:
            sig = signal.Signals(signum)
            if sig == signal.SIGXFSZ:
                reason = f"stopped: it wrote more than {output_bytes / 2**20:.0f} MB (the output cap)"
            else:
                reason = f"crashed with signal {signum} ({sig.name})"
        if reason is None and rc != 0 and self.mode == "bwrap" and stderr.startswith("bwrap:"):
            reason = f"the sandbox could not start: {stderr.strip()}"
        if reason is None and rc != 0 and ("bad_alloc" in stderr or "memory" in stderr.lower()):
            reason = f"ran out of memory (limit {self.limits['memory_mb']} MB)"
        out_dir = pathlib.Path(rw.get("/plab/out", log_dir)) if rw else log_dir
        return Run(rc, took, reason, log_dir / "stdout", stderr, out_dir, cpu, totals)

    def end_everything(self, proc):
        """Kills the program's process group and, under a dedicated uid, every process of that
        uid (what escaped the group with setsid() included)."""
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()
        if self.mode != "none" and _root():
            for _ in range(5):  # kill(-1) as the uid: every process of it but the killer itself,
                killed = subprocess.run(self._as_sandbox_user()[:-1] + ["kill", "-KILL", "-1"],
                                        capture_output=True).returncode == 0
                if not killed:  # until none was left (kill fails with "no such process")
                    break


def _probe(mode, scratch):
    """Whether `mode` can start a program here; (ok, what went wrong)."""
    sb = Sandbox(scratch, {"memory_mb": 512, "processes": 64}, mode)
    probe = sb.shared_dir("probe")
    (probe / "hello").write_text("hello\n")
    out = sb.writable_dir(scratch, "probe-out-")
    try:
        run = sb.run(["/bin/cp", "/plab/in/hello", "/plab/out/seen"],
                     {"/plab/in": probe}, {"/plab/out": out}, "/plab/out", 20, 2**20)
        ok = run.rc == 0 and run.read_output("seen") == "hello\n"
        return ok, run.stderr.strip() or f"exit {run.rc}"
    finally:
        shutil.rmtree(probe, ignore_errors=True)
        shutil.rmtree(out, ignore_errors=True)


def _cannot(mode):
    """Why `mode` cannot be tried at all here, or None."""
    if mode == "bwrap":
        return None if shutil.which("bwrap") else "bubblewrap: not installed (Debian package bubblewrap)"
    if not _root():
        return "unprivileged user: needs the grader to run as root"
    return None if shutil.which("setpriv") else \
        "unprivileged user: setpriv not found (Debian package util-linux)"


def choose(request, scratch):
    """The isolation to grade with: `request` is auto, bwrap, user or none. Returns (mode,
    None) or (None, why nothing works)."""
    if request == "none":
        return "none", None
    failed = {"bwrap": "bubblewrap: namespaces not allowed here",
              "user": f"unprivileged user: could not run as uid {SANDBOX_UID}"}
    tried = []
    for mode in ("bwrap", "user"):  # strongest first
        if request not in ("auto", mode):
            continue
        why = _cannot(mode)
        if why is None:
            ok, problem = _probe(mode, scratch)
            if ok:
                return mode, None
            why = f"{failed[mode]} ({problem})"
        tried.append(why)
    return None, "; ".join(tried)


def private_readable(paths):
    """Which of `paths` the sandbox's uid could read (for the unprivileged-user mode, where
    nothing but file permissions hides them)."""
    if not _root():
        return [str(p) for p in paths]
    seen = []
    for p in paths:
        test = ["setpriv", f"--reuid={SANDBOX_UID}", f"--regid={SANDBOX_UID}", "--clear-groups",
                "test", "-r" if pathlib.Path(p).is_file() else "-x", str(p)]
        if pathlib.Path(p).exists() and subprocess.run(test, capture_output=True).returncode == 0:
            seen.append(str(p))
    return seen


#: Where readable_copies() does not look: the system, and what is not files.
_NOT_SEARCHED = {"/proc", "/sys", "/dev", "/usr", "/lib", "/lib32", "/lib64", "/libx32", "/bin",
                 "/sbin", "/etc", "/boot", "/run", "/snap", "/var/lib", "/var/cache", "/var/log"}


def _answers_below(top, depth, skip, found):
    """Files below `top` (at most `depth` folders down) that hold a stage's answer: a built
    solution (plab-run-NN-solution) or a solution's source (solutions/NN-name/*.cpp, .cu)."""
    if depth < 0 or top in _NOT_SEARCHED or any(top == s or top.startswith(s + "/") for s in skip):
        return
    try:
        entries = list(os.scandir(top))
    except OSError:
        return
    for e in entries:
        try:
            if e.is_symlink():
                continue
            if e.is_dir():
                if e.name not in (".git", "CMakeFiles", "node_modules", "__pycache__"):
                    _answers_below(e.path, depth - 1, skip, found)
            elif e.name.startswith("plab-run-") and e.name.endswith("-solution"):
                found.append(e.path)
            elif (e.name.endswith((".cpp", ".cu")) and
                  os.path.basename(os.path.dirname(os.path.dirname(e.path))) == "solutions"):
                found.append(e.path)
        except OSError:
            continue


def readable_copies(skip=(), roots=("/",), depth=6):
    """Answers the sandbox's uid could read anywhere on the machine (the unprivileged-user mode
    has nothing but file permissions): built solutions and solutions' sources, outside `skip`
    (the folders the grader made private itself). At most 20 paths."""
    found = []
    for root in roots:
        _answers_below(root, depth, [str(s) for s in skip], found)
    if not found or not _root():
        return found[:20]
    script = 'for f; do [ -r "$f" ] && echo "$f"; done'
    seen = []
    for i in range(0, len(found), 200):
        seen += subprocess.run(["setpriv", f"--reuid={SANDBOX_UID}", f"--regid={SANDBOX_UID}",
                                "--clear-groups", "sh", "-c", script, "sh", *found[i:i + 200]],
                               capture_output=True, text=True).stdout.split()
    return seen[:20]


def make_private(paths):
    """Takes every permission of group and others off `paths` (recursively) where this process
    may (the kit's solutions, goldens and builds, in the unprivileged-user mode). Returns the
    paths it could not change."""
    failed = []
    for top in paths:
        top = pathlib.Path(top)
        if not top.exists():
            continue
        for path in [top, *(top.rglob("*") if top.is_dir() else [])]:
            try:
                if not path.is_symlink():
                    os.chmod(path, stat.S_IMODE(path.stat().st_mode) & 0o700)
            except OSError:
                failed.append(str(path))
                break
    return failed
