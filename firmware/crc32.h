/* crc32.h - CRC-32/ISO-HDLC of the serial link (docs/protocol.md §2.2).
 *
 * Reflected polynomial 0xEDB88320, initial 0xFFFFFFFF, final XOR 0xFFFFFFFF; the CRC of
 * "123456789" is 0xCBF43926. Four bits at a time through a 16-entry table (64 bytes of flash):
 * two lookups per byte instead of eight shifts of a 32-bit value. Entry i is the CRC register
 * after shifting the nibble i through the bitwise algorithm four times. */
#ifndef CRC32_H
#define CRC32_H

#include <stdint.h>
#include <avr/pgmspace.h>

#define CRC32_INIT 0xFFFFFFFFUL

static const uint32_t crc32_nibble[16] PROGMEM = {
    0x00000000UL, 0x1DB71064UL, 0x3B6E20C8UL, 0x26D930ACUL,
    0x76DC4190UL, 0x6B6B51F4UL, 0x4DB26158UL, 0x5005713CUL,
    0xEDB88320UL, 0xF00F9344UL, 0xD6D6A3E8UL, 0xCB61B38CUL,
    0x9B64C2B0UL, 0x86D3D2D4UL, 0xA00AE278UL, 0xBDBDF21CUL,
};

/* Add one byte to a running CRC (start from CRC32_INIT; finish with crc32_final). */
static inline uint32_t crc32_update(uint32_t crc, uint8_t byte)
{
    crc ^= byte;
    crc = (crc >> 4) ^ pgm_read_dword(&crc32_nibble[crc & 0x0F]);
    crc = (crc >> 4) ^ pgm_read_dword(&crc32_nibble[crc & 0x0F]);
    return crc;
}

static inline uint32_t crc32_final(uint32_t crc)
{
    return ~crc;
}

#endif
