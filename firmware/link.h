/* link.h - the device end of the serial link of docs/protocol.md: frames, CRC, sequence numbers. */
#ifndef LINK_H
#define LINK_H

#include <stdint.h>

/* Answer opcodes (docs/protocol.md §8). */
#define ANS_ACK   0x80
#define ANS_NAK   0x81
#define ANS_BUSY  0x82
#define ANS_ERR   0x83
#define ANS_POS   0x84
#define ANS_STAT  0x85
#define ANS_SESS  0x86

/* ERR codes. */
#define ERR_OPCODE      1
#define ERR_LENGTH      2
#define ERR_VALUE       3
#define ERR_NOT_SYNCED  4
#define ERR_SEQUENCE    5
#define ERR_REFUSED     6

#define OP_SYNC  0x7F

/* Forget both channels, as at power-up: the host must SYNC again (once at start: it counts the
 * start in EEPROM, so session numbers never repeat). */
void link_init(void);
/* Once a millisecond: the heartbeat's count of milliseconds since the host's last frame. */
void link_tick_1ms(void);
uint16_t link_silent_ms(void);
/* Feed one byte from the host; complete frames are checked, answered and delivered. */
void link_receive(uint8_t byte);
/* Whether the next byte may be fed: the answer it may complete fits the transmit buffer now, so
 * answering never waits for the wire (a host that polls faster than the answers drain would
 * otherwise hold the main loop, and the motion it prepares, in uart_putc). */
uint8_t link_can_receive(void);

/* Supplied by the command layer: handle one good payload, write the answer payload into
 * `answer` (at most MAX_PAYLOAD bytes) and return its length. An answer of BUSY means the
 * command was not taken and will come again. */
uint8_t command_deliver(const uint8_t *payload, uint8_t len, uint8_t *answer);

#endif
