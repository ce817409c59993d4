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
 * a thread pass always starts at the same spindle angle. */
#include "stepper_int.h"

line_t stepper_lines[LINES];
segment_t st_ring[SEGMENTS];
volatile uint8_t st_ring_head, st_ring_tail;   /* the main loop writes head, the interrupt tail */

volatile uint8_t st_state, st_halted, st_events, st_index_seen, st_index_wait, st_pulse_high;
volatile uint8_t st_stepped_negative = 0xFF;  /* bit i: axis i last stepped towards - */
static volatile uint8_t st_index_pulse;       /* SIND came since stepper_index_quiet looked */
int32_t st_position[N_AXES];                 /* 002's actual position, steps, ... */
volatile int16_t st_moved[N_AXES];           /* ... plus the steps it counted (wrapping), */
volatile uint16_t st_fired;                   /* and events of the axes that step every one */
int16_t st_moved_seen[N_AXES];               /* st_moved at the running line's last look */
static int16_t folded[N_AXES];               /* st_moved at the main loop's last fold */
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

/* Whether the next encoder count is an event of the line (the host's IndexerTrack). After the
 * synchronising index it waits st_enc_wait counts; then, over the lead-in's 2 L counts, the
 * events follow the parabola round(k^2 / 4 L) of the lead-in's count k (at most one a count:
 * its slope k / 2 L reaches 1 at its end, where it meets the line: L events in 2 L counts);
 * then every count is one. */
static inline uint8_t enc_gate(void)
{
    if (st_enc_wait) {
        st_enc_wait--;
        return 0;
    }
    if (!st_enc_lead)
        return 1;
    st_enc_lead--;
    st_lead_q += st_lead_odd;                    /* k^2, for the next k */
    st_lead_odd += 2;
    if (st_lead_q < st_lead_next)                /* not yet past the next half event */
        return 0;
    st_lead_next += st_lead_4l;
    return 1;
}

/* The event of the next encoder count into st_enc_bits (st_enc_ev: it is one), computed ahead
 * so the count's interrupt raises its pins first thing: Bresenham with the line's encoder
 * counts as the base (every axis, so the timer's always-stepping shortcut is not used), and
 * the limit switches of the axes that would step. 0 when a limit stops the line (halted). Runs
 * with INT0 masked or before the line's state is ENCODER. */
uint8_t enc_prepare(void)
{
    uint8_t b = 0, bres = st_bres_axes | st_always_axes;
    st_enc_ev = enc_gate();
    if (st_enc_ev) {
        FOR_EACH_AXIS(BRESENHAM)
        if ((b & LIMIT_AXES) && switch_blocks(b, st_ln->dir_bits)) {
            halt(EV_LIMIT);
            return 0;
        }
    }
    st_enc_bits = b;
    return 1;
}

/* An ISTP line begins (its segment's ticks and period: the counts to wait after the index and
 * the lead-in's counts); its first event. Not inlined: the step tick's common path keeps its
 * registers few. */
__attribute__((noinline)) uint8_t enc_begin(uint16_t wait, uint16_t lead)
{
    st_enc_left = st_base;
    st_index_wait = !st_ln->chained;             /* a thread pass waits for SIND */
    st_enc_wait = wait;
    st_enc_lead = (uint16_t)(2 * lead);
    st_lead_q = 0;
    st_lead_odd = 1;
    st_lead_next = 2 * (uint32_t)lead;
    st_lead_4l = 4 * (uint32_t)lead;
    return enc_prepare();
}

/* ICLK: one encoder count of the spindle is one Bresenham event of an ISTP line. With
 * interrupts off only its pins change (the event was prepared at the count before); the
 * counting and the next event run with interrupts on and INT0 masked, and a count that came
 * meanwhile is served at the end, in the same interrupt (its flag is cleared by hand: simavr
 * does not take a flag raised while its interrupt was masked; the CPU would). */
ISR(INT0_vect)
{
    if (st_state != ENCODER || st_index_wait)
        return;
    for (;;) {
        /* A pulse still high is left to compare B (a count without a step must not cut it: at
         * 2 000 rpm on 400 counts a count comes every 75 us, and 100 us pulses ended at 75);
         * only a step that comes before its end (no line allows one) ends it here. */
        uint8_t bits = st_enc_bits;
        if (bits) {
            if (st_pulse_high) {                  /* (never at a rate the line may have) */
                FOR_EACH_AXIS(STEP_LOW)
                st_pulse_high = 0;
                if (st_dir_pending) {
                    write_directions(st_dir_next);
                    st_dir_pending = 0;
                }
            }
            FOR_EACH_AXIS(STEP_HIGH)
            OCR1B = TCNT1 + FALL_AFTER_RISE_COUNTS;   /* (the pins rose in this count) */
            TIFR1 = _BV(OCF1B);                   /* an earlier pulse's compare ends none now */
            TIMSK1 |= _BV(OCIE1B);
            st_pulse_high = 1;
        }
        EIMSK &= (uint8_t)~_BV(INT0);
        sei();
        uint8_t neg = st_ln->dir_bits;
        FOR_EACH_AXIS(COUNT)
        uint8_t more = (!st_enc_ev || --st_enc_left != 0) && enc_prepare();
        if (!more && st_state == ENCODER)
            line_check();                        /* (its steps; a mismatch halts it) */
        else if (!(st_enc_left & 0x3FFF))
            line_absorb();
        cli();
        EIMSK |= _BV(INT0);
        if (st_state != ENCODER)                  /* a limit or the check halted the line */
            return;
        if (!more) {
            st_events |= EV_DONE;
            st_state = IDLE;
            wake();                            /* the next segments, on the timer again */
            return;
        }
        if (!(EIFR & _BV(INTF0)))
            return;
        EIFR = _BV(INTF0);                        /* a count came meanwhile: it is served here */
    }
}

/* SIND: the indexer start, once a spindle revolution. */
ISR(INT1_vect)
{
    st_index_seen = st_index_pulse = 1;
    if (st_state == ENCODER)
        st_index_wait = 0;                        /* the thread starts at this spindle angle */
}

/* ---- main-loop side ------------------------------------------------------------------- */

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
    EIMSK = _BV(INT0) | _BV(INT1);
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

uint8_t stepper_index_seen(void) { return st_index_seen; }

void stepper_clear_index_seen(void) { st_index_seen = 0; }

uint8_t stepper_index_quiet(void)
{
    uint8_t quiet = st_state == ENCODER && !st_index_pulse;
    st_index_pulse = 0;
    return quiet;
}

