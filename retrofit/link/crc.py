"""CRC-32 of the serial link: CRC-32/ISO-HDLC (the CRC of zlib, Ethernet and PNG).

Polynomial 0x04C11DB7 reflected (0xEDB88320), initial 0xFFFFFFFF, final XOR 0xFFFFFFFF:

    >>> hex(crc32(b"123456789"))
    '0xcbf43926'

``crc32`` is zlib's (compiled); ``crc32_bitwise`` is the one-bit-at-a-time reference form a
firmware can copy, and ``crc16_ccitt_false`` the check of protocol version 1, kept only so the
fault bench can show side by side what 16 bits let through.
"""

from __future__ import annotations

import binascii
import zlib

POLY_REFLECTED = 0xEDB88320
#: CRC of the nine ASCII bytes ``123456789``: the catalogue's check value for this variant
CHECK = 0xCBF43926


def crc32(data: bytes) -> int:
    """CRC-32/ISO-HDLC of ``data`` (an unsigned 32-bit value)."""
    return zlib.crc32(data) & 0xFFFFFFFF


def crc32_bitwise(data: bytes) -> int:
    """The same CRC one bit at a time (the reference form; slow, used to check ``crc32``)."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ POLY_REFLECTED if crc & 1 else crc >> 1
    return crc ^ 0xFFFFFFFF


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): version 1's check, for comparison only.

    binascii's CRC-CCITT is this polynomial, unreflected, from the initial value given.
    """
    return binascii.crc_hqx(data, 0xFFFF)
