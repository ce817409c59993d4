/* interp.h - 002's interpreter and processor: fetch, immediate commands, status. */
#ifndef INTERP_H
#define INTERP_H

#include <stdint.h>
#include "command.h"

void interp_init(void);            /* INIT: defaults, empty queue, position 0, ready */
void interp_stop(void);            /* STOP: abrupt stop, queue cleared */
void interp_override(const command_t *cmd);         /* FFDR, MFDR: the feed, even mid-move */
/* 0 if the controller refuses a command now (ERR 6): after STOP or an error, until INIT. */
uint8_t interp_accepts(const command_t *cmd);
uint8_t interp_position_answer(uint8_t *answer);   /* POS */
uint8_t interp_status_answer(uint8_t *answer);     /* STAT */
/* One pass of the interpreter: fetch the next command when the processor can take it. */
void interp_run(void);
/* Once a millisecond: dwell and homing time. */
void interp_tick_1ms(void);
/* The heartbeat's stop (heartbeat.c): work under way or waiting; HOST_LOST set; brake every
 * planned move to `crawl_mm_min` and refuse motion (STOPPED, HOST_LOST) until INIT; at rest,
 * drop what is left and switch the spindle and coolant off. */
uint8_t interp_has_work(void);
uint8_t interp_host_lost(void);
void interp_brake(float crawl_mm_min);
void interp_halt_outputs(void);

#endif
