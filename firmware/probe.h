/* probe.h - PROB's line: a move that ends where the probe input (the tool setter's beam) changes. */
#ifndef PROBE_H
#define PROBE_H

#include <stdint.h>
#include "config.h"

enum { PROBE_RUNNING, PROBE_FOUND, PROBE_ENDED };

/* Queue the line from `from` to `to` (machine steps) at `feed` mm/min, at rest, to end at the
 * first step after which the probe input closes (or opens: `until_open`). PROBE_FOUND: the
 * input already is so (no step); PROBE_ENDED: a line of no length; else PROBE_RUNNING. */
uint8_t probe_start(const int32_t *from, const int32_t *to, uint8_t until_open, float feed);
uint8_t probe_running(void);
void probe_cancel(void);           /* STOP, an error, INIT: the line was dropped */
/* While the line runs: after the step interrupt's `events` (the caller has dropped the rest of a
 * line that ended on its switch) and with the machine `at_rest` or not. PROBE_FOUND: it stopped
 * on the probe, `position` gets where the axes are; PROBE_ENDED: it reached its end. */
uint8_t probe_update(uint8_t events, uint8_t at_rest, int32_t *position);

#endif
