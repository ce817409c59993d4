/* steprate.h - the settings of retrofit/machines/steprate.toml the firmware compiles in.
 * Written by firmware/tools/machine_header.py (make machine MACHINE=steprate);
 * edit the machine file, not this header: a test checks that they agree. */
#define MACHINE_NAME        "steprate"
#define N_AXES              4
#define AXIS_LETTERS        "XYZA"
#define AXIS_BITS           { 0, 1, 2, 3 }   /* link mask bit of each axis */
#define FOR_EACH_AXIS(M)   M(0, X) M(1, Y) M(2, Z) M(3, E0)   /* index, RAMPS socket */
#define DIR_INVERT          0x00
#define STEPS_PER_MM        { 1000.0f, 1000.0f, 1000.0f, 1000.0f }
#define MAX_RATE_STEPS_S    { 100000.0f, 100000.0f, 100000.0f, 100000.0f }
#define ACCEL_STEPS_S2      { 1e+08f, 1e+08f, 1e+08f, 1e+08f }
#define BACKLASH_STEPS      { 0, 0, 0, 0 }
#define MIN_STEPS           { -1000000, -1000000, -1000000, -1000000 }   /* soft limits */
#define MAX_STEPS           { 1000000, 1000000, 1000000, 1000000 }
#define TRAVEL_STEPS        { 2205500, 2205500, 2205500, 2205500 }   /* the longest homing seek */
#define PULSE_HIGH_US       2   /* 'dunu': the step pulse */
#define MIN_PERIOD_US       12   /* 'perioada': the shortest step period */
#define DIR_SETUP_US        1
#define RAPID_FEED_MM_MIN   6000.0f
#define DEFAULT_FEED_MM_MIN 300.0f
#define JUNCTION_DEVIATION_MM 0.01f
#define ENCODER_COUNTS_PER_REV 0
#define SPINDLE_MAX_RPM     3000UL
#define SPINDLE_SPEED_TOLERANCE 0.0f   /* a thread is planned for a spindle this much faster */
#define SYNC_ACCEL_SHARE    1.0f   /* of the acceleration, for a thread's lead-in */
#define INDEX_TIMEOUT_MS    5000UL   /* a thread pass without an index pulse this long: ERROR */
/* SWITCH(id, axis, side, kind, RAMPS endstop connector, status bit or -1) */
#define SWITCHES \

#define N_SWITCHES          0
#define PROBE_SWITCH        255   /* PROB watches it; 255: no probe input */
#define HOME_COUNT          0
#define HOME_ORDER          { 0, 0, 0, 0 }
#define HOME_DIRS           { 1, 1, 1, 1 }
#define HOME_SEEK_SWITCH    { 255, 255, 255, 255 }   /* 255: the axis is not homed */
#define HOME_REF_SWITCH     { 255, 255, 255, 255 }
#define HOME_STEPS          { 0, 0, 0, 0 }   /* the position at the reference switch */
#define HOME_BACKOFF_STEPS  { 0, 0, 0, 0 }
#define HOME_LATCH_MM_MIN   { 30.0f, 30.0f, 30.0f, 30.0f }
