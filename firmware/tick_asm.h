/* tick_asm.h - what the step interrupt's assembly (tick_asm.c, tick_slow.c) shares: raising
 * and lowering the step pins, whether a pulse ends inside the tick, the operands of the entry. */
#ifndef TICK_ASM_H
#define TICK_ASM_H

#include "stepper_int.h"

#define RISE_ASM(i, slot)                                                                   \
    if (_SFR_IO_REG_P(PIN_OF(slot, _STEP_PORT)))                                            \
        __asm__ __volatile__("sbrc r24, %0\n\tsbi %1, %2\n\t" ::"n"(i),                     \
                             "n"(_SFR_IO_ADDR(PIN_OF(slot, _STEP_PORT))),                   \
                             "n"(PIN_OF(slot, _STEP_BIT)));                                 \
    else                                                                                    \
        __asm__ __volatile__("sbrs r24, %0\n\trjmp 2f\n\tlds r25, %1\n\tori r25, %2\n\t"    \
                             "sts %1, r25\n2:\n\t" ::"n"(i),                                \
                             "n"(_SFR_MEM_ADDR(PIN_OF(slot, _STEP_PORT))),                  \
                             "n"(_BV(PIN_OF(slot, _STEP_BIT))));
/* Lower the step pin of axis i (the pulse's end, in assembly). */
#define FALL_ASM(i, slot)                                                                   \
    if (_SFR_IO_REG_P(PIN_OF(slot, _STEP_PORT)))                                            \
        __asm__ __volatile__("cbi %0, %1\n\t" ::"n"(_SFR_IO_ADDR(PIN_OF(slot, _STEP_PORT))), \
                             "n"(PIN_OF(slot, _STEP_BIT)));                                 \
    else                                                                                    \
        __asm__ __volatile__("lds r24, %0\n\tandi r24, %1\n\tsts %0, r24\n\t"              \
                             ::"n"(_SFR_MEM_ADDR(PIN_OF(slot, _STEP_PORT))),                \
                             "n"(0xFF & ~_BV(PIN_OF(slot, _STEP_BIT))));

/* The waits poll the counter's low byte (5 cycles a turn, so no count of 8 cycles is missed):
 * no compare flag is cleared by hand. (simavr 1.6 clears every flag of TIFR1 at any write.) */
#define ENTRY_OPERANDS                                                                       \
    [bits] "i"(&st_ev_bits), [next] "i"(&st_tick_next), [high] "i"(&st_pulse_high),            \
    [ocrbh] "n"(_SFR_MEM_ADDR(OCR1BH)), [ocrbl] "n"(_SFR_MEM_ADDR(OCR1BL)),                    \
    [tcntl] "n"(_SFR_MEM_ADDR(TCNT1L)), [tcnth] "n"(_SFR_MEM_ADDR(TCNT1H)),                    \
    [slot] "n"(SLOT_COUNTS), [busy] "i"(&st_busy)

#endif
