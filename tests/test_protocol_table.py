"""The protocol is defined once: the host's table (retrofit/link/codec.py) generates the firmware's
opcode header, and the firmware's headers, read as C, name the same opcodes, replies and errors."""

from __future__ import annotations

import re
from pathlib import Path

from retrofit.commands import COMMANDS
from retrofit.link import codec, replies
from retrofit.link.header import HEADER, main, render

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"


def defines(path: Path) -> dict[str, int]:
    """``#define NAME value`` lines of a C header, the value read as C reads an integer literal."""
    found = {}
    for name, value in re.findall(r"^#define\s+(\w+)\s+(0[xX][0-9A-Fa-f]+|\d+)\b", path.read_text(), re.M):
        found[name] = int(value, 0)
    return found


def test_the_committed_header_is_what_the_table_generates():
    assert HEADER == FIRMWARE / "opcodes.h"
    assert HEADER.read_text() == render(), "run: python3 -m retrofit.link.header"
    assert main(["--check"]) == 0


def test_every_command_has_the_same_opcode_on_both_sides():
    c = defines(FIRMWARE / "opcodes.h")
    ops = {k: v for k, v in c.items() if k.startswith("OP_")}
    assert ops == {f"OP_{cls.mnemonic}": op for cls, op in codec.OPCODES.items()}
    assert set(codec.OPCODES) <= set(COMMANDS.values())            # (DOUT, PAUS stay on the host)
    assert len(set(ops.values())) == len(ops)                     # no two commands share an opcode
    assert c["PROB_UNTIL_OPEN"] == codec.PROB_AWAY


def test_sync_replies_and_error_codes_agree_with_the_links_header():
    link = defines(FIRMWARE / "link.h")
    assert link["OP_SYNC"] == codec.SYNC
    assert {k: link[f"ANS_{k}"] for k in ("ACK", "NAK", "BUSY", "ERR", "POS", "STAT", "SESS")} == {
        "ACK": replies.ACK, "NAK": replies.NAK, "BUSY": replies.BUSY, "ERR": replies.ERR, "POS": replies.POS,
        "STAT": replies.STAT, "SESS": replies.SESS}
    for name in ("OPCODE", "LENGTH", "VALUE", "NOT_SYNCED", "SEQUENCE", "REFUSED"):
        assert link[f"ERR_{name}"] == getattr(codec, f"ERR_{name}"), name


def test_a_changed_header_is_caught(tmp_path, monkeypatch):
    import retrofit.link.header as header
    stale = tmp_path / "opcodes.h"
    stale.write_text(render().replace("0x11", "0x12"))              # PROB moved on one side only
    monkeypatch.setattr(header, "HEADER", stale)
    assert header.main(["--check"]) == 1
    assert defines(stale)["OP_PROB"] != codec.OPCODES[next(c for c in codec.OPCODES if c.mnemonic == "PROB")]
