/* switches.h - 002's limit and precise-position switches on the RAMPS endstop connectors. */
#ifndef SWITCHES_H
#define SWITCHES_H

#include <stdint.h>

/* Kinds of switch (the machine header's SWITCHES table). */
#define SW_LIMIT    0   /* motion towards it stops when it closes: NLSX, PLSX, PLSZ */
#define SW_HOME     1   /* only homing looks at it */
#define SW_PRECISE  2   /* 002's precise-position switch: homing's fine reference (PPSX, PPSZ) */
#define SW_PROBE    3   /* the tool setter's beam: only PROB looks at it (PROBE_SWITCH) */

void switches_init(void);
/* Sample every switch pin: once a millisecond, from the clock's interrupt (debouncing). */
void switches_sample(void);
/* All below read the debounced state.
 * 1 if a step of axes `bits` in directions `dirs` (bit i set: negative) runs into an
 * actuated limit switch. Called in the step interrupt. */
uint8_t switch_blocks(uint8_t bits, uint8_t dirs);
/* 1 while switch `id` (its number in SWITCHES) is actuated. */
uint8_t switch_on(uint8_t id);
/* The switch bits of the status word (docs/protocol.md §8: bits 2..6). */
uint16_t switch_status(void);

#endif
