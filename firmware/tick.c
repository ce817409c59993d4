/* tick.c - the step interrupt's slow path, in C: a new segment, a new line or AMASS level, the
 * end of what was prepared, the switches of a homing move or of a limit. The common tick (the
 * next event within a segment of a line without switches to watch) is in tick_asm.c; both are
 * described in stepper.c. */
#include "stepper_int.h"

/* The end of a tick's rest: a match that came meanwhile is taken at once. The next tick may
 * take the common path (it never nests in this one) only from here on. */
static inline __attribute__((always_inline)) void finish_tick(uint8_t fast)
{
    cli();
    if (st_missed) {
        st_missed = 0;
        set_next(TCNT1 + 3);
    }
    st_busy = 0;
    st_fast = fast;
    sei();
}

/* The Bresenham increments at AMASS level `level` (the events of the axes that step at every
 * one folded before); at level 0 an axis that steps at every event needs no arithmetic. */
static void set_level(uint8_t level)
{
    const line_t *l = st_ln;
    st_seg_level = level;
    if (!level) {
        st_always_axes = l->always0;
        st_bres_axes = (uint8_t)(l->moving & ~l->always0);
#define INC0(i, slot) st_inc[i] = l->steps[i];
        FOR_EACH_AXIS(INC0)
#undef INC0
    } else {
        st_always_axes = 0;
        st_bres_axes = l->moving;
#define INC(i, slot) st_inc[i] = l->steps[i] >> level;
        FOR_EACH_AXIS(INC)
#undef INC
    }
}

/* A new line (its events folded before): Bresenham's terms at the mid-point, its directions,
 * where its steps start; what needs no interrupt's work was prepared with the line. */
static void begin_line(uint8_t index)
{
    const line_t *l = &stepper_lines[index];
    st_ln = l;
    st_base = l->base;
    int32_t c = l->counter0;
#define RESTART(i, slot) st_moved_seen[i] = st_moved[i]; st_line_acc[i] = 0; st_counter[i] = c;
    FOR_EACH_AXIS(RESTART)
#undef RESTART
    uint8_t moving = l->moving;
    st_plain = l->kind == MOVE_LINE && !(moving & LIMIT_AXES);
    set_directions(l->dir_bits);
    st_stepped_negative = (uint8_t)((st_stepped_negative & ~moving) | (l->dir_bits & moving));
    st_seg_level = 0xFF;
}

/* Take the next segment; 0 when there is none to tick (the end, or an ISTP line). */
static uint8_t next_segment(void)
{
    uint8_t t = st_ring_tail;
    if (t == st_ring_head) {
        st_state = IDLE;                          /* the end of what was prepared */
        st_ev_bits = 0;
        return 0;
    }
    const segment_t *s = &st_ring[t];
    fold_events();                                /* (the common tick leaves them to here) */
    st_seg_flags = s->flags;
    if (!(st_seg_flags & SEG_FIRST))
        line_absorb();
    if (st_seg_flags & SEG_FIRST)
        begin_line(s->line);
    uint8_t level = s->level;
    uint16_t ticks = s->ticks, p = s->period;
    st_ring_tail = (uint8_t)(t + 1 == SEGMENTS ? 0 : t + 1);
    if (level != st_seg_level)
        set_level(level);
    if (st_seg_flags & SEG_INDEXER) {
        st_ev_bits = 0;
        if (enc_begin(ticks, p)) {                /* its first event (a limit may halt it) */
            uint8_t sreg = SREG;
            cli();
            st_state = ENCODER;                   /* the encoder's clock takes over, last; */
            EIFR = _BV(INTF0);                    /* its counts from now on, none from before */
            EIMSK |= _BV(INT0);
            SREG = sreg;
        }
        return 0;
    }
    st_ticks_left = ticks;
    st_period = p;
    return 1;
}

/* Prepare the event of the next tick. */
static inline void prepare(void)
{
    if (!st_ticks_left && !next_segment())
        return;
    st_ticks_left--;
    uint8_t b = st_always_axes, bres = st_bres_axes;
    FOR_EACH_AXIS(BRESENHAM)
    const line_t *l = st_ln;
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
    st_ev_neg = l->dir_bits;
    st_ev_count = kind != MOVE_TAKEUP;            /* take-up steps do not move the position */
    st_ev_last = !st_ticks_left && (st_seg_flags & SEG_LAST) && kind != MOVE_TAKEUP;
    st_ev_bits = b;
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmisspelled-isr"
void tick_body(void) __attribute__((signal, used, externally_visible));
void tick_body(void)
{
    uint8_t bits = st_ev_bits;
    st_tick_at = st_tick_next;                       /* the match being served */
    if (bits && st_ev_count) {
        uint8_t neg = st_ev_neg;
        FOR_EACH_AXIS(COUNT)
    }
    if (st_ev_last) {
        st_ev_last = 0;
        st_events |= EV_DONE;
        check_line();
    }
    if (!st_halted)
        prepare();
    uint8_t fast = st_plain && st_ticks_left && !st_ev_last;
    uint16_t t = st_tick_at + st_period;       /* the next segment's period is known now */
    cli();
    if (st_state != TICKING)
        TIMSK1 = IDLE_TIMSK;
    /* The counter read and the match set with interrupts off: an interrupt between them let
     * the counter pass the match, and the next tick waited for the 16-bit wrap (32.8 ms). */
    if ((int16_t)(t - TCNT1) < 3)
        t = TCNT1 + 3;
    set_next(t);
    finish_tick(fast);
}
#pragma GCC diagnostic pop
