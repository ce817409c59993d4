"""The HTML report's binary store: arrays and texts gzip-packed into one block of the page, almost
byte for byte (no base64), which the page's ``RV.unpack`` (``static/unpack.js``) turns back into
typed arrays.

The page is written in windows-1252, the one HTML encoding that gives each of the 256 byte values
a character, so packed bytes stand in the page as themselves. Five of them cannot: NUL and CR
(the HTML parser changes them), ``<`` (it could close the script element) and ``=`` (the escape
itself) are written as ``=`` followed by the byte plus 64 -- about 1.6 % more bytes, where base64
adds 33 %. Everything else on the page is ASCII (other characters as character references).

Numbers are quantised where the page shows no more: positions to the step (integers, stored as
differences from the value before), so runs of equal moves pack to almost nothing.
"""

from __future__ import annotations

import gzip

import numpy as np

#: bytes written as "=" and the byte plus 64
ESCAPED = (0x00, 0x0D, 0x3C, 0x3D)


def escaped(data: bytes) -> bytes:
    """``data`` with the bytes of :data:`ESCAPED` written as ``=`` and the byte plus 64."""
    out = data.replace(b"=", b"=}")
    for b in (0x00, 0x0D, 0x3C):
        out = out.replace(bytes([b]), bytes([0x3D, b + 64]))
    return out


def unescaped(text: bytes) -> bytes:
    """The bytes :func:`escaped` was given (the page's ``RV.bytes`` does the same)."""
    out, i = bytearray(), 0
    while i < len(text):
        if text[i] == 0x3D:
            out.append(text[i + 1] - 64)
            i += 2
        else:
            out.append(text[i])
            i += 1
    return bytes(out)


def planes(values, dtype) -> bytes:
    """Little-endian ``dtype`` numbers with their bytes grouped by place (every first byte, then
    every second ...: the high bytes of small numbers are runs of zeros that gzip packs away)."""
    dtype = np.dtype(dtype).newbyteorder("<")
    raw = np.frombuffer(np.ascontiguousarray(values, dtype=dtype).tobytes(), np.uint8)
    return raw.reshape(-1, dtype.itemsize).T.tobytes()


class Store:
    """The packed blocks of one report; each ``add`` gives the reference the page unpacks by."""

    def __init__(self) -> None:
        self.blocks: list[bytes] = []
        self.size = 0

    def _put(self, raw: bytes, ref: dict) -> dict:
        data = gzip.compress(raw, 9, mtime=0)
        ref.update(at=self.size, len=len(data))
        self.blocks.append(data)
        self.size += len(data)
        return ref

    def drop(self, count: int) -> None:
        """Forget every block after the first ``count`` (their references are no longer valid)."""
        del self.blocks[count:]
        self.size = sum(len(b) for b in self.blocks)

    def array(self, values, dtype) -> dict:
        """``values`` as ``dtype`` (u8, u32, f32 ...)."""
        dtype = np.dtype(dtype)
        return self._put(planes(values, dtype), {"type": dtype.kind + str(dtype.itemsize)})

    def steps(self, mm, per_mm) -> dict:
        """Millimetres quantised to the step: rows of ``mm`` (one column per axis, ``per_mm`` steps
        per mm each) as integer steps, each column stored as differences (zigzag); the page gives
        back millimetres (Float64Array, row after row)."""
        scale = np.asarray(per_mm, np.float64).ravel()
        mm = np.asarray(mm, np.float64).reshape(-1, len(scale))
        steps = np.round(mm * scale).astype(np.int64)
        diff = np.diff(steps, axis=0, prepend=np.zeros((1, steps.shape[1]), np.int64))
        zig = (diff << 1) ^ (diff >> 63)
        if zig.size and zig.max() >= 2 ** 32:
            raise ValueError(f"a position of {np.abs(mm).max():.3f} mm is beyond what the report packs")
        return self._put(planes(zig.T.ravel(), np.uint32),
                         {"type": "steps", "cols": int(steps.shape[1]), "per_mm": [float(s) for s in scale]})

    def text(self, text: str) -> dict:
        """A text (UTF-8)."""
        return self._put(text.encode("utf-8"), {"type": "text"})

    def page_text(self) -> str:
        """The store as the page holds it: one string whose characters are the escaped bytes."""
        return escaped(b"".join(self.blocks)).decode("latin-1")


def ascii_page(text: str) -> str:
    """HTML text with every non-ASCII character as a character reference."""
    return text.encode("ascii", "xmlcharrefreplace").decode("ascii")


def ascii_script(code: str) -> str:
    """JavaScript with every non-ASCII character as a ``\\u{...}`` escape (in its strings and comments)."""
    return "".join(c if ord(c) < 128 else f"\\u{{{ord(c):x}}}" for c in code)
