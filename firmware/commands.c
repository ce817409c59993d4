/* commands.c - payloads to commands (docs/protocol.md §7), the queue, and what each one answers.
 *
 * 002's serial module validates a message and puts its command in the queue; the interpreter
 * finds the immediate commands (STOP, RDPS, RDST) and runs them at once. Here both happen as a
 * frame arrives: command_deliver decodes the payload (answering ERR 1, 2 or 3 for a layout
 * error, in the order the Python codec checks), runs the immediate commands (STOP, RDPS, RDST),
 * INIT and the operator's feed overrides (FFDR, MFDR: "immediate altering") at once, and queues
 * the rest, answering BUSY when three already wait. */
#include <string.h>

#include "commands.h"
#include "interp.h"
#include "link.h"

static command_t queue[QUEUE_DEPTH];
static uint8_t q_first, q_count;

/* The machine axis of each link axis bit (X = 0, Y = 1, Z = 2, ...), or 0xFF. */
static uint8_t axis_of_bit(uint8_t bit)
{
    static const uint8_t bits[N_AXES] = AXIS_BITS;
    for (uint8_t i = 0; i < N_AXES; i++)
        if (bits[i] == bit)
            return i;
    return 0xFF;
}

static uint32_t be32(const uint8_t *p)
{
    return ((uint32_t)p[0] << 24) | ((uint32_t)p[1] << 16) | ((uint16_t)p[2] << 8) | p[3];
}

/* The positions field: a mask, then a signed 24-bit value per set bit. Returns an ERR code. */
static uint8_t decode_positions(const uint8_t *args, uint8_t n, command_t *cmd)
{
    if (n == 0)
        return ERR_LENGTH;
    uint8_t mask = args[0], k = 0;
    for (uint8_t b = 0; b < 8; b++)
        k += (mask >> b) & 1;
    if (n != 1 + 3 * k)
        return ERR_LENGTH;
    const uint8_t *p = args + 1;
    for (uint8_t b = 0; b < 8; b++) {
        if (!((mask >> b) & 1))
            continue;
        uint8_t axis = axis_of_bit(b);
        if (axis == 0xFF)
            return ERR_VALUE;                              /* an axis the machine lacks */
        int32_t v = ((int32_t)p[0] << 16) | ((uint16_t)p[1] << 8) | p[2];
        if (v == 0x800000L)
            return ERR_VALUE;                              /* reserved */
        if (v & 0x800000L)
            v -= 0x1000000L;                               /* two's complement, 24 bits */
        cmd->pos[axis] = v;
        cmd->axes |= (uint8_t)(1 << axis);
        p += 3;
    }
    return 0;
}

static uint8_t decode_zmov(const uint8_t *args, uint8_t n, command_t *cmd)
{
    if (n == 0 || n != 1 + args[0])
        return ERR_LENGTH;
    uint8_t seen = 0;
    for (uint8_t i = 0; i < args[0]; i++) {
        uint8_t axis = args[1 + i] < 8 ? axis_of_bit(args[1 + i]) : 0xFF;
        if (axis == 0xFF || (seen >> axis) & 1)
            return ERR_VALUE;
        seen |= (uint8_t)(1 << axis);
        cmd->order[i] = axis;
    }
    cmd->n_order = args[0];
    return 0;
}

/* PROB: the flags byte, then positions as PMOV's. */
static uint8_t decode_prob(const uint8_t *args, uint8_t n, command_t *cmd)
{
    if (n == 0)
        return ERR_LENGTH;
    uint8_t code = decode_positions(args + 1, (uint8_t)(n - 1), cmd);
    if (!code && (args[0] & ~PROB_UNTIL_OPEN))
        code = ERR_VALUE;                                  /* a flag this firmware lacks */
    cmd->value = args[0];
    return code;
}

/* Argument bytes of the fixed-length opcodes, 0x01 .. 0x10 (0xFF: checked on its own). */
static const uint8_t fixed_args[16] = {
    0, 0xFF, 0xFF, 0xFF, 0, 4, 4, 4, 4, 0, 0, 0xFF, 0, 0, 3, 1
};

/* Decode a payload; returns 0 or the ERR code to answer. */
static uint8_t decode(const uint8_t *p, uint8_t len, command_t *cmd)
{
    memset(cmd, 0, sizeof *cmd);
    cmd->op = p[0];
    if (p[0] < OP_INIT || p[0] > OP_PROB)
        return ERR_OPCODE;
    const uint8_t *args = p + 1;
    uint8_t n = len - 1;
    if (p[0] == OP_FMOV || p[0] == OP_PMOV || p[0] == OP_PSTN)
        return decode_positions(args, n, cmd);
    if (p[0] == OP_ZMOV)
        return decode_zmov(args, n, cmd);
    if (p[0] == OP_PROB)
        return decode_prob(args, n, cmd);
    if (n != fixed_args[p[0] - 1])
        return ERR_LENGTH;
    if (n == 4)
        cmd->value = be32(args);
    if (p[0] == OP_SPIN) {
        if (args[2] != 0x00 && args[2] != 0x01 && args[2] != 0xFF)
            return ERR_VALUE;                              /* direction: M3, stopped, M4 */
        cmd->value = ((uint32_t)args[0] << 16) | ((uint16_t)args[1] << 8) | args[2];
    }
    if (p[0] == OP_COOL) {
        if (args[0] != 0 && args[0] != 7 && args[0] != 8)
            return ERR_VALUE;
        cmd->value = args[0];
    }
    return 0;
}

static uint8_t err(uint8_t *answer, uint8_t code, uint8_t detail)
{
    answer[0] = ANS_ERR;
    answer[1] = code;
    answer[2] = detail;
    return 3;
}

uint8_t command_deliver(const uint8_t *payload, uint8_t len, uint8_t *answer)
{
    command_t cmd;
    uint8_t code = decode(payload, len, &cmd);
    if (code)
        return err(answer, code, payload[0]);
    answer[0] = ANS_ACK;
    switch (cmd.op) {                                      /* 002's immediate commands */
    case OP_STOP:
        interp_stop();
        return 1;
    case OP_RDPS:
        return interp_position_answer(answer);
    case OP_RDST:
        return interp_status_answer(answer);
    case OP_INIT:                                          /* clears all queues: not queued */
        interp_init();
        return 1;
    case OP_FFDR:                                          /* the operator's feed overrides */
    case OP_MFDR:
        if (cmd.value == 0)
            return err(answer, ERR_VALUE, cmd.op);         /* a feed of 0 would never end */
        interp_override(&cmd);
        return 1;
    default:
        break;
    }
    if (!interp_accepts(&cmd))
        return err(answer, ERR_REFUSED, cmd.op);
    if (q_count == QUEUE_DEPTH) {
        answer[0] = ANS_BUSY;
        return 1;
    }
    queue[(q_first + q_count) % QUEUE_DEPTH] = cmd;
    q_count++;
    return 1;
}

uint8_t queue_count(void) { return q_count; }

command_t *queue_head(void) { return &queue[q_first]; }

void queue_pop(void)
{
    q_first = (q_first + 1) % QUEUE_DEPTH;
    q_count--;
}

void queue_clear(void) { q_first = q_count = 0; }

uint8_t queue_holds(uint8_t op)
{
    for (uint8_t i = 0; i < q_count; i++)
        if (queue[(q_first + i) % QUEUE_DEPTH].op == op)
            return 1;
    return 0;
}
