/* segment.h - the step generator's preparation: planned moves cut into short segments. */
#ifndef SEGMENT_H
#define SEGMENT_H

#include <stdint.h>

/* Segments last about this long; SEGMENTS of them are prepared ahead of the interrupt. */
#define SEGMENT_MS 5.0f

/* In the main loop: prepare the next segment if there is room and a move to cut. */
void segment_prepare(void);
/* Forget the move being cut (after a stop): the next one starts from rest. */
void segment_reset(void);
/* While held, nothing new is prepared (a dwell runs). */
void segment_hold(uint8_t on);
uint8_t segment_active(void);      /* a move is being cut */
/* Enough segments are ready (or nothing is left to cut): the main loop may serve the link.
 * While it is not, the segments come first, so serial traffic never starves the steps. */
uint8_t segment_fed(void);

#endif
