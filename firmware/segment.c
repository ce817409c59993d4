/* segment.c - the planned moves cut into segments the step interrupt only has to count out.
 *
 * Each segment covers about SEGMENT_MS of the oldest planned move. Its speed follows the move's
 * trapezoid from where the last segment left it: accelerate at the move's acceleration towards
 * its feed, cruise, and brake so as to reach the planned exit speed (the next move's entry, or a
 * stop) exactly at its end; a feed override or a new plan is picked up at the next segment. The
 * distance covered becomes a whole number of events (the fraction of an event travelled is
 * carried), the time a tick period in timer counts (the rounding is carried too), so neither the
 * steps nor the time drift over a move. At low rates the segment ticks 2^level times per event
 * (AMASS), at most MAX_RATE ticks a second. Everything here runs in the main loop, in floats. */
#include <math.h>

#include "config.h"
#include "planner.h"
#include "segment.h"
#include "stepper.h"

/* Below this many events a second the interrupt ticks faster than the base axis steps. */
#define AMASS_HZ 8000.0f
#define TICK_MIN_COUNTS ((float)TIMER_HZ / MAX_RATE)
#define START_SEGMENTS 4
#define EVENT_BY_EVENT 2.5f
#define SEGMENT_EVENTS 8.0f
/* A move whose last event is this close (a fraction of an event) is at its end. */
#define END_EVENTS 1e-3f
/* Above this rate a segment lasts twice SEGMENT_MS: the main loop's float work per second is
 * halved where the step interrupt leaves it the least CPU. */
#define LONG_SEGMENT_HZ 20000.0f
/* The link waits while fewer segments than this are ready and there is motion to cut. */
#define FED_SEGMENTS (SEGMENTS / 2)
/* A segment's ticks are 16-bit: the most events a segment can hold at the fastest rate. */
_Static_assert(MAX_RATE * 2.0f * SEGMENT_MS / 1000.0f * 1.5f < 32767.0f, "segment ticks overflow");

static uint8_t active, held, stopped = 1, first, line_slot;
static float v;                  /* mm/s at the end of the last segment */
static uint32_t left;            /* events of the move not yet in a segment */
static float frac;               /* of the next event, already travelled */
static float per_mm;             /* events per mm of the move */
static float carry;              /* timer counts owed to the next segment */

void segment_reset(void)
{
    active = 0;
    stopped = 1;
    carry = 0.0f;
}

void segment_hold(uint8_t on) { held = on; }

uint8_t segment_active(void) { return active; }

uint8_t segment_fed(void)
{
    return held || !planner_first() || stepper_queued() >= FED_SEGMENTS;
}

/* A new line slot for move `m`: steps shifted for AMASS unless the encoder clocks it. */
static uint8_t new_line(const move_t *m)
{
    line_slot = (uint8_t)(line_slot + 1 == LINES ? 0 : line_slot + 1);
    line_t *l = &stepper_lines[line_slot];
    uint8_t shift = m->indexer ? 0 : AMASS_MAX;
    /* what the step interrupt would otherwise work out at the line's first tick */
    l->moving = l->always0 = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        l->steps[i] = m->delta[i] << shift;
        l->want[i] = (m->dir_bits >> i) & 1 ? -(int32_t)m->delta[i] : (int32_t)m->delta[i];
        if (m->delta[i])
            l->moving |= (uint8_t)(1 << i);
        if (m->delta[i] && m->delta[i] == m->events)
            l->always0 |= (uint8_t)(1 << i);
    }
    l->base = m->events << shift;
    l->counter0 = -(int32_t)(l->base >> 1);
    l->dir_bits = m->dir_bits;
    l->kind = m->kind;
    l->watch = m->watch;
    l->chained = m->chained;
    return line_slot;
}

/* Where a segment is along the trapezoid: speed s (mm/s), distance d (mm), time left (s). */
typedef struct {
    float s, d, time;
} pos_t;

/* Speed v changing at `acc` (negative: braking) for up to the time left or until `to` is
 * reached (then 1): the distance and the time go on. */
static uint8_t ramp(pos_t *p, float acc, float to)
{
    float t = (to - p->s) / acc;
    if (t >= p->time) {
        p->d += p->s * p->time + 0.5f * acc * p->time * p->time;
        p->s += acc * p->time;
        p->time = 0.0f;
        return 0;
    }
    p->d += (to * to - p->s * p->s) / (2.0f * acc);
    p->s = to;
    p->time -= t;
    return 1;
}

/* Brake over the r mm left to reach ve at the end (at most at a): 1 when the end is reached. */
static uint8_t brake(pos_t *p, float r, float ve, float a)
{
    float ad = fminf(a, (p->s * p->s - ve * ve) / (2.0f * r));
    float s2 = p->s * p->s - 2.0f * ad * r;
    float se = s2 > 0.0f ? sqrtf(s2) : 0.0f;
    float t_end = (p->s - se) / ad;
    if (t_end > p->time) {
        ramp(p, -ad, se);
        return 0;
    }
    p->d += r;
    p->s = se;
    p->time -= t_end;
    return 1;
}

/* Travel up to *t seconds along the trapezoid from speed v with `rem` mm left, towards exit
 * speed ve, feed vn, acceleration a. Returns the distance; *t becomes the time used and *done
 * is set when the move's end is reached. */
static float advance(float rem, float ve, float vn, float a, float end, float *t, uint8_t *done)
{
    pos_t p = {v, 0.0f, *t};
    float to;
    for (uint8_t k = 0; k < 5 && p.time > 0.0f && !*done; k++) {
        float r = rem - p.d;
        float braking = (p.s * p.s - ve * ve) / (2.0f * a);
        float top = sqrtf(0.5f * (2.0f * a * r + p.s * p.s + ve * ve));   /* accelerate until */
        if (r <= fmaxf(1e-7f * rem, end))
            *done = 1;
        else if (braking > 0.0f && (r <= braking || p.s >= top))
            *done = brake(&p, r, ve, a);                        /* to ve at the end */
        else if (p.s < vn && p.s < top &&                       /* accelerate, by more than */
                 (to = fminf(vn, fminf(top, sqrtf(p.s * p.s + 2.0f * a * r)))) >
                     p.s * 1.000001f)                           /* a float can tell apart */
            ramp(&p, a, to);
        else if (p.s > vn * 1.0001f)                            /* down to a lowered feed */
            ramp(&p, -a, vn);
        else {                                                  /* cruise up to the braking */
            float tc = (r - fmaxf(braking, 0.0f)) / p.s;
            float tt = fminf(tc, p.time);
            p.d += p.s * tt;
            p.time -= tt;
        }
    }
    if (p.d > rem)
        p.d = rem;
    v = p.s;
    *t -= p.time;
    return p.d;
}

/* Start cutting the oldest move; 0 when it was an ISTP line, handed over whole. */
static uint8_t start(move_t *m)
{
    if (m->indexer) {
        segment_t *s = stepper_slot();
        if (!s)
            return 0;
        s->line = new_line(m);
        /* the lead-in: `period` counts each side of the reference index, which is the first
         * index after the pass synchronises when that leaves room for them, else a later one;
         * `ticks` counts to wait from the synchronising index to the lead-in's start */
#if ENCODER_COUNTS_PER_REV
        uint16_t lead = m->lead;
        uint16_t revs = (uint16_t)((lead + ENCODER_COUNTS_PER_REV - 1) / ENCODER_COUNTS_PER_REV);
        s->ticks = (uint16_t)(revs * ENCODER_COUNTS_PER_REV - lead);
        s->period = lead;
#else
        s->ticks = s->period = 0;                 /* (no encoder: ISTP is refused) */
#endif
        s->level = 0;
        s->flags = SEG_FIRST | SEG_LAST | SEG_INDEXER;
        stepper_push();
        stepper_start();
        planner_pop();
        stopped = 1;                           /* the next move starts from rest */
        return 0;
    }
    first = 1;
    active = 1;
    left = m->events;
    frac = 0.0f;
    per_mm = (float)m->events / m->mm;
    if (stopped || v < move_rest(m))
        v = move_rest(m);
    stopped = 0;
    return 1;
}

/* The AMASS level of a segment at `rate` events/s: ticks faster than AMASS_HZ if it can. */
static uint8_t amass_level(float rate, uint32_t n)
{
    uint8_t level = 0;
    while (level < AMASS_MAX && rate * (float)(2UL << level) <= MAX_RATE &&
           rate * (float)(1UL << level) < AMASS_HZ && (n << (level + 1)) <= 65535UL)
        level++;
    return level;
}

/* Travel the oldest move for about one segment from speed v: the whole events covered (at
 * least one), their time *t_seg and the events travelled with fractions *travelled. */
static uint32_t cover(const move_t *m, float ve, float *t_seg, float *travelled, uint8_t *done)
{
    uint32_t n = 0;
    /* Near the stop rate (below EVENT_BY_EVENT times it) a segment is cut every event, so that
     * starting and braking come out event by event, not as a staircase of whole segments. */
    float rate = v * per_mm, dt = SEGMENT_MS / 1000.0f;
    if (rate < EVENT_BY_EVENT * move_rest(m) * per_mm && rate * dt < 2.0f * SEGMENT_EVENTS &&
        v < 0.999f * m->v_nominal)             /* (not a cruise at a feed below the stop rate:
                                                  a segment an event there outran the main loop) */
        dt = 1.0f / rate;
    else if (rate > LONG_SEGMENT_HZ)
        dt *= 2.0f;             /* fast: half as many segments to compute, the same time ahead */
    *t_seg = *travelled = 0.0f;
    for (uint16_t tries = 0; !n && !*done && tries < 2000; tries++) {
        float t = dt;
        float d = advance(((float)left - frac) / per_mm, ve, m->v_nominal, m->accel,
                          END_EVENTS / per_mm, &t, done);
        *t_seg += t;
        *travelled += d * per_mm;
        float x = frac + d * per_mm;
        uint32_t k = (uint32_t)x;
        if (*done || k >= left)
            k = *done ? left : left - 1;
        frac = *done ? 0.0f : fminf(x - (float)k, 0.9999f);
        n += k;
        left -= k;
    }
    return n;
}

/* The segment of n events at `rate` events/s: ticks (AMASS) and the tick period in counts,
 * the rounding carried into the next segment. */
static void timing(segment_t *s, uint32_t n, float rate)
{
    uint8_t level = amass_level(rate, n);
    uint16_t ticks = (uint16_t)(n << level);
    float counts = (float)n * (float)TIMER_HZ / rate + carry;
    float p = counts / (float)ticks;
    if (p < TICK_MIN_COUNTS)
        p = TICK_MIN_COUNTS;
    if (p > 65535.0f)
        p = 65535.0f;
    s->period = (uint16_t)(p + 0.5f);
    s->ticks = ticks;
    s->level = level;
    carry = fmaxf(-30000.0f, fminf(30000.0f, counts - (float)s->period * (float)ticks));
}

void segment_prepare(void)
{
    if (held)
        return;
    segment_t *s = stepper_slot();
    move_t *m = planner_first();
    if (!s || !m)
        return;
    if (!active && !start(m))
        return;
    float ve = fmaxf(planner_exit_speed(), move_rest(m));
    float t_seg, travelled;
    uint8_t done = 0;
    uint32_t n = cover(m, ve, &t_seg, &travelled, &done);
    if (!n)
        return;                                /* cannot happen: v >= MIN_RATE events/s */
    /* The events come at the segment's mean speed; the fraction of an event travelled beyond
     * the last whole one is carried into the next segment, and so is its time. */
    float rate = t_seg > 0.0f ? travelled / t_seg : 0.0f;
    if (!(rate >= MIN_RATE))                   /* a move's last sliver of an event, in no time */
        rate = fmaxf(v * per_mm, MIN_RATE);
    timing(s, n, rate);
    s->line = first ? new_line(m) : line_slot;
    s->flags = (uint8_t)((first ? SEG_FIRST : 0) | (done ? SEG_LAST : 0));
    first = 0;
    stepper_push();
    if (done) {
        active = 0;
        planner_pop();
        if (planner_empty())
            stopped = 1;                       /* braked to the stop rate: the next starts there */
    }
    /* From rest, a few segments are ready before the first step (the interrupt must not run
     * out of them while the next ones are computed). */
    if (stepper_queued() >= START_SEGMENTS || planner_empty())
        stepper_start();
}
