/* stepper.c - phase two of 002's path planner: Bresenham over prepared segments.
 *
 * Timer1 counts freely at 2 MHz (normal mode: no compare value ever resets the counter). Each
 * compare match on OCR1A is one tick. The tick's event - which axes step - was computed in the
 * tick before, so the interrupt raises those step pins first thing, at a fixed count after the
 * match (SLOT_COUNTS: whatever delayed its entry is absorbed, and the period from rise to rise
 * is exact to a count). The compare OCR1B, PULSE_COUNTS after the rise, ends the pulse in an
 * interrupt of its own ('dunu'), and the same compare changes the direction pins when the next
 * event belongs to a line going another way, so each direction change comes after a pulse's end
 * and one step period minus the pulse before the next rise. The next match is scheduled at the
 * previous one plus the segment's period, never at a count the counter has passed: a late
 * interrupt stretches one tick and nothing waits for the 16-bit wrap.
 *
 * After the rise the interrupt runs with interrupts on: it counts the positions and prepares
 * the next event (Bresenham over the line's steps at the segment's AMASS level), taking the next
 * segment from the ring when the current one is used up. Under ISTP the spindle encoder's clock
 * (ICLK, INT0) performs the events of the line instead, from the next indexer start pulse (SIND,
 * INT1) on, so a thread pass always starts at the same spindle angle. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stddef.h>
#include <util/atomic.h>

#include "board.h"
#include "planner.h"
#include "stepper.h"
#include "switches.h"

#define PASTE(a, b, c) a##b##c
#define PIN_OF(slot, what) PASTE(RAMPS_, slot, what)

#define PULSE_COUNTS US_TO_COUNTS(PULSE_HIGH_US)
/* The pins rise this many counts after the match: the interrupt's entry and register saves
 * (about 60 cycles) plus the longest time another interrupt or an interrupts-off stretch may
 * hold it off. */
#ifndef SLOT_COUNTS
#define SLOT_COUNTS 9
#endif
/* From a wake-up (the first segment, or the end of an ISTP line) to the first tick. */
#define WAKE_COUNTS (PULSE_COUNTS + SLOT_COUNTS + 40)
/* The pulse's end is set this many counts early: the end's interrupt lowers the pins about as
 * much later after its match as the entry raised them after the slot. */
#ifndef FALL_LEAD_COUNTS
#define FALL_LEAD_COUNTS (-1)
#endif

line_t stepper_lines[LINES];
static segment_t ring[SEGMENTS];
static volatile uint8_t ring_head, ring_tail;   /* the main loop writes head, the interrupt tail */

enum { IDLE, TICKING, ENCODER };
static volatile uint8_t state, halted, events, index_seen, index_wait, pulse_high;
static volatile uint8_t stepped_negative = 0xFF;  /* bit i: axis i last stepped towards - */
static int32_t position[N_AXES];                 /* 002's actual position, steps, ... */
static volatile int16_t moved[N_AXES];           /* ... plus the steps counted since its update, */
static volatile uint16_t fired;                   /* and events of the axes that step every one */

/* The running segment and its line. */
static const line_t *ln;
static uint8_t seg_flags, seg_level, bres_axes, always_axes;
static uint16_t ticks_left, period, tick_at, tick_next;
static int32_t counter[N_AXES];                  /* Bresenham's error term minus the base */
static uint32_t inc[N_AXES], base, enc_left;
/* The event of the next tick, and when its pins rise and fall (read by the interrupt's entry). */
static volatile uint8_t ev_bits;
static uint8_t ev_neg, ev_count, ev_last;
static uint16_t fall_at;
static uint8_t pin_dirs;                          /* bit i set: axis i's pin says negative */
static volatile uint8_t dir_pending, dir_next;
static volatile uint8_t busy, missed;             /* tick_body runs; a match came meanwhile */
static uint8_t plain, fast;       /* a line without switches to watch; the next tick is plain */

/* ---- pins ---------------------------------------------------------------------------- */

/* Raise the step pin of axis i if bit i of r24 is set (the tick's entry, in assembly). */
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
                         ::[b] "n"(i), [m] "i"(&moved[i]));
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
                         ::[b] "n"(i), [c] "i"(&counter[i]), [n] "i"(&inc[i]), [k] "i"(&base), \
                           [mask] "n"(1 << (i)));
#define SET_NEXT_ASM                                                                        \
    "sts %[ocrah], r19\n\tsts %[ocral], r18\n\tsts %[nx]+1, r19\n\tsts %[nx], r18\n\t"         \
    "movw r20, r18\n\tsubi r20, lo8(-(%[slot]))\n\tsbci r21, hi8(-(%[slot]))\n\t"              \
    "sts %[ocrch], r21\n\tsts %[ocrcl], r20\n\tldi r22, %[ocfc]\n\tout %[tifr], r22\n\t"       \
    "subi r20, lo8(-(%[fallofs]))\n\tsbci r21, hi8(-(%[fallofs]))\n\t"                       \
    "sts %[fall]+1, r21\n\tsts %[fall], r20\n\t"
#define SET_NEXT_OPERANDS                                                                   \
    [ocrah] "n"(_SFR_MEM_ADDR(OCR1AH)), [ocral] "n"(_SFR_MEM_ADDR(OCR1AL)), [nx] "i"(&tick_next), \
    [slot] "n"(SLOT_COUNTS), [ocrch] "n"(_SFR_MEM_ADDR(OCR1CH)),                            \
    [ocrcl] "n"(_SFR_MEM_ADDR(OCR1CL)), [ocfc] "M"(_BV(OCF1C)), [tifr] "I"(_SFR_IO_ADDR(TIFR1)), \
    [fall] "i"(&fall_at), [fallofs] "n"(PULSE_COUNTS - FALL_LEAD_COUNTS)

/* Lower the step pin of axis i (the pulse's end, in assembly). */
#define FALL_ASM(i, slot)                                                                   \
    if (_SFR_IO_REG_P(PIN_OF(slot, _STEP_PORT)))                                            \
        __asm__ __volatile__("cbi %0, %1\n\t" ::"n"(_SFR_IO_ADDR(PIN_OF(slot, _STEP_PORT))), \
                             "n"(PIN_OF(slot, _STEP_BIT)));                                 \
    else                                                                                    \
        __asm__ __volatile__("lds r24, %0\n\tandi r24, %1\n\tsts %0, r24\n\t"              \
                             ::"n"(_SFR_MEM_ADDR(PIN_OF(slot, _STEP_PORT))),                \
                             "n"(0xFF & ~_BV(PIN_OF(slot, _STEP_BIT))));
#define STEP_HIGH(i, slot) \
    if (bits & (1 << (i))) PIN_OF(slot, _STEP_PORT) |= _BV(PIN_OF(slot, _STEP_BIT));
#define STEP_LOW(i, slot) PIN_OF(slot, _STEP_PORT) &= (uint8_t)~_BV(PIN_OF(slot, _STEP_BIT));
/* Direction: pin high = positive (003: 5 V = right), unless the axis inverts it. */
#define DIR_SET(i, slot)                                                          \
    if ((((dirs >> (i)) & 1) ^ ((DIR_INVERT >> (i)) & 1)) == 0)                   \
        PIN_OF(slot, _DIR_PORT) |= _BV(PIN_OF(slot, _DIR_BIT));                   \
    else                                                                          \
        PIN_OF(slot, _DIR_PORT) &= (uint8_t)~_BV(PIN_OF(slot, _DIR_BIT));
#define PINS_OUT(i, slot)                                                         \
    PIN_OF(slot, _STEP_DDR) |= _BV(PIN_OF(slot, _STEP_BIT));                      \
    PIN_OF(slot, _DIR_DDR) |= _BV(PIN_OF(slot, _DIR_BIT));                        \
    PIN_OF(slot, _EN_DDR) |= _BV(PIN_OF(slot, _EN_BIT));                          \
    PIN_OF(slot, _EN_PORT) &= (uint8_t)~_BV(PIN_OF(slot, _EN_BIT)); /* enabled */
/* One Bresenham event of axis i into the step bits b; the term runs from -base to 0. */
#define BRESENHAM(i, slot)                                                        \
    if (bres & (1 << (i))) {                                                      \
        counter[i] += inc[i];                                                     \
        if (counter[i] >= 0) {                                                    \
            counter[i] -= base;                                                   \
            b |= (uint8_t)(1 << (i));                                             \
        }                                                                         \
    }
#define COUNT(i, slot)                                                            \
    if (bits & (1 << (i))) {                                                      \
        if (neg & (1 << (i)))                                                     \
            moved[i]--;                                                           \
        else                                                                      \
            moved[i]++;                                                           \
    }
/* The axes whose limit switches stop them (switches.c checks which is actuated). */
#define SWITCH(id, axis, side, kind, stop, bit) | ((kind) == SW_LIMIT ? 1 << (axis) : 0)
#define LIMIT_AXES (0 SWITCHES)

static inline void write_directions(uint8_t dirs)
{
    FOR_EACH_AXIS(DIR_SET)
}

/* The direction pins of a new line: at once when no pulse is high, else at its end. */
static void set_directions(uint8_t dirs)
{
    if (dirs == pin_dirs)
        return;
    pin_dirs = dirs;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        if (pulse_high) {
            dir_next = dirs;
            dir_pending = 1;
        } else
            write_directions(dirs);
    }
}

/* ---- the interrupt's side ------------------------------------------------------------- */

/* The next match at count t, and when its pins rise (compare C) and fall (fall_at).
 * schedule() puts it one period after this one, never at a count the counter has passed. */
static inline __attribute__((always_inline)) void set_next(uint16_t t)
{
    OCR1A = t;
    tick_next = t;
    OCR1C = t + SLOT_COUNTS;                   /* its flag marks when the pins rise */
    TIFR1 = _BV(OCF1C);
    fall_at = t + (uint16_t)(SLOT_COUNTS + PULSE_COUNTS - FALL_LEAD_COUNTS);
}

static inline __attribute__((always_inline)) void schedule(void)
{
    uint16_t t = tick_at + period;
    if ((int16_t)(t - TCNT1) < 3)
        t = TCNT1 + 3;
    set_next(t);
}

/* The end of a tick's rest: a match that came meanwhile is taken at once. */
static inline __attribute__((always_inline)) void finish_tick(void)
{
    cli();
    if (missed) {
        missed = 0;
        set_next(TCNT1 + 3);
    }
    busy = 0;
    sei();
}

static void halt(uint8_t why)
{
    events |= why | EV_DONE;
    halted = 1;                                /* no wake-up until the main loop flushes */
    state = IDLE;
    ev_bits = 0;
}

/* The events counted once for the axes that step at every one, into each axis's count (before
 * that set of axes or their directions change). */
static void fold_fired(void)
{
    uint16_t n = fired;
    fired = 0;
    for (uint8_t i = 0; i < N_AXES; i++)
        if (always_axes & (1 << i))
            moved[i] += (ev_neg >> i) & 1 ? -(int16_t)n : (int16_t)n;
}

/* The Bresenham increments at AMASS level `level`; at level 0 an axis that steps at every
 * event needs no arithmetic. */
static void set_level(uint8_t level)
{
    fold_fired();
    seg_level = level;
    bres_axes = always_axes = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        uint32_t steps = ln->steps[i];
        inc[i] = steps >> level;
        if (!steps)
            continue;
        if (!level && steps == base)
            always_axes |= (uint8_t)(1 << i);
        else
            bres_axes |= (uint8_t)(1 << i);
    }
}

/* A new line: Bresenham's terms at the mid-point, its directions. */
static void begin_line(uint8_t index)
{
    fold_fired();
    ln = &stepper_lines[index];
    base = ln->base;
    uint8_t moving = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        counter[i] = -(int32_t)(base >> 1);
        if (ln->steps[i])
            moving |= (uint8_t)(1 << i);
    }
    plain = ln->kind == MOVE_LINE && !(moving & LIMIT_AXES);
    set_directions(ln->dir_bits);
    stepped_negative = (uint8_t)((stepped_negative & ~moving) | (ln->dir_bits & moving));
    seg_level = 0xFF;
}

/* Take the next segment; 0 when there is none to tick (the end, or an ISTP line). */
static uint8_t next_segment(void)
{
    uint8_t t = ring_tail;
    if (t == ring_head) {
        state = IDLE;                          /* the end of what was prepared */
        ev_bits = 0;
        return 0;
    }
    const segment_t *s = &ring[t];
    seg_flags = s->flags;
    if (seg_flags & SEG_FIRST)
        begin_line(s->line);
    uint8_t level = s->level;
    uint16_t ticks = s->ticks, p = s->period;
    ring_tail = (uint8_t)(t + 1 == SEGMENTS ? 0 : t + 1);
    if (level != seg_level)
        set_level(level);
    if (seg_flags & SEG_INDEXER) {
        state = ENCODER;                       /* the encoder's clock takes over */
        enc_left = base;
        index_wait = !ln->chained;             /* a thread pass waits for SIND */
        ev_bits = 0;
        return 0;
    }
    ticks_left = ticks;
    period = p;
    return 1;
}

/* Prepare the event of the next tick. */
static inline void prepare(void)
{
    if (!ticks_left && !next_segment())
        return;
    ticks_left--;
    uint8_t b = always_axes, bres = bres_axes;
    FOR_EACH_AXIS(BRESENHAM)
    const line_t *l = ln;
    uint8_t kind = l->kind;
    if (kind != MOVE_LINE) {
        if (kind != MOVE_TAKEUP && switch_on(l->watch) == (kind == MOVE_SEEK)) {
            halt(EV_SWITCH);                   /* the homing switch closed / opened */
            return;
        }
    }
    if ((b & LIMIT_AXES) && kind != MOVE_TAKEUP && switch_blocks(b, l->dir_bits)) {
        halt(EV_LIMIT);                        /* a limit switch: everything stops here */
        return;
    }
    ev_neg = l->dir_bits;
    ev_count = kind != MOVE_TAKEUP;            /* take-up steps do not move the position */
    ev_last = !ticks_left && (seg_flags & SEG_LAST) && kind != MOVE_TAKEUP;
    ev_bits = b;
}

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
        "sbic %[tifr], %[ocfc]\n\t"
        "rjmp 2f\n\t"
        "clt\n\t"
        "lds r24, %[fall]+1\n\t"             /* on time: the pulse ends at fall_at */
        "sts %[ocrh], r24\n\t"
        "lds r24, %[fall]\n\t"
        "sts %[ocrl], r24\n\t"
        "1: sbis %[tifr], %[ocfc]\n\t"        /* compare C marks the slot */
        "rjmp 1b\n\t"
        "2: lds r24, %[bits]\n\t"
        "sts %[high], r24\n\t"
        ::[bits] "i"(&ev_bits), [fall] "i"(&fall_at), [high] "i"(&pulse_high),
          [busy] "i"(&busy), [ocrh] "n"(_SFR_MEM_ADDR(OCR1BH)), [ocrl] "n"(_SFR_MEM_ADDR(OCR1BL)),
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
        ::[busy] "i"(&busy), [missed] "i"(&missed), [fast] "i"(&fast), [bits] "i"(&ev_bits),
          [neg] "i"(&ev_neg), [fired] "i"(&fired), [always] "i"(&always_axes));
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
        ::[next] "i"(&tick_next), [at] "i"(&tick_at), [period] "i"(&period),
          [tcnt] "n"(_SFR_MEM_ADDR(TCNT1L)), [bres] "i"(&bres_axes), [always] "i"(&always_axes),
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
        ::[bits] "i"(&ev_bits), [left] "i"(&ticks_left), [missed] "i"(&missed), [busy] "i"(&busy),
          [tcnt] "n"(_SFR_MEM_ADDR(TCNT1L)), [next] "i"(&tick_next), SET_NEXT_OPERANDS);
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmisspelled-isr"
void tick_body(void) __attribute__((signal, used, externally_visible));
void tick_body(void)
{
    uint8_t bits = ev_bits;
    tick_at = tick_next;                       /* the match being served */
    if (bits && ev_count) {
        uint8_t neg = ev_neg;
        FOR_EACH_AXIS(COUNT)
    }
    if (ev_last) {
        ev_last = 0;
        events |= EV_DONE;
    }
    prepare();
    fast = plain && ticks_left && !ev_last;
    cli();
    if (state != TICKING)
        TIMSK1 = _BV(OCIE1B);
    sei();
    schedule();                                /* the next segment's period is known now */
    finish_tick();
}

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
        ::[flags] "i"(&seg_flags), [lastbit] "n"(1), [tail] "i"(&ring_tail), [head] "i"(&ring_head),
          [ring] "i"(ring), [o_flags] "n"(offsetof(segment_t, flags)),
          [o_level] "n"(offsetof(segment_t, level)), [o_ticks] "n"(offsetof(segment_t, ticks)),
          [o_period] "n"(offsetof(segment_t, period)), [newline] "M"(SEG_FIRST | SEG_INDEXER),
          [level] "i"(&seg_level), [left] "i"(&ticks_left), [period] "i"(&period),
          [nseg] "M"(SEGMENTS), [fast] "i"(&fast), [last] "i"(&ev_last));
}
#pragma GCC diagnostic pop

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
        ::[high] "i"(&pulse_high), [pending] "i"(&dir_pending));
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmisspelled-isr"
void dir_body(void) __attribute__((signal, used, externally_visible));
void dir_body(void)
{
    write_directions(dir_next);
    dir_pending = 0;
}
#pragma GCC diagnostic pop

/* Start ticking when segments wait and nothing steps (interrupts off). */
static void wake(void)
{
    if (state != IDLE || halted || ring_tail == ring_head)
        return;
    state = TICKING;
    ev_bits = ev_last = fast = 0;
    ticks_left = 0;
    tick_at = TCNT1;
    period = WAKE_COUNTS;                      /* the first tick takes the first segment */
    schedule();
    TIFR1 = _BV(OCF1A);
    TIMSK1 = _BV(OCIE1A) | _BV(OCIE1B);
}

/* ICLK: one encoder count of the spindle is one Bresenham event of an ISTP line. */
ISR(INT0_vect)
{
    if (state != ENCODER || index_wait)
        return;
    if (pulse_high) {                          /* steps this close: end the last pulse early */
        FOR_EACH_AXIS(STEP_LOW)
        pulse_high = 0;
    }
    uint8_t b = 0, bres = bres_axes | always_axes;
    FOR_EACH_AXIS(BRESENHAM)
    if ((b & LIMIT_AXES) && switch_blocks(b, ln->dir_bits)) {
        halt(EV_LIMIT);
        return;
    }
    if (b) {
        uint8_t bits = b, neg = ln->dir_bits;
        FOR_EACH_AXIS(STEP_HIGH)
        OCR1B = TCNT1 + PULSE_COUNTS;
        pulse_high = 1;
        FOR_EACH_AXIS(COUNT)
    }
    if (--enc_left == 0) {
        events |= EV_DONE;
        state = IDLE;
        wake();                                /* the next segments, on the timer again */
    }
}

/* SIND: the indexer start, once a spindle revolution. */
ISR(INT1_vect)
{
    index_seen = 1;
    if (state == ENCODER)
        index_wait = 0;                        /* the thread starts at this spindle angle */
}

/* ---- main-loop side ------------------------------------------------------------------- */

void stepper_init(void)
{
    FOR_EACH_AXIS(PINS_OUT)
    pin_dirs = (uint8_t)(~DIR_INVERT & ((1 << N_AXES) - 1));   /* low pins, as after reset */
    TCCR1A = 0;
    TCCR1B = _BV(CS11);                        /* normal mode, clock / 8: 2 MHz, never reset */
    TIMSK1 = 0;
    ICLK_PORT |= _BV(ICLK_BIT);                /* pull-ups on the indexer inputs */
    SIND_PORT |= _BV(SIND_BIT);
    EICRA = _BV(ISC01) | _BV(ISC00) | _BV(ISC11) | _BV(ISC10);   /* rising edges */
    EIMSK = _BV(INT0) | _BV(INT1);
}

segment_t *stepper_slot(void)
{
    uint8_t next = (uint8_t)(ring_head + 1 == SEGMENTS ? 0 : ring_head + 1);
    return next == ring_tail ? 0 : &ring[ring_head];
}

void stepper_push(void)
{
    ring_head = (uint8_t)(ring_head + 1 == SEGMENTS ? 0 : ring_head + 1);
}

uint8_t stepper_queued(void)
{
    int8_t n = (int8_t)(ring_head - ring_tail);
    return (uint8_t)(n < 0 ? n + SEGMENTS : n);
}

void stepper_start(void)
{
    if (state == IDLE)
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { wake(); }
}

uint8_t stepper_busy(void)
{
    return state != IDLE || ring_head != ring_tail;
}

void stepper_stop(void)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        TIMSK1 = 0;
        fold_fired();
        FOR_EACH_AXIS(STEP_LOW)
        if (dir_pending)
            write_directions(dir_next);
        dir_pending = 0;
        state = IDLE;
        halted = 0;
        ring_head = ring_tail = 0;
        ticks_left = 0;
        pulse_high = 0;
        ev_bits = ev_last = fast = 0;
        busy = missed = 0;
        events = 0;
    }
}

uint8_t stepper_take_events(void)
{
    uint8_t e;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        e = events;
        events = 0;
    }
    return e;
}

/* The steps the interrupt counted in 16 bits go into the 32-bit position (a few at a time, so
 * the interrupts stay off only for one axis's sum). */
void stepper_fold(void)
{
    uint16_t n;
    uint8_t mask, neg;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        n = fired;
        fired = 0;
        mask = always_axes;
        neg = ev_neg;
    }
    for (uint8_t i = 0; i < N_AXES; i++)
        if (mask & (1 << i))
            position[i] += (neg >> i) & 1 ? -(int32_t)n : (int32_t)n;
    for (uint8_t i = 0; i < N_AXES; i++) {
        int16_t m;
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
            m = moved[i];
            moved[i] = 0;
        }
        position[i] += m;
    }
}

void stepper_position(int32_t *steps)
{
    stepper_fold();
    for (uint8_t i = 0; i < N_AXES; i++)
        steps[i] = position[i];
}

void stepper_set_position(uint8_t axis, int32_t steps)
{
    stepper_fold();
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        position[axis] = steps;
        moved[axis] = 0;
    }
}

void stepper_directions(int8_t *dirs)
{
    uint8_t negative = stepped_negative;
    for (uint8_t i = 0; i < N_AXES; i++)
        dirs[i] = (negative >> i) & 1 ? -1 : 1;
}

uint8_t stepper_index_seen(void) { return index_seen; }

void stepper_clear_index_seen(void) { index_seen = 0; }
