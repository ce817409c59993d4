/* heartbeat.c - a machine whose host fell silent brakes to a stop (docs/protocol.md §5.1).
 *
 * A machine with work (a move, a dwell, a homing, a command waiting) that has received no intact
 * frame for HEARTBEAT_MS brakes as a feed override to a crawl would (interp_brake): the queue is
 * dropped and every planned move's feed goes to BRAKE_RATE steps a second of the axis with the
 * fewest steps per mm (a lower one would make segment.c cut ever emptier segments), so once the
 * segments already cut have run out the speed ramps down at the moves' own acceleration. When no
 * axis has stepped for BRAKE_QUIET_MS (slower than any axis starts from rest), or the moves have
 * ended, or after the longest braking an axis can need (a thread pass follows the spindle and
 * does not slow), what is left is dropped and the spindle and coolant go off
 * (interp_halt_outputs). The status says STOPPED and HOST_LOST, and motion is refused until
 * INIT. The position stays what the step counters say. */
#include "config.h"
#include "heartbeat.h"
#include "interp.h"
#include "link.h"
#include "segment.h"
#include "stepper.h"

#define HEARTBEAT_MS   500
#define BRAKE_QUIET_MS 20
#define BRAKE_RATE     10.0f           /* steps/s of the axis with the fewest steps per mm */

static uint8_t braking;
static uint16_t brake_ms, brake_limit_ms, quiet_ms;
static int32_t seen[N_AXES];

static void brake_start(void)
{
    static const float rate[N_AXES] = MAX_RATE_STEPS_S, accel[N_AXES] = ACCEL_STEPS_S2;
    static const float per_mm[N_AXES] = STEPS_PER_MM;
    float longest = 0.0f, coarsest = per_mm[0];
    for (uint8_t i = 0; i < N_AXES; i++) {
        if (rate[i] / accel[i] > longest)
            longest = rate[i] / accel[i];
        if (per_mm[i] < coarsest)
            coarsest = per_mm[i];
    }
    brake_limit_ms = (uint16_t)(2000.0f * longest + SEGMENTS * SEGMENT_MS + 100.0f);
    brake_ms = quiet_ms = 0;
    braking = 1;
    interp_brake(60.0f * BRAKE_RATE / coarsest);
    stepper_position(seen);
}

void heartbeat_tick_1ms(void)
{
    if (braking && !interp_host_lost())
        braking = 0;                                   /* INIT came: the host is back */
    if (!braking) {
        if (!interp_host_lost() && interp_has_work() && link_silent_ms() >= HEARTBEAT_MS)
            brake_start();
        return;
    }
    int32_t now[N_AXES];
    stepper_position(now);
    uint8_t moved = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        moved |= now[i] != seen[i];
        seen[i] = now[i];
    }
    quiet_ms = moved ? 0 : quiet_ms + 1;
    if (quiet_ms >= BRAKE_QUIET_MS || !interp_has_work() || ++brake_ms >= brake_limit_ms) {
        braking = 0;
        interp_halt_outputs();                         /* at rest: nothing left to run */
    }
}
