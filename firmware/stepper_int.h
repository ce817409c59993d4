/* stepper_int.h - what the step generator's files share: the interrupt's state, the pins of
 * the RAMPS sockets, the timing constants, the running line's bookkeeping. stepper_core.c
 * defines the state and the functions below; encoder.c the enc_ ones; tick*.c (the timer's
 * ticks) and stepper.c (the main loop's side) use them, and nothing here calls back into those.
 * Not for others. */
#ifndef STEPPER_INT_H
#define STEPPER_INT_H

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
/* The pins rise when the counter reaches the match plus this many counts (80 cycles): the
 * interrupt's entry and register saves (about 42 cycles) plus the time another interrupt or an
 * interrupts-off stretch may hold it off (the 1 ms clock's and the serial interrupts' first
 * cycles, 10-20). */
#ifndef SLOT_COUNTS
#define SLOT_COUNTS 10
#endif
/* From a wake-up (the first segment, or the end of an ISTP line) to the first tick. */
#define WAKE_COUNTS (PULSE_COUNTS + SLOT_COUNTS + 40)
/* Compare B's interrupt ends a pulse: it comes FALL_EARLY_COUNTS before the count the pulse
 * ends at and waits for that count itself, so its entry's delay (10-20 cycles, whatever it
 * waited for) does not lengthen the pulse. A pulse that rose in count c ends at the start of
 * c + PULSE_COUNTS + 1: 0.2-0.8 us longer than configured, never shorter. */
#define FALL_EARLY_COUNTS (PULSE_COUNTS >= 4 ? 3 : 1)
#define FALL_AFTER_RISE_COUNTS (PULSE_COUNTS + 1 - FALL_EARLY_COUNTS)   /* compare B - c */
/* A pulse this short (the bench's 2 us) ends inside the common tick, after a wait that the
 * tick's own work fills; a longer one ends in compare B's interrupt. */
#ifndef FALL_IN_TICK_MAX_COUNTS
#define FALL_IN_TICK_MAX_COUNTS 6
#endif
#define FALL_IN_TICK (PULSE_HIGH_US * (F_CPU / 8000000UL) <= FALL_IN_TICK_MAX_COUNTS)
/* Compare B's interrupt is on only while it may have a pulse to end: always while the timer
 * ticks when the pulses end there, else only for the encoder's pulses (then it turns itself
 * off). A compare left on with nothing to end would come at every wrap of the free-running
 * counter, every 32.8 ms, and could hold a tick's entry back by its 57 cycles. */
#define TICK_TIMSK (_BV(OCIE1A) | (FALL_IN_TICK ? 0 : _BV(OCIE1B)))
#define IDLE_TIMSK (FALL_IN_TICK ? 0 : _BV(OCIE1B))     /* (the last tick's pulse) */


extern segment_t st_ring[SEGMENTS];
extern volatile uint8_t st_ring_head, st_ring_tail;   /* the main loop writes head, the interrupt tail */

enum { IDLE, TICKING, ENCODER };
extern volatile uint8_t st_state, st_halted, st_events, st_index_seen, st_index_wait, st_pulse_high;
extern volatile uint8_t st_stepped_negative;  /* bit i: axis i last stepped towards - */
extern int32_t st_position[N_AXES];                 /* 002's actual position, steps, ... */
extern volatile int16_t st_moved[N_AXES];           /* ... plus the steps it counted, */
extern volatile uint16_t st_fired;                   /* and events of the axes that step every one */
/* st_moved counts freely (16-bit, wrapping): the main loop folds what it gained into the 32-bit
 * position (stepper_fold), and the interrupt into the running line's count st_line_acc at least
 * every 16 384 events (line_absorb); neither writes what the other reads. */
extern int16_t st_moved_seen[N_AXES];
extern int32_t st_line_acc[N_AXES];
extern volatile uint8_t st_fold_seq;                /* fold_fired() calls (mod 256) */

/* The running segment and its line. */
extern const line_t *st_ln;
extern uint8_t st_seg_flags, st_seg_level, st_bres_axes, st_always_axes;
extern uint16_t st_ticks_left, st_period, st_tick_at, st_tick_next;
extern int32_t st_counter[N_AXES];                  /* Bresenham's error term minus the base */
extern uint32_t st_inc[N_AXES], st_base, st_enc_left;
/* The event of the next tick (read by the interrupt's entry). */
extern volatile uint8_t st_ev_bits, st_enc_bits;   /* (the next encoder count's) */
/* ISTP: the next count is an event; counts to wait after the index, counts of lead-in left;
 * the lead-in's k^2, 2k + 1, the k^2 of its next event (4 L e + 2 L), 4 L */
extern uint8_t st_enc_ev;
extern uint16_t st_enc_wait, st_enc_lead;
extern uint32_t st_lead_q, st_lead_odd, st_lead_next, st_lead_4l;
extern uint8_t st_ev_neg, st_ev_count, st_ev_last;
extern uint8_t st_pin_dirs;                          /* bit i set: axis i's pin says negative */
extern volatile uint8_t st_dir_pending, st_dir_next;
extern volatile uint8_t st_busy, st_missed;             /* tick_body runs; a match came meanwhile */
extern uint8_t st_plain, st_fast;       /* a line without switches to watch; the next tick is plain */


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
        st_counter[i] += st_inc[i];                                                     \
        if (st_counter[i] >= 0) {                                                    \
            st_counter[i] -= st_base;                                                   \
            b |= (uint8_t)(1 << (i));                                             \
        }                                                                         \
    }
#define COUNT(i, slot)                                                            \
    if (bits & (1 << (i))) {                                                      \
        if (neg & (1 << (i)))                                                     \
            st_moved[i]--;                                                           \
        else                                                                      \
            st_moved[i]++;                                                           \
    }
/* The axes whose limit switches stop them (switches.c checks which is actuated). */
#define SWITCH(id, axis, side, kind, stop, bit) | ((kind) == SW_LIMIT ? 1 << (axis) : 0)
#define LIMIT_AXES (0 SWITCHES)

static inline void write_directions(uint8_t dirs)
{
    FOR_EACH_AXIS(DIR_SET)
}

/* The next match at count t (its pins rise at t + SLOT_COUNTS, their fall is set from there).
 * schedule() puts it one period after this one, never at a count the counter has passed. */
static inline __attribute__((always_inline)) void set_next(uint16_t t)
{
    OCR1A = t;
    st_tick_next = t;
}

static inline __attribute__((always_inline)) void schedule(void)
{
    uint16_t t = st_tick_at + st_period;
    if ((int16_t)(t - TCNT1) < 3)
        t = TCNT1 + 3;
    set_next(t);
}

/* stepper_core.c */
void set_directions(uint8_t dirs);
void halt(uint8_t why);
void fold_fired(void);
void line_check(void);
void line_absorb(void);
void wake(void);
/* encoder.c */
uint8_t enc_prepare(void);
uint8_t enc_begin(uint16_t wait, uint16_t lead);


/* The events counted once for the axes that step at every one, into each axis's count (before
 * that set of axes or their directions change). */
static inline __attribute__((always_inline)) void fold_events(void)
{
    uint16_t n = st_fired;
    if (!n)
        return;
    uint8_t mask = st_always_axes, neg = st_ev_neg;
    st_fired = 0;
    st_fold_seq++;
#define FOLD(i, slot)                                                             \
    if (mask & (1 << (i)))                                                        \
        st_moved[i] += (neg >> (i)) & 1 ? -(int16_t)n : (int16_t)n;
    FOR_EACH_AXIS(FOLD)
#undef FOLD
}

/* A line has made its last step: each axis's steps since the line began must be the line's
 * own, else the position is not what the plan says and everything stops (EV_STEPS). The next
 * line's start (begin_line) sets the counts again. */
#define CHECK(i, slot) || st_line_acc[i] + (int16_t)(st_moved[i] - st_moved_seen[i]) != l->want[i]
static inline __attribute__((always_inline)) void check_line(void)
{
    fold_events();
    const line_t *l = st_ln;
    if (0 FOR_EACH_AXIS(CHECK))
        halt(EV_STEPS);
}

#endif
