"""The student's side of a sandboxed lab check: set up the sandbox, import the student's file, and
answer the checks' requests over two pipes (run as ``python -m retrofit.lab.sandbox``).

The settings come as JSON in ``RETROFIT_SANDBOX``: the student's file, data files to copy, the
folders to hide, the uid to run as and the limits. As root, before any student code runs, the
process takes a mount namespace of its own (when the kernel lets it): the hidden folders (the
labs, the submissions, the grades) and ``/tmp``, ``/var/tmp``, ``/dev/shm`` get empty, small
tmpfs mounts; a folder on the way to Python that others may not enter (``/root`` for a pyenv)
becomes an empty tmpfs with only Python's own folder put back. Then the limits are set, the
supplementary groups dropped and the uid and gid changed; only then is the student's file read.
"""

from __future__ import annotations

import ctypes
import json
import os
import pickle
import resource
import signal
import stat
import sys
import tempfile
from pathlib import Path

from . import wire as labwire

CLONE_NEWNS, CLONE_NEWNET = 0x00020000, 0x40000000
MS_BIND, MS_REC, MS_PRIVATE, MS_MOVE = 0x1000, 0x4000, 0x40000, 0x2000
SETUP_FAILED = 70                   # the exit code of a sandbox that could not be set up
_TABLE: dict[int, object] = {}
_STATE = {"sending": False, "path": ""}


class Interrupted(BaseException):
    """The grader's time for this check ran out (raised where the student's code was running)."""


def _libc():
    return ctypes.CDLL(None, use_errno=True)


def _mount(libc, source, target, fstype, flags, data=None) -> None:
    enc = (lambda s: None if s is None else str(s).encode())
    if libc.mount(enc(source), enc(str(target)), enc(fstype), flags, enc(data)) != 0:
        raise OSError(ctypes.get_errno(), f"mount {fstype or source} on {target}")


def _blocked(path: Path):
    """The first folder on the way to ``path`` that others may not enter, or None."""
    for folder in [*reversed(path.parents), path][1:]:
        try:
            if not os.stat(folder).st_mode & stat.S_IXOTH:
                return folder
        except OSError:
            return None
    return None


def _isolate(config: dict) -> str:
    """Hide what the student may not see; say what was done ("" when the kernel refused)."""
    libc = _libc()
    unshare = getattr(libc, "unshare", None)        # Linux only
    if unshare is None or unshare(CLONE_NEWNS | CLONE_NEWNET) != 0 and unshare(CLONE_NEWNS) != 0:
        return ""
    _mount(libc, "none", "/", None, MS_REC | MS_PRIVATE)
    stage = Path(tempfile.mkdtemp(prefix="retrofit-stage-"))
    for need in config.get("reach", []):
        for _ in range(8):                      # each pass opens one closed folder on the way
            blocked = _blocked(Path(need))
            if blocked is None:
                break
            inner = Path(need).relative_to(blocked).parts[0]
            keep = stage / str(len(os.listdir(stage)))
            keep.mkdir()
            _mount(libc, blocked / inner, keep, None, MS_BIND | MS_REC)
            _mount(libc, "tmpfs", blocked, "tmpfs", 0, "size=64k,mode=0755")
            (blocked / inner).mkdir()
            _mount(libc, keep, blocked / inner, None, MS_MOVE)
    for hide in config.get("hide", []):
        if os.path.isdir(hide):
            _mount(libc, "tmpfs", hide, "tmpfs", 0, "size=64k,mode=0755")
    size = int(config.get("tmp_mb", 64))
    for tmp in ("/tmp", "/var/tmp", "/dev/shm"):
        if not os.path.isdir(tmp):
            continue
        # a fresh tmpfs, with the folders Python needs that live under it (a checkout in /tmp)
        # bound back in, then moved over the old one
        fresh = Path(tempfile.mkdtemp(prefix="retrofit-tmpfs-"))     # in whichever /tmp is seen now
        _mount(libc, "tmpfs", fresh, "tmpfs", 0, f"size={size}m,mode=1777")
        for need in map(Path, config.get("reach", [])):
            if need != Path(tmp) and need.is_relative_to(tmp) and need.is_dir():
                inside = fresh / need.relative_to(tmp)
                inside.mkdir(parents=True, exist_ok=True)
                _mount(libc, need, inside, None, MS_BIND | MS_REC)
        _mount(libc, fresh, tmp, None, MS_MOVE)
    return "namespace"


def _limits(config: dict) -> None:
    for name, value in config.get("rlimits", {}).items():
        value = int(value)
        resource.setrlimit(getattr(resource, name), (value, value))


def _drop(uid: int, gid: int) -> None:
    os.setgroups([])
    os.setgid(gid)
    os.setuid(uid)
    if os.getuid() != uid or os.geteuid() != uid:
        raise SystemExit("the sandbox could not change its user")
    try:
        os.setuid(0)
    except PermissionError:
        return
    raise SystemExit("the sandbox could take root back; refusing to run student code")


def setup(config: dict) -> Path:
    """Everything before the student's code: files read, sandbox made, privileges dropped."""
    files = {name: Path(source).read_bytes() for name, source in config["files"]}
    root = os.geteuid() == 0
    isolated = _isolate(config) if root and config.get("isolate") else ""
    scratch = Path(config["scratch"])
    scratch.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        path = scratch / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    uid = config.get("uid")
    if root and uid is not None:
        for folder, _, names in os.walk(scratch):
            for item in [folder, *(os.path.join(folder, n) for n in names)]:
                os.chown(item, uid, config["gid"])
        os.chmod(scratch, 0o700)
    os.chdir(scratch)
    _limits(config)
    if root and uid is not None:
        _drop(uid, config["gid"])
        library = os.path.dirname(os.__file__)
        if not os.access(library, os.R_OK | os.X_OK):
            raise SystemExit(f"Python's library {library} cannot be read by the sandbox's uid {uid}; give the "
                             "grader CAP_SYS_ADMIN (a mount namespace), or use a Python every user may read")
    os.environ["RETROFIT_SANDBOX"] = isolated or "plain"
    return scratch / config["files"][0][0]


# ---- the serving loop (student side) ---------------------------------------------------------


class GraderObject(labwire.Proxy):
    """An object the checks handed to the student's code: it stays in the grader's process."""

    __slots__ = ("_id", "_name")

    def __init__(self, ident: int, name: str = ""):
        object.__setattr__(self, "_id", ident)
        object.__setattr__(self, "_name", name)

    def _request(self, op, name, args, kwargs=None):
        if op == "call" and self._name:
            op, name = "callattr", self._name
        return _ask({"k": "req", "op": op, "id": self._id, "name": name,
                     "args": [_enc(a) for a in args], "kw": {k: _enc(v) for k, v in (kwargs or {}).items()}})


class _Unpickler(pickle.Unpickler):
    def persistent_load(self, pid):
        kind, ident, name = pid
        if kind == "h":
            return _TABLE[ident]
        if kind == "m":
            return getattr(_TABLE[ident], name)
        return GraderObject(ident, name if kind == "gm" else "")


def _load(data: bytes):
    import io
    return _Unpickler(io.BytesIO(data)).load()


def _handle(obj):
    if isinstance(obj, GraderObject):
        return {"$": "g", "v": obj._id} if not obj._name else {"$": "gm", "v": [obj._id, obj._name]}
    ident = len(_TABLE)
    _TABLE[ident] = obj
    return {"$": "h", "v": [ident, type(obj).__name__[:60]]}


def _enc(value):
    return labwire.encode(value, _handle)


def _send(message: dict) -> None:
    _STATE["sending"] = True
    try:
        labwire.write_all(_STATE["out"], labwire.frame(b"J", labwire.dumps(message)))
    finally:
        _STATE["sending"] = False


def _receive():
    reader = _STATE["reader"]
    while True:
        got = reader.next()
        if got is not None:
            return pickle.loads(got[1])
        data = os.read(_STATE["in"], 1 << 16)
        if not data:
            os._exit(0)                      # the grader has gone: nothing more to answer
        reader.feed(data)


def _ask(message: dict):
    """Ask the grader for something (a call on an object it handed over); serve its requests meanwhile."""
    _send(message)
    while True:
        reply = _receive()
        if reply[0] == "req":
            _serve(reply)
        elif reply[0] == "ok":
            return _load(reply[1])
        else:
            raise _rebuild(reply[1])


def _rebuild(record: dict) -> BaseException:
    import builtins
    cls = getattr(builtins, record.get("type", ""), None)
    if not (isinstance(cls, type) and issubclass(cls, Exception)):
        cls = RuntimeError
    return cls(record.get("msg", ""))


def _serve(request) -> None:
    """Carry out one request of the grader's and send the answer."""
    _, op, ident, name, args, kwargs = request
    try:
        target = _TABLE[ident]
        value = labwire.apply(target, op, name, [_load(a) for a in args], {k: _load(v) for k, v in kwargs.items()})
        if op == "getattr" and callable(value) and not isinstance(value, GraderObject):
            reply = {"k": "ok", "v": {"$": "m", "v": [ident, name]}}
        else:
            reply = {"k": "ok", "v": _enc(value)}
    except Interrupted:
        reply = {"k": "err", "e": {"type": "Interrupted", "msg": "", "where": _where_now()}}
    except BaseException as exc:          # noqa: B036 (SystemExit too: the student's code ends, we answer)
        reply = {"k": "err", "e": labwire.error_record(exc, _STATE["path"])}
    _send(reply)


def _where_now():
    return _STATE.pop("interrupted_at", [])


def _on_interrupt(signum, frame):
    if _STATE["sending"]:
        return
    where, f = [], frame
    while f is not None:
        if f.f_code.co_filename == _STATE["path"]:
            where.append([f.f_lineno, f.f_code.co_name])
        f = f.f_back
    _STATE["interrupted_at"] = list(reversed(where))[-3:]
    raise Interrupted()


def serve(path: Path, fd_in: int, fd_out: int) -> None:
    """Import the student's file as module 0, then answer requests until the grader closes the pipe."""
    import importlib.util
    _STATE.update({"in": fd_in, "out": fd_out, "reader": labwire.Reader(), "path": str(path)})
    signal.signal(signal.SIGUSR1, _on_interrupt)
    try:
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[path.stem] = module
        spec.loader.exec_module(module)
        _TABLE[0] = module
        _send({"k": "ok", "v": {"$": "h", "v": [0, "module"]}})
    except Interrupted:
        _send({"k": "err", "e": {"type": "Interrupted", "msg": "", "where": _where_now()}})
    except BaseException as exc:         # noqa: B036 (a SystemExit at import is a failed import too)
        _send({"k": "err", "e": labwire.error_record(exc, str(path))})
    while True:
        _serve(_receive())


def main() -> None:
    config = json.loads(os.environ.pop("RETROFIT_SANDBOX"))
    fd_in, fd_out = config["fds"]
    try:
        path = setup(config)
    except BaseException as exc:          # noqa: B036 (nothing of the student's has run yet)
        sys.stderr.write(f"the sandbox could not be set up: {type(exc).__name__}: {exc}\n")
        sys.stderr.flush()
        os._exit(SETUP_FAILED)
    for fd in (fd_in, fd_out):
        os.set_inheritable(fd, False)
    serve(path, fd_in, fd_out)


if __name__ == "__main__":
    main()
