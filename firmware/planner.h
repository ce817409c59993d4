/* planner.h - phase one of 002's path planner (prepare a move) and its speed profile. */
#ifndef PLANNER_H
#define PLANNER_H

#include <stdint.h>
#include "stepper.h"

/* Power-up: each nut rests on its negative face (no take-up before a first move towards -). */
void planner_reset(void);
/* After a stop: each nut rests on the face the axis last stepped towards. */
void planner_resync(void);
/* Prepare a straight line from `from` to `to` (steps). `feed` is mm/min, or mm per spindle
 * revolution when `indexer` is set. Returns 0 for a line of no length (nothing to do). */
uint8_t plan_line(move_t *m, const int32_t *from, const int32_t *to, uint8_t feed_kind,
                  float feed, uint8_t indexer);
/* An ISTP line at `rpm`: 0 if an axis would need more steps than encoder counts, or a step rate
 * above its limit (the host controller refuses the same threads). */
uint8_t plan_thread_ok(const move_t *m, float rpm);
/* Prepare a homing move of `axis`: up to `steps` steps in `dir` (+1 / -1); a SEEK or RELEASE
 * move ends early when switch `watch` closes or opens. */
void plan_home(move_t *m, uint8_t axis, int8_t dir, uint32_t steps, uint8_t kind, uint8_t watch,
               uint8_t feed_kind, float feed);
/* Once a millisecond: the running move's step-cycle rate (accelerate, cruise, brake). */
void profile_update(void);

#endif
