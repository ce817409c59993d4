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
static volatile int16_t moved[N_AXES];           /* ... plus the steps counted since its update */

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

/* The Bresenham increments at AMASS level `level`; at level 0 an axis that steps at every
 * event needs no arithmetic. */
static void set_level(uint8_t level)
{
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
        "lds r25, %[fast]\n\t"
        "tst r25\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "brne 4f\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "sei\n\t"
        "jmp tick_body\n\t"
        "4: out __SREG__, r24\n\t"
        "pop r24\n\t"
        "sei\n\t"
        "jmp tick_fast\n\t"
        "9: sts %[missed], r24\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n\t"
        ::[busy] "i"(&busy), [missed] "i"(&missed), [fast] "i"(&fast));
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

/* The common tick: the same as tick_body within a segment of a line without switches to watch,
 * with nothing else to do, so it saves few registers. */
void tick_fast(void) __attribute__((signal, used, externally_visible));
void tick_fast(void)
{
    uint8_t bits = ev_bits;
    tick_at = tick_next;
    if (bits && ev_count) {
        uint8_t neg = ev_neg;
        FOR_EACH_AXIS(COUNT)
    }
    uint8_t b = always_axes, bres = bres_axes;
    FOR_EACH_AXIS(BRESENHAM)
    ev_bits = b;
    uint16_t next_period = period;             /* of the event after this one */
    if (--ticks_left == 0) {                   /* the segment's last event: what comes next */
        uint8_t t = ring_tail;
        const segment_t *s = &ring[t];
        if ((seg_flags & SEG_LAST) || t == ring_head || (s->flags & (SEG_FIRST | SEG_INDEXER)) ||
            s->level != seg_level) {
            fast = 0;                          /* a new line, a new level or the end: slowly */
            ev_last = (seg_flags & SEG_LAST) != 0;
        } else {                               /* the next segment of the same line */
            seg_flags = s->flags;
            ticks_left = s->ticks;
            next_period = s->period;
            ring_tail = (uint8_t)(t + 1 == SEGMENTS ? 0 : t + 1);
        }
    }
    schedule();                                /* 16-bit writes: no other interrupt uses */
    period = next_period;                      /* the timer's TEMP register meanwhile */
    finish_tick();
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
