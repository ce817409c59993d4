/* tick_asm.c - the step interrupt's entry and its common tick, in assembly: the pins must rise
 * and fall a fixed number of counts after their match, and the common tick must cost few enough
 * cycles for 60 kHz (about 215 with a short pulse's end; a period is 267). Only r18-r25, r30,
 * r31 and SREG are used, saved by hand; any other tick goes on in tick_slow.c and tick_body
 * (tick.c). See stepper.c for the design. */
#include <stddef.h>

#include "tick_asm.h"

#define STRINGIFY(x) #x
#define EXPAND_STRINGIFY(x) STRINGIFY(x)
#define CLOCK_VECTOR EXPAND_STRINGIFY(TIMER3_COMPA_vect)   /* the 1 ms clock's interrupt (io.c) */

/* The common tick in assembly: count the event raised (moved[i] += or -= 1, r24 the bits,
 * r23 the negative directions), one Bresenham event of axis i (r22 the axes that need it, r25
 * the bits of the next event), and the next match at r19:r18 with its slot and pulse end. */
#define COUNT_ASM(i, slot)                                                                  \
    __asm__ __volatile__("sbrs r24, %[b]\n\trjmp 12f\n\tlds r20, %[m]\n\tlds r21, %[m]+1\n\t"  \
                         "sbrc r23, %[b]\n\trjmp 10f\n\tsubi r20, 0xFF\n\tsbci r21, 0xFF\n\t"     \
                         "rjmp 11f\n\t10: subi r20, 1\n\tsbci r21, 0\n\t"                         \
                         "11: sts %[m]+1, r21\n\tsts %[m], r20\n\t12:\n\t"                        \
                         ::[b] "n"(i), [m] "i"(&st_moved[i]));
#define BRES_ASM(i, slot)                                                                   \
    __asm__ __volatile__("sbrs r22, %[b]\n\trjmp 14f\n\t"                                    \
                         "lds r18, %[c]\n\tlds r19, %[c]+1\n\tlds r20, %[c]+2\n\tlds r21, %[c]+3\n\t" \
                         "lds r30, %[n]\n\tadd r18, r30\n\tlds r30, %[n]+1\n\tadc r19, r30\n\t"    \
                         "lds r30, %[n]+2\n\tadc r20, r30\n\tlds r30, %[n]+3\n\tadc r21, r30\n\t"  \
                         "brmi 13f\n\t"                                                       \
                         "lds r30, %[k]\n\tsub r18, r30\n\tlds r30, %[k]+1\n\tsbc r19, r30\n\t"    \
                         "lds r30, %[k]+2\n\tsbc r20, r30\n\tlds r30, %[k]+3\n\tsbc r21, r30\n\t"  \
                         "ori r25, %[mask]\n\t"                                               \
                         "13: sts %[c], r18\n\tsts %[c]+1, r19\n\tsts %[c]+2, r20\n\t"        \
                         "sts %[c]+3, r21\n\t14:\n\t"                                        \
                         ::[b] "n"(i), [c] "i"(&st_counter[i]), [n] "i"(&st_inc[i]), [k] "i"(&st_base), \
                           [mask] "n"(1 << (i)));
/* The tick's entry. The common tick (st_fast: the next event within a segment of a plain line)
 * runs here whole: it waits for the slot, raises the prepared event's pins, sets the next
 * match, and (short pulses) lowers the pins PULSE_COUNTS after they rose, with interrupts off
 * (at most 10 us); then, with interrupts on but its own next match and the 1 ms clock masked,
 * it counts the event and prepares the next one. Anything else goes to slow_entry. */
ISR(TIMER1_COMPA_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
#if !FALL_IN_TICK
        "lds r24, %[busy]\n\t"              /* this tick's rest runs with interrupts on */
        "tst r24\n\t"
        "breq 29f\n\t"
        "jmp slow_entry\n\t"               /* (which marks the match missed) */
        "29:\n\t"
#endif
        "lds r24, %[fast]\n\t"
        "tst r24\n\t"
        "brne 30f\n\t"
        "jmp slow_entry\n\t"
        "30: push r25\n\t"
        "push r18\n\t"
        "push r19\n\t"
        "push r20\n\t"
        "push r21\n\t"
        "46: clt\n\t"                         /* T: pins are high */
        "lds r18, %[next]\n\t"               /* this match */
        "lds r19, %[next]+1\n\t"
        "lds r24, %[bits]\n\t"
        "tst r24\n\t"
        "breq 34f\n\t"                        /* no pins this tick */
        "set\n\t"
        "mov r20, r18\n\t"
        "subi r20, lo8(-(%[slot]))\n\t"
#if !FALL_IN_TICK
        "lds r21, %[tcntl]\n\t"               /* the slot come at the first look (T stays */
        "sub r21, r20\n\t"                    /* set): when in its count is unknown, compare */
        "brpl 32f\n\t"                        /* B is set from the count after the rise */
        "clt\n\t"
        "31: lds r21, %[tcntl]\n\t"
        "sub r21, r20\n\t"
        "brmi 31b\n\t"
        "32:\n\t"
#elif PULSE_HIGH_US * (F_CPU / 8000000UL) >= 5   /* (PULSE_COUNTS: the wait is not filled) */
        "lds r21, %[tcntl]\n\t"              /* the slot come at the first look: late, */
        "sub r21, r20\n\t"                    /* and when in the count read is unknown: */
        "brmi 31f\n\t"                        /* the pins may rise in the next one, which */
        "inc r21\n\t"                         /* times the pulse's end (r21: the counts */
        "rjmp 32f\n\t"                        /* from the slot to the rise's) */
        "31: lds r21, %[tcntl]\n\t"           /* on time: the slot, r21 = 0 */
        "sub r21, r20\n\t"
        "brmi 31b\n\t"
        "32:\n\t"
#else
        "31: lds r21, %[tcntl]\n\t"           /* the slot (at once if it has passed); a */
        "sub r21, r20\n\t"                    /* pulse this short ends after the tick's */
        "brmi 31b\n\t"                        /* work, late or not */
#endif
        ::ENTRY_OPERANDS, [fast] "i"(&st_fast));
    FOR_EACH_AXIS(RISE_ASM)
#if FALL_IN_TICK
    __asm__ __volatile__(
        "add r20, r21\n\t"                    /* the count they rose in, plus the pulse and */
        "subi r20, lo8(-(%[pulse]))\n\t"      /* one: they rose 4-11 cycles into that count */
        ::[pulse] "n"(PULSE_COUNTS + 1));       /* (late, timed from the count read before */
                                                /* the rise, 3 us pulses were 44 cycles) */
#else
    __asm__ __volatile__(
        "sts %[high], r24\n\t"
        "brts 27f\n\t"
        "movw r24, r18\n\t"                   /* compare B's interrupt ends the pulse */
        "subi r24, lo8(-(%[fallofs]))\n\t"
        "sbci r25, hi8(-(%[fallofs]))\n\t"
        "add r24, r21\n\t"
        "brcc 28f\n\t"
        "inc r25\n\t"
        "rjmp 28f\n\t"
        "27: lds r24, %[tcntl]\n\t"
        "lds r25, %[tcnth]\n\t"
        "subi r24, lo8(-(%[after]))\n\t"
        "sbci r25, hi8(-(%[after]))\n\t"
        "28: sts %[ocrbh], r25\n\t"
        "sts %[ocrbl], r24\n\t"
        ::ENTRY_OPERANDS, [fallofs] "n"(SLOT_COUNTS + FALL_AFTER_RISE_COUNTS),
          [after] "n"(FALL_AFTER_RISE_COUNTS));
#endif
    __asm__ __volatile__(
        "34: lds r24, %[period]\n\t"         /* the next match, one period on, never passed */
        "lds r25, %[period]+1\n\t"
        "add r18, r24\n\t"
        "adc r19, r25\n\t"
        "lds r24, %[tcntl]\n\t"
        "lds r25, %[tcnth]\n\t"
        "sub r24, r18\n\t"
        "sbc r25, r19\n\t"
        "subi r24, lo8(-3)\n\t"
        "sbci r25, hi8(-3)\n\t"
        "brlt 35f\n\t"
        "add r18, r24\n\t"                    /* passed already: the counter plus 3 */
        "adc r19, r25\n\t"
        "35: sts %[ocrah], r19\n\t"
        "sts %[ocral], r18\n\t"
#if FALL_IN_TICK
        "ldi r24, %[t1tail]\n\t"            /* the rest of this tick runs with interrupts */
        "sts %[timsk1], r24\n\t"            /* on, but the next match and the 1 ms clock */
        "clr r24\n\t"                       /* (it would lengthen this tick past the period) */
        "sts %[timsk3], r24\n\t"            /* wait for its end */
        "brtc 37f\n\t"
        "36: lds r21, %[tcntl]\n\t"           /* the pulse's end */
        "sub r21, r20\n\t"
        "brmi 36b\n\t"
#else
        "ldi r24, 1\n\t"                      /* the pulse's end may come meanwhile, not */
        "sts %[busy], r24\n\t"               /* the 1 ms clock: nested in a segment's */
        "clr r24\n\t"                         /* hand-over it pushed the next tick past its */
        "sts %[timsk3], r24\n\t"              /* slot (a rise 6 us late at 42.5 kHz) */
        "sei\n\t"
#endif
        ::ENTRY_OPERANDS, [period] "i"(&st_period), [ocrah] "n"(_SFR_MEM_ADDR(OCR1AH)),
          [ocral] "n"(_SFR_MEM_ADDR(OCR1AL)), [timsk3] "n"(_SFR_MEM_ADDR(TIMSK3)),
          [t1tail] "M"(TICK_TIMSK & ~_BV(OCIE1A)), [timsk1] "n"(_SFR_MEM_ADDR(TIMSK1)));
#if FALL_IN_TICK
    FOR_EACH_AXIS(FALL_ASM)
    __asm__ __volatile__(
        "37: sei\n\t"                        /* the pins are done: the rest with interrupts on */
        ::);
#endif
    __asm__ __volatile__(
        "sts %[next]+1, r19\n\t"
        "sts %[next], r18\n\t"
        "lds r20, %[fired]\n\t"              /* the event just raised: count it, once for */
        "lds r21, %[fired]+1\n\t"            /* the axes that step at every event */
        "subi r20, 0xFF\n\t"
        "sbci r21, 0xFF\n\t"
        "sts %[fired]+1, r21\n\t"
        "sts %[fired], r20\n\t"
        "lds r24, %[bits]\n\t"
        "lds r25, %[always]\n\t"
        "com r25\n\t"
        "and r24, r25\n\t"
        "brne 42f\n\t"
        "rjmp 38f\n\t"
        "42: push r23\n\t"
        "lds r23, %[neg]\n\t"
        ::ENTRY_OPERANDS, [fired] "i"(&st_fired), [always] "i"(&st_always_axes), [neg] "i"(&st_ev_neg));
    FOR_EACH_AXIS(COUNT_ASM)
    __asm__ __volatile__(
        "pop r23\n\t"
        "38: lds r25, %[always]\n\t"          /* the next event */
        "lds r24, %[bres]\n\t"
        "tst r24\n\t"
        "brne 43f\n\t"
        "rjmp 39f\n\t"
        "43: push r22\n\t"
        "push r30\n\t"
        "mov r22, r24\n\t"
        ::[always] "i"(&st_always_axes), [bres] "i"(&st_bres_axes));
    FOR_EACH_AXIS(BRES_ASM)
    __asm__ __volatile__(
        "pop r30\n\t"
        "pop r22\n\t"
        "39: sts %[bits], r25\n\t"
        "lds r20, %[left]\n\t"
        "lds r21, %[left]+1\n\t"
        "subi r20, 1\n\t"
        "sbci r21, 0\n\t"
        "sts %[left]+1, r21\n\t"
        "sts %[left], r20\n\t"
        "brne 40f\n\t"
        "push r30\n\t"
        "call seg_boundary_asm\n\t"         /* the segment is used up: what comes next */
        "pop r30\n\t"
        "40:\n\t"
#if FALL_IN_TICK
        "cli\n\t"                           /* the match and the clock again */
        "ldi r24, %[t1]\n\t"
        "sts %[timsk1], r24\n\t"
        "ldi r24, %[t3]\n\t"
        "sts %[timsk3], r24\n\t"
        "sbis %[tifr1], %[ocf1a]\n\t"       /* the next match came meanwhile: served now */
        "rjmp 47f\n\t"                      /* from its match (its slot may not have */
        "sbi %[tifr1], %[ocf1a]\n\t"        /* passed yet), as its interrupt would, if */
        "lds r24, %[fast]\n\t"              /* it is a common tick; any other (the segment */
        "tst r24\n\t"                       /* ended: st_ticks_left is 0) goes to */
        "breq 48f\n\t"                      /* slow_entry from a match at once (missed) */
        "rjmp 46b\n\t"
        "48: ldi r24, 1\n\t"
        "sts %[missed], r24\n\t"
        "47:\n\t"
#else
        "cli\n\t"                           /* the clock again */
        "ldi r24, %[t3]\n\t"
        "sts %[timsk3], r24\n\t"
#endif
        "clr r24\n\t"                        /* done: a match may nest from here on (and no */
        "sts %[busy], r24\n\t"               /* interrupts-off tail delays compare B's) */
        "lds r24, %[missed]\n\t"           /* a match came meanwhile: take it at once */
        "tst r24\n\t"
        "breq 41f\n\t"
        "cli\n\t"
        "clr r24\n\t"
        "sts %[missed], r24\n\t"
        "lds r18, %[tcntl]\n\t"
        "lds r19, %[tcnth]\n\t"
        "subi r18, lo8(-3)\n\t"
        "sbci r19, hi8(-3)\n\t"
        "sts %[ocrah], r19\n\t"
        "sts %[ocral], r18\n\t"
        "sts %[next]+1, r19\n\t"
        "sts %[next], r18\n\t"
        "41:\n\t"
        "pop r21\n\t"
        "pop r20\n\t"
        "pop r19\n\t"
        "pop r18\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "sbic %[tifr3], %[ocf3a]\n\t"       /* the clock came while masked: its interrupt */
        "rjmp 44f\n\t"                      /* now, as the CPU would take it after reti */
        "reti\n\t"
        "44: sbi %[tifr3], %[ocf3a]\n\t"    /* (simavr 1.6 would never take it: it does */
        "jmp " CLOCK_VECTOR "\n\t"          /* not look at a flag raised while masked) */
        ::ENTRY_OPERANDS, [left] "i"(&st_ticks_left), [missed] "i"(&st_missed),
          [tifr3] "I"(_SFR_IO_ADDR(TIFR3)), [ocf3a] "n"(OCF3A), [tifr1] "I"(_SFR_IO_ADDR(TIFR1)),
          [ocf1a] "n"(OCF1A), [t1] "M"(TICK_TIMSK), [timsk1] "n"(_SFR_MEM_ADDR(TIMSK1)),
          [ocrah] "n"(_SFR_MEM_ADDR(OCR1AH)), [ocral] "n"(_SFR_MEM_ADDR(OCR1AL)),
          [t3] "M"(_BV(OCIE3A)), [timsk3] "n"(_SFR_MEM_ADDR(TIMSK3)), [fast] "i"(&st_fast));
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmisspelled-isr"
/* The common tick's segment is used up (called from its assembly, r20, r21 and r30 free): the
 * next segment of the same line at the same level is taken at once (its period from the tick
 * after the one just scheduled); a new line, a new level or the end is left to tick_body. */
void seg_boundary_asm(void) __attribute__((naked, used));
void seg_boundary_asm(void)
{
    __asm__ __volatile__(
        "push r31\n\t"
        "lds r20, %[firedh]\n\t"            /* 16 384 events wait to be folded: the next */
        "sbrc r20, 6\n\t"                    /* tick is slow and folds them (st_moved is */
        "rjmp 21f\n\t"                       /* 16-bit) */
        "lds r20, %[flags]\n\t"
        "sbrc r20, %[lastbit]\n\t"
        "rjmp 21f\n\t"
        "lds r30, %[tail]\n\t"
        "lds r21, %[head]\n\t"
        "cp r30, r21\n\t"
        "breq 21f\n\t"
        "mov r21, r30\n\t"                    /* Z = ring + 7 * tail */
        "lsl r21\n\t"
        "lsl r21\n\t"
        "lsl r21\n\t"
        "sub r21, r30\n\t"
        "ldi r30, lo8(%[ring])\n\t"
        "ldi r31, hi8(%[ring])\n\t"
        "add r30, r21\n\t"
        "clr r21\n\t"
        "adc r31, r21\n\t"
        "ldd r20, Z+%[o_flags]\n\t"
        "andi r20, %[newline]\n\t"
        "brne 21f\n\t"
        "ldd r20, Z+%[o_level]\n\t"
        "lds r21, %[level]\n\t"
        "cp r20, r21\n\t"
        "brne 21f\n\t"
        "ldd r20, Z+%[o_flags]\n\t"
        "sts %[flags], r20\n\t"
        "ldd r20, Z+%[o_ticks]\n\t"
        "ldd r21, Z+%[o_ticks]+1\n\t"
        "sts %[left]+1, r21\n\t"
        "sts %[left], r20\n\t"
        "ldd r20, Z+%[o_period]\n\t"
        "ldd r21, Z+%[o_period]+1\n\t"
        "sts %[period]+1, r21\n\t"
        "sts %[period], r20\n\t"
        "lds r20, %[tail]\n\t"
        "inc r20\n\t"
        "cpi r20, %[nseg]\n\t"
        "brne 20f\n\t"
        "clr r20\n\t"
        "20: sts %[tail], r20\n\t"
        "pop r31\n\t"
        "ret\n\t"
        "21: clr r21\n\t"                      /* slowly, from the next tick on */
        "sts %[fast], r21\n\t"
        "lds r20, %[flags]\n\t"
        "sbrc r20, %[lastbit]\n\t"
        "inc r21\n\t"
        "sts %[last], r21\n\t"
        "pop r31\n\t"
        "ret\n\t"
        ::[flags] "i"(&st_seg_flags), [lastbit] "n"(1), [tail] "i"(&st_ring_tail), [head] "i"(&st_ring_head),
          [ring] "i"(st_ring), [o_flags] "n"(offsetof(segment_t, flags)),
          [o_level] "n"(offsetof(segment_t, level)), [o_ticks] "n"(offsetof(segment_t, ticks)),
          [o_period] "n"(offsetof(segment_t, period)), [newline] "M"(SEG_FIRST | SEG_INDEXER),
          [level] "i"(&st_seg_level), [left] "i"(&st_ticks_left), [period] "i"(&st_period),
          [nseg] "M"(SEGMENTS), [fast] "i"(&st_fast), [last] "i"(&st_ev_last),
          [firedh] "i"((uint8_t *)&st_fired + 1));
}

#pragma GCC diagnostic pop
