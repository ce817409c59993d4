"""The HTML report's store (retrofit.console.packing): every byte value survives the escaping the
page's parser needs, and positions come back to the step they were quantised to."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from retrofit.console.packing import ESCAPED, Store, escaped, unescaped


def test_every_byte_survives_and_the_parsers_bytes_never_stand_alone():
    data = bytes(range(256)) * 4 + bytes([0x3D, 0x3D, 0x3C, 0x0D, 0x0A, 0x00])
    out = escaped(data)
    assert unescaped(out) == data
    assert b"<" not in out and b"\r" not in out and b"\0" not in out
    assert len(out) == len(data) + sum(data.count(b) for b in ESCAPED)


def test_positions_come_back_within_half_a_step():
    store = Store()
    mm = np.array([[0.0, 1.0], [0.5, -2.0], [12.3456, 7.0001], [12.3456, 7.0001]])
    ref = store.steps(mm, [400.0, 80.0])
    raw = gzip.decompress(store.blocks[0])
    n = len(raw) // 4
    zig = np.frombuffer(raw, np.uint8).reshape(4, n).T.copy().view("<u4").ravel().astype(np.int64)
    diff = np.where(zig & 1, -((zig + 1) // 2), zig // 2).reshape(ref["cols"], -1).T
    back = np.cumsum(diff, axis=0) / np.array(ref["per_mm"])
    assert np.abs(back - mm).max() <= 0.5 / 80.0
    assert back[1, 1] == -2.0 and back[2, 0] == pytest.approx(12.345, abs=1e-9)
