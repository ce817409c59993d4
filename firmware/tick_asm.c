/* tick_asm.c - the step interrupt's entry, its common tick and the pulse's end, in assembly:
 * the pins must rise and fall a fixed number of cycles after their compares, and a tick must
 * cost few enough cycles for 45 kHz. Only r18-r25, r30, r31 and SREG are used, saved by hand;
 * anything else goes on in tick_body (tick.c). See stepper.c for the design. */
#include <stddef.h>

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
#define SET_NEXT_ASM                                                                        \
    "sts %[ocrah], r19\n\tsts %[ocral], r18\n\tsts %[nx]+1, r19\n\tsts %[nx], r18\n\t"         \
    "movw r20, r18\n\tsubi r20, lo8(-(%[slot]))\n\tsbci r21, hi8(-(%[slot]))\n\t"              \
    "sts %[ocrch], r21\n\tsts %[ocrcl], r20\n\tldi r22, %[ocfc]\n\tout %[tifr], r22\n\t"       \
    "subi r20, lo8(-(%[fallofs]))\n\tsbci r21, hi8(-(%[fallofs]))\n\t"                       \
    "sts %[fall]+1, r21\n\tsts %[fall], r20\n\t"
#define SET_NEXT_OPERANDS                                                                   \
    [ocrah] "n"(_SFR_MEM_ADDR(OCR1AH)), [ocral] "n"(_SFR_MEM_ADDR(OCR1AL)), [nx] "i"(&st_tick_next), \
    [slot] "n"(SLOT_COUNTS), [ocrch] "n"(_SFR_MEM_ADDR(OCR1CH)),                            \
    [ocrcl] "n"(_SFR_MEM_ADDR(OCR1CL)), [ocfc] "M"(_BV(OCF1C)), [tifr] "I"(_SFR_IO_ADDR(TIFR1)), \
    [fall] "i"(&st_fall_at), [fallofs] "n"(PULSE_COUNTS - FALL_LEAD_COUNTS)

/* Lower the step pin of axis i (the pulse's end, in assembly). */
#define FALL_ASM(i, slot)                                                                   \
    if (_SFR_IO_REG_P(PIN_OF(slot, _STEP_PORT)))                                            \
        __asm__ __volatile__("cbi %0, %1\n\t" ::"n"(_SFR_IO_ADDR(PIN_OF(slot, _STEP_PORT))), \
                             "n"(PIN_OF(slot, _STEP_BIT)));                                 \
    else                                                                                    \
        __asm__ __volatile__("lds r24, %0\n\tandi r24, %1\n\tsts %0, r24\n\t"              \
                             ::"n"(_SFR_MEM_ADDR(PIN_OF(slot, _STEP_PORT))),                \
                             "n"(0xFF & ~_BV(PIN_OF(slot, _STEP_BIT))));

/* The tick's entry: the pulse's end is set, the prepared event's pins rise at SLOT_COUNTS after
 * the match, then the rest runs in tick_body with interrupts on (and this compare off). Only
 * r24, r25 and SREG are used here, so the pins rise about 40 cycles after the match. */
ISR(TIMER1_COMPA_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "lds r24, %[busy]\n\t"               /* the last tick's rest still runs: late */
        "tst r24\n\t"
        "breq 8f\n\t"
        "rjmp 9f\n\t"
        "8: push r25\n\t"
        "lds r24, %[bits]\n\t"
        "tst r24\n\t"
        "brne 7f\n\t"
        "rjmp 3f\n\t"
        "7: set\n\t"                          /* T: the slot has passed (a late entry) */
        "lds r24, %[fall]+1\n\t"             /* on time: the pulse ends at fall_at (a late */
        "sts %[ocrh], r24\n\t"               /* entry sets it again, from now) */
        "lds r24, %[fall]\n\t"
        "sts %[ocrl], r24\n\t"
        "sbic %[tifr], %[ocfc]\n\t"          /* checked last, right before the wait: a slot */
        "rjmp 2f\n\t"                        /* passing in between rises a cycle or two late */
        "clt\n\t"
        "1: sbis %[tifr], %[ocfc]\n\t"        /* compare C marks the slot */
        "rjmp 1b\n\t"
        "2: lds r24, %[bits]\n\t"
        "sts %[high], r24\n\t"
        ::[bits] "i"(&st_ev_bits), [fall] "i"(&st_fall_at), [high] "i"(&st_pulse_high),
          [busy] "i"(&st_busy), [ocrh] "n"(_SFR_MEM_ADDR(OCR1BH)), [ocrl] "n"(_SFR_MEM_ADDR(OCR1BL)),
          [tifr] "I"(_SFR_IO_ADDR(TIFR1)), [ocfc] "I"(OCF1C));
    FOR_EACH_AXIS(RISE_ASM)
    __asm__ __volatile__(
        "brtc 3f\n\t"                         /* late: the pulse ends PULSE_COUNTS from now */
        "lds r24, %[tcnt]\n\t"
        "lds r25, %[tcnt]+1\n\t"
        "subi r24, lo8(-(%[pulse]))\n\t"
        "sbci r25, hi8(-(%[pulse]))\n\t"
        "sts %[ocrh], r25\n\t"
        "sts %[ocrl], r24\n\t"
        ::[tcnt] "n"(_SFR_MEM_ADDR(TCNT1L)), [ocrh] "n"(_SFR_MEM_ADDR(OCR1BH)),
          [ocrl] "n"(_SFR_MEM_ADDR(OCR1BL)), [pulse] "n"(PULSE_COUNTS + 1));
    __asm__ __volatile__(
        "3: ldi r24, 1\n\t"
        "sts %[busy], r24\n\t"
        "sei\n\t"                             /* the pulse's end may come now */
        "lds r24, %[fast]\n\t"
        "tst r24\n\t"
        "brne 4f\n\t"
        "pop r25\n\t"                         /* a new segment, line or level: in C */
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "sei\n\t"
        "jmp tick_body\n\t"
        "9: sts %[missed], r24\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        "4: push r18\n\t"                     /* the common tick, from here on */
        "push r19\n\t"
        "push r20\n\t"
        "push r21\n\t"
        "push r22\n\t"
        "push r23\n\t"
        "push r30\n\t"
        "lds r20, %[fired]\n\t"              /* the event just raised: count it, once for */
        "lds r21, %[fired]+1\n\t"            /* the axes that step at every event */
        "subi r20, 0xFF\n\t"
        "sbci r21, 0xFF\n\t"
        "sts %[fired]+1, r21\n\t"
        "sts %[fired], r20\n\t"
        "lds r24, %[always]\n\t"
        "com r24\n\t"
        "lds r20, %[bits]\n\t"
        "and r24, r20\n\t"
        "lds r23, %[neg]\n\t"
        ::[busy] "i"(&st_busy), [missed] "i"(&st_missed), [fast] "i"(&st_fast), [bits] "i"(&st_ev_bits),
          [neg] "i"(&st_ev_neg), [fired] "i"(&st_fired), [always] "i"(&st_always_axes));
    FOR_EACH_AXIS(COUNT_ASM)
    __asm__ __volatile__(
        "lds r18, %[next]\n\t"               /* this match; the next one period later */
        "lds r19, %[next]+1\n\t"
        "sts %[at]+1, r19\n\t"
        "sts %[at], r18\n\t"
        "lds r20, %[period]\n\t"
        "lds r21, %[period]+1\n\t"
        "add r18, r20\n\t"
        "adc r19, r21\n\t"
        "lds r20, %[tcnt]\n\t"
        "lds r21, %[tcnt]+1\n\t"
        "movw r22, r18\n\t"
        "sub r22, r20\n\t"
        "sbc r23, r21\n\t"
        "subi r22, 3\n\t"
        "sbci r23, 0\n\t"
        "brge 15f\n\t"
        "movw r18, r20\n\t"                   /* passed already: at once */
        "subi r18, lo8(-3)\n\t"
        "sbci r19, hi8(-3)\n\t"
        "15:\n\t"
        SET_NEXT_ASM
        "lds r22, %[bres]\n\t"               /* the next event: Bresenham */
        "lds r25, %[always]\n\t"
        ::[next] "i"(&st_tick_next), [at] "i"(&st_tick_at), [period] "i"(&st_period),
          [tcnt] "n"(_SFR_MEM_ADDR(TCNT1L)), [bres] "i"(&st_bres_axes), [always] "i"(&st_always_axes),
          SET_NEXT_OPERANDS);
    FOR_EACH_AXIS(BRES_ASM)
    __asm__ __volatile__(
        "sts %[bits], r25\n\t"
        "lds r20, %[left]\n\t"
        "lds r21, %[left]+1\n\t"
        "subi r20, 1\n\t"
        "sbci r21, 0\n\t"
        "sts %[left]+1, r21\n\t"
        "sts %[left], r20\n\t"
        "brne 16f\n\t"
        "call seg_boundary_asm\n\t"         /* the segment is used up: what comes next */
        "16: cli\n\t"
        "lds r24, %[missed]\n\t"             /* a match came meanwhile: take it at once */
        "tst r24\n\t"
        "breq 17f\n\t"
        "clr r24\n\t"
        "sts %[missed], r24\n\t"
        "lds r18, %[tcnt]\n\t"
        "lds r19, %[tcnt]+1\n\t"
        "subi r18, lo8(-3)\n\t"
        "sbci r19, hi8(-3)\n\t"
        SET_NEXT_ASM
        "17: clr r24\n\t"
        "sts %[busy], r24\n\t"
        "pop r30\n\t"
        "pop r23\n\t"
        "pop r22\n\t"
        "pop r21\n\t"
        "pop r20\n\t"
        "pop r19\n\t"
        "pop r18\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        ::[bits] "i"(&st_ev_bits), [left] "i"(&st_ticks_left), [missed] "i"(&st_missed), [busy] "i"(&st_busy),
          [tcnt] "n"(_SFR_MEM_ADDR(TCNT1L)), [next] "i"(&st_tick_next), SET_NEXT_OPERANDS);
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
          [nseg] "M"(SEGMENTS), [fast] "i"(&st_fast), [last] "i"(&st_ev_last));
}

/* The pulse's end: a few cycles after its match, in assembly (r24 and SREG only); a direction
 * change waiting for it goes on in dir_body. */
ISR(TIMER1_COMPB_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t");
    FOR_EACH_AXIS(FALL_ASM)
    __asm__ __volatile__(
        "clr r24\n\t"
        "sts %[high], r24\n\t"
        "lds r24, %[pending]\n\t"
        "tst r24\n\t"
        "pop r24\n\t"
        "breq 5f\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "jmp dir_body\n\t"
        "5: out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        ::[high] "i"(&st_pulse_high), [pending] "i"(&st_dir_pending));
}



void dir_body(void) __attribute__((signal, used, externally_visible));
void dir_body(void)
{
    write_directions(st_dir_next);
    st_dir_pending = 0;
}
#pragma GCC diagnostic pop
