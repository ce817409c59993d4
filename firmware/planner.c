/* planner.c - phase one of 002's path planner, and the look-ahead over the queued moves.
 *
 * 002: "First phase is executed immediately upon interpreting command as a motion command. On
 * the end of first phase all calculated data for phase two are saved as parameters of the new
 * pending movement." Here that data is the Bresenham set-up (steps per axis, the base count),
 * the directions, the backlash take-up, and the move's length, direction and speed limits.
 *
 * Prepared moves wait in a queue of PLANNER_MOVES. The speed at each joint follows the host
 * planner's rule (retrofit/motion/lookahead.py): the joint is rounded by an arc that deviates
 * JUNCTION_DEVIATION_MM from the corner, whose centripetal acceleration must stay within the
 * moves' acceleration; each axis's velocity jump at the joint must fit half its acceleration
 * over one step; a move that turns at speed keeps the other half of its acceleration. A
 * backward pass over the queue then brings every entry speed down to what still lets the tool
 * brake to a stop at the end of the last queued move, so a link that falls silent stops the
 * machine as planned. "A stop" is the rate a motor at rest may start at (one event's worth of
 * acceleration), as without look-ahead. The step generator (segment.c) reads the oldest move. */
#include <math.h>

#include "config.h"
#include "planner.h"
#include "stepper.h"

static const float steps_per_mm[N_AXES] = STEPS_PER_MM;
static const float max_rate[N_AXES] = MAX_RATE_STEPS_S;       /* steps/s */
static const float max_accel[N_AXES] = ACCEL_STEPS_S2;        /* steps/s^2 */
static const uint16_t backlash[N_AXES] = BACKLASH_STEPS;      /* 'JocL' / 'JocT' */

/* The fastest timer event rate (base-axis steps/s) the step interrupt keeps while the main loop
 * still prepares the segments and answers the link (RDST every 2 ms), by the number of moving
 * axes, for lines whose axes all step at every event (PLAIN) and for lines with Bresenham axes
 * (BRES): measured in simavr by bench/firmware_steprate.py. No line is planned faster, whatever
 * its feed: a rate the interrupt cannot keep would starve the segment supply mid-move. 4 axes in
 * Bresenham ratios: 35 000 restarted the board under the heaviest polling, 30 000 holds. */
#ifndef KEEP_RATE_PLAIN
#define KEEP_RATE_PLAIN { 47500.0f, 47500.0f, 50000.0f, 47500.0f, 40000.0f }
#define KEEP_RATE_BRES  { 47500.0f, 42500.0f, 40000.0f, 30000.0f, 30000.0f }
#endif
/* Three axes in Bresenham ratios are also held to a sum of steps a second: there a tick's cost
 * grows with the steps it makes (bench/firmware_isr_cost.py: 332 cycles an event at 1:0.5:0.25,
 * 347 at 1:0.67:0.67, 368 at 1:0.99:0.89), and 1:0.99:0.89 at 40 000 events/s left the main loop
 * 8 % of the CPU: one turn planning a short move took 33 ms, near the stall guard's 50 (the mixed
 * stress's board 116 restarted there with the encoder's interrupt on as well). The sum is that
 * of 1:0.67:0.67 at 40 000 (87 % of the CPU in the interrupt); 1:0.99:0.89 then runs at 32 500
 * (75 %). With one, two or four axes every case measured stays within 83 %: no sum. */
#ifndef KEEP_RATE_STEPS_BRES
#define KEEP_RATE_STEPS_BRES { 1e9f, 1e9f, 93600.0f, 1e9f, 1e9f }
#endif
/* A line that watches a switch (a homing seek or release, PROB) runs on the slow tick, which
 * reads the switch before every step: 25 000 events/s held under RDST every 2 ms, 27 500 restarted
 * the board (tests/test_firmware_stress_mix.py); kept with the host's margin of 0.8. */
#define KEEP_RATE_WATCH 20000.0f
static const float keep_plain[5] = KEEP_RATE_PLAIN, keep_bres[5] = KEEP_RATE_BRES;
static const float keep_steps_bres[5] = KEEP_RATE_STEPS_BRES;

#define JUNCTION_SHARE 0.5f            /* of an axis's acceleration, for a turn's velocity jump */
#define FEED_NONE 255                  /* a take-up move: no override changes it */

static int8_t last_dir[N_AXES];        /* +1 / -1: which way the axis last moved */
static move_t queue[PLANNER_MOVES];
static uint8_t q_first, q_count;
static uint8_t cut[PLANNER_MOVES];     /* the move's acceleration was cut for a turn */

/* Each axis's limits per mm and its joint terms (jump_limit), worked out once: the same floats
 * the planner computed at every move before, without its divisions and roots. */
static float rate_mm[N_AXES], accel_mm[N_AXES], jump_c[N_AXES], jump_budget[N_AXES];

void planner_reset(void)
{
    for (uint8_t i = 0; i < N_AXES; i++) {
        last_dir[i] = -1;                    /* at power-up the nut rests on its negative face */
        float acc = max_accel[i] / steps_per_mm[i], step = 1.0f / steps_per_mm[i];
        rate_mm[i] = max_rate[i] / steps_per_mm[i];
        accel_mm[i] = acc;
        jump_c[i] = sqrtf(2.0f * acc * step);
        jump_budget[i] = JUNCTION_SHARE * acc * step;
    }
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

/* The feed along the path (mm/s): within the axes' limit, at least MIN_RATE events a second. */
static float nominal(float feed_mm_min, float cap, float per_mm)
{
    float v = feed_mm_min / 60.0f < cap ? feed_mm_min / 60.0f : cap;
    return v * per_mm < MIN_RATE ? MIN_RATE / per_mm : v;
}

/* Speed and acceleration limits of a move along its path, from the axes that move. */
static void limits(move_t *m)
{
    float v = 1e9f, a = 1e12f;
    uint8_t moving = 0, bres = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        if (!m->delta[i])
            continue;
        moving++;
        bres |= m->delta[i] != m->events;
        float share = (float)m->delta[i] / steps_per_mm[i] / m->mm;   /* |unit| of the axis */
        if (rate_mm[i] / share < v)
            v = rate_mm[i] / share;
        if (accel_mm[i] / share < a)
            a = accel_mm[i] / share;
    }
    float per_mm = (float)m->events / m->mm;
    float keep = moving ? (bres ? keep_bres : keep_plain)[moving - 1] : MAX_RATE;
    if (bres && keep_steps_bres[moving - 1] < 1e9f) {   /* the steps a tick makes */
        float steps = 0.0f;
        for (uint8_t i = 0; i < N_AXES; i++)
            steps += (float)m->delta[i];
        float cap = keep_steps_bres[moving - 1] * (float)m->events / steps;
        if (cap < keep)
            keep = cap;
    }
    if (keep > MAX_RATE)
        keep = MAX_RATE;
    if ((m->kind == MOVE_SEEK || m->kind == MOVE_RELEASE) && keep > KEEP_RATE_WATCH)
        keep = KEEP_RATE_WATCH;
    if (v * per_mm > keep)
        v = keep / per_mm;                     /* the rate the firmware keeps */
    m->v_cap = v;
    m->accel = a;
    m->v_rest = sqrtf(2.0f * a / per_mm);      /* the speed after one event from rest */
    if (m->v_rest < MIN_RATE / per_mm)
        m->v_rest = MIN_RATE / per_mm;
    if (m->v_rest > v)
        m->v_rest = v;
    m->v_nominal = nominal(m->feed, v, per_mm);
    m->v_junction = 0.0f;
    m->v_entry = move_rest(m);
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
        m->unit[i] = (float)d / steps_per_mm[i];
        if (!d)
            continue;
        if (d < 0)
            m->dir_bits |= (uint8_t)(1 << i);
        m->takeup[i] = takeup(i, d < 0 ? -1 : 1);
        length2 += m->unit[i] * m->unit[i];
        if (m->delta[i] > most)
            most = m->delta[i];
    }
    if (!most)
        return 0;
    m->mm = sqrtf(length2);
    for (uint8_t i = 0; i < N_AXES; i++)
        m->unit[i] /= m->mm;
    m->events = most;                          /* clock: the base axis steps every event */
    m->feed = feed;
    m->chained = 0;
    limits(m);
    if (indexer && feed > 0.0f) {              /* ISTP: the encoder counts of the line (at */
        float counts = m->mm / feed * (float)ENCODER_COUNTS_PER_REV;   /* most one step each: */
        m->events = counts < 1e9f ? (uint32_t)(counts + 0.5f) : 1000000000UL;   /* checked by */
        if (!m->events)                                                          /* plan_thread) */
            m->events = 1;
    }
    return 1;
}

/* The lead-in (retrofit/motion/indexer.py, the host's rule): an axis at rest cannot jump to
 * thread speed, so it starts L counts before the reference index and follows a parabola in the
 * count that meets the line, with its slope, L counts after it; at the fastest the spindle may
 * turn, that takes SYNC_ACCEL_SHARE of the path's acceleration: L = C f r^2 / (2 a), f the feed
 * in mm a revolution, r revolutions a second. */
#define LEAD_MAX 30000U                /* (2 L)^2 must fit 32 bits in the encoder's interrupt */

uint8_t plan_thread(move_t *m, float rpm)
{
    m->lead = 0;
    if (!m->indexer)
        return 1;
    if (rpm <= 0.0f)
        return 0;                              /* no spindle to follow */
    float revs = rpm * (1.0f + SPINDLE_SPEED_TOLERANCE) / 60.0f;
    float counts = (float)m->events;           /* the encoder counts of the line */
    for (uint8_t i = 0; i < N_AXES; i++) {
        if (m->delta[i] > m->events)
            return 0;                          /* more steps than counts: the pitch would be cut */
        float rate = (float)m->delta[i] / counts * (float)ENCODER_COUNTS_PER_REV * revs;
        if (rate > max_rate[i])
            return 0;                          /* the axis cannot follow the spindle */
    }
    if (m->chained)
        return 1;                              /* it goes on from the pass before: no lead-in */
    float lead = (float)ENCODER_COUNTS_PER_REV * m->feed * revs * revs /
                 (2.0f * m->accel * SYNC_ACCEL_SHARE);
    lead = ceilf(lead - 1e-3f);                /* (rounded up: the acceleration stays within) */
    if (lead > counts || lead > (float)LEAD_MAX)
        return 0;                              /* the lead-in would be longer than the line */
    m->lead = (uint16_t)lead;
    return 1;
}

void plan_home(move_t *m, uint8_t axis, int8_t dir, uint32_t steps, uint8_t kind, uint8_t watch,
               uint8_t feed_kind, float feed)
{
    for (uint8_t i = 0; i < N_AXES; i++) {
        m->delta[i] = 0;
        m->takeup[i] = 0;
        m->unit[i] = 0.0f;                     /* no joint with anything: it starts and stops */
    }
    m->kind = kind;
    m->feed_kind = feed_kind;
    m->indexer = m->chained = 0;
    m->lead = 0;
    m->watch = watch;
    m->delta[axis] = steps;
    m->takeup[axis] = takeup(axis, dir);
    m->dir_bits = dir < 0 ? (uint8_t)(1 << axis) : 0;
    m->events = steps;
    m->mm = (float)steps / steps_per_mm[axis];
    m->feed = feed;
    limits(m);
}

/* ---- the queue and the look-ahead -------------------------------------------------------- */

static uint8_t slot(uint8_t k)
{
    uint8_t s = (uint8_t)(q_first + k);
    return s >= PLANNER_MOVES ? (uint8_t)(s - PLANNER_MOVES) : s;
}

uint8_t planner_room(void) { return (uint8_t)(PLANNER_MOVES - q_count); }

uint8_t planner_empty(void) { return q_count == 0; }

void planner_clear(void) { q_count = 0; }

move_t *planner_first(void) { return q_count ? &queue[q_first] : 0; }

void planner_pop(void)
{
    if (!q_count)
        return;
    q_first = slot(1);
    q_count--;
}

float planner_exit_speed(void)
{
    return q_count > 1 ? queue[slot(1)].v_entry : 0.0f;
}

/* The highest speed each axis's velocity jump allows at a turn (lookahead.py _jump_limit). */
static float jump_limit(const move_t *a, const move_t *b)
{
    float best = 1e9f;
    for (uint8_t k = 0; k < N_AXES; k++) {
        float du = fabsf(b->unit[k] - a->unit[k]);
        if (!(du > 0.0f))
            continue;
        float m = fmaxf(fabsf(a->unit[k]), fabsf(b->unit[k]));
        float c = jump_c[k], budget = jump_budget[k];
        float v = (-du * c + sqrtf(du * du * c * c + 4.0f * du * m * budget)) / (2.0f * du * m);
        if (v < best)
            best = v;
    }
    return best;
}

/* The joint of `a` into `b`, geometry only (the feeds come in at each plan): mm/s. */
static float junction(const move_t *a, uint8_t a_cut, const move_t *b)
{
    if (a->indexer || b->indexer || a->kind != MOVE_LINE || b->kind != MOVE_LINE)
        return 0.0f;                           /* a thread, a homing or take-up move: a stop */
    float cos_turn = 0.0f;
    for (uint8_t k = 0; k < N_AXES; k++)
        cos_turn += a->unit[k] * b->unit[k];
    if (cos_turn >= 1.0f - 1e-6f)
        return 1e9f;                           /* straight on: only the feeds limit it */
    if (cos_turn <= -1.0f + 1e-6f)
        return 0.0f;                           /* a reversal */
    float sin_half = sqrtf(0.5f * (1.0f + cos_turn));
    float acc = fminf(a_cut ? 2.0f * a->accel : a->accel, b->accel);
    float radius = JUNCTION_DEVIATION_MM * sin_half / (1.0f - sin_half);
    return fminf(sqrtf(acc * radius), jump_limit(a, b));
}

/* Backward pass: each entry speed as high as the joint, the feeds and braking to a stop at the
 * end of the queue allow. The oldest move is under way: its entry is history. */
static void replan(void)
{
    if (q_count < 2)
        return;
    float exit = move_rest(&queue[slot(q_count - 1)]);
    for (uint8_t k = q_count - 1; k >= 1; k--) {
        move_t *m = &queue[slot(k)];
        const move_t *before = &queue[slot(k - 1)];
        float v = fminf(m->v_junction, fminf(m->v_nominal, before->v_nominal));
        float reach = sqrtf(exit * exit + 2.0f * m->accel * m->mm);
        if (reach < v)
            v = reach;
        if (v < move_rest(m))
            v = move_rest(m);
        m->v_entry = v;
        exit = v;
    }
}

uint8_t planner_submit(move_t *m)
{
    uint8_t need = 1, any = 0;
    if (m->kind == MOVE_SEEK || m->kind == MOVE_RELEASE)
        limits(m);                             /* (PROB makes its line a watched one after planning) */
    for (uint8_t i = 0; i < N_AXES; i++)
        any |= m->takeup[i] != 0;
    need += any;
    if (planner_room() < need)
        return 0;
    if (any) {                                 /* 003: the clearance first, at the stop rate */
        move_t *t = &queue[slot(q_count)];
        *t = *m;
        t->kind = MOVE_TAKEUP;
        t->feed_kind = FEED_NONE;
        t->indexer = 0;
        t->events = 0;
        for (uint8_t i = 0; i < N_AXES; i++) {
            t->delta[i] = m->takeup[i];
            if (t->delta[i] > t->events)
                t->events = t->delta[i];
        }
        t->mm = (float)t->events * m->mm / (float)m->events;
        t->v_cap = t->v_nominal = t->v_entry = t->v_rest = move_rest(m);
        t->v_junction = 0.0f;
        cut[slot(q_count)] = 0;
        q_count++;
    }
    uint8_t s = slot(q_count);
    queue[s] = *m;
    cut[s] = 0;
    if (q_count) {
        uint8_t p = slot(q_count - 1);
        float j = junction(&queue[p], cut[p], &queue[s]);
        queue[s].v_junction = j;
        if (j > 0.0f && j < 1e9f) {            /* a turn at speed: half the acceleration */
            if (!cut[p] && p != q_first)
                queue[p].accel *= 1.0f - JUNCTION_SHARE;
            cut[p] = 1;
            queue[s].accel *= 1.0f - JUNCTION_SHARE;
            cut[s] = 1;
        }
    }
    q_count++;
    replan();
    return 1;
}

void planner_set_feed(uint8_t kind, float feed)
{
    for (uint8_t k = 0; k < q_count; k++) {
        move_t *m = &queue[slot(k)];
        if (m->feed_kind != kind || m->indexer)
            continue;
        m->feed = feed;
        m->v_nominal = nominal(feed, m->v_cap, (float)m->events / m->mm);
    }
    replan();
}
