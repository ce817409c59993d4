/* commands.h - the command set of 002 as the firmware holds it, and the three-deep queue. */
#ifndef COMMANDS_H
#define COMMANDS_H

#include <stdint.h>
#include "config.h"

/* Opcodes (docs/protocol.md §7). */
#define OP_INIT  0x01
#define OP_FMOV  0x02
#define OP_ZMOV  0x03
#define OP_PMOV  0x04
#define OP_STOP  0x05
#define OP_FFDR  0x06
#define OP_MFDR  0x07
#define OP_PFDR  0x08
#define OP_DELY  0x09
#define OP_CSTP  0x0A
#define OP_ISTP  0x0B
#define OP_PSTN  0x0C
#define OP_RDPS  0x0D
#define OP_RDST  0x0E
#define OP_SPIN  0x0F
#define OP_COOL  0x10
#define OP_PROB  0x11

#define PROB_UNTIL_OPEN 0x01       /* PROB's flags: move until the probe input opens (G38.4/5) */

/* One decoded command. Positions are steps of the machine's axes (index 0 .. N_AXES-1, in the
 * order of the machine file), not of the link's axis bits. */
typedef struct {
    uint8_t op;
    uint8_t axes;                  /* bit i: machine axis i is named (FMOV, PMOV, PSTN) */
    int32_t pos[N_AXES];           /* steps */
    uint32_t value;                /* feed in 0.1 um/min (or /rev), dwell ms, coolant mode,
                                      spindle rpm << 8 | direction byte, PROB's flags */
    uint8_t n_order;               /* ZMOV: axes to home, in order (0: the machine's order) */
    uint8_t order[N_AXES];
} command_t;

/* The queue of 002's interpreter: commands waiting to be fetched, oldest first. */
uint8_t queue_count(void);
command_t *queue_head(void);       /* the oldest waiting command (queue_count() > 0) */
void queue_pop(void);
void queue_clear(void);
uint8_t queue_holds(uint8_t op);   /* a command with opcode `op` waits */

#endif
