/* planner.h - phase one of 002's path planner: moves prepared and queued, with look-ahead.
 *
 * A move (FMOV, PMOV, a homing move) is prepared into a move_t and queued here. The queue holds
 * PLANNER_MOVES moves; each time one is added (or a feed override changes the feeds) the
 * junction speeds are planned again over the whole queue, so that the tool passes nearly
 * colinear joints at speed and can always brake to a stop at the end of what is queued. */
#ifndef PLANNER_H
#define PLANNER_H

#include <stdint.h>
#include "config.h"

/* A line ends at its end point; a homing move also ends when its switch closes (SEEK) or
 * opens (RELEASE), and a homing move that runs out of travel has missed its switch. A TAKEUP
 * move turns motors through the backlash (003) without changing the position. */
enum move_kind { MOVE_LINE, MOVE_SEEK, MOVE_RELEASE, MOVE_TAKEUP };
enum feed_kind { FEED_FAST, FEED_MACHINING, FEED_HOMING };

/* Moves the planner looks ahead over (the link's queue of three waits in front of it). */
#define PLANNER_MOVES 18

/* 002's "pending movement": what phase one leaves for the step generator. Lengths in mm along
 * the path, speeds in mm/s along it, accelerations in mm/s^2. */
typedef struct {
    uint8_t kind;                  /* enum move_kind */
    uint8_t feed_kind;             /* which feed governs its speed (FFDR / MFDR may change it) */
    uint8_t indexer;               /* 1: the spindle encoder clocks it (ISTP), 0: the timer */
    uint8_t chained;               /* ISTP: continues the pass before it (no wait for SIND) */
    uint16_t lead;                 /* ISTP: encoder counts of lead-in on each side of the index */
    uint8_t dir_bits;              /* bit i: axis i moves towards negative */
    uint8_t watch;                 /* the switch a homing move watches */
    uint32_t delta[N_AXES];        /* steps of each axis */
    uint32_t events;               /* Bresenham's base count: step cycles or encoder counts */
    uint16_t takeup[N_AXES];       /* backlash: motor steps through the clearance first */
    float mm;                      /* length along the path */
    float unit[N_AXES];            /* direction, mm space (0 for a homing or take-up move) */
    float feed;                    /* mm/min now (FFDR / MFDR update it while it waits) */
    float v_cap;                   /* mm/s the axes' speed limits allow */
    float accel;                   /* mm/s^2 the axes' acceleration limits allow */
    float v_rest;                  /* mm/s a motor at rest may start at (one event from rest) */
    float v_nominal;               /* min(feed, v_cap) */
    float v_junction;              /* highest entry speed the joint with the move before allows */
    float v_entry;                 /* planned entry speed */
} move_t;

/* The speed a move starts from and stops at: a motor at rest may take it, and it is not above
 * the move's feed (a feed below the start rate is taken from rest). */
static inline float move_rest(const move_t *m)
{
    return m->v_rest < m->v_nominal ? m->v_rest : m->v_nominal;
}

/* Power-up: each nut rests on its negative face (no take-up before a first move towards -). */
void planner_reset(void);
/* After a stop: each nut rests on the face the axis last stepped towards. */
void planner_resync(void);
/* Prepare a straight line from `from` to `to` (steps). `feed` is mm/min, or mm per spindle
 * revolution when `indexer` is set. Returns 0 for a line of no length (nothing to do). */
uint8_t plan_line(move_t *m, const int32_t *from, const int32_t *to, uint8_t feed_kind,
                  float feed, uint8_t indexer);
/* An ISTP line at `rpm` (the last SPIN), by the host controller's rules: 0 (refused) when the
 * spindle is stopped, an axis would need more steps than encoder counts, an axis would step
 * above its limit with the spindle up to SPINDLE_SPEED_TOLERANCE faster, or (a pass that is not
 * chained) its lead-in would be longer than the line; else the lead-in's counts go in m->lead. */
uint8_t plan_thread(move_t *m, float rpm);
/* Prepare a homing move of `axis`: up to `steps` steps in `dir` (+1 / -1); a SEEK or RELEASE
 * move ends early when switch `watch` closes or opens. */
void plan_home(move_t *m, uint8_t axis, int8_t dir, uint32_t steps, uint8_t kind, uint8_t watch,
               uint8_t feed_kind, float feed);

/* The queue. planner_submit takes a prepared move (and its take-up move, if any): 0 when
 * there is no room for both. */
uint8_t planner_room(void);
uint8_t planner_submit(move_t *m);
uint8_t planner_empty(void);
void planner_clear(void);
/* The oldest move (the step generator's), or 0; planner_pop drops it once fully prepared. */
move_t *planner_first(void);
void planner_pop(void);
/* The entry speed the move after the oldest one is planned to start at (its exit speed). */
float planner_exit_speed(void);
/* FFDR, MFDR: the feed of every queued move governed by `kind`, then a new plan. */
void planner_set_feed(uint8_t kind, float feed_mm_min);

#endif
