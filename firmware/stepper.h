/* stepper.h - phase two of 002's path planner: the move executing in the timer interrupt. */
#ifndef STEPPER_H
#define STEPPER_H

#include <stdint.h>
#include "config.h"

/* A line ends at its end point; a homing move also ends when its switch closes (SEEK) or
 * opens (RELEASE), and a homing move that runs out of travel has missed its switch. */
enum move_kind { MOVE_LINE, MOVE_SEEK, MOVE_RELEASE };
enum feed_kind { FEED_FAST, FEED_MACHINING, FEED_HOMING };

/* What phase one (prepare, in the main loop) leaves for phase two (execute, in the interrupt):
 * 002's "pending movement". Rates count step cycles (Bresenham events) per second. */
typedef struct {
    uint8_t kind;                  /* enum move_kind */
    uint8_t feed_kind;             /* which feed governs its speed (FFDR / MFDR may change it) */
    uint8_t indexer;               /* 1: the spindle encoder clocks it (ISTP), 0: the timer */
    uint8_t chained;               /* ISTP: continues the pass before it (no wait for SIND) */
    uint8_t dir_bits;              /* bit i: axis i moves towards negative */
    uint8_t watch;                 /* the switch a homing move watches */
    uint32_t delta[N_AXES];        /* steps of each axis */
    uint32_t events;               /* Bresenham's base count: step cycles or encoder counts */
    uint16_t takeup[N_AXES];       /* backlash: motor steps through the clearance first (003) */
    float feed;                    /* mm/min now (FFDR / MFDR update it while it runs) */
    float k_feed;                  /* events/s per mm/min */
    float rate_max;                /* events/s the axes' speed limits allow */
    float accel;                   /* events/s^2 the axes' acceleration limits allow */
    float rate_start;              /* events/s a motor at rest may start at (and stop from) */
    uint16_t start_ocr;            /* the start rate as a timer period (set by stepper_submit) */
    uint8_t start_skip;
} move_t;

/* Events the interrupt reports to the main loop (stepper_take_events). */
#define EV_LIMIT   0x01            /* a limit switch stopped a move: the queue must be dropped */
#define EV_SWITCH  0x02            /* a homing move ended on its switch (closed / opened) */
#define EV_DONE    0x04            /* a move ended */

void stepper_init(void);
/* Hand a prepared move to the interrupt; 0 if the pending slot is still full. */
uint8_t stepper_submit(const move_t *move);
uint8_t stepper_pending(void);     /* the pending slot is full */
uint8_t stepper_running(void);     /* a move executes */
/* While held, the interrupt does not start the pending move (a dwell runs). */
void stepper_hold(uint8_t on);
/* Abrupt stop: the running and the pending move are dropped at once. */
void stepper_stop(void);
uint8_t stepper_take_events(void);
void stepper_position(int32_t *steps);
void stepper_set_position(uint8_t axis, int32_t steps);
/* The step-cycle rate (events/s) the interrupt uses from its next cycle, if the move numbered
 * `sequence` (stepper_snapshot) still runs. */
void stepper_set_rate(float rate, uint8_t sequence);
/* A rate as timer cycles: after a step pulse, `skip` + 1 cycles of `ocr` counts each. */
void stepper_period(float rate, uint16_t *ocr, uint8_t *skip);
/* Change the feed of the running and pending moves governed by `kind` (FFDR, MFDR). */
void stepper_set_feed(uint8_t kind, float feed_mm_min);
/* For the speed profile: the running move's feed (and with `whole` its constant limits and
 * rates) and the events it has left (0: none). */
uint32_t stepper_snapshot(move_t *copy, uint8_t *sequence, uint8_t whole);
/* Which way each axis last stepped (+1 / -1; -1 before any step). */
void stepper_directions(int8_t *dirs);
uint8_t stepper_index_seen(void);  /* SIND has pulsed since the last call to clear it */
void stepper_clear_index_seen(void);

#endif
