/* tick_slow.c - in assembly, the entry of any tick the common one (tick_asm.c) does not serve:
 * the pins rise at the slot as there, then tick_body (tick.c) goes on with interrupts on; and the
 * pulse's end by compare B. See stepper.c for the design. */
#include "tick_asm.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmisspelled-isr"
/* Any other tick (a new line or AMASS level, switches to watch, the end): the pins rise at the
 * slot as in the common tick, a short pulse ends here too (a longer one by compare B's
 * interrupt), then tick_body (tick.c) runs with interrupts on. A match that comes while
 * tick_body still runs is marked missed. */
void slow_entry(void) __attribute__((naked, used));
void slow_entry(void)
{
    __asm__ __volatile__(
        "lds r24, %[busy]\n\t"               /* the last tick's rest still runs: late */
        "tst r24\n\t"
        "breq 8f\n\t"
        "rjmp 9f\n\t"
        "8: push r25\n\t"
        "lds r24, %[bits]\n\t"
        "tst r24\n\t"
        "brne 7f\n\t"
        "rjmp 3f\n\t"
        "7:\n\t"
#if !FALL_IN_TICK
        "lds r24, %[next]\n\t"               /* on time: the pulse ends a fixed count after */
        "lds r25, %[next]+1\n\t"             /* the match (a late entry sets it again) */
        "subi r24, lo8(-(%[fallofs]))\n\t"
        "sbci r25, hi8(-(%[fallofs]))\n\t"
        "sts %[ocrbh], r25\n\t"
        "sts %[ocrbl], r24\n\t"
#endif
        "push r23\n\t"
        "set\n\t"                             /* T: the slot had come at the first look */
        "lds r25, %[next]\n\t"                /* (late, or when in its count unknown) */
        "subi r25, lo8(-(%[slot]))\n\t"
        "lds r24, %[bits]\n\t"
        "lds r23, %[tcntl]\n\t"
        "sub r23, r25\n\t"
        "brpl 2f\n\t"
        "clt\n\t"
        "1: lds r23, %[tcntl]\n\t"             /* the pins rise as soon as in the common tick */
        "sub r23, r25\n\t"
        "brmi 1b\n\t"
        "2:\n\t"
#if FALL_IN_TICK
        "add r23, r25\n\t"                    /* the count they rise in */
#endif
        ::ENTRY_OPERANDS, [fallofs] "n"(SLOT_COUNTS + FALL_AFTER_RISE_COUNTS));
    FOR_EACH_AXIS(RISE_ASM)
#if FALL_IN_TICK
    __asm__ __volatile__(
        "ldi r24, 1\n\t"                      /* (while the pulse is high) */
        "sts %[busy], r24\n\t"
        "subi r23, lo8(-(%[pulse1]))\n\t"     /* a short pulse ends here too, as in the */
        "4: lds r25, %[tcntl]\n\t"            /* common tick (and 4 cycles more: the last */
        "sub r25, r23\n\t"                    /* axis's pin falls 3 cycles nearer its rise */
        "brmi 4b\n\t"                         /* than the first's) */
        "rjmp .+0\n\t"
        "rjmp .+0\n\t"
        ::ENTRY_OPERANDS, [pulse1] "n"(PULSE_COUNTS + 1));
    FOR_EACH_AXIS(FALL_ASM)
    __asm__ __volatile__(
        "sei\n\t"                            /* the pins are done: interrupts on at once */
        "pop r23\n\t"
        "rjmp 10f\n\t"
        ::ENTRY_OPERANDS);
#else
    __asm__ __volatile__(
        "sts %[high], r24\n\t"
        "brtc 4f\n\t"                         /* late: the pulse ends from the count read */
        "lds r24, %[tcntl]\n\t"             /* after the rise (the count seen before it may */
        "lds r25, %[tcnth]\n\t"             /* end just before the pins rise: a Z pulse */
        "subi r24, lo8(-(%[after]))\n\t"    /* was one cycle short so) */
        "sbci r25, hi8(-(%[after]))\n\t"
        "sts %[ocrbh], r25\n\t"
        "sts %[ocrbl], r24\n\t"
        "4: pop r23\n\t"
        ::ENTRY_OPERANDS, [after] "n"(FALL_AFTER_RISE_COUNTS));
#endif
    __asm__ __volatile__(
        "3: ldi r24, 1\n\t"
        "sts %[busy], r24\n\t"
        "10: pop r25\n\t"
        "pop r24\n\t"
        "ori r24, 0x80\n\t"                 /* the pulse's end may come now */
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "jmp tick_body\n\t"
        "9: sts %[missed], r24\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        ::ENTRY_OPERANDS, [missed] "i"(&st_missed));
}

/* The pulse's end: compare B comes FALL_EARLY_COUNTS early, the pins fall when the counter
 * reaches the end's count (at once if it has passed, or if this is no pulse's compare at all);
 * r24, r25 and SREG only. A direction change waiting for it goes on in dir_body. */
ISR(TIMER1_COMPB_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "push r25\n\t"
        "lds r25, %[ocrbl]\n\t"
        "subi r25, lo8(-(%[early]))\n\t"
        "lds r24, %[tcntl]\n\t"
        "sub r24, r25\n\t"
        "cpi r24, lo8(-(%[early]))\n\t"      /* not within the counts before the end: now */
        "brlo 2f\n\t"
        "1: lds r24, %[tcntl]\n\t"            /* else wait for the end's count */
        "sub r24, r25\n\t"
        "brmi 1b\n\t"
        "rjmp .+0\n\t"                        /* (4 cycles: a Z pin falls 3-10 cycles after */
        "rjmp .+0\n\t"                        /* the width, X 5-13) */
        "2:\n\t"
        ::[ocrbl] "n"(_SFR_MEM_ADDR(OCR1BL)), [tcntl] "n"(_SFR_MEM_ADDR(TCNT1L)),
          [early] "n"(FALL_EARLY_COUNTS));
    FOR_EACH_AXIS(FALL_ASM)
#if FALL_IN_TICK
    __asm__ __volatile__(                     /* only the encoder's pulses come here: once */
        "lds r24, %[timsk]\n\t"
        "andi r24, %[off]\n\t"
        "sts %[timsk], r24\n\t"
        ::[timsk] "n"(_SFR_MEM_ADDR(TIMSK1)), [off] "n"(0xFF & ~_BV(OCIE1B)));
#endif
    __asm__ __volatile__(
        "pop r25\n\t"
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
