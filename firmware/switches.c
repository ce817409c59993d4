/* switches.c - limit (NLSX, PLSX, PLSZ) and precise-position (PPSX, PPSZ) switches.
 *
 * Which endstop connector is which switch comes from the machine header (SWITCHES). The inputs
 * have the AVR pull-ups on. With normally-closed switches wired to ground, a released switch
 * reads low and an actuated one - or a broken wire - reads high: SWITCH_ACTUATED_LEVEL 1, the
 * safe wiring and the default.
 *
 * Debouncing: the pins are sampled once a millisecond (switches_sample, from the clock's
 * interrupt) and a switch changes state only when SWITCH_DEBOUNCE_SAMPLES samples in a row
 * read the new level. A bounce or a glitch shorter than SWITCH_DEBOUNCE_SAMPLES - 1 ms never
 * trips a switch; a level held SWITCH_DEBOUNCE_SAMPLES ms always does, that much later. Everything
 * else (the step interrupt, homing, the status word) reads the debounced state. */
#include <avr/io.h>
#include <util/delay.h>

#include "board.h"
#include "config.h"
#include "switches.h"

#ifndef SWITCH_ACTUATED_LEVEL
#define SWITCH_ACTUATED_LEVEL 1
#endif

#ifndef SWITCH_DEBOUNCE_SAMPLES
#define SWITCH_DEBOUNCE_SAMPLES 3
#endif
#if N_SWITCHES > 8
#error "the debounced state keeps a bit a switch: at most 8 switches"
#endif

/* The pin's level, as read now. */
#define RAW(stop) ((((RAMPS_##stop##_PIN) >> (RAMPS_##stop##_BIT)) & 1) == SWITCH_ACTUATED_LEVEL)
/* The debounced state of switch `id`. */
#define ON(id) ((actuated >> (id)) & 1)

static volatile uint8_t actuated;            /* bit id: switch id is actuated (debounced) */
static uint8_t differing[N_SWITCHES > 0 ? N_SWITCHES : 1];   /* samples in a row at the other level */

void switches_init(void)
{
#define SWITCH(id, axis, side, kind, stop, bit) RAMPS_##stop##_PORT |= _BV(RAMPS_##stop##_BIT);
    SWITCHES
#undef SWITCH
    _delay_us(20);                           /* the pull-ups charge the wiring */
    uint8_t now = 0;                         /* at power-up the levels are taken as they are */
#define SWITCH(id, axis, side, kind, stop, bit) if (RAW(stop)) now |= (uint8_t)(1u << (id));
    SWITCHES
#undef SWITCH
    actuated = now;
}

/* One sample of one switch: count the samples in a row that disagree with its state. */
static inline void sample(uint8_t id, uint8_t level)
{
    if (level == ON(id))
        differing[id] = 0;
    else if (++differing[id] >= SWITCH_DEBOUNCE_SAMPLES) {
        actuated ^= (uint8_t)(1u << id);
        differing[id] = 0;
    }
}

void switches_sample(void)
{
#define SWITCH(id, axis, side, kind, stop, bit) sample((id), RAW(stop));
    SWITCHES
#undef SWITCH
}

uint8_t switch_blocks(uint8_t bits, uint8_t dirs)
{
#define SWITCH(id, axis, side, kind, stop, bit)                                       \
    if ((kind) == SW_LIMIT && ((bits >> (axis)) & 1) &&                               \
        (((dirs >> (axis)) & 1) == ((side) < 0)) && ON(id))                         \
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
#define SWITCH(id, axis, side, kind, stop, bit) case (id): return ON(id);
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
    if ((bit) >= 0 && ON(id)) status |= (uint16_t)(1u << ((bit) & 15));
    SWITCHES
#undef SWITCH
    return status;
}
