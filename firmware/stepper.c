/* stepper.c - phase two of 002's path planner: Bresenham over prepared segments.
 *
 * Timer1 counts freely at 2 MHz (normal mode: no compare value ever resets the counter). Each
 * compare match on OCR1A is one tick. The tick's event - which axes step - was computed in the
 * tick before, so the interrupt raises those step pins first thing, when the counter reaches the
 * match plus SLOT_COUNTS (whatever delayed its entry is absorbed, and the period from rise to
 * rise is exact to a few cycles). The pulse ('dunu') ends PULSE_COUNTS after the rise: inside the
 * common tick for a short pulse, else by the compare OCR1B in an interrupt of its own, which also
 * changes the direction pins when the next event belongs to a line going another way, so each
 * direction change comes after a pulse's end and one step period minus the pulse before the next
 * rise. The next match is scheduled at the previous one plus the segment's period, never at a
 * count the counter has passed: a late interrupt stretches one tick and nothing waits for the
 * 16-bit wrap.
 *
 * The common tick (tick_asm.c) keeps interrupts off up to the pins' fall, then runs its rest
 * with its own match and the 1 ms clock masked; any other tick runs its rest in
 * tick_body (tick.c) with interrupts on: it counts the positions and prepares the next event
 * (Bresenham over the line's steps at the segment's AMASS level), taking the next segment from
 * the ring when the current one is used up. Under ISTP the spindle encoder's clock (ICLK, INT0)
 * performs the events of the line instead, from the next indexer start pulse (SIND, INT1) on, so
 * a thread pass always starts at the same spindle angle (encoder.c).
 *
 * A new line costs its first tick little: what needs no interrupt's work (the moving axes, those
 * that step at every event, Bresenham's starting term) was put in its line_t when the main loop
 * cut its first segment (segment.c). The state the ticks share and the running line's
 * bookkeeping are in stepper_core.c; this file is the main loop's side. */
#include "stepper_int.h"

static int16_t folded[N_AXES];               /* st_moved at the main loop's last fold */

void stepper_init(void)
{
    FOR_EACH_AXIS(PINS_OUT)
    st_pin_dirs = (uint8_t)(~DIR_INVERT & ((1 << N_AXES) - 1));   /* low pins, as after reset */
    TCCR1A = 0;
    TCCR1B = _BV(CS11);                        /* normal mode, clock / 8: 2 MHz, never reset */
    TIMSK1 = 0;
    ICLK_PORT |= _BV(ICLK_BIT);                /* pull-ups on the indexer inputs */
    SIND_PORT |= _BV(SIND_BIT);
    EICRA = _BV(ISC01) | _BV(ISC00) | _BV(ISC11) | _BV(ISC10);   /* rising edges */
    EIMSK = _BV(INT1);                         /* INT0 only while a line follows the encoder */
}

segment_t *stepper_slot(void)
{
    uint8_t next = (uint8_t)(st_ring_head + 1 == SEGMENTS ? 0 : st_ring_head + 1);
    return next == st_ring_tail ? 0 : &st_ring[st_ring_head];
}

void stepper_push(void)
{
    st_ring_head = (uint8_t)(st_ring_head + 1 == SEGMENTS ? 0 : st_ring_head + 1);
}

uint8_t stepper_queued(void)
{
    int8_t n = (int8_t)(st_ring_head - st_ring_tail);
    return (uint8_t)(n < 0 ? n + SEGMENTS : n);
}

void stepper_start(void)
{
    if (st_state == IDLE)
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { wake(); }
}

uint8_t stepper_busy(void)
{
    return st_state != IDLE || st_ring_head != st_ring_tail;
}

/* Everything stops: with interrupts off only the step timer's interrupts are masked, the
 * encoder's made idle and the pins lowered; none of them can run after that, so the rest is
 * put in order with interrupts on (the main loop resumes only when every interrupt returned). */
void stepper_stop(void)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        TIMSK1 = 0;
        st_state = IDLE;
        FOR_EACH_AXIS(STEP_LOW)
    }
    fold_fired();
    if (st_dir_pending)
        write_directions(st_dir_next);
    st_dir_pending = 0;
    st_halted = 0;
    st_ring_head = st_ring_tail = 0;
    st_ticks_left = 0;
    st_pulse_high = 0;
    st_ev_bits = st_ev_last = st_fast = 0;
    st_busy = st_missed = 0;
    st_events = 0;
}

uint8_t stepper_take_events(void)
{
    uint8_t e;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        e = st_events;
        st_events = 0;
    }
    return e;
}

/* The steps the interrupt counted (st_moved, 16-bit, counting freely) go into the 32-bit
 * position: what each axis's count gained since the last fold (at least every 0.5 s: it wraps
 * after 32 767). The interrupts stay off only to read a count; nothing the interrupt reads is
 * written. The events of the axes that step at every one (st_fired) are the interrupt's to fold. */
void stepper_fold(void)
{
    for (uint8_t i = 0; i < N_AXES; i++) {
        int16_t m;
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { m = st_moved[i]; }
        st_position[i] += (int16_t)(m - folded[i]);
        folded[i] = m;
    }
}

/* The position now: the folded one plus the events of the axes that step at every one not yet
 * folded by the interrupt; read again if the interrupt folded them meanwhile. */
void stepper_position(int32_t *steps)
{
    uint16_t n;
    uint8_t mask, neg, seq;
    do {
        seq = st_fold_seq;
        stepper_fold();
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
            n = st_fired;
            mask = st_always_axes;
            neg = st_ev_neg;
        }
    } while (seq != st_fold_seq);
    for (uint8_t i = 0; i < N_AXES; i++) {
        int32_t fired = !(mask & (1 << i)) ? 0 : (neg >> i) & 1 ? -(int32_t)n : (int32_t)n;
        steps[i] = st_position[i] + fired;
    }
}

void stepper_set_position(uint8_t axis, int32_t steps)
{
    stepper_fold();
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        st_position[axis] = steps;
        folded[axis] = st_moved[axis];
    }
}

void stepper_directions(int8_t *dirs)
{
    uint8_t negative = st_stepped_negative;
    for (uint8_t i = 0; i < N_AXES; i++)
        dirs[i] = (negative >> i) & 1 ? -1 : 1;
}
