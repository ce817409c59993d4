/* link.c - frames on the byte stream and the device's rules (docs/protocol.md §2, §4, §5).
 *
 * A frame is SOF 0x7E, then the stuffed body LEN SEQ PAYLOAD[LEN] CRC[4] (CRC-32, most
 * significant byte first); inside the body 0x7E and 0x7D travel as 0x7D, byte ^ 0x20. The
 * receiver below is §2.4 step by step. For each good frame the device applies §5: a SYNC opens
 * a session on its channel with a number this device never issued before (the EEPROM's boot
 * count, then a counter), answered SESS; every other frame of the channel, both ways, is bound to
 * that number (the CRC covers it first), so frames of another session - recorded, replayed, a
 * second host's - fail the CRC. A repeated sequence number is a duplicate (answered again, not
 * delivered), a number out of step is ERR 5, and the answer that consumes a number is kept for
 * duplicates. BUSY consumes nothing. Every intact frame, bound or not, resets the heartbeat's
 * count of silent milliseconds (interp.c stops a machine whose host fell silent). */
#include <string.h>
#include <avr/eeprom.h>

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
static uint8_t nonce[2][SYNC_LEN - 1];    /* the host's nonce in the SYNC that opened it */
static uint8_t running[2][5];              /* its SESS answer, for a resend or a late copy */
static uint8_t in_session[2];             /* the channel runs a session */
static uint32_t seed[2];                  /* the CRC register after the session's 4 bytes */
static uint16_t boot;                     /* sessions are boot << 16 | count */
static uint16_t count_sessions;
static uint16_t silent_ms;                /* since the last frame of a session */
static uint16_t EEMEM ee_boot;            /* starts counted in EEPROM: no number comes twice */

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

/* Send one frame: SOF, then LEN SEQ PAYLOAD CRC, stuffed; `bound`: the CRC covers the session of
 * the channel first. */
static void send_frame(uint8_t seq, const uint8_t *payload, uint8_t len, uint8_t bound)
{
    uint32_t crc = bound ? seed[seq >> 7] : CRC32_INIT;
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

static void send_err(uint8_t seq, uint8_t code, uint8_t detail, uint8_t bound)
{
    uint8_t p[3] = { ANS_ERR, code, detail };
    send_frame(seq, p, 3, bound);
}

static void send_nak(void)
{
    uint8_t p = ANS_NAK;
    send_frame(0x00, &p, 1, 0);      /* NAK answers a frame whose sequence byte is not trusted */
}

/* Record the answer that consumes sequence number `number` of `channel`, and send it. */
static void answered(uint8_t channel, uint8_t number, uint8_t seq, const uint8_t *p, uint8_t len,
                     uint8_t bound)
{
    last[channel] = number;
    if (len > ANSWER_MAX)
        len = ANSWER_MAX;
    memcpy(answer[channel], p, len);
    answer_len[channel] = len;
    send_frame(seq, p, len, bound);
}

/* A session number this device never issued before: boot count, then a counter. */
static uint32_t new_session(void)
{
    uint32_t number = ((uint32_t)boot << 16) | count_sessions;
    if (++count_sessions == 0)
        eeprom_update_word(&ee_boot, ++boot);              /* 65 536 in one boot: count a boot */
    return number;
}

/* Rule 1: a SYNC opens a session; the host's resend of it (same nonce and number, nothing taken
 * since) and a late copy of it (frames taken since) are answered the running session's SESS and
 * change nothing: only a new nonce opens a new session. */
static void sync(uint8_t channel, uint8_t number, uint8_t seq, const uint8_t *payload, uint8_t len)
{
    if (len != SYNC_LEN) {
        send_err(seq, ERR_LENGTH, OP_SYNC, 0);
        return;
    }
    if (in_session[channel] && memcmp(nonce[channel], payload + 1, SYNC_LEN - 1) == 0) {
        send_frame(seq, running[channel], 5, 0);
        return;
    }
    uint32_t s = new_session();
    uint8_t reply[5] = { ANS_SESS, (uint8_t)(s >> 24), (uint8_t)(s >> 16), (uint8_t)(s >> 8),
                         (uint8_t)s };
    memcpy(running[channel], reply, 5);
    memcpy(nonce[channel], payload + 1, SYNC_LEN - 1);
    uint32_t crc = CRC32_INIT;
    for (uint8_t i = 1; i < 5; i++)
        crc = crc32_update(crc, reply[i]);
    seed[channel] = crc;
    in_session[channel] = 1;
    answered(channel, number, seq, reply, 5, 0);
}

/* §5: the device's rules for one good frame; `bound`: its CRC covered the channel's session. */
static void good_frame(uint8_t seq, const uint8_t *payload, uint8_t len, uint8_t bound)
{
    uint8_t channel = seq >> 7, number = seq & 0x7F;
    uint8_t reply[MAX_PAYLOAD];

    if (!bound) {
        if (payload[0] == OP_SYNC)
            sync(channel, number, seq, payload, len);
        else
            send_err(seq, ERR_NOT_SYNCED, 0, 0);           /* rule 2: of no session here */
        return;
    }
    if (number == last[channel]) {                         /* rule 3: a duplicate */
        send_frame(seq, answer[channel], answer_len[channel], 1);
        return;
    }
    if (number != ((last[channel] + 1) & 0x7F) || number == 0) {   /* rule 4: out of step; */
        if (number)                                        /* numbers never wrap in a session */
            send_err(seq, ERR_SEQUENCE, last[channel], 1);
        else
            send_err(seq, ERR_NOT_SYNCED, 0, 1);
        return;
    }
    uint8_t n = command_deliver(payload, len, reply);      /* rules 5 and 6 */
    if (reply[0] == ANS_BUSY) {
        send_frame(seq, reply, 1, 1);                      /* not recorded: it will come again */
        return;
    }
    answered(channel, number, seq, reply, n, 1);
}

/* A frame's body is complete: check its CRC (§2.4 step 5), bound to the channel's session or
 * plain. */
static void frame_complete(void)
{
    uint8_t len = body[0], channel = body[1] >> 7;
    uint32_t crc = 0;
    for (uint8_t i = 0; i < CRC_BYTES; i++)
        crc = (crc << 8) | body[len + 2 + i];
    in_frame = 0;
    if (in_session[channel]) {
        uint32_t c = seed[channel];
        for (uint8_t i = 0; i < len + 2; i++)
            c = crc32_update(c, body[i]);
        if (crc32_final(c) == crc) {
            silent_ms = 0;                                 /* the host is there */
            good_frame(body[1], &body[2], len, 1);
            return;
        }
    }
    if (crc32(body, len + 2) != crc) {
        send_nak();                                        /* bad (CRC), or of another session */
        return;
    }
    silent_ms = 0;
    good_frame(body[1], &body[2], len, 0);
}

void link_init(void)
{
    last[0] = last[1] = NONE;
    in_session[0] = in_session[1] = 0;
    in_frame = escaped = 0;
    count = 0;
    boot = eeprom_read_word(&ee_boot) + 1;                 /* erased (0xFFFF): the first is 0 */
    eeprom_update_word(&ee_boot, boot);
    count_sessions = 0;
}

void link_tick_1ms(void)
{
    if (silent_ms != 0xFFFF)
        silent_ms++;
}

uint16_t link_silent_ms(void) { return silent_ms; }

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
