/* stepper.h - phase two of 002's path planner: the step interrupt over prepared segments.
 *
 * The main loop (segment.c) cuts the planned moves into short segments, each with its number
 * of timer ticks and the tick period already computed; the Timer1 interrupt only runs Bresenham
 * over them. A move's stepping data (steps per axis, directions) is a line_t; its segments name
 * it. Under ISTP a line's events come from the spindle encoder instead (INT0). */
#ifndef STEPPER_H
#define STEPPER_H

#include <stdint.h>
#include "config.h"

/* Adaptive multi-axis step smoothing (AMASS): at low rates the interrupt ticks 2^level times
 * per event of the base axis, so the other axes step at finer times. Step counts are kept
 * shifted left by AMASS_MAX, so each level divides them by a shift. */
#define AMASS_MAX 6

typedef struct {
    uint32_t steps[N_AXES];        /* steps of each axis (<< AMASS_MAX for a timed line) */
    uint32_t base;                 /* Bresenham's base count (<< AMASS_MAX for a timed line) */
    int32_t want[N_AXES];          /* the steps it must make, signed: checked at its end */
    int32_t counter0;              /* Bresenham's term at its start: -(base / 2) */
    uint8_t moving;                /* bit i: axis i steps */
    uint8_t always0;               /* bit i: axis i steps at every event (at AMASS level 0) */
    uint8_t dir_bits;              /* bit i: axis i moves towards negative */
    uint8_t kind;                  /* enum move_kind (planner.h) */
    uint8_t watch;                 /* the switch a homing line watches */
    uint8_t chained;               /* ISTP: no wait for SIND */
} line_t;

#define SEG_FIRST    0x01          /* the first segment of its line: counters and directions */
#define SEG_LAST     0x02          /* its last: the line ends with it */
#define SEG_INDEXER  0x04          /* the whole line, clocked by the spindle encoder; its ticks
                                      are the counts to wait after the index, its period the
                                      lead-in's counts (each side of the reference index) */

typedef struct {
    uint16_t ticks;                /* timer ticks (events << level) */
    uint16_t period;               /* timer counts (0.5 us) a tick */
    uint8_t level;                 /* AMASS level */
    uint8_t line;                  /* index in stepper_lines */
    uint8_t flags;
} segment_t;

#define SEGMENTS 12                /* prepared ahead: SEGMENTS x SEGMENT_MS of motion */
#define LINES (SEGMENTS + 2)
extern line_t stepper_lines[LINES];

/* Events the interrupt reports to the main loop (stepper_take_events). */
#define EV_LIMIT   0x01            /* a limit switch stopped a move: the queue must be dropped */
#define EV_SWITCH  0x02            /* a homing move ended on its switch (closed / opened) */
#define EV_DONE    0x04            /* a line ended */
#define EV_STEPS   0x08            /* a line ended with steps other than its own: all stopped */

void stepper_init(void);
/* The free segment slot, or 0 when SEGMENTS wait; stepper_push publishes it. */
segment_t *stepper_slot(void);
void stepper_push(void);
uint8_t stepper_queued(void);      /* segments waiting */
void stepper_start(void);          /* tick, if idle and segments wait */
uint8_t stepper_busy(void);        /* segments wait, or the interrupt steps */
/* Abrupt stop: stepping ends at once and every prepared segment is dropped. */
void stepper_stop(void);
uint8_t stepper_take_events(void);
void stepper_position(int32_t *steps);
void stepper_fold(void);           /* at least every 0.5 s: the interrupt counts in 16 bits */
void stepper_set_position(uint8_t axis, int32_t steps);
/* Which way each axis last stepped (+1 / -1; -1 before any step). */
void stepper_directions(int8_t *dirs);
uint8_t stepper_index_seen(void);  /* SIND has pulsed since the last call to clear it */
void stepper_clear_index_seen(void);
/* 1 while an ISTP line runs or waits for SIND, if no SIND has come since the last call. */
uint8_t stepper_index_quiet(void);

#endif
