/* crc32.h - CRC-32/ISO-HDLC of the serial link (docs/protocol.md §2.2).
 *
 * Reflected polynomial 0xEDB88320, initial 0xFFFFFFFF, final XOR 0xFFFFFFFF; the CRC of
 * "123456789" is 0xCBF43926. One bit at a time: 8 shifts per byte, about 150 cycles, so a
 * 38-byte body costs some 0.4 ms at 16 MHz, well inside the 20 ms answer latency. */
#ifndef CRC32_H
#define CRC32_H

#include <stdint.h>

#define CRC32_INIT 0xFFFFFFFFUL

/* Add one byte to a running CRC (start from CRC32_INIT; finish with crc32_final). */
static inline uint32_t crc32_update(uint32_t crc, uint8_t byte)
{
    crc ^= byte;
    for (uint8_t i = 0; i < 8; i++)
        crc = (crc & 1) ? (crc >> 1) ^ 0xEDB88320UL : crc >> 1;
    return crc;
}

static inline uint32_t crc32_final(uint32_t crc)
{
    return ~crc;
}

#endif
