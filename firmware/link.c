/* link.c - frames on the byte stream and the device's rules (docs/protocol.md §2, §4, §5).
 *
 * A frame is SOF 0x7E, then the stuffed body LEN SEQ PAYLOAD[LEN] CRC[4] (CRC-32, most
 * significant byte first); inside the body 0x7E and 0x7D travel as 0x7D, byte ^ 0x20. The
 * receiver below is §2.4 step by step. For each good frame the device applies §5: SYNC of a new
 * session starts a channel (one of the running session changes nothing), a repeated sequence number
 * is a duplicate (answered again, not delivered), a number out of step is ERR 5, and the answer
 * that consumes a number is kept for duplicates. BUSY consumes nothing. */
#include <string.h>

#include "config.h"
#include "crc32.h"
#include "link.h"
#include "uart.h"

#define SOF      0x7E
#define ESC      0x7D
#define ESC_XOR  0x20
#define NONE     0xFF                /* `last` before the channel's first SYNC */
#define ANSWER_MAX (2 + 3 * 8)       /* the longest answer kept: POS of eight axes */
#define CRC_BYTES 4
#define SYNC_LEN  5                  /* SYNC and its 32-bit session number */

/* Receiver state (§2.4): hunting for SOF, or inside a frame with `count` body bytes. */
static uint8_t body[MAX_PAYLOAD + 2 + CRC_BYTES];
static uint8_t count;
static uint8_t in_frame, escaped;

/* Per channel (0 queued, 1 immediate): the last answered number and that answer's payload. */
static uint8_t last[2];
static uint8_t answer[2][ANSWER_MAX];
static uint8_t answer_len[2];
static uint8_t session[2][SYNC_LEN - 1];  /* session number of the channel's last SYNC */

static uint32_t crc32(const uint8_t *p, uint8_t n)
{
    uint32_t crc = CRC32_INIT;
    while (n--)
        crc = crc32_update(crc, *p++);
    return crc32_final(crc);
}

static void put_stuffed(uint8_t byte)
{
    if (byte == SOF || byte == ESC) {
        uart_putc(ESC);
        uart_putc(byte ^ ESC_XOR);
    } else {
        uart_putc(byte);
    }
}

/* The longest answer on the wire: SOF, then LEN, SEQ, POS of every axis and the CRC, each
 * byte stuffed at worst into two. */
#define ANSWER_MAX_BYTES (1 + 2 * (1 + 1 + 2 + 3 * N_AXES + 4))

uint8_t link_can_receive(void)
{
    return uart_tx_free() >= ANSWER_MAX_BYTES;
}

/* Send one frame: SOF, then LEN SEQ PAYLOAD CRC, stuffed. */
static void send_frame(uint8_t seq, const uint8_t *payload, uint8_t len)
{
    uint32_t crc = CRC32_INIT;
    crc = crc32_update(crc, len);
    crc = crc32_update(crc, seq);
    for (uint8_t i = 0; i < len; i++)
        crc = crc32_update(crc, payload[i]);
    crc = crc32_final(crc);
    uart_putc(SOF);
    put_stuffed(len);
    put_stuffed(seq);
    for (uint8_t i = 0; i < len; i++)
        put_stuffed(payload[i]);
    for (int8_t shift = 24; shift >= 0; shift -= 8)
        put_stuffed((uint8_t)(crc >> shift));
}

static void send_err(uint8_t seq, uint8_t code, uint8_t detail)
{
    uint8_t p[3] = { ANS_ERR, code, detail };
    send_frame(seq, p, 3);
}

static void send_nak(void)
{
    uint8_t p = ANS_NAK;
    send_frame(0x00, &p, 1);         /* NAK answers a frame whose sequence byte is not trusted */
}

/* Record the answer that consumes sequence number `number` of `channel`, and send it. */
static void answered(uint8_t channel, uint8_t number, uint8_t seq, const uint8_t *p, uint8_t len)
{
    last[channel] = number;
    if (len > ANSWER_MAX)
        len = ANSWER_MAX;
    memcpy(answer[channel], p, len);
    answer_len[channel] = len;
    send_frame(seq, p, len);
}

/* §5: the device's rules for one good frame. */
static void good_frame(uint8_t seq, const uint8_t *payload, uint8_t len)
{
    uint8_t channel = seq >> 7, number = seq & 0x7F;
    uint8_t reply[MAX_PAYLOAD];

    if (payload[0] == OP_SYNC) {                           /* rule 1: SYNC starts the channel */
        if (len != SYNC_LEN) {
            send_err(seq, ERR_LENGTH, OP_SYNC);
            return;
        }
        reply[0] = ANS_ACK;
        if (last[channel] != NONE && memcmp(session[channel], payload + 1, SYNC_LEN - 1) == 0) {
            send_frame(seq, reply, 1);                     /* the running session: no rewind */
            return;
        }
        memcpy(session[channel], payload + 1, SYNC_LEN - 1);
        answered(channel, number, seq, reply, 1);
        return;
    }
    if (last[channel] == NONE) {                           /* rule 2: not synchronised */
        send_err(seq, ERR_NOT_SYNCED, 0);
        return;
    }
    if (number == last[channel]) {                         /* rule 3: a duplicate */
        send_frame(seq, answer[channel], answer_len[channel]);
        return;
    }
    if (number != ((last[channel] + 1) & 0x7F)) {          /* rule 4: out of step */
        send_err(seq, ERR_SEQUENCE, last[channel]);
        return;
    }
    uint8_t n = command_deliver(payload, len, reply);      /* rules 5 and 6 */
    if (reply[0] == ANS_BUSY) {
        send_frame(seq, reply, 1);                         /* not recorded: it will come again */
        return;
    }
    answered(channel, number, seq, reply, n);
}

/* A frame's body is complete: check its CRC (§2.4 step 5). */
static void frame_complete(void)
{
    uint8_t len = body[0];
    uint32_t crc = 0;
    for (uint8_t i = 0; i < CRC_BYTES; i++)
        crc = (crc << 8) | body[len + 2 + i];
    in_frame = 0;
    if (crc32(body, len + 2) != crc) {
        send_nak();                                        /* bad (CRC) */
        return;
    }
    good_frame(body[1], &body[2], len);
}

void link_init(void)
{
    last[0] = last[1] = NONE;
    in_frame = escaped = 0;
    count = 0;
}

void link_receive(uint8_t byte)
{
    if (byte == SOF) {                  /* step 1: a frame starts; one in progress was truncated */
        in_frame = 1;
        escaped = 0;
        count = 0;
        return;
    }
    if (!in_frame)                      /* step 2: noise between frames */
        return;
    if (escaped) {                      /* step 3: the byte after an escape */
        escaped = 0;
        byte ^= ESC_XOR;
        if (byte != SOF && byte != ESC) {
            in_frame = 0;
            send_nak();                 /* bad (escape) */
            return;
        }
    } else if (byte == ESC) {           /* step 4 */
        escaped = 1;
        return;
    }
    body[count++] = byte;               /* step 5 */
    if (count == 1 && (byte < 1 || byte > MAX_PAYLOAD)) {
        in_frame = 0;
        send_nak();                     /* bad (length) */
        return;
    }
    if (count >= 2 + CRC_BYTES && count == body[0] + 2 + CRC_BYTES)
        frame_complete();
}
