"""The wire between a lab's checks and the student's code in its sandbox: framed messages, and the
small tagged JSON that carries values back from the student's process (never unpickled).

What may come back from the student's code (``decode`` builds nothing else):

- ``None``, ``bool``, ``int``, ``float`` (nan and ±inf too), ``complex``, ``str``, ``bytes``,
  ``bytearray``, ``tuple``, ``list``, ``dict``, ``set``, ``frozenset``;
- NumPy arrays and scalars of bool, integer, unsigned, float or complex dtype;
- instances of retrofit's own dataclasses and enums (rebuilt with their constructor, so their
  checks run), e.g. ``Machine``, ``PMov``;
- anything else stays in the student's process and comes back as a *handle* the grader calls
  through (see :mod:`retrofit.lab.proxy`).

Frames are a 4-byte big-endian length, one byte kind (``J`` JSON, ``P`` pickle) and the body.
The grader sends pickles (the student's process trusts the grader), the student's process JSON.
"""

from __future__ import annotations

import base64
import dataclasses
import enum
import importlib
import json
import math
import os
import re
import struct
import sys

MAX_MESSAGE = 64 << 20            # bytes one message may hold; a bigger one is an error, not a memory blow-up
_HEADER = struct.Struct(">IB")
_DTYPE = re.compile(r"^[<>|=][biufc]\d{1,2}$")
_MODULE = re.compile(r"^retrofit(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_QUALNAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


#: keys of the plain (untagged) JSON objects a message is made of: the message and an error's record
_PLAIN = {"k", "v", "e", "op", "id", "name", "args", "kw", "type", "msg", "where", "line", "text"}


class WireError(Exception):
    """A message from the student's process that is not what the protocol allows."""


def frame(kind: bytes, body: bytes) -> bytes:
    """One message as it goes on the pipe."""
    return _HEADER.pack(len(body), kind[0]) + body


def write_all(fd: int, data: bytes) -> None:
    """Write every byte (the pipe may take them in pieces)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


class Reader:
    """Collects bytes from a pipe and hands out whole frames; refuses frames over MAX_MESSAGE."""

    def __init__(self):
        self.buffer = bytearray()

    def feed(self, data: bytes) -> None:
        self.buffer += data

    def next(self):
        """(kind, body) of the first whole frame, or None until one has arrived."""
        if len(self.buffer) < _HEADER.size:
            return None
        size, kind = _HEADER.unpack_from(self.buffer)
        if size > MAX_MESSAGE:
            raise WireError(f"a message of {size} bytes (at most {MAX_MESSAGE} are accepted)")
        if len(self.buffer) < _HEADER.size + size:
            return None
        body = bytes(self.buffer[_HEADER.size:_HEADER.size + size])
        del self.buffer[:_HEADER.size + size]
        return chr(kind), body


def _is_retrofit_type(cls) -> bool:
    return _MODULE.match(getattr(cls, "__module__", "") or "") is not None


def encode(value, handle):
    """``value`` as tagged JSON data; ``handle(obj)`` gives the tag of an object that stays behind."""
    np = sys.modules.get("numpy")           # no NumPy value can exist before NumPy is imported
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int) and type(value) is int:
        return value
    if type(value) is float:
        return value if math.isfinite(value) else {"$": "fl", "v": repr(value)}
    if type(value) is complex:
        return {"$": "c", "v": [encode(value.real, handle), encode(value.imag, handle)]}
    if type(value) in (bytes, bytearray):
        return {"$": "by" if type(value) is bytes else "ba", "v": base64.b64encode(value).decode("ascii")}
    if type(value) in (list, tuple, set, frozenset):
        items = [encode(v, handle) for v in value]
        return items if type(value) is list else {"$": {tuple: "t", set: "s", frozenset: "fs"}[type(value)], "v": items}
    if type(value) is dict:
        return {"$": "d", "v": [[encode(k, handle), encode(v, handle)] for k, v in value.items()]}
    if np is not None and type(value) is np.ndarray and _DTYPE.match(value.dtype.str):
        return {"$": "nd", "dt": value.dtype.str, "sh": list(value.shape),
                "v": base64.b64encode(np.ascontiguousarray(value).tobytes()).decode("ascii")}
    if np is not None and isinstance(value, np.generic) and _DTYPE.match(value.dtype.str):
        return {"$": "ns", "dt": value.dtype.str, "v": base64.b64encode(value.tobytes()).decode("ascii")}
    cls = type(value)
    if _is_retrofit_type(cls) and isinstance(value, enum.Enum):
        return {"$": "en", "cls": f"{cls.__module__}:{cls.__qualname__}", "v": value.name}
    if _is_retrofit_type(cls) and dataclasses.is_dataclass(value):
        fields = [[f.name, encode(getattr(value, f.name), handle)] for f in dataclasses.fields(value) if f.init]
        return {"$": "dc", "cls": f"{cls.__module__}:{cls.__qualname__}", "v": fields}
    return handle(value)


def _retrofit_class(name):
    module, _, qualname = name.partition(":") if isinstance(name, str) else ("", "", "")
    if not (_MODULE.match(module) and _QUALNAME.match(qualname)):
        raise WireError(f"{name!r} is not a retrofit class")
    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part, None)
    if not isinstance(obj, type) or not _is_retrofit_type(obj):
        raise WireError(f"{name!r} is not a retrofit class")
    return obj


def _items(tag):
    if not isinstance(tag.get("v"), list):
        raise WireError(f"a {tag['$']!r} without its items")
    return tag["v"]


def _binary(tag) -> bytes:
    try:
        return base64.b64decode(tag["v"], validate=True)
    except (KeyError, TypeError, ValueError):
        raise WireError("bytes that are not base64") from None


def _array(tag):
    import numpy as np
    dtype, shape = tag.get("dt"), tag.get("sh", ())
    if not (isinstance(dtype, str) and _DTYPE.match(dtype)):
        raise WireError(f"a NumPy dtype {dtype!r}: only bool, integer, float and complex cross")
    dt = np.dtype(dtype)
    data = _binary(tag)
    if tag["$"] == "ns":
        if len(data) != dt.itemsize:
            raise WireError("a NumPy scalar of the wrong size")
        return np.frombuffer(data, dt)[0]
    if not (isinstance(shape, list) and all(type(n) is int and n >= 0 for n in shape)):
        raise WireError(f"a NumPy shape {shape!r}")
    if math.prod(shape) * dt.itemsize != len(data):
        raise WireError("a NumPy array whose data does not fit its shape")
    return np.frombuffer(data, dt).reshape(shape).copy()


def _build(tag, handles):
    """One tagged value (its parts already decoded) back into a Python value."""
    kind = tag.get("$")
    if kind == "fl":
        if tag.get("v") not in ("nan", "inf", "-inf"):
            raise WireError(f"a float {tag.get('v')!r}")
        return float(tag["v"])
    if kind == "c":
        re_im = _items(tag)
        if len(re_im) != 2 or not all(type(x) in (int, float) for x in re_im):
            raise WireError("a complex number that is not two numbers")
        return complex(*re_im)
    if kind in ("by", "ba"):
        return _binary(tag) if kind == "by" else bytearray(_binary(tag))
    if kind in ("t", "s", "fs"):
        return {"t": tuple, "s": set, "fs": frozenset}[kind](_items(tag))
    if kind == "d":
        pairs = _items(tag)
        if not all(isinstance(p, list) and len(p) == 2 for p in pairs):
            raise WireError("a dict whose items are not pairs")
        return {k: v for k, v in pairs}
    if kind in ("nd", "ns"):
        return _array(tag)
    if kind == "en":
        cls = _retrofit_class(tag.get("cls"))
        if not issubclass(cls, enum.Enum) or tag.get("v") not in cls.__members__:
            raise WireError(f"{tag.get('v')!r} is not a member of {tag.get('cls')}")
        return cls[tag["v"]]
    if kind == "dc":
        cls = _retrofit_class(tag.get("cls"))
        pairs = _items(tag)
        names = {f.name for f in dataclasses.fields(cls) if f.init} if dataclasses.is_dataclass(cls) else set()
        if not names or not all(isinstance(p, list) and len(p) == 2 and p[0] in names for p in pairs):
            raise WireError(f"{tag.get('cls')} with other fields than its own")
        return cls(**dict(pairs))
    if kind in handles:
        return handles[kind](tag)
    raise WireError(f"a value tagged {kind!r}")


def decode(body: bytes, handles: dict):
    """The value a message from the student's process carries; ``handles`` builds the handle tags."""
    def hook(obj):
        if "$" not in obj:
            return obj if set(obj) <= _PLAIN else _bad(obj)
        try:
            return _build(obj, handles)
        except WireError:
            raise
        except Exception as exc:          # a retrofit class refusing its fields, a bad dtype ...
            raise WireError(f"a {obj.get('$')!r} value that does not build: {type(exc).__name__}: {exc}") from None
    try:
        return json.loads(body.decode("utf-8"), object_hook=hook)
    except WireError:
        raise
    except (ValueError, RecursionError, UnicodeDecodeError, TypeError) as exc:
        raise WireError(f"not a message: {type(exc).__name__}: {str(exc)[:200]}") from None


def _bad(obj):
    raise WireError(f"an object with keys {sorted(obj)[:5]}")


def dumps(message) -> bytes:
    """A JSON message (the student's side)."""
    return json.dumps(message, separators=(",", ":"), allow_nan=False).encode("utf-8")


#: what a proxy may ask of the object behind it besides attributes and calls (``op`` requests)
OPS = {"repr": repr, "str": str, "len": len, "bool": bool, "hash": hash, "float": float, "int": int,
       "index": lambda a: a.__index__(), "iter": list, "getitem": lambda a, k: a[k],
       "contains": lambda a, k: k in a, "eq": lambda a, b: a == b, "ne": lambda a, b: a != b,
       "lt": lambda a, b: a < b, "le": lambda a, b: a <= b, "gt": lambda a, b: a > b, "ge": lambda a, b: a >= b,
       "neg": lambda a: -a, "abs": abs, "add": lambda a, b: a + b, "sub": lambda a, b: a - b,
       "mul": lambda a, b: a * b, "truediv": lambda a, b: a / b, "array": lambda a: __import__("numpy").asarray(a)}


def apply(obj, op: str, name: str, args: list, kwargs: dict):
    """Carry out one request on ``obj``: getattr / setattr / callattr / call / op."""
    if op == "getattr":
        return getattr(obj, name)
    if op == "setattr":
        setattr(obj, name, args[0])
        return None
    if op == "callattr":
        return getattr(obj, name)(*args, **kwargs)
    if op == "call":
        return obj(*args, **kwargs)
    if op == "op" and name in OPS:
        return OPS[name](obj, *args)
    raise WireError(f"no request {op!r} {name!r}")


def _op(name, arity=0):
    if arity:
        return lambda self, other: self._request("op", name, [other])
    return lambda self: self._request("op", name, [])


class Proxy:
    """An object that lives in the other process: attributes, calls and operators are requests.

    Subclasses give ``_request(op, name, args, kwargs=None)``. Names starting with ``_`` are not
    forwarded, so a proxy never reaches the other side's internals.
    """

    __slots__ = ()

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return self._request("getattr", name, [])

    def __setattr__(self, name, value):
        if name.startswith("_"):
            object.__setattr__(self, name, value)
        else:
            self._request("setattr", name, [value])

    def __call__(self, *args, **kwargs):
        return self._request("call", "", list(args), kwargs)

    def __iter__(self):
        return iter(self._request("op", "iter", []))

    def __array__(self, dtype=None, copy=None):
        import numpy as np
        value = self._request("op", "array", [])
        if isinstance(value, Proxy):
            raise TypeError("the value is not an array of numbers (bool, integer, float or complex)")
        array = np.asarray(value)
        return array.astype(dtype) if dtype is not None else array

    __repr__, __str__, __len__, __bool__, __hash__ = _op("repr"), _op("str"), _op("len"), _op("bool"), _op("hash")
    __float__, __int__, __index__, __neg__, __abs__ = _op("float"), _op("int"), _op("index"), _op("neg"), _op("abs")
    __getitem__, __contains__ = _op("getitem", 1), _op("contains", 1)
    __eq__, __ne__, __lt__, __le__, __gt__, __ge__ = (_op(n, 1) for n in ("eq", "ne", "lt", "le", "gt", "ge"))
    __add__, __sub__, __mul__, __truediv__ = (_op(n, 1) for n in ("add", "sub", "mul", "truediv"))


def error_record(exc: BaseException, path: str) -> dict:
    """What the grader needs to know of an exception raised by the student's code."""
    import traceback
    record = {"type": type(exc).__name__, "msg": _text(exc)[:2000], "where": []}
    if isinstance(exc, SyntaxError) and exc.filename == path:
        record["line"], record["text"] = exc.lineno or 0, str(exc.msg)[:500]
    try:
        frames = traceback.extract_tb(exc.__traceback__)
    except Exception:
        frames = []
    record["where"] = [[f.lineno or 0, str(f.name)[:100]] for f in frames if f.filename == path][-3:]
    return record


def _text(exc) -> str:
    try:
        return str(exc)
    except Exception:
        return ""


# ---- errors that cross ---------------------------------------------------------------------


class CheckTimeout(Exception):
    """A check ran longer than its time limit."""


class StudentProcessEnded(Exception):
    """The student's process ended (or was killed) while a check was using it."""


class StudentError(Exception):
    """An exception of the student's code of a type the grader does not rebuild (named like it)."""


def where_text(where, name: str) -> str:
    frames = [w for w in where if isinstance(w, list) and len(w) == 2 and type(w[0]) is int and isinstance(w[1], str)]
    if not frames:
        return ""
    line, function = frames[-1]
    return f"{name} line {line}, in {function[:100]}"


def rebuild(record: dict, name: str) -> Exception:
    """The student's exception, rebuilt from its record (a builtin type, or one named like it)."""
    import builtins
    type_name, text = str(record.get("type", ""))[:60], str(record.get("msg", ""))[:2000]
    cls = getattr(builtins, type_name, None)
    if type_name == "SyntaxError" and type(record.get("line")) is int:
        exc = SyntaxError(str(record.get("text", ""))[:500], (name, record["line"], 0, ""))
    elif isinstance(cls, type) and issubclass(cls, Exception) and not issubclass(cls, (Warning,)):
        exc = cls.__new__(cls)
        Exception.__init__(exc, text)
    else:
        safe = type_name if type_name.isidentifier() else "StudentError"
        exc = type(safe, (StudentError,), {})(text)
    exc.student_where = where_text(record.get("where", []), name)
    return exc


def again(exc: Exception) -> Exception:
    """A fresh copy of a failure that every later check meets too (the file did not import)."""
    copy = exc.__class__.__new__(exc.__class__)
    copy.args = exc.args
    copy.__dict__.update(exc.__dict__)
    return copy
