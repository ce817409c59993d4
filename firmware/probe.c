/* probe.c - PROB (docs/protocol.md §7): a straight line at the machining feed from rest to rest,
 * watched by the step interrupt as homing's seek (SEEK: until the probe input closes) or release
 * (RELEASE: until it opens) watches its switch (tick.c prepare(): before each step, on the
 * debounced state). Nothing runs after it until it has ended (interp.c). */
#include "planner.h"
#include "probe.h"
#include "stepper.h"
#include "switches.h"

static uint8_t running;

uint8_t probe_start(const int32_t *from, const int32_t *to, uint8_t until_open, float feed)
{
    move_t m;
    uint8_t kind = until_open ? MOVE_RELEASE : MOVE_SEEK;
    running = 0;
    if (switch_on(PROBE_SWITCH) == (kind == MOVE_SEEK))
        return PROBE_FOUND;                            /* found before any step */
    if (!plan_line(&m, from, to, FEED_MACHINING, feed, 0))
        return PROBE_ENDED;                            /* no length: nothing to probe */
    m.kind = kind;                                     /* no joint: it starts and ends at rest */
    m.watch = PROBE_SWITCH;
    planner_submit(&m);
    running = 1;
    return PROBE_RUNNING;
}

uint8_t probe_running(void) { return running; }

void probe_cancel(void) { running = 0; }

uint8_t probe_update(uint8_t events, uint8_t at_rest, int32_t *position)
{
    if (events & EV_SWITCH) {
        stepper_position(position);                    /* later moves go on from here */
        planner_resync();                              /* and from the nuts' faces there */
        running = 0;
        return PROBE_FOUND;
    }
    if (at_rest)
        running = 0;
    return at_rest ? PROBE_ENDED : PROBE_RUNNING;
}
