/* command.h - one decoded command of 002, as commands.c decodes it and interp.c runs it. */
#ifndef COMMAND_H
#define COMMAND_H

#include <stdint.h>
#include "config.h"

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

#endif
