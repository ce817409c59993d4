/* planner.c - phase one of 002's path planner, and the trapezoidal speed profile.
 *
 * 002: "First phase is executed immediately upon interpreting command as a motion command. On
 * the end of first phase all calculated data for phase two are saved as parameters of the new
 * pending movement." Here that data is the Bresenham set-up (steps per axis, the base count),
 * the directions, the backlash take-up and the speed limits in step cycles per second.
 *
 * The speed of the running move is set once a millisecond from the main loop: it starts at the
 * rate a motor at rest can take, rises at the axes' acceleration to the feed (which FFDR and
 * MFDR may change at any time), and falls again so that it is back at the start rate when the
 * last step comes. Moves do not blend: each starts and ends at the start rate. */
#include <math.h>

#include "config.h"
#include "planner.h"

static const float steps_per_mm[N_AXES] = STEPS_PER_MM;
static const float max_rate[N_AXES] = MAX_RATE_STEPS_S;       /* steps/s */
static const float max_accel[N_AXES] = ACCEL_STEPS_S2;        /* steps/s^2 */
static const uint16_t backlash[N_AXES] = BACKLASH_STEPS;      /* 'JocL' / 'JocT' */

static int8_t last_dir[N_AXES];          /* +1 / -1: which way the axis last moved */

void planner_reset(void)
{
    for (uint8_t i = 0; i < N_AXES; i++)
        last_dir[i] = -1;                    /* at power-up the nut rests on its negative face */
}

void planner_resync(void)
{
    stepper_directions(last_dir);
}

/* 003's backlash: on a reversal the motor first turns through the clearance. */
static uint16_t takeup(uint8_t axis, int8_t dir)
{
    uint16_t steps = last_dir[axis] != dir ? backlash[axis] : 0;
    last_dir[axis] = dir;
    return steps;
}

/* Speed limits of a move, in events/s and events/s^2, from the axes that move. */
static void limits(move_t *m)
{
    m->rate_max = MAX_RATE;
    m->accel = 1e12f;
    for (uint8_t i = 0; i < N_AXES; i++) {
        if (!m->delta[i])
            continue;
        float scale = (float)m->events / (float)m->delta[i];
        if (max_rate[i] * scale < m->rate_max)
            m->rate_max = max_rate[i] * scale;
        if (max_accel[i] * scale < m->accel)
            m->accel = max_accel[i] * scale;
    }
    m->rate_start = sqrtf(2.0f * m->accel);      /* the rate after one event from rest */
    if (m->rate_start > m->rate_max)
        m->rate_start = m->rate_max;
}

uint8_t plan_line(move_t *m, const int32_t *from, const int32_t *to, uint8_t feed_kind,
                  float feed, uint8_t indexer)
{
    float length2 = 0.0f;
    uint32_t most = 0;
    m->kind = MOVE_LINE;
    m->feed_kind = feed_kind;
    m->indexer = indexer;
    m->dir_bits = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        int32_t d = to[i] - from[i];
        m->delta[i] = d < 0 ? (uint32_t)-d : (uint32_t)d;
        m->takeup[i] = 0;
        if (!d)
            continue;
        if (d < 0)
            m->dir_bits |= (uint8_t)(1 << i);
        m->takeup[i] = takeup(i, d < 0 ? -1 : 1);
        float mm = (float)d / steps_per_mm[i];
        length2 += mm * mm;
        if (m->delta[i] > most)
            most = m->delta[i];
    }
    if (!most)
        return 0;
    float length = sqrtf(length2);
    m->events = most;                          /* clock: the base axis steps every cycle */
    m->feed = feed;
    m->k_feed = (float)m->events / length / 60.0f;
    m->chained = 0;
    limits(m);                                 /* in steps of the base axis (take-up's rate) */
    if (indexer && feed > 0.0f) {              /* ISTP: the encoder counts of the line; at */
        float counts = length / feed * (float)ENCODER_COUNTS_PER_REV;   /* most one step each */
        if (counts > (float)most)
            m->events = counts < 1e9f ? (uint32_t)(counts + 0.5f) : 1000000000UL;
    }
    return 1;
}

uint8_t plan_thread_ok(const move_t *m, float rpm)
{
    if (!m->indexer)
        return 1;
    float counts = (float)m->events;           /* the encoder counts of the line */
    for (uint8_t i = 0; i < N_AXES; i++) {
        if (m->delta[i] > m->events)
            return 0;                          /* more steps than counts: the pitch would be cut */
        float rate = (float)m->delta[i] / counts * (float)ENCODER_COUNTS_PER_REV * rpm / 60.0f;
        if (rate > max_rate[i])
            return 0;                          /* the axis cannot follow the spindle */
    }
    return 1;
}

void plan_home(move_t *m, uint8_t axis, int8_t dir, uint32_t steps, uint8_t kind, uint8_t watch,
               uint8_t feed_kind, float feed)
{
    for (uint8_t i = 0; i < N_AXES; i++) {
        m->delta[i] = 0;
        m->takeup[i] = 0;
    }
    m->kind = kind;
    m->feed_kind = feed_kind;
    m->indexer = m->chained = 0;
    m->watch = watch;
    m->delta[axis] = steps;
    m->takeup[axis] = takeup(axis, dir);
    m->dir_bits = dir < 0 ? (uint8_t)(1 << axis) : 0;
    m->events = steps;
    m->feed = feed;
    m->k_feed = steps_per_mm[axis] / 60.0f;
    limits(m);
}

void profile_update(void)
{
    static float rate;
    static uint8_t seen = 255;
    static move_t m;                           /* the running move's constants */
    uint8_t seq;
    uint32_t left = stepper_snapshot(&m, &seq, 0);
    if (left && seq != seen) {                 /* a new move started at its start rate */
        left = stepper_snapshot(&m, &seq, 1);
        if (!left)
            return;
        seen = seq;
        rate = m.rate_start;
    }
    if (!left || m.indexer)
        return;
    float cruise = m.feed * m.k_feed;
    if (cruise > m.rate_max)
        cruise = m.rate_max;
    if (cruise < MIN_RATE)
        cruise = MIN_RATE;
    float end = m.rate_start < cruise ? m.rate_start : cruise;
    float brake = (rate * rate - end * end) / (2.0f * m.accel);   /* events to slow down in */
    float dv = m.accel * 0.001f;
    if ((float)left <= brake + 1.0f)
        rate = rate - dv > end ? rate - dv : end;
    else if (rate < cruise)
        rate = rate + dv < cruise ? rate + dv : cruise;
    else if (rate > cruise)
        rate = rate - dv > cruise ? rate - dv : cruise;
    stepper_set_rate(rate, seq);
}
