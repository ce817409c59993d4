/* encoder.c - ISTP: the spindle encoder's clock steps a line (ICLK, INT0) from the indexer's
 * start pulse on (SIND, INT1), and the main loop's looks at the index. See stepper.c for the
 * design. */
#include "stepper_int.h"

static volatile uint8_t st_index_pulse;       /* SIND came since stepper_index_quiet looked */

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
    if (st_state != ENCODER) {                   /* no line follows the encoder: its counts */
        EIMSK &= (uint8_t)~_BV(INT0);            /* cost nothing until one does (tick.c) */
        return;
    }
    if (st_index_wait)
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

uint8_t stepper_index_seen(void) { return st_index_seen; }

void stepper_clear_index_seen(void) { st_index_seen = 0; }

uint8_t stepper_index_quiet(void)
{
    uint8_t quiet = st_state == ENCODER && !st_index_pulse;
    st_index_pulse = 0;
    return quiet;
}
