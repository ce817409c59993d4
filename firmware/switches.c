/* switches.c - limit (NLSX, PLSX, PLSZ) and precise-position (PPSX, PPSZ) switches.
 *
 * Which endstop connector is which switch comes from the machine header (SWITCHES). The inputs
 * have the AVR pull-ups on. With normally-closed switches wired to ground, a released switch
 * reads low and an actuated one - or a broken wire - reads high: SWITCH_ACTUATED_LEVEL 1, the
 * safe wiring and the default. */
#include <avr/io.h>

#include "board.h"
#include "config.h"
#include "switches.h"

#ifndef SWITCH_ACTUATED_LEVEL
#define SWITCH_ACTUATED_LEVEL 1
#endif

#define ON(stop) ((((RAMPS_##stop##_PIN) >> (RAMPS_##stop##_BIT)) & 1) == SWITCH_ACTUATED_LEVEL)

void switches_init(void)
{
#define SWITCH(id, axis, side, kind, stop, bit) RAMPS_##stop##_PORT |= _BV(RAMPS_##stop##_BIT);
    SWITCHES
#undef SWITCH
}

uint8_t switch_blocks(uint8_t bits, uint8_t dirs)
{
#define SWITCH(id, axis, side, kind, stop, bit)                                       \
    if ((kind) == SW_LIMIT && ((bits >> (axis)) & 1) &&                               \
        (((dirs >> (axis)) & 1) == ((side) < 0)) && ON(stop))                         \
        return 1;
    SWITCHES
#undef SWITCH
    (void)bits;
    (void)dirs;
    return 0;
}

uint8_t switch_on(uint8_t id)
{
    switch (id) {
#define SWITCH(id, axis, side, kind, stop, bit) case (id): return ON(stop);
    SWITCHES
#undef SWITCH
    default:
        return 0;
    }
}

uint16_t switch_status(void)
{
    uint16_t status = 0;
#define SWITCH(id, axis, side, kind, stop, bit) \
    if ((bit) >= 0 && ON(stop)) status |= (uint16_t)(1u << ((bit) & 15));
    SWITCHES
#undef SWITCH
    return status;
}
