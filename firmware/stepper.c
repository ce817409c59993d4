/* stepper.c - phase two of 002's path planner: Bresenham, one step cycle per timer compare.
 *
 * Timer1 runs in CTC mode at 2 MHz; each compare match is one step cycle (002: "phase two is
 * executed in every step cycle while the actual position does not reach the final position").
 * A cycle takes the pending move if none runs, or performs one Bresenham event: every axis adds
 * its step count to its error term and steps when the term reaches the base count. Under ISTP
 * the timer only takes up the backlash; then the spindle encoder's clock (ICLK, INT0) performs
 * the events, from the next indexer start pulse (SIND, INT1) on, so a thread pass always starts
 * at the same spindle angle (a pass that continues the one before it does not wait).
 *
 * A step pulse rises in a step cycle and the next compare, PULSE_HIGH_US later, lowers it ('dunu'
 * in the lathe paper); the rest of the step period ('perioada') follows. Every compare is a CTC
 * match, so no compare can be missed when an interrupt comes late. An encoder-driven step starts
 * the timer as a one-shot for its pulse. The direction pins change only when a move starts, and
 * its first step comes one start period (at least DIR_SETUP_US) after that. The main loop sets
 * the period (stepper_set_rate); periods beyond 16 bits are made of several equal timer cycles. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "board.h"
#include "stepper.h"
#include "switches.h"

#define PASTE(a, b, c) a##b##c
#define PIN_OF(slot, what) PASTE(RAMPS_, slot, what)

static move_t pending, run;                  /* 002's pending movement and the executing one */
static volatile uint8_t pending_full, running, held, timer_on, index_wait;
static volatile uint8_t events, sequence, index_seen;
static volatile uint8_t stepped_negative = 0xFF;  /* bit i: axis i last stepped towards - */
static volatile int32_t position[N_AXES];    /* 002's actual position, steps */
static uint32_t error_term[N_AXES];
static uint32_t left;                        /* Bresenham events left in the running move */
static uint16_t takeup_left[N_AXES];
static uint8_t takeup_bits;
static volatile uint16_t next_ocr = 2000;    /* the gap from a pulse's end to the next step */
static volatile uint8_t next_skip;           /*   as next_skip + 1 timer cycles of next_ocr */
static uint8_t skip_left;
static volatile uint8_t pulse_on;            /* step pins high: the next compare ends the pulse */
static uint16_t rise_delay;                  /* counts from a step cycle's match to its rise */
static uint8_t in_timer;                     /* step_event runs in the Timer1 interrupt */

/* Pulses up to this width end inside the step interrupt that raised them: a busy wait of at most
 * 20 us on the counter, so the width is exact to a count (0.5 us) and a step costs one interrupt,
 * not two. Longer pulses end at a compare of their own. */
#define INLINE_PULSE_COUNTS US_TO_COUNTS(20)
#define INLINE_PULSE (PULSE_COUNTS <= INLINE_PULSE_COUNTS)
#define RISE_SLOT_COUNTS US_TO_COUNTS(8)
/* The wait ends up to a count late and the pins fall ~10 cycles after it (measured in simavr):
 * waiting two counts less than the width gives the width to +0.6 us, never less. */
#define PULSE_WAIT_COUNTS (PULSE_COUNTS - 2)

/* ---- pins ---------------------------------------------------------------------------- */

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

#define PULSE_COUNTS US_TO_COUNTS(PULSE_HIGH_US)

/* A compare value `counts` after the match that started this cycle, but never at or below the
 * counter: in CTC mode a compare value the counter has passed is only matched after the 16-bit
 * wrap (32.8 ms). A late interrupt stretches the cycle instead. */
static inline void compare_after(uint16_t counts)
{
    uint16_t now = TCNT1;
    OCR1A = counts > now + 4 ? counts : now + 4;
}

/* Raise the step pins of `bits`; the compare PULSE_COUNTS after the rise lowers them, so the
 * pulse is as wide as configured however late in the interrupt the pins rose. */
static inline void pulse_start(uint8_t bits)
{
    if (!bits)
        return;
    stepped_negative = (stepped_negative & (uint8_t)~bits) | (run.dir_bits & bits);
    FOR_EACH_AXIS(STEP_HIGH)
    rise_delay = TCNT1;
    if (INLINE_PULSE && in_timer) {            /* a short pulse: timed and ended right here */
        OCR1A = 0xFFFF;                        /* no match meanwhile */
        while ((uint16_t)(TCNT1 - rise_delay) < PULSE_WAIT_COUNTS)
            ;
        FOR_EACH_AXIS(STEP_LOW)
        pulse_on = 2;
        return;
    }
    OCR1A = rise_delay + PULSE_COUNTS;
    pulse_on = 1;
}

static inline void pulse_end(void)
{
    FOR_EACH_AXIS(STEP_LOW)
    pulse_on = 0;
}

static inline void set_directions(uint8_t dirs)
{
    FOR_EACH_AXIS(DIR_SET)
}

/* ---- timer ---------------------------------------------------------------------------- */

static void timer_start(uint16_t first)
{
    TCNT1 = 0;
    OCR1A = first;
    TIFR1 = _BV(OCF1A);
    skip_left = 0;
    pulse_on = 0;
    TCCR1B = _BV(WGM12) | _BV(CS11);           /* CTC on OCR1A, clock / 8 */
    timer_on = 1;
}

static void timer_halt(void)
{
    TCCR1B = _BV(WGM12);
    timer_on = 0;
}

/* Start the timer if it sleeps, so the pending move begins within 20 us. */
static void wake(void)
{
    if (!timer_on)
        timer_start(US_TO_COUNTS(20));
}

/* ---- phase two ------------------------------------------------------------------------ */

static void step_compute(void);

/* Take the pending move: constants in, directions out. Interrupt context. */
static uint8_t load(void)
{
    if (!pending_full || held)
        return 0;
    run = pending;
    pending_full = 0;
    left = run.events;
    takeup_bits = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        error_term[i] = run.events / 2;     /* Bresenham's mid-point start */
        takeup_left[i] = run.takeup[i];
        if (run.takeup[i])
            takeup_bits |= (uint8_t)(1 << i);
    }
    set_directions(run.dir_bits);
    index_wait = run.indexer && !run.chained;        /* a thread pass waits for SIND */
    running = 1;
    sequence++;
    step_compute();                                  /* the first event, ready to fire */
    return 1;
}

static void finish(uint8_t why)
{
    running = 0;
    events |= why | EV_DONE;
}

/* Each event is prepared one event ahead (step_compute), so that the step interrupt raises the
 * pins first thing (step_fire) and its timing does not depend on how long Bresenham takes. */
static uint8_t ready_bits, ready_takeup, fired;

/* Prepare the next event: a step of backlash take-up, or one Bresenham event. */
static void step_compute(void)
{
    uint8_t bits = takeup_bits;
    ready_takeup = bits != 0;
    if (!bits) {
        for (uint8_t i = 0; i < N_AXES; i++) {
            error_term[i] += run.delta[i];
            if (error_term[i] >= run.events) {
                error_term[i] -= run.events;
                bits |= (uint8_t)(1 << i);
            }
        }
    }
    ready_bits = bits;
}

/* Perform the prepared event: switches checked, pins raised, positions counted. */
static void step_fire(void)
{
    uint8_t bits = ready_bits;
    if (ready_takeup) {                        /* 003: the motor turns through the clearance; */
        pulse_start(bits);                     /* the actual position does not change */
        for (uint8_t i = 0; i < N_AXES; i++)
            if ((bits & (1 << i)) && --takeup_left[i] == 0)
                takeup_bits &= (uint8_t)~(1 << i);
        return;
    }
    if (run.kind != MOVE_LINE && switch_on(run.watch) == (run.kind == MOVE_SEEK)) {
        finish(EV_SWITCH);             /* the homing switch closed (SEEK) or opened (RELEASE) */
        return;
    }
    if (switch_blocks(bits, run.dir_bits)) {
        pending_full = 0;                      /* a limit switch: everything stops here */
        finish(EV_LIMIT);
        return;
    }
    pulse_start(bits);
    fired = 1;
}

/* Count the event just fired (after its pulse has been timed): positions, events left. */
static void step_account(void)
{
    if (!fired)
        return;
    fired = 0;
    uint8_t bits = ready_bits;
    for (uint8_t i = 0; i < N_AXES; i++)
        if (bits & (1 << i))
            position[i] += (run.dir_bits >> i) & 1 ? -1 : 1;
    if (--left == 0)
        finish(0);
}

/* One event and the preparation of the next (the encoder's path). Interrupt context. */
static void step_event(void)
{
    step_fire();
    step_account();
    if (running)
        step_compute();
}

/* The rest of the step period after a pulse. */
static inline void gap(void)
{
    /* the next rise comes about rise_delay after the next match: the period counts rise to rise */
    compare_after(next_ocr > rise_delay + 8 ? next_ocr - rise_delay : 8);
    skip_left = next_skip;
}

ISR(TIMER1_COMPA_vect)
{
    if (pulse_on) {                            /* 'dunu' is over */
        pulse_end();
        if (running && run.indexer && !takeup_bits)
            timer_halt();                      /* the encoder's one-shot, or the take-up, ends */
        else
            gap();
        return;
    }
    if (skip_left) {                           /* a long period: several equal timer cycles */
        skip_left--;
        return;
    }
    if (!running) {
        OCR1A = 0xFFFF;       /* loading takes longer than the 20 us wake-up compare: no match */
        if (!load() || (run.indexer && !takeup_bits)) {
            timer_halt();                      /* nothing to do, or the encoder clocks it */
            return;
        }
        next_ocr = run.start_ocr;              /* the start rate, until the profile speeds up */
        next_skip = run.start_skip;
        gap();                                 /* the first step: direction set-up is over */
        uint16_t setup = TCNT1 + US_TO_COUNTS(DIR_SETUP_US) + 2;
        if (OCR1A < setup)
            OCR1A = setup;
        return;
    }
    if (run.indexer && !takeup_bits) {         /* backlash taken up: the encoder drives on */
        timer_halt();
        return;
    }
    /* The pins rise at a fixed count after the match, whatever delayed the interrupt's entry
     * (another interrupt, a short interrupts-off window): the period is exact to a count. */
    while (TCNT1 < RISE_SLOT_COUNTS)
        ;
    in_timer = 1;
    step_fire();
    in_timer = 0;
    if (pulse_on == 2) {                       /* a short pulse, already over */
        pulse_on = 0;
        /* the whole period from this match: the next rise comes as late after the next match */
        uint16_t ocr = next_ocr;
        compare_after(ocr > 0xFFFF - PULSE_COUNTS ? 0xFFFF : ocr + PULSE_COUNTS);
        skip_left = next_skip;
    } else if (!pulse_on)
        gap();                                 /* no step this cycle (a homing move ended) */
    step_account();
    if (running)
        step_compute();                        /* the next event, while the timer runs */
}

/* ICLK: one encoder count of the spindle is one Bresenham event of an ISTP move. */
ISR(INT0_vect)
{
    if (!running || !run.indexer || index_wait || takeup_bits)
        return;
    if (pulse_on)
        pulse_end();                           /* steps this close: end the last pulse early */
    step_event();
    if (pulse_on || !running) {                /* the timer times the pulse as a one-shot, */
        uint8_t high = pulse_on;               /* then takes the next pending move */
        timer_start(high ? PULSE_COUNTS : US_TO_COUNTS(20));
        pulse_on = high;
    }
}

/* SIND: the indexer start, once a spindle revolution. */
ISR(INT1_vect)
{
    index_seen = 1;
    if (running && run.indexer && !takeup_bits)
        index_wait = 0;                        /* the thread starts at this spindle angle */
}

/* ---- main-loop side ------------------------------------------------------------------- */

void stepper_init(void)
{
    FOR_EACH_AXIS(PINS_OUT)
    TCCR1A = 0;
    TCCR1B = _BV(WGM12);
    TIMSK1 = _BV(OCIE1A);
    ICLK_PORT |= _BV(ICLK_BIT);                /* pull-ups on the indexer inputs */
    SIND_PORT |= _BV(SIND_BIT);
    EICRA = _BV(ISC01) | _BV(ISC00) | _BV(ISC11) | _BV(ISC10);   /* rising edges */
    EIMSK = _BV(INT0) | _BV(INT1);
}

uint8_t stepper_submit(const move_t *move)
{
    if (pending_full)
        return 0;
    pending = *move;
    stepper_period(move->rate_start, &pending.start_ocr, &pending.start_skip);
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        pending_full = 1;
        if (!running)
            wake();
    }
    return 1;
}

uint8_t stepper_pending(void) { return pending_full; }

uint8_t stepper_running(void) { return running; }

void stepper_hold(uint8_t on)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        held = on;
        if (!on && pending_full && !running)
            wake();
    }
}

void stepper_stop(void)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        timer_halt();
        pulse_end();
        running = pending_full = 0;
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

void stepper_position(int32_t *steps)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        for (uint8_t i = 0; i < N_AXES; i++)
            steps[i] = position[i];
    }
}

void stepper_set_position(uint8_t axis, int32_t steps)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { position[axis] = steps; }
}

void stepper_period(float rate, uint16_t *ocr, uint8_t *skip)
{
    if (rate < MIN_RATE)
        rate = MIN_RATE;
    if (rate > MAX_RATE)
        rate = MAX_RATE;
    uint32_t counts = (uint32_t)((float)TIMER_HZ / rate) - PULSE_COUNTS;   /* after the pulse */
    uint8_t cycles = (uint8_t)(counts / 65536UL) + 1;  /* equal timer cycles */
    *ocr = (uint16_t)(counts / cycles);
    *skip = cycles - 1;
}

void stepper_set_rate(float rate, uint8_t seq)
{
    uint16_t ocr;
    uint8_t skip;
    stepper_period(rate, &ocr, &skip);
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        if (seq == sequence) {                 /* still the move the rate was computed for */
            next_ocr = ocr;
            next_skip = skip;
        }
    }
}

void stepper_set_feed(uint8_t kind, float feed_mm_min)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        if (running && run.feed_kind == kind)
            run.feed = feed_mm_min;
        if (pending_full && pending.feed_kind == kind)
            pending.feed = feed_mm_min;
    }
}

uint32_t stepper_snapshot(move_t *copy, uint8_t *seq, uint8_t whole)
{
    uint32_t n;
    /* Only the fields the profile reads, and the per-move constants only when asked: the
     * interrupts stay off for a few microseconds, not for a copy of the whole move. */
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        n = running ? left : 0;
        copy->feed = run.feed;
        *seq = sequence;
    }
    if (whole && n) {
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
            copy->indexer = run.indexer;
            copy->rate_start = run.rate_start;
            copy->k_feed = run.k_feed;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
            copy->rate_max = run.rate_max;
            copy->accel = run.accel;
            if (*seq != sequence)
                n = 0;                         /* a new move began meanwhile: next time */
        }
    }
    return n;
}

void stepper_directions(int8_t *dirs)
{
    uint8_t negative = stepped_negative;
    for (uint8_t i = 0; i < N_AXES; i++)
        dirs[i] = (negative >> i) & 1 ? -1 : 1;
}

uint8_t stepper_index_seen(void) { return index_seen; }

void stepper_clear_index_seen(void) { index_seen = 0; }
