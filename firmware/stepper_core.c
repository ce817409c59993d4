/* stepper_core.c - the step generator's shared state and the bookkeeping of the running line
 * that the timer's ticks (tick*.c), the encoder's (encoder.c) and the main loop's side
 * (stepper.c) all use: the directions of a new line, a halt, the folded counts, the check of a
 * line's steps at its end, the timer's wake-up. It calls none of them. See stepper.c for the
 * design. */
#include "stepper_int.h"

line_t stepper_lines[LINES];
segment_t st_ring[SEGMENTS];
volatile uint8_t st_ring_head, st_ring_tail;   /* the main loop writes head, the interrupt tail */

volatile uint8_t st_state, st_halted, st_events, st_index_seen, st_index_wait, st_pulse_high;
volatile uint8_t st_stepped_negative = 0xFF;  /* bit i: axis i last stepped towards - */
int32_t st_position[N_AXES];                 /* 002's actual position, steps, ... */
volatile int16_t st_moved[N_AXES];           /* ... plus the steps it counted (wrapping), */
volatile uint16_t st_fired;                   /* and events of the axes that step every one */
int16_t st_moved_seen[N_AXES];               /* st_moved at the running line's last look */
int32_t st_line_acc[N_AXES];
volatile uint8_t st_fold_seq;

/* The running segment and its line. */
const line_t *st_ln;
uint8_t st_seg_flags, st_seg_level, st_bres_axes, st_always_axes;
uint16_t st_ticks_left, st_period, st_tick_at, st_tick_next;
int32_t st_counter[N_AXES];                  /* Bresenham's error term minus the base */
uint32_t st_inc[N_AXES], st_base, st_enc_left;
/* The event of the next tick (read by the interrupt's entry). */
volatile uint8_t st_ev_bits, st_enc_bits;
uint8_t st_enc_ev;
uint16_t st_enc_wait, st_enc_lead;
uint32_t st_lead_q, st_lead_odd, st_lead_next, st_lead_4l;
uint8_t st_ev_neg, st_ev_count, st_ev_last;
uint8_t st_pin_dirs;                          /* bit i set: axis i's pin says negative */
volatile uint8_t st_dir_pending, st_dir_next;
volatile uint8_t st_busy, st_missed;             /* tick_body runs; a match came meanwhile */
uint8_t st_plain, st_fast;       /* a line without switches to watch; the next tick is plain */


/* The direction pins of a new line: at once when no pulse is high, else at its end. */
void set_directions(uint8_t dirs)
{
    if (dirs == st_pin_dirs)
        return;
    st_pin_dirs = dirs;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        if (st_pulse_high) {
            st_dir_next = dirs;
            st_dir_pending = 1;
        } else
            write_directions(dirs);
    }
}

void halt(uint8_t why)
{
    st_events |= why | EV_DONE;
    st_halted = 1;                                /* no wake-up until the main loop flushes */
    st_state = IDLE;
    st_ev_bits = 0;
}

void fold_fired(void)
{
    fold_events();
}

/* What each axis's count gained since the last look, into the running line's count (at least
 * every 16 384 events: st_moved is 16-bit). */
#define ABSORB(i, slot)                                                           \
    {                                                                             \
        int16_t d = (int16_t)(st_moved[i] - st_moved_seen[i]);                    \
        st_moved_seen[i] += d;                                                    \
        st_line_acc[i] += d;                                                      \
    }
void line_absorb(void)
{
    FOR_EACH_AXIS(ABSORB)
}

void line_check(void)
{
    check_line();
}

/* Start ticking when segments wait and nothing steps (interrupts off). */
void wake(void)
{
    if (st_state != IDLE || st_halted || st_ring_tail == st_ring_head)
        return;
    st_state = TICKING;
    st_ev_bits = st_ev_last = st_fast = 0;
    st_ticks_left = 0;
    st_tick_at = TCNT1;
    st_period = WAKE_COUNTS;                      /* the first tick takes the first segment */
    schedule();
    TIFR1 = _BV(OCF1A);
    TIMSK1 = TICK_TIMSK | (st_pulse_high ? _BV(OCIE1B) : 0);   /* (an encoder's pulse) */
}
