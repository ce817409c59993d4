/* queue.h - the three-deep queue of 002's interpreter (kept by commands.c, fetched by interp.c). */
#ifndef QUEUE_H
#define QUEUE_H

#include <stdint.h>
#include "command.h"

/* The queue of 002's interpreter: commands waiting to be fetched, oldest first. */
uint8_t queue_count(void);
command_t *queue_head(void);       /* the oldest waiting command (queue_count() > 0) */
void queue_pop(void);
void queue_clear(void);
uint8_t queue_holds(uint8_t op);   /* a command with opcode `op` waits */

#endif
