"""The grader's side of a sandboxed lab check: start the student's process, send it the checks'
requests, time them, and give the checks proxies for the student's module and objects.

A check's time limit lives here, in the grader's process: the student's processor time is read
from ``/proc`` while the grader waits, with ten times as much wall time as a backstop (less the
time the process sat ready while every processor was busy, so a loaded computer is no timeout). When the
time is up the student's process gets SIGUSR1 (to say where it was) and, if it does not answer
within :data:`GRACE_S`, is killed and started afresh for the next check.

What goes to the student's process is pickled (it trusts the grader); objects of the checks'
own classes, lambdas and the like stay here and go as handles the student's code calls back
through. What comes back is the tagged JSON of :mod:`retrofit.lab.wire`, never a pickle.
"""

from __future__ import annotations

import atexit
import io
import json
import os
import pickle
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

from . import wire as labwire
from .process import (
    BUDGET,
    Sandbox,
    child_path,
    cpu_seconds,
    data_files,
    ended_text,
    kill_group,
    library_paths,
    needs_handle,
    send_signal,
    sweep_uid,
    waited_for_cpu,
)
from .wire import CheckTimeout, StudentProcessEnded, WireError, again, rebuild, where_text

GRACE_S = 2.0                       # wall seconds the student's process has to say where it was
MAX_STARTS = 8                      # starts of one student's process before the checks give up


class _MethodRef:
    def __init__(self, ident, name):
        self.ident, self.name = ident, name


class RemoteObject(labwire.Proxy):
    """An object that lives in the student's process."""

    __slots__ = ("_session", "_gen", "_id", "_type")

    def __init__(self, session, gen, ident, type_name):
        for name, value in (("_session", session), ("_gen", gen), ("_id", ident), ("_type", type_name)):
            object.__setattr__(self, name, value)

    def _request(self, op, name, args, kwargs=None):
        return self._session.request(self._gen, self._id, op, name, args, kwargs or {})

    # Comparisons are the checks' to make: an object of the student's is equal only to itself, and
    # ``in`` looks through its items here (a student's __eq__ could say yes to anything).
    def __eq__(self, other):
        return isinstance(other, RemoteObject) and (other._session, other._gen, other._id) == (
            self._session, self._gen, self._id)

    def __ne__(self, other):
        return not self == other

    def __hash__(self):
        return hash((id(self._session), self._gen, self._id))

    def __contains__(self, item):
        return any(item == x for x in self._request("op", "iter", []))

    def _compare(self, other):
        raise TypeError(f"an object of type {self._type} from the student's code is not ordered by the checks; "
                        "compare plain values (float(x), list(x), tuple(x))")

    __lt__ = __le__ = __gt__ = __ge__ = _compare


class RemoteMethod(RemoteObject):
    """A function or method of the student's: ``__call__`` asks for it by name, in one request."""

    def _request(self, op, name, args, kwargs=None):
        if op == "call":
            return self._session.request(self._gen, self._id, "callattr", self._type, args, kwargs or {})
        if op == "op" and name in ("repr", "str"):
            return f"<{self._type} of the student's code>"
        raise TypeError(f"{self._type} of the student's code can only be called")


class ModuleProxy(RemoteObject):
    """The student's module: started on first use and again after the student's process died."""

    def _request(self, op, name, args, kwargs=None):
        return self._session.request(None, 0, op, name, args, kwargs or {})


class Session:
    """One student's process and the pipes to it."""

    def __init__(self, target: Path, lab_path: Path, sandbox: Sandbox):
        self.target, self.lab_path, self.sandbox = Path(target), Path(lab_path), sandbox
        self.proc, self.gen, self.starts, self.failed, self.exports = None, 0, 0, None, []
        self.mark, self.calls, self.depth, self.scratch, self.stderr = None, 0, 0, None, None
        OPEN.append(self)

    # ---- the process ----------------------------------------------------------------------------
    def start(self) -> None:
        self.close()
        if self.starts >= MAX_STARTS:
            self.failed = StudentProcessEnded(f"your program ended or hung {MAX_STARTS} times; the checks gave up on it")
            raise self.failed
        self.starts += 1
        to_child, from_grader = os.pipe()
        from_child, to_grader = os.pipe()
        self.scratch = tempfile.mkdtemp(prefix="retrofit-lab-")
        reach, hide = library_paths()
        box = self.sandbox
        config = {"fds": [to_child, to_grader], "scratch": self.scratch, "reach": reach, "isolate": box.isolate,
                  "hide": sorted({*hide, *box.hide}), "uid": box.uid, "gid": box.gid if box.gid is not None else box.uid,
                  "files": [[self.target.name, str(self.target)], *data_files(self.lab_path)],
                  "tmp_mb": box.file_mb,
                  "rlimits": {"RLIMIT_CPU": box.cpu_seconds, "RLIMIT_AS": box.memory_mb << 20,
                              "RLIMIT_FSIZE": box.file_mb << 20, "RLIMIT_CORE": 0,
                              **({"RLIMIT_NPROC": box.processes} if box.uid is not None else {})}}
        env = {"PATH": os.defpath, "PYTHONPATH": os.pathsep.join(child_path()), "HOME": self.scratch, "LANG": "C.UTF-8",
               "MPLBACKEND": "Agg", "MPLCONFIGDIR": os.path.join(self.scratch, ".mpl"), "PYTHONDONTWRITEBYTECODE": "1",
               "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "RETROFIT_SANDBOX": json.dumps(config)}
        self.stderr = tempfile.TemporaryFile()
        try:
            self.proc = subprocess.Popen([sys.executable, "-S", "-m", "retrofit.lab.sandbox"], env=env, cwd="/",
                                         pass_fds=(to_child, to_grader), start_new_session=True,
                                         stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=self.stderr)
        finally:
            os.close(to_child)
            os.close(to_grader)
        self.out, self.inp, self.reader = from_grader, from_child, labwire.Reader()
        os.set_blocking(self.inp, False)
        self.gen += 1
        self.exports = []
        try:
            self._wait()                  # the import of the student's file: a failure is final
        except Exception as exc:
            exc.at_import = True
            self.failed = exc
            raise

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def close(self) -> None:
        """End the student's process, its process group and (as root) every process of its uid."""
        if self.proc is None:
            return
        for fd in (self.out, self.inp):
            try:
                os.close(fd)
            except OSError:
                pass
        kill_group(self.proc)
        if self.sandbox.uid is not None:
            sweep_uid(self.sandbox.uid, self.sandbox.gid if self.sandbox.gid is not None else self.sandbox.uid)
        self.proc = None
        if self.scratch:
            shutil.rmtree(self.scratch, ignore_errors=True)
        if self.stderr is not None:
            self.stderr.close()
            self.stderr = None

    # ---- requests -------------------------------------------------------------------------------
    def request(self, gen, ident, op, name, args, kwargs):
        if self.failed is not None:
            raise again(self.failed)
        if gen is None:
            if not self.alive():
                self.start()
        elif gen != self.gen or not self.alive():
            raise StudentProcessEnded("an object your code gave back earlier is gone: your program was started "
                                      "afresh after it ended or hung")
        message = ("req", op, ident, name, [self._pickle(a) for a in args],
                   {k: self._pickle(v) for k, v in kwargs.items()})
        self.calls += self.depth == 0
        self.depth += 1
        try:
            self._send(message)
            return self._wait()
        finally:
            self.depth -= 1

    def _pickle(self, value) -> bytes:
        buffer = io.BytesIO()
        try:
            _GraderPickler(buffer, self).dump(value)
        except (pickle.PicklingError, TypeError, AttributeError):
            buffer = io.BytesIO()
            _GraderPickler(buffer, self, force=value).dump(value)
        return buffer.getvalue()

    def export(self, obj) -> int:
        self.exports.append(obj)
        return len(self.exports) - 1

    def _send(self, message) -> None:
        try:
            labwire.write_all(self.out, labwire.frame(b"P", pickle.dumps(message)))
        except OSError:
            self._ended()

    def _wait(self):
        """The answer to the last request; serves the student's call-backs meanwhile; keeps the time."""
        try:
            while True:
                message = self._message()
                kind = message.get("k") if isinstance(message, dict) else None
                if kind == "ok" and "v" in message:
                    return message["v"]
                if kind == "err" and isinstance(message.get("e"), dict):
                    raise self._error(message["e"])
                if kind == "req":
                    self._serve(message)
                    continue
                raise WireError("a message that is neither an answer nor a request")
        except WireError as exc:
            kill_group(self.proc)
            raise StudentProcessEnded(f"your program broke the link to the checks ({exc})") from None
        except BaseException as exc:
            if not getattr(exc, "_from_student", False) and not isinstance(exc, StudentProcessEnded):
                kill_group(self.proc)     # stopped half-way through a request: this process is out of step
            raise

    def _message(self):
        """The next whole message from the student's process, keeping the check's time meanwhile."""
        interrupted = None
        while True:
            got = self.reader.next()
            if got is not None:
                if got[0] != "J":
                    raise WireError("a message that is not JSON")
                message = labwire.decode(got[1], self._handles())
                if interrupted is None:
                    return message
                return self._timed_out(message)
            if interrupted is None and self._over_budget():
                interrupted = time.monotonic()
                send_signal(self.proc, signal.SIGUSR1)
            elif interrupted is not None and time.monotonic() - interrupted > GRACE_S:
                kill_group(self.proc)
                raise self._timeout([])
            ready, _, _ = select.select([self.inp], [], [], 0.05)
            if ready:
                try:
                    data = os.read(self.inp, 1 << 16)
                except BlockingIOError:
                    continue
                if not data:
                    self._ended()
                self.reader.feed(data)

    def _timed_out(self, message):
        """The student's answer after SIGUSR1: where it was (or it asked or answered something else,
        then it is killed); either way the time is up."""
        record = message.get("e") if isinstance(message, dict) and message.get("k") == "err" else None
        if not isinstance(record, dict):
            kill_group(self.proc)
        raise self._timeout(record.get("where", []) if isinstance(record, dict) else [])

    def _timeout(self, where) -> CheckTimeout:
        seconds, title = (BUDGET.seconds, BUDGET.title) if BUDGET.seconds is not None else (self._seconds(), "")
        exc = CheckTimeout(f"{title + ': ' if title else ''}did not finish within {seconds:g} s")
        exc._from_student = True
        exc.student_where = where_text(where, self.target.name)
        return exc

    @staticmethod
    def _seconds() -> float:
        from .core import check_seconds
        return check_seconds()

    def _over_budget(self) -> bool:
        """Has the student's process used up the check's time (or the request's, outside a check)?"""
        if BUDGET.seconds is not None:
            key, seconds, wall0 = ("check", BUDGET.epoch, self.gen), BUDGET.seconds, BUDGET.wall0
        else:
            key, seconds, wall0 = ("call", self.calls, self.gen), self._seconds(), None
        if self.mark is None or self.mark[0] != key:
            self.mark = (key, cpu_seconds(self.proc.pid), wall0 or time.monotonic(), waited_for_cpu(self.proc.pid))
        used = cpu_seconds(self.proc.pid) - self.mark[1]
        waited = time.monotonic() - self.mark[2] - (waited_for_cpu(self.proc.pid) - self.mark[3])
        return used > seconds or waited > 10 * seconds

    def _ended(self):
        code = self.proc.wait() if self.proc is not None else None
        kill_group(self.proc)
        raise StudentProcessEnded(ended_text(code, self.sandbox, self._stderr_tail()))

    def _stderr_tail(self) -> str:
        if self.stderr is None:
            return ""
        self.stderr.seek(0, os.SEEK_END)
        self.stderr.seek(max(0, self.stderr.tell() - 400))
        lines = [ln for ln in self.stderr.read().decode("utf-8", "replace").splitlines() if ln.strip()]
        return lines[-1][:200] if lines else ""

    def _handles(self) -> dict:
        gen = self.gen

        def handle(tag):
            ident, type_name = _pair(tag)
            return RemoteObject(self, gen, ident, type_name[:60])

        def method(tag):
            ident, name = _pair(tag)
            return RemoteMethod(self, gen, ident, name[:100])

        def mine(tag):
            value = tag.get("v")
            ident, name = (value, "") if tag["$"] == "g" else _pair(tag)
            if not (type(ident) is int and 0 <= ident < len(self.exports)):
                raise WireError(f"no object {ident!r} was handed to the student's code")
            obj = self.exports[ident]
            return getattr(obj, name) if name and not name.startswith("_") else obj
        return {"h": handle, "m": method, "g": mine, "gm": mine}

    def _serve(self, message) -> None:
        """A call-back of the student's code on an object the checks handed it."""
        op, ident, name = message.get("op"), message.get("id"), message.get("name", "")
        args, kwargs = message.get("args", []), message.get("kw", {})
        try:
            if not (type(ident) is int and 0 <= ident < len(self.exports)) or not isinstance(name, str):
                raise LookupError("no such object was handed to your code")
            if op in ("getattr", "setattr", "callattr") and (name.startswith("_") or not name):
                raise AttributeError(f"{name!r}: names starting with _ are not handed to your code")
            if op == "op" and name not in labwire.OPS or not isinstance(args, list) or not isinstance(kwargs, dict):
                raise LookupError(f"no request {op!r} {name!r}")
            value = labwire.apply(self.exports[ident], op, name, args, kwargs)
            if op == "getattr" and callable(value):
                value = _MethodRef(ident, name)
            reply = ("ok", self._pickle(value))
        except Exception as exc:          # the checks' object refused: the student's code gets the error
            reply = ("err", {"type": type(exc).__name__, "msg": str(exc)[:500]})
        self._send(reply)

    def _error(self, record: dict) -> Exception:
        if record.get("type") == "Interrupted":
            return self._timeout(record.get("where", []))
        exc = rebuild(record, self.target.name)
        exc._from_student = True
        return exc


def _pair(tag):
    value = tag.get("v")
    if not (isinstance(value, list) and len(value) == 2 and type(value[0]) is int and isinstance(value[1], str)):
        raise WireError(f"a {tag['$']!r} tag that is not [number, name]")
    return value


class _GraderPickler(pickle.Pickler):
    def __init__(self, buffer, session: Session, force=None):
        super().__init__(buffer, protocol=pickle.HIGHEST_PROTOCOL)
        self.session, self.force = session, force

    def persistent_id(self, obj):
        if isinstance(obj, RemoteObject):
            if not isinstance(obj, ModuleProxy) and (obj._session is not self.session or obj._gen != self.session.gen):
                raise StudentProcessEnded("an object your code gave back earlier is gone: your program was started afresh")
            if isinstance(obj, RemoteMethod):
                return ("m", obj._id, obj._type)
            return ("h", 0 if isinstance(obj, ModuleProxy) else obj._id, "")
        if isinstance(obj, _MethodRef):
            return ("gm", obj.ident, obj.name)
        if isinstance(obj, types.ModuleType):
            raise pickle.PicklingError("a module is not handed to student code")
        if (self.force is not None and obj is self.force) or needs_handle(obj):
            return ("g", self.session.export(obj), "")
        return None


#: the students' processes open in this process (closed by :func:`close_all`, and at exit)
OPEN: list[Session] = []


def close_all() -> None:
    """End every student's process this process started."""
    while OPEN:
        OPEN.pop().close()


atexit.register(close_all)


def open_target(target: Path, lab_path: Path, sandbox: Sandbox) -> ModuleProxy:
    """Start the student's file in its sandbox; the proxy of its module (raises when it does not import)."""
    session = Session(target, lab_path, sandbox)
    session.start()
    return ModuleProxy(session, 0, 0, "module")
