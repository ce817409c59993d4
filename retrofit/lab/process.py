"""The student's process from outside: its sandbox settings, its limits in words, and killing it
with every process it started (its process group, and as root every process of its uid).

Each student's process runs as a uid of its own when the grader is root:
``UID_BASE + 64 * (grader pid % 10**6) + slot`` (``slot`` < 64 is the grading job), so a sweep
of that uid kills that student's processes and nobody else's. No account needs to exist.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import types
from dataclasses import asdict, dataclass, field
from pathlib import Path

UID_BASE = 1_900_000_000
#: what never goes into the student's folder: the teacher's files, the checks, other Python files
TEACHER_ONLY = ("solution.py", "teacher.md", "wrong", "right", "out", "__pycache__", ".ipynb_checkpoints")


@dataclass
class Sandbox:
    """How the student's process runs: its user, what it may not see, and its limits."""

    uid: int | None = None          # None: the grader's own user (a grader that is not root)
    gid: int | None = None
    hide: list[str] = field(default_factory=list)
    cpu_seconds: int = 120
    memory_mb: int = 2048
    processes: int = 64
    file_mb: int = 64
    isolate: bool = True            # a mount namespace of its own, when the kernel allows it

    def to_env(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_env(cls, text: str) -> Sandbox:
        return cls(**json.loads(text))


def sandbox_uid(slot: int = 0) -> int | None:
    """A uid no one else uses for the student's process (None when the grader is not root)."""
    if os.geteuid() != 0:
        return None
    return UID_BASE + 64 * (os.getpid() % 1_000_000) + slot


def data_files(lab_path: Path) -> list[tuple[str, str]]:
    """The lab's files a student's code may read: data, not Python, never the teacher's."""
    files = []
    for path in sorted(lab_path.rglob("*")):
        rel = path.relative_to(lab_path)
        if path.is_file() and path.suffix not in (".py", ".pyc") and not any(
                part in TEACHER_ONLY or part.startswith(".") for part in rel.parts):
            files.append((rel.as_posix(), str(path)))
    return files


def library_paths() -> tuple[list[str], list[str]]:
    """Folders the student's Python must reach, and labs/ folders beside a retrofit on the path."""
    import numpy
    reach = {sys.prefix, sys.base_prefix, sys.exec_prefix, str(Path(numpy.__file__).parent.parent),
             str(Path(__file__).resolve().parent.parent.parent), str(Path(os.__file__).parent)}
    hide = {str(Path(p) / "labs") for p in [*sys.path, *reach] if p and (Path(p) / "retrofit").is_dir()
            and (Path(p) / "labs").is_dir()}
    return sorted(reach), sorted(hide)



def waited_for_cpu(pid: int) -> float:
    """Seconds the process has sat ready to run while no processor was free (``/proc/PID/schedstat``;
    0 where the kernel does not say): on a busy computer, wall time the process could not use."""
    try:
        with open(f"/proc/{pid}/schedstat", "rb") as handle:
            return int(handle.read().split()[1]) / 1e9
    except (OSError, ValueError, IndexError):
        return 0.0


def cpu_seconds(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/stat", "rb") as handle:
            fields = handle.read().rsplit(b")", 1)[1].split()
        return sum(int(f) for f in fields[11:15]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return 0.0



def ended_text(code, sandbox: Sandbox, stderr: str) -> str:
    """Why the student's process ended, in words."""
    if code is None:
        return "your program ended"
    if code < 0:
        sig = -code
        what = {signal.SIGXCPU: f"it used more than {sandbox.cpu_seconds} s of processor time",
                signal.SIGXFSZ: f"it wrote a file larger than {sandbox.file_mb} MiB",
                signal.SIGKILL: "it was killed (out of memory, or a limit)",
                signal.SIGSEGV: "it crashed (segmentation fault)"}.get(sig, f"signal {sig}")
        return f"your program was stopped: {what}"
    if code == 70:
        return f"the grader's sandbox did not start: {stderr}"
    tail = f": {stderr}" if stderr and code not in (0,) else ""
    return f"your program ended with exit code {code} while the checks were using it{tail}"



def send_signal(proc, sig) -> None:
    try:
        if proc is not None and proc.poll() is None:
            os.kill(proc.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def kill_group(proc) -> None:
    """SIGKILL the student's process and its process group, and wait for the process."""
    if proc is None:
        return
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    send_signal(proc, signal.SIGKILL)
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        pass


def sweep_uid(uid: int, gid: int) -> int:
    """As root: kill every process of ``uid`` (grandchildren that left the process group too).

    ``kill -9 -1`` run as that uid sends SIGKILL to every process it may signal, i.e. every process
    of the uid; repeated until /proc shows none (a fork storm may fork in between). Returns how
    many rounds it took; 0 when none was running.
    """
    if os.geteuid() != 0:
        return 0
    kill = shutil.which("kill", path="/usr/bin:/bin")
    for rounds in range(100):
        if not processes_of(uid):
            return rounds
        if kill:
            subprocess.run([kill, "-9", "-1"], user=uid, group=gid, extra_groups=[], stdin=subprocess.DEVNULL,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        else:
            _kill_as(uid, gid)
    return rounds


def _kill_as(uid: int, gid: int) -> None:
    """``kill(-1, SIGKILL)`` from a forked child that took ``uid`` (where there is no kill program)."""
    pid = os.fork()
    if pid == 0:                          # pragma: no cover (the forked child)
        try:
            os.setgroups([])
            os.setgid(gid)
            os.setuid(uid)
            os.kill(-1, signal.SIGKILL)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)


def processes_of(uid: int) -> list[int]:
    """Pids of the processes whose real or effective uid is ``uid`` (from /proc)."""
    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                for line in open(f"/proc/{entry}/status", encoding="ascii", errors="replace"):
                    if line.startswith("Uid:"):
                        if str(uid) in line.split()[1:3]:
                            pids.append(int(entry))
                        break
            except OSError:
                continue
    return pids


def needs_handle(obj) -> bool:
    """Does ``obj`` stay here (a handle), or can the student's process rebuild it from a pickle?

    Classes and functions of modules the student's process imports too (Python's own, installed
    packages, retrofit) go by reference, their instances by value; those of the checks' own
    files, lambdas and local functions stay here.
    """
    if isinstance(obj, (type, types.FunctionType, types.BuiltinFunctionType)):
        if "<" in getattr(obj, "__qualname__", "<"):
            return True
        return not _importable(getattr(obj, "__module__", None))
    if isinstance(obj, types.MethodType):
        return needs_handle(obj.__func__) or needs_handle(obj.__self__)
    return not _importable(type(obj).__module__)


_IMPORTABLE: dict[str, bool] = {}


def _importable(name) -> bool:
    if not isinstance(name, str):
        return False
    if name not in _IMPORTABLE:
        module = sys.modules.get(name)
        where = getattr(module, "__file__", None) if module is not None else ""
        roots = _library_roots()
        _IMPORTABLE[name] = module is not None and (where is None or any(where.startswith(r) for r in roots))
    return _IMPORTABLE[name]


def child_path() -> list[str]:
    """The student's process's import path: retrofit's folder, then the installed packages (it starts
    without ``site``, which saves a fifth of its start-up)."""
    import site
    import sysconfig
    paths = sysconfig.get_paths()
    extra = [*site.getsitepackages(), site.getusersitepackages()] if hasattr(site, "getsitepackages") else []
    found = [str(Path(__file__).resolve().parent.parent.parent), paths["purelib"], paths["platlib"], *extra]
    return [p for p in dict.fromkeys(found) if os.path.isdir(p)]


def _library_roots() -> tuple[str, ...]:
    import sysconfig
    paths = sysconfig.get_paths()
    return tuple({paths["stdlib"], paths["platstdlib"], paths["purelib"], paths["platlib"],
                  str(Path(__file__).resolve().parent.parent) + os.sep})


class Budget:
    """The running check's time limit, set by the checks' runner (``labs._collector``)."""

    def __init__(self):
        self.seconds, self.title, self.epoch, self.wall0 = None, "", 0, 0.0

    def begin(self, seconds: float, title: str) -> None:
        self.seconds, self.title, self.epoch, self.wall0 = seconds, title, self.epoch + 1, time.monotonic()

    def end(self) -> None:
        self.seconds = None


BUDGET = Budget()


PR_SET_CHILD_SUBREAPER = 36


def become_subreaper() -> bool:
    """Make this process the one orphaned descendants are handed to (Linux); False where it cannot."""
    try:
        import ctypes
        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def children_of(pid: int) -> list[int]:
    """Pids whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat", "rb") as handle:
                    if int(handle.read().rsplit(b")", 1)[1].split()[1]) == pid:
                        found.append(int(entry))
            except (OSError, ValueError, IndexError):
                continue
    return found


def kill_children() -> int:
    """SIGKILL every child of this process, again for the orphans handed to it, until none is left.

    With :func:`become_subreaper`, a grandchild that left its session and its parent comes here,
    so this reaches it without root. Returns how many processes were killed.
    """
    killed = 0
    for _ in range(100):
        pids = children_of(os.getpid())
        if not pids:
            break
        for pid in pids:
            send_pid(pid)
            killed += 1
        for pid in pids:
            try:
                os.waitpid(pid, 0)
            except ChildProcessError:
                pass
    return killed


def send_pid(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
