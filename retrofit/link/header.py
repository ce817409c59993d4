"""The firmware's opcode header (firmware/opcodes.h), generated from the link's one table (codec.OPCODES).

    python3 -m retrofit.link.header          # write firmware/opcodes.h
    python3 -m retrofit.link.header --check  # exit 1 when the file differs from the table
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .codec import OPCODES, PROB_AWAY

HEADER = Path(__file__).resolve().parents[2] / "firmware" / "opcodes.h"


def render() -> str:
    """The text of firmware/opcodes.h: one ``#define OP_<MNEMONIC>`` per command, as the host codes it."""
    lines = ["/* opcodes.h - the command set's opcodes (docs/protocol.md §7). Generated from",
             " * retrofit/link/codec.py's OPCODES by `python3 -m retrofit.link.header`: do not edit. */",
             "#ifndef OPCODES_H", "#define OPCODES_H", ""]
    lines += [f"#define OP_{cls.mnemonic:<4}  0x{op:02X}" for cls, op in sorted(OPCODES.items(), key=lambda i: i[1])]
    lines += ["", f"#define PROB_UNTIL_OPEN 0x{PROB_AWAY:02X}       /* PROB's flags: move until the probe input "
              "opens (G38.4/5) */", "", "#endif", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 when it differs")
    args = ap.parse_args(argv)
    text = render()
    if args.check:
        same = HEADER.is_file() and HEADER.read_text() == text
        if not same:
            print(f"{HEADER}: differs from retrofit/link/codec.py's OPCODES; run python3 -m retrofit.link.header",
                  file=sys.stderr)
        return 0 if same else 1
    HEADER.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
