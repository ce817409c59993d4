"""CRC-16/CCITT-FALSE of the serial link: poly 0x1021, init 0xFFFF, no reflection, no final XOR.

    >>> hex(crc16_ccitt_false(b"123456789"))
    '0x29b1'

The table is the usual 256-entry form of the bitwise algorithm below; firmware may use either.
"""

from __future__ import annotations

POLY = 0x1021
INIT = 0xFFFF
#: CRC of the nine ASCII bytes ``123456789``: the catalogue's check value for this variant
CHECK = 0x29B1


def crc16_bitwise(data: bytes, crc: int = INIT) -> int:
    """The CRC one bit at a time (the reference form; slow, used to check the table)."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ POLY) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


_TABLE = tuple(crc16_bitwise(bytes([i]), 0) for i in range(256))


def crc16_ccitt_false(data: bytes, crc: int = INIT) -> int:
    """CRC-16/CCITT-FALSE of ``data``; pass a previous result as ``crc`` to continue a running CRC."""
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ _TABLE[(crc >> 8) ^ byte]
    return crc
